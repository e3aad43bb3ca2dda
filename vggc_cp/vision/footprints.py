"""Action footprints: visual evidence localized by the trace's own actions (beyond the paper).

A pick or a place changes the scene in one place. Averaging ``|o_{t+1} - o_t|`` over the
transitions of one action ``a`` gives the image area that ``a`` acts on, its *footprint*
``F_a``; the part that every action shares (the gripper taking or releasing an object) is
removed by subtracting the per-pixel median over actions. Each observation is then described
by the mean colour it shows inside every footprint, ``c_a(o) = sum_p F_a(p) x_o(p)`` (shape
``(A, 3)``), after dividing each frame by its per-channel median (a per-frame lighting gain
and tint cancel). Two renders of one state show the same things in every footprint; two
states differ by an object that is present in one footprint and absent in another.

The distance counts the footprints that changed. The change in footprint ``a`` is measured
in units of the action's *contrast* ``k_a`` (the median change of ``c_a`` across the action's
own transitions, an object present against absent) and mapped to ``[0, 1]`` by a soft step
that treats changes below ``noise_floor`` as noise and counts anything above
``noise_floor + saturation`` as a whole change (an apple and a strawberry of one task class
in one place differ by a fraction of ``k_a``)::

    z_a(o, o') = || c_a(o) - c_a(o') || / k_a
    d(o, o')   = mean over taken actions a of clip((z_a - noise_floor) / saturation, 0, 1)

Nothing here reads ground-truth states, and nothing needs weights: the trace supervises the
metric (the actions say where the state can differ), so the same code adapts to another
table, camera or lighting. Cost: one pass over the transitions and ``O(A N^2)`` for the
distances (fruit-6x8, |D| = 1500: a few seconds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.trace import PICK, PLACE, Trace


@dataclass(frozen=True)
class FootprintParams:
    """Settings of the footprint evidence.

    Attributes
    ----------
    noise_floor : float
        Change in a footprint, in units of the action's contrast, treated as rendering noise.
    saturation : float
        Change above ``noise_floor`` (same units) that counts as one whole change.
    prior_transitions : float
        Shrinks the contrast of a rarely taken action towards the median contrast, as if
        this many transitions had shown the median.
    """

    noise_floor: float = 0.15
    saturation: float = 0.5
    prior_transitions: float = 3.0

    def __post_init__(self) -> None:
        if not self.noise_floor >= 0:
            raise VggcError(f"noise_floor must be >= 0, got {self.noise_floor}")
        if not self.saturation > 0:
            raise VggcError(f"saturation must be > 0, got {self.saturation}")
        if not self.prior_transitions >= 0:
            raise VggcError(f"prior_transitions must be >= 0, got {self.prior_transitions}")


@dataclass(frozen=True, eq=False)
class Footprints:
    """Footprints of a trace's actions and the observations' descriptors.

    Attributes
    ----------
    maps : ndarray of float32, shape (A, H, W)
        ``F_a``, each summing to 1; all zeros for an action the trace never takes.
    features : ndarray of float32, shape (N, A, 3)
        ``c_a(o)``: mean normalized colour of every observation inside every footprint.
    contrast : ndarray of float64, shape (A,)
        ``k_a``, the typical change of ``c_a`` across the action's own transitions.
    counts : ndarray of int64, shape (A,)
        Transitions of every action.
    """

    maps: np.ndarray
    features: np.ndarray
    contrast: np.ndarray
    counts: np.ndarray

    @property
    def taken(self) -> np.ndarray:
        """Indices of the actions the trace takes at least once."""
        return np.flatnonzero(self.counts > 0)


def normalise_frames(observations: np.ndarray, chunk: int = 512) -> np.ndarray:
    """Divide each frame by its per-channel median (cancels a per-frame gain and tint).

    Parameters
    ----------
    observations : ndarray of uint8, shape (N, H, W, 3)

    Returns
    -------
    ndarray of float32, shape (N, H, W, 3)
    """
    n = len(observations)
    out = np.empty(observations.shape, dtype=np.float32)
    for s in range(0, n, chunk):
        x = observations[s:s + chunk].astype(np.float32) / 255.0
        med = np.median(x.reshape(len(x), -1, 3), axis=1)
        out[s:s + chunk] = x / np.maximum(med, 1e-3)[:, None, None, :]
    return out


def action_footprints(trace: Trace, params: FootprintParams | None = None) -> Footprints:
    """Footprints of every action of ``trace`` and the descriptors of its observations.

    Raises
    ------
    VggcError
        When the trace has no transition.
    """
    params = params or FootprintParams()
    src, act, dst = trace.transitions()
    if len(act) == 0:
        raise VggcError("footprint evidence needs at least one transition")
    x = normalise_frames(trace.observations)
    n_act = trace.n_actions
    h, w = x.shape[1:3]
    maps = np.zeros((n_act, h, w), dtype=np.float32)
    counts = np.bincount(act, minlength=n_act).astype(np.int64)
    for a in np.flatnonzero(counts):
        sel = act == a
        maps[a] = np.abs(x[dst[sel]] - x[src[sel]]).sum(axis=-1).mean(axis=0)
    taken = counts > 0
    shared = np.median(maps[taken], axis=0)
    maps = np.maximum(maps - shared, 0.0)
    maps[~taken] = 0.0
    total = maps.sum(axis=(1, 2), keepdims=True)
    maps = np.where(total > 0, maps / np.maximum(total, 1e-12), 0.0).astype(np.float32)
    features = np.einsum("nhwc,ahw->nac", x, maps, optimize=True).astype(np.float32)
    contrast = _contrast(features, src, act, dst, counts, params.prior_transitions)
    return Footprints(maps, features, contrast, counts)


def _contrast(features, src, act, dst, counts, prior: float) -> np.ndarray:
    """Median change of each action's descriptor over its own transitions, shrunk towards
    the median over actions for rarely taken ones."""
    n_act = len(counts)
    raw = np.full(n_act, np.nan)
    for a in np.flatnonzero(counts):
        sel = act == a
        change = np.linalg.norm(features[dst[sel], a] - features[src[sel], a], axis=-1)
        raw[a] = float(np.median(change))
    med = float(np.nanmedian(raw)) if np.isfinite(raw).any() else 1.0
    med = med if med > 0 else 1.0
    raw = np.where(np.isfinite(raw), raw, med)
    shrunk = (counts * raw + prior * med) / np.maximum(counts + prior, 1e-12)
    return np.maximum(shrunk, 1e-6)


def footprint_distance_matrix(features: np.ndarray, contrast: np.ndarray, taken: np.ndarray,
                              params: FootprintParams | None = None) -> np.ndarray:
    """Pairwise footprint distances of one set of observations.

    Parameters
    ----------
    features : ndarray, shape (n, A, 3)
    contrast : ndarray, shape (A,)
    taken : ndarray of int
        Actions whose footprints count.

    Returns
    -------
    ndarray of float64, shape (n, n), symmetric, zero diagonal, values in [0, 1].
    """
    params = params or FootprintParams()
    n = len(features)
    d = np.zeros((n, n), dtype=np.float64)
    if n == 0 or len(taken) == 0:
        return d
    for a in taken:
        g = features[:, a, :].astype(np.float64) / contrast[a]
        sq = (g * g).sum(axis=1)
        z2 = np.maximum(sq[:, None] + sq[None, :] - 2.0 * (g @ g.T), 0.0)
        d += np.clip((np.sqrt(z2) - params.noise_floor) / params.saturation, 0.0, 1.0)
    d /= len(taken)
    np.fill_diagonal(d, 0.0)
    return d


def footprint_distances(trace: Trace, params: FootprintParams | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Within-role footprint distances of ``trace``: ``(dist_pick, dist_place)``, rows in the
    order of ``flatnonzero(roles == PICK)`` and ``flatnonzero(roles == PLACE)``."""
    params = params or FootprintParams()
    fp = action_footprints(trace, params)
    roles = trace.roles()
    return tuple(footprint_distance_matrix(fp.features[roles == role], fp.contrast, fp.taken,
                                           params) for role in (PICK, PLACE))
