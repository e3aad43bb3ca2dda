"""The visual distance stage: attention maps -> within-role Sinkhorn divergences, cached.

``d_vis(o_i, o_j) = S_eps(M(o_i), M(o_j))`` (the paper's Eq. for d_vis) for every pair of
observations of the same role (pick x pick, place x place); see :mod:`.attention` for ``M`` and
:mod:`.sinkhorn` for ``S_eps``. The stage never reads ``trace.states``.

With ``colour="auto"`` (the default) and a trace whose foreground carries at least two object
colours, the divergences of the colour-channel maps (:func:`.attention.colour_channel_maps`)
are added: ``d = S_eps(M(o_i), M(o_j)) + sum_c S_eps(M_c(o_i), M_c(o_j))``, so two scenes that
differ only by which coloured object stands where are told apart. With one colour (or
``colour="off"``) ``d`` is the paper's distance.
With the ``keypoints`` backend and two or more colours, ``d = sum_c S_eps(M_c(o_i), M_c(o_j))``
over the keypoint colour channels alone (every keypoint of the main map is in one of them).

Cache
-----
Directory: the ``cache_dir`` argument, else ``DistanceConfig.cache_dir`` (``--cache-dir``),
else ``$VGGC_CP_CACHE/distances``, else ``.cache/vggc-cp/distances`` under the current
directory (git-ignored). One file per (trace, configuration), ``<key digest>.npz``, written
atomically (temporary file + rename), with members

================  ========================  ==================================================
``dist_pick``     float64 (n_pick, n_pick)  rows in the order ``flatnonzero(roles == 0)``
``dist_place``    float64 (n_place,n_place) rows in the order ``flatnonzero(roles == 1)``
``key``           unicode scalar            JSON of the cache key (below)
``stats``         unicode scalar            JSON: Sinkhorn statistics, seconds per stage
================  ========================  ==================================================

The key holds ``format`` (``vggc-distances/1``), ``algorithm`` (:data:`ALGORITHM_VERSION`,
bumped when the code changes the numbers), the trace's
:meth:`~vggc_cp.trace.Trace.content_hash` (observations and actions, not states), and every
field of :class:`DistanceConfig` that changes the numbers (:meth:`DistanceConfig.key`), with the
SHA-256 of the weights file for weight-based backends. The file name is the SHA-256 of the
key's canonical JSON; on load the stored key must equal the expected one, so a changed
parameter, trace or weights file never reuses a stale file.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from vggc_cp.atomic import atomic_path
from vggc_cp.errors import VggcError, lookup
from vggc_cp.parallel import Executor
from vggc_cp.trace import PICK, PLACE, Trace
from vggc_cp.vision.attention import (
    ATTENTION_BACKENDS,
    KEYPOINT_BACKENDS,
    NEEDS_WEIGHTS,
    SALIENCY_BACKENDS,
    AttentionConfig,
    attention_maps,
    colour_channel_maps,
)
from vggc_cp.vision.sinkhorn import DEVICES, cost_matrix, sinkhorn_divergence_matrix

CACHE_FORMAT = "vggc-distances/1"
#: most Sinkhorn threads (--sinkhorn-threads)
MAX_THREADS = 1024
#: Bumped whenever a backend or the solver changes its numbers (part of the cache key).
ALGORITHM_VERSION = 2
COLOUR_MODES = ("auto", "off")
CACHE_ENV = "VGGC_CP_CACHE"


def _exec(default, **kw):
    """A field that only changes how fast the numbers come, not the numbers (not in the key)."""
    return field(default=default, metadata={"key": False}, **kw)


@dataclass(frozen=True)
class DistanceConfig:
    """Every setting of the distance stage.

    Fields that change the distances form the cache key; ``device``, ``threads``, ``block``,
    ``rows``, ``cache_dir`` and ``use_cache`` only change speed or storage.

    Attributes
    ----------
    backend : str
        Attention backend (``saliency``, ``keypoints`` or ``dinov2``).
    grid : int
        Patch grid side ``g`` (``g^2`` histogram bins).
    eps : float
        Entropic regularisation of ``S_eps``; costs live in the unit square (patch centres in
        ``[0, 1]^2``).
    floor : float
        Uniform mass added to every map.
    noise_k, min_contrast : float
        Saliency threshold (see :mod:`.attention`).
    weights : str or None
        DINOv2 weights file (else ``$VGGC_CP_DINOV2_WEIGHTS``); its SHA-256 enters the key.
    tol : float
        Sinkhorn stopping tolerance on the L1 marginal error.
    max_iter : int
        Sinkhorn iterations per problem before giving up.
    omega : float
        Sinkhorn over-relaxation.
    dtype : str
        Precision of the Sinkhorn matrix products (``float32`` or ``float64``).
    colour : str
        ``auto``: add colour-channel divergences when the trace shows two or more object
        colours (module docstring); ``off``: the paper's distance only.
    colour_min_share : float
        Share of the chromatic foreground mass that makes a hue bin a colour channel.
    rows : int or None
        Split each role's pairs into blocks of ``rows`` rows, one task each (run on the
        executor given to :func:`compute_distances_full`, e.g. a dask cluster); None: one
        block per role. The same ``rows`` gives the same numbers on every backend; other
        block sizes differ by float32 rounding only (about 1e-7), so it is not in the key.
    """

    backend: str = "saliency"
    grid: int = 16
    eps: float = 0.05
    floor: float = 0.01
    noise_k: float = 3.0
    min_contrast: float = 0.04
    weights: str | None = None
    tol: float = 1e-6
    max_iter: int = 20000
    omega: float = 1.5
    dtype: str = "float32"
    colour: str = "auto"
    colour_min_share: float = 0.1
    device: str = _exec("torch")
    threads: int | None = _exec(2)
    block: int = _exec(2048)
    rows: int | None = _exec(None)
    cache_dir: str | None = _exec(None)
    use_cache: bool = _exec(True)

    def __post_init__(self) -> None:
        lookup(ATTENTION_BACKENDS, self.backend, "attention backend")
        if self.grid < 2:
            raise VggcError(f"--grid must be at least 2, got {self.grid}")
        if not 0 < self.eps < float("inf"):
            raise VggcError(f"--eps must be positive and finite, got {self.eps}")
        if not 0 < self.floor < 1:
            raise VggcError(f"--floor must lie in (0, 1), got {self.floor}")
        if not 0 < self.tol < float("inf"):
            raise VggcError(f"--sinkhorn-tol must be positive and finite, got {self.tol}")
        if not 1 <= self.omega < 2:
            raise VggcError(f"--omega must lie in [1, 2), got {self.omega}")
        if self.colour not in COLOUR_MODES:
            raise VggcError(f"--colour must be one of {', '.join(COLOUR_MODES)}, "
                            f"got {self.colour!r}")
        if not 0 < self.colour_min_share < 1:
            raise VggcError(f"--colour-min-share must lie in (0, 1), got "
                            f"{self.colour_min_share}")
        if self.dtype not in ("float32", "float64"):
            raise VggcError(f"--sinkhorn-dtype must be float32 or float64, got {self.dtype!r}")
        lookup({d: d for d in DEVICES}, self.device, "device")
        if self.rows is not None and self.rows < 1:
            raise VggcError(f"--distance-rows must be at least 1, got {self.rows}")
        if self.threads is not None and not 1 <= self.threads <= MAX_THREADS:
            raise VggcError(f"--sinkhorn-threads {self.threads}: expected 1 to {MAX_THREADS}")

    def attention_params(self) -> AttentionConfig:
        return AttentionConfig(grid=self.grid, floor=self.floor, noise_k=self.noise_k,
                               min_contrast=self.min_contrast, weights=self.weights)

    def key(self) -> dict:
        """The fields that change the numbers (weights as a file hash, other backends drop it)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.metadata.get("key", True)}
        out.pop("weights")
        if self.backend in NEEDS_WEIGHTS:
            from vggc_cp.vision.dinov2 import resolve_weights, weights_sha256

            out["weights_sha256"] = weights_sha256(resolve_weights(self.weights))
        if self.colour == "off":
            out.pop("colour_min_share")
            if self.backend not in SALIENCY_BACKENDS:  # the saliency threshold shapes no map
                out.pop("noise_k")
                out.pop("min_contrast")
        return out


