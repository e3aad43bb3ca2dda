"""Action footprints: visual evidence localized by the trace's own actions (beyond the paper).

A pick or a place changes the scene in one place. Averaging ``|o_{t+1} - o_t|`` over the
transitions of one action ``a`` gives the image area that ``a`` acts on, its *footprint*
``F_a`` (shape ``(H, W)``, summing to 1). Three things are removed first: the part every action
shares (the per-pixel median over actions), the gripper (pixels where the mean pick
observation and the mean place observation differ by more than ``gripper`` of their largest
difference: what the gripper holds is implied by what stands on the table), and the faint
floor that sensor noise leaves everywhere (``support`` of the footprint's peak). Frames are
divided by their per-channel median first, so a per-frame lighting gain and tint cancel.

The trace also says what the footprint looks like *empty*: after a pick of ``a`` (before a
place of ``a``) the object is gone. With ``e_a`` the mean of those observations, every
observation ``o`` is described in every footprint by

* its **presence** ``p_a(o)``: the deviation ``m_a(o) = sum_p F_a(p) |x_o(p) - e_a(p)|_1``
  scaled so that the median over the action's empty observations is 0 and ``saturation``
  times the median over its occupied ones (before a pick, after a place) is 1, clipped to
  ``[0, 1]``. Objects of one task class differ in size and shape; clipping at a fraction of
  the typical object makes any of them count as present;
* its **chroma** ``c_a(o)``: the chromaticity ``(r, g) / (r + g + b)`` of the mean colour of
  the deviating pixels (weights ``F_a(p) |x_o(p) - e_a(p)|_1``), which tells a red object from
  a yellow one whatever their shapes. The objects an action ``a`` moves are of one task class,
  so the spread ``s_a`` of their chroma (the 75th percentile of the occupied observations'
  chroma distances from their median, at least 0.02) is what one class varies by (shades,
  stems, lighting, placement); a chroma difference counts from ``chroma`` times ``s_a`` on
  and in full from twice that.

Two renders of one state agree in every footprint; two states differ by an object present in
one footprint and absent in another, or of another colour. The distance counts the footprints
that differ::

    k_a(o, o') = clip((|c_a(o) - c_a(o')| - chroma s_a) / (chroma s_a), 0, 1)
    d_a(o, o') = min(1, |p_a(o) - p_a(o')| + min(p_a(o), p_a(o')) k_a(o, o'))
    d(o, o')   = mean over the actions a that the trace takes of d_a(o, o')

Nothing here reads ground-truth states, and nothing needs weights: the trace supervises the
metric (its actions say where states can differ and what empty looks like), so the same code
adapts to another table, camera or lighting. Cost: one pass over the transitions and
``O(A N^2)`` for the distances (fruit-6x8, |D| = 1500: seconds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.trace import PICK, PLACE, Trace


@dataclass(frozen=True)
class FootprintParams:
    """Settings of the footprint evidence (module docstring).

    Attributes
    ----------
    gripper : float
        Pixels whose pick/place mean difference exceeds this share of its maximum are the
        gripper's and leave every footprint.
    support : float
        Share of a footprint's peak subtracted from it (sensor noise leaves a faint floor of
        changes over the whole image).
    saturation : float
        Share of the typical occupied deviation at which presence reaches 1.
    chroma : float
        Multiple of an action's within-class chroma spread ``s_a`` that a difference may
        reach before it counts (in full from twice that).
    spread_quantile, spread_floor : float
        ``s_a`` is this quantile of the occupied observations' chroma distances from their
        median, and at least the floor (identical objects would otherwise make placement
        jitter, which mixes the table into the footprint, count as another colour).
    """

    gripper: float = 0.5
    support: float = 0.2
    saturation: float = 0.5
    chroma: float = 2.0
    spread_quantile: float = 0.75
    spread_floor: float = 0.02

    def __post_init__(self) -> None:
        for name in ("gripper", "support"):
            v = getattr(self, name)
            if not 0 <= v < 1:
                raise VggcError(f"footprint {name} must lie in [0, 1), got {v}")
        if not 0 < self.spread_quantile <= 1:
            raise VggcError(f"footprint spread_quantile must lie in (0, 1], got "
                            f"{self.spread_quantile}")
        for name in ("saturation", "chroma", "spread_floor"):
            v = getattr(self, name)
            if not v > 0:
                raise VggcError(f"footprint {name} must be positive, got {v}")


@dataclass(frozen=True, eq=False)
class Footprints:
    """Footprints of a trace's actions and the observations' descriptors.

    Attributes
    ----------
    maps : ndarray of float32, shape (A, H, W)
        ``F_a``, each summing to 1; all zeros for an action the trace never takes.
    presence : ndarray of float64, shape (N, A)
        ``p_a(o)`` in ``[0, 1]``.
    chroma : ndarray of float64, shape (N, A, 2)
        ``c_a(o)``.
    spread : ndarray of float64, shape (A,)
        ``s_a``, the chroma spread of the action's occupied observations.
    counts : ndarray of int64, shape (A,)
        Transitions of every action.
    """

    maps: np.ndarray
    presence: np.ndarray
    chroma: np.ndarray
    spread: np.ndarray
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
    out = np.empty(observations.shape, dtype=np.float32)
    for s in range(0, len(observations), chunk):
        x = observations[s:s + chunk].astype(np.float32) / 255.0
        med = np.median(x.reshape(len(x), -1, 3), axis=1)
        out[s:s + chunk] = x / np.maximum(med, 1e-3)[:, None, None, :]
    return out


def footprint_maps(x: np.ndarray, roles: np.ndarray, src: np.ndarray, act: np.ndarray,
                   dst: np.ndarray, n_actions: int, params: FootprintParams) -> np.ndarray:
    """``F_a`` of every action (module docstring), shape ``(A, H, W)``."""
    h, w = x.shape[1:3]
    maps = np.zeros((n_actions, h, w), dtype=np.float32)
    counts = np.bincount(act, minlength=n_actions)
    for a in np.flatnonzero(counts):
        sel = act == a
        maps[a] = np.abs(x[dst[sel]] - x[src[sel]]).sum(axis=-1).mean(axis=0)
    taken = counts > 0
    maps = np.maximum(maps - np.median(maps[taken], axis=0), 0.0)
    if (roles == PICK).any() and (roles == PLACE).any():
        diff = np.abs(x[roles == PLACE].mean(axis=0) - x[roles == PICK].mean(axis=0)).sum(-1)
        maps[:, diff > params.gripper * diff.max()] = 0.0
    maps[~taken] = 0.0
    maps = np.maximum(maps - params.support * maps.max(axis=(1, 2), keepdims=True), 0.0)
    total = maps.sum(axis=(1, 2), keepdims=True)
    return np.where(total > 0, maps / np.maximum(total, 1e-12), 0.0).astype(np.float32)


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
    maps = footprint_maps(x, trace.roles(), src, act, dst, n_act, params)
    kinds = trace.action_kinds()
    counts = np.bincount(act, minlength=n_act).astype(np.int64)
    presence = np.zeros((trace.n_obs, n_act))
    chroma = np.zeros((trace.n_obs, n_act, 2))
    spread = np.ones(n_act)
    for a in np.flatnonzero(counts):
        sel = act == a
        empty, occupied = (dst[sel], src[sel]) if kinds[a] == PICK else (src[sel], dst[sel])
        support = maps[a] > 0
        if not support.any():
            continue
        weight = maps[a][support]                       # (P,)
        pixels = x[:, support]                          # (N, P, 3)
        dev = np.abs(pixels - pixels[empty].mean(axis=0)).sum(axis=-1)  # (N, P)
        mag = dev @ weight
        lo, hi = np.median(mag[empty]), np.median(mag[occupied])
        presence[:, a] = np.clip((mag - lo) / max(params.saturation * (hi - lo), 1e-9), 0, 1)
        wdev = dev * weight
        colour = np.einsum("np,npc->nc", wdev, pixels) / np.maximum(wdev.sum(1), 1e-12)[:, None]
        chroma[:, a] = colour[:, :2] / np.maximum(colour.sum(axis=1, keepdims=True), 1e-12)
        own = chroma[occupied, a]
        spread[a] = max(float(np.quantile(np.linalg.norm(own - np.median(own, axis=0), axis=1),
                                          params.spread_quantile)), params.spread_floor)
    return Footprints(maps, presence, chroma, spread, counts)


def footprint_distance_matrix(presence: np.ndarray, chroma: np.ndarray, spread: np.ndarray,
                              taken: np.ndarray, params: FootprintParams | None = None
                              ) -> np.ndarray:
    """Pairwise footprint distances of one set of observations.

    Parameters
    ----------
    presence : ndarray, shape (n, A)
    chroma : ndarray, shape (n, A, 2)
    spread : ndarray, shape (A,)
    taken : ndarray of int
        Actions whose footprints count.

    Returns
    -------
    ndarray of float64, shape (n, n), symmetric, zero diagonal, values in [0, 1].
    """
    params = params or FootprintParams()
    n = len(presence)
    d = np.zeros((n, n), dtype=np.float64)
    if n == 0 or len(taken) == 0:
        return d
    for a in taken:
        p = presence[:, a]
        c = chroma[:, a]
        free = params.chroma * spread[a]
        dc = np.sqrt(((c[:, None, :] - c[None, :, :]) ** 2).sum(axis=-1))
        other = np.clip((dc - free) / free, 0.0, 1.0)
        both = np.minimum(p[:, None], p[None, :])
        d += np.minimum(np.abs(p[:, None] - p[None, :]) + both * other, 1.0)
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
    return tuple(footprint_distance_matrix(fp.presence[roles == role], fp.chroma[roles == role],
                                           fp.spread, fp.taken, params)
                 for role in (PICK, PLACE))
