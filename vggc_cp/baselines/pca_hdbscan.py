"""PCA-HDBSCAN roadmap: the paper's first baseline.

Every RGB observation is flattened and scaled to [0, 1]; one PCA (seeded randomized SVD) is
fit on all observations of the trace with the largest ``n_components`` of the grid, and the
first ``n`` components serve each grid point (principal components are nested). HDBSCAN
(:class:`sklearn.cluster.HDBSCAN`, Euclidean) then clusters the pick observations and the place
observations separately; one node per cluster; the edges are those induced by the observed
transitions (aggregated: an edge exists when some transition supports it).

Noise points (HDBSCAN label -1) are handled by ``noise``:

* ``"nearest"`` (default) — joins the cluster of its nearest non-noise observation of the
  same role in PCA space (a role where everything is noise becomes one node);
* ``"own"`` — becomes a node of its own.

The grid ``n_components x min_cluster_size x min_samples`` is swept and the graph chosen by
:func:`vggc_cp.baselines.base.select` (fewest Exactly-One violations, then fewest nodes).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from itertools import product

import numpy as np

from vggc_cp.baselines.base import (
    Baseline,
    Candidate,
    graph_stats,
    induced_graph,
    labels_from_roles,
    register_baseline,
    within_role_score,
)
from vggc_cp.errors import VggcError
from vggc_cp.trace import PICK, PLACE, Trace

NOISE_MODES = ("nearest", "own")


def pca_features(observations: np.ndarray, n_components: int, seed: int = 0) -> np.ndarray:
    """PCA scores of flattened observations.

    Parameters
    ----------
    observations : ndarray of uint8, shape (N, H, W, 3)
    n_components : int
        Clipped to ``min(N, H*W*3)``.
    seed : int
        Seed of the randomized SVD.

    Returns
    -------
    ndarray of float64, shape (N, n_components')
    """
    from sklearn.decomposition import PCA

    x = observations.reshape(len(observations), -1).astype(np.float64) / 255.0
    k = int(max(1, min(n_components, x.shape[0], x.shape[1])))
    if x.shape[0] < 2:
        return np.zeros((x.shape[0], k))
    pca = PCA(n_components=k, svd_solver="randomized", random_state=seed)
    return pca.fit_transform(x)


def assign_noise(features: np.ndarray, clusters: np.ndarray, mode: str) -> np.ndarray:
    """Resolve HDBSCAN noise (-1) in ``clusters`` (shape (n,)) by ``mode`` (see module doc)."""
    clusters = np.asarray(clusters, dtype=np.int64).copy()
    noise = np.flatnonzero(clusters < 0)
    if len(noise) == 0:
        return clusters
    if mode == "own":
        clusters[noise] = clusters.max(initial=-1) + 1 + np.arange(len(noise))
        return clusters
    core = np.flatnonzero(clusters >= 0)
    if len(core) == 0:
        return np.zeros_like(clusters)
    d = ((features[noise, None, :] - features[None, core, :]) ** 2).sum(-1)
    clusters[noise] = clusters[core[np.argmin(d, axis=1)]]
    return clusters


def hdbscan_clusters(features: np.ndarray, min_cluster_size: int, min_samples: int | None,
                     noise: str) -> np.ndarray:
    """HDBSCAN cluster of every row of ``features`` (shape (n, F)), noise resolved.

    A role with fewer observations than ``min_cluster_size`` is one cluster.
    """
    from sklearn.cluster import HDBSCAN

    n = len(features)
    if n < max(2, min_cluster_size, min_samples or 0):
        return np.zeros(n, dtype=np.int64)
    model = HDBSCAN(min_cluster_size=min_cluster_size, min_samples=min_samples,
                    metric="euclidean", copy=True)
    return assign_noise(features, model.fit_predict(features), noise)


@dataclass(frozen=True)
class PcaHdbscanConfig:
    """Sweep grid and options of :class:`PcaHdbscanRoadmap`.

    Attributes
    ----------
    n_components : tuple of int
        PCA dimensions tried.
    min_cluster_size : tuple of int
        HDBSCAN ``min_cluster_size`` values (>= 2).
    min_samples : tuple of int or None
        HDBSCAN ``min_samples`` values (None: equal to ``min_cluster_size``).
    noise : str
        ``"nearest"`` or ``"own"`` (module doc).
    seed : int
        Seed of the PCA's randomized SVD.
    """

    n_components: tuple[int, ...] = (8, 16, 32)
    min_cluster_size: tuple[int, ...] = (2, 3, 5, 8)
    min_samples: tuple[int | None, ...] = (1, None)
    noise: str = "nearest"
    seed: int = 0

    def __post_init__(self) -> None:
        if self.noise not in NOISE_MODES:
            raise VggcError(f"unknown noise handling {self.noise!r}; known: "
                            f"{', '.join(NOISE_MODES)}")
        if not self.n_components or min(self.n_components) < 1:
            raise VggcError("n_components must hold positive integers")
        if not self.min_cluster_size or min(self.min_cluster_size) < 2:
            raise VggcError("min_cluster_size must hold integers >= 2")
        if not self.min_samples or any(m is not None and m < 1 for m in self.min_samples):
            raise VggcError("min_samples must hold positive integers or None")


@register_baseline
class PcaHdbscanRoadmap(Baseline):
    """PCA of the observations, HDBSCAN per role, edges from the transitions (module doc)."""

    name = "pca-hdbscan"

    config_class = PcaHdbscanConfig

    def __init__(self, config: PcaHdbscanConfig | None = None, **options) -> None:
        self.config = config or PcaHdbscanConfig(**options)

    def _work(self) -> tuple[int, str]:
        cfg = self.config
        return len(cfg.n_components) * len(cfg.min_cluster_size) * len(cfg.min_samples), "point"

    def _sweep(self, trace: Trace, advance: Callable[[int], object]) -> list[Candidate]:
        cfg = self.config
        t0 = time.perf_counter()
        full = pca_features(trace.observations, max(cfg.n_components), cfg.seed)
        pca_seconds = time.perf_counter() - t0
        roles = trace.roles()
        pick, place = np.flatnonzero(roles == PICK), np.flatnonzero(roles == PLACE)
        out: list[Candidate] = []
        for i, (nc, mcs, ms) in enumerate(product(cfg.n_components, cfg.min_cluster_size,
                                                  cfg.min_samples)):
            t1 = time.perf_counter()
            feats = full[:, :nc]
            labels = labels_from_roles(
                roles,
                hdbscan_clusters(feats[pick], mcs, ms, cfg.noise),
                hdbscan_clusters(feats[place], mcs, ms, cfg.noise))
            stats = graph_stats(induced_graph(trace, labels))
            J = within_role_score(roles, labels, feats, p=2)
            seconds = time.perf_counter() - t1 + (pca_seconds if i == 0 else 0.0)
            params = {"n_components": int(feats.shape[1]), "min_cluster_size": int(mcs),
                      "min_samples": None if ms is None else int(ms), "noise": cfg.noise}
            out.append(Candidate(params, labels, stats, J, seconds))
            advance(1)
        return out