def default_cache_dir() -> Path:
    """``$VGGC_CP_CACHE/distances`` if set, else ``./.cache/vggc-cp/distances``."""
    root = os.environ.get(CACHE_ENV)
    return Path(root) / "distances" if root else Path(".cache") / "vggc-cp" / "distances"


def cache_key(trace: Trace, cfg: DistanceConfig) -> dict:
    return {"format": CACHE_FORMAT, "algorithm": ALGORITHM_VERSION,
            "trace": trace.content_hash(), "trace_identity": trace.identity_hash(),
            "config": cfg.key()}


def cache_path(trace: Trace, cfg: DistanceConfig, cache_dir: str | Path | None = None
               ) -> tuple[Path, dict]:
    """Where the distances of ``trace`` under ``cfg`` are cached, and the key."""
    key = cache_key(trace, cfg)
    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:40]
    root = Path(cache_dir or cfg.cache_dir or default_cache_dir())
    return root / f"{digest}.npz", key


def load_cached(path: Path, key: dict, n_pick: int, n_place: int
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """The cached pair if ``path`` holds exactly ``key`` with the right shapes, else None."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            if json.loads(str(data["key"])) != json.loads(json.dumps(key)):
                return None
            dp, dq = data["dist_pick"], data["dist_place"]
    except Exception:  # unreadable or foreign file: recompute and overwrite
        return None
    for name, d, m in (("dist_pick", dp, n_pick), ("dist_place", dq, n_place)):
        if d.shape != (m, m) or d.dtype.kind != "f" or not np.all(np.isfinite(d)) \
                or np.any(d < 0):
            from vggc_cp.safeio import warn

            warn(f"{path}: cache entry {name} is damaged (shape, NaN/inf or negative "
                 f"distances); ignored, recomputing")
            return None
    return dp.astype(np.float64), dq.astype(np.float64)


def save_cached(path: Path, key: dict, dist_pick: np.ndarray, dist_place: np.ndarray,
                stats: dict) -> None:
    """Atomically write the cache file (format in the module docstring)."""
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.savez(f, dist_pick=dist_pick, dist_place=dist_place,
                     key=np.array(json.dumps(key, sort_keys=True)),
                     stats=np.array(json.dumps(stats, sort_keys=True)))


@dataclass(frozen=True)
class DistanceResult:
    """Distances with their provenance (what ``vggc-cp distances`` prints)."""

    dist_pick: np.ndarray
    dist_place: np.ndarray
    path: Path | None
    cached: bool
    stats: dict = field(default_factory=dict)


def role_maps(trace: Trace, cfg: DistanceConfig,
              progress: Callable[[int], None] | None = None) -> np.ndarray:
    """Attention maps of every observation of ``trace``, ``(N, g*g)`` (never reads states)."""
    return attention_maps(trace.observations, cfg.backend, cfg.attention_params(), progress)


def distance_matrices(maps: np.ndarray, roles: np.ndarray, cfg: DistanceConfig,
                      on_done: Callable[[int], None] | None = None,
                      executor: Executor | None = None) -> tuple[np.ndarray, np.ndarray, dict]:
    """Within-role Sinkhorn divergences of given maps.

    Parameters
    ----------
    maps : ndarray, shape (N, g*g)
    roles : ndarray of int, shape (N,)
    on_done : callable, optional
        Called with the number of OT problems just finished.
    executor : vggc_cp.parallel.Executor, optional
        Where the row blocks of ``cfg.rows`` run (default: here).

    Returns
    -------
    dist_pick, dist_place : float64, symmetric, zero diagonal, non-negative
        Entries are ``max(S_eps, 0)``: at a converged plan ``S_eps`` of two near-identical maps
        can come out a rounding error below zero.
    stats : dict
        Per role, :class:`~vggc_cp.vision.sinkhorn.SinkhornStats` as a dict.
    """
    M = cost_matrix(cfg.grid)
    out, stats = [], {}
    for role, name in ((PICK, "pick"), (PLACE, "place")):
        h = maps[np.flatnonzero(roles == role)]
        if len(h) == 0:
            out.append(np.zeros((0, 0)))
            continue
        S, st = sinkhorn_divergence_matrix(
            h, M, cfg.eps, tol=cfg.tol, max_iter=cfg.max_iter, omega=cfg.omega,
            dtype=cfg.dtype, device=cfg.device, block=cfg.block, threads=cfg.threads,
            on_done=on_done, rows=cfg.rows, executor=executor)
        out.append(np.maximum(S, 0.0))
        stats[name] = asdict(st)
    return out[0], out[1], stats


def n_problems(roles: np.ndarray) -> int:
    """OT problems of the stage: ``m (m + 1) / 2`` per role of ``m`` observations."""
    total = 0
    for role in (PICK, PLACE):
        m = int(np.count_nonzero(roles == role))
        total += m * (m + 1) // 2
    return total


def compute_distances_full(trace: Trace, cfg: DistanceConfig | None = None,
                           cache_dir: str | Path | None = None, progress: bool = True,
                           executor: Executor | None = None) -> DistanceResult:
    """:func:`compute_distances` with provenance: cache path, hit or miss, statistics.

    ``executor`` (:func:`vggc_cp.parallel.open_executor`) runs the Sinkhorn row blocks of
    ``cfg.rows``; attention maps and the cache stay in this process."""
    from vggc_cp.safeio import cache_writable, check_grid

    cfg = cfg or DistanceConfig()
    check_grid(trace, cfg.grid)
    roles = trace.roles()
    n_pick = int(np.count_nonzero(roles == PICK))
    n_place = int(np.count_nonzero(roles == PLACE))
    path = key = None
    if cfg.use_cache:
        path, key = cache_path(trace, cfg, cache_dir)
        hit = load_cached(path, key, n_pick, n_place)
        if hit is not None:
            return DistanceResult(hit[0], hit[1], path, True)
    elif cfg.backend in NEEDS_WEIGHTS:
        cfg.key()  # fail early on missing weights
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=trace.n_obs, desc=f"attention ({cfg.backend})", unit="img",
                   leave=False)
    t0 = time.perf_counter()
    channels, kept = (colour_channel_maps(trace.observations, cfg.attention_params(),
                                          cfg.colour_min_share,
                                          keypoints=cfg.backend in KEYPOINT_BACKENDS)
                      if cfg.colour == "auto" else (np.zeros((trace.n_obs, 0, 1)), []))
    # keypoint colour channels hold every blob of the main map, each in its colour: the main
    # map would only add the colour-blind view of the same keypoints, so it is not computed
    main = not (cfg.backend in KEYPOINT_BACKENDS and kept)
    if main:
        maps = role_maps(trace, cfg, bar.update if bar is not None else None)
    elif bar is not None:
        bar.update(trace.n_obs)
    t_att = time.perf_counter() - t0
    if bar is not None:
        bar.close()
        bar = tqdm(total=n_problems(roles) * (len(kept) + int(main)), desc="sinkhorn", unit="pair",
                   unit_scale=True)
    t1 = time.perf_counter()
    stats = {}
    dp = dq = 0.0
    if main:
        dp, dq, stats = distance_matrices(maps, roles, cfg,
                                          bar.update if bar is not None else None, executor)
    for c, hue_bin in enumerate(kept):
        cp, cq, cstats = distance_matrices(channels[:, c], roles, cfg,
                                           bar.update if bar is not None else None, executor)
        dp, dq = dp + cp, dq + cq
        stats[f"colour_{hue_bin}"] = cstats
    if bar is not None:
        bar.close()
    stats["colour_bins"] = kept
    stats["seconds"] = {"attention": t_att, "sinkhorn": time.perf_counter() - t1}
    if cfg.use_cache and cache_writable(path):
        save_cached(path, key, dp, dq, stats)
    return DistanceResult(dp, dq, path, False, stats)


def compute_distances(trace: Trace, cfg: DistanceConfig | None = None,
                      cache_dir: str | Path | None = None, progress: bool = True
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Within-role visual distances of a trace, from the cache when possible.

    Parameters
    ----------
    trace : Trace
        Only observations and actions are read (never ``states``).
    cfg : DistanceConfig, optional
    cache_dir : path, optional
        Overrides ``cfg.cache_dir`` and the default (module docstring).
    progress : bool
        tqdm progress bars on stderr.

    Returns
    -------
    dist_pick : ndarray, float64, shape (n_pick, n_pick)
        Over the pick observations in the order ``np.flatnonzero(trace.roles() == 0)``;
        symmetric, zero diagonal, non-negative.
    dist_place : ndarray, float64, shape (n_place, n_place)
    """
    res = compute_distances_full(trace, cfg, cache_dir, progress)
    return res.dist_pick, res.dist_place
