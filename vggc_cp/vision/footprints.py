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

from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage

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
    calibrate: bool = True
    colour: str = "classes"
    mask: str = "shared"
    one_place: bool = True
    held: float = 2.0
    site: bool = True
    site_overlap: float = 0.2
    widen: float = 0.0
    nuisance_quantile: float = 0.9

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
    nuisance: np.ndarray | None = None
    posterior: np.ndarray | None = None

    @property
    def colour(self) -> np.ndarray:
        """What the distance compares of the colour: class posteriors when computed, else
        chroma."""
        return self.chroma if self.posterior is None else self.posterior

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
    shared = np.median(maps[taken], axis=0)
    if params.mask == "shared":
        peak = maps[taken].max(axis=0)
        gripper = shared > params.gripper * np.maximum(peak, 1e-12)
    maps = np.maximum(maps - shared, 0.0)
    if params.mask == "shared":
        maps[:, gripper] = 0.0
    if params.held > 0 and (roles == PICK).sum() > 1 and (roles == PLACE).sum() > 1:
        # what the gripper holds varies (shapes, sizes): pixels that vary far more while
        # holding (place role) than with the hand empty (pick role) are the gripper's
        holding = x[roles == PLACE].std(axis=0).sum(axis=-1)          # (H, W)
        empty = x[roles == PICK].std(axis=0).sum(axis=-1)
        maps[:, holding > params.held * empty + np.median(empty)] = 0.0
    elif (roles == PICK).any() and (roles == PLACE).any():
        diff = np.abs(x[roles == PLACE].mean(axis=0) - x[roles == PICK].mean(axis=0)).sum(-1)
        maps[:, diff > params.gripper * diff.max()] = 0.0
    maps[~taken] = 0.0
    maps = np.maximum(maps - params.support * maps.max(axis=(1, 2), keepdims=True), 0.0)
    if params.one_place:
        for a in np.flatnonzero(taken):
            maps[a] = heaviest_component(maps[a])
    total = maps.sum(axis=(1, 2), keepdims=True)
    return np.where(total > 0, maps / np.maximum(total, 1e-12), 0.0).astype(np.float32)


def overlaps(maps: np.ndarray) -> np.ndarray:
    """``ov(a, b) = sum_p min(F_a(p), F_b(p))`` in ``[0, 1]``, shape (A, A): how much two
    footprints share a place."""
    flat = maps.reshape(len(maps), -1).astype(np.float64)
    return np.stack([np.minimum(flat[a], flat).sum(axis=-1) for a in range(len(flat))])


def site_maps(maps: np.ndarray, ov: np.ndarray, widen: float = 0.0) -> np.ndarray:
    """Each footprint widened to its *site*: ``G_a = sum_b ov(a, b) F_b`` (normalized).
    Actions at one place (a pick and a place, or the actions of two classes there) overlap
    and share one site, which covers the shapes of every class the place holds; footprints
    elsewhere do not overlap. Shape (A, H, W).
    """
    flat = maps.reshape(len(maps), -1).astype(np.float64)
    site = (ov @ flat).reshape(maps.shape)
    if widen > 0:
        # objects land anywhere near their place (placement noise): widen each site by its
        # own radius, so that an object a little off its usual spot still lies inside
        for a in range(len(site)):
            npix = np.count_nonzero(site[a])
            if npix:
                site[a] = ndimage.gaussian_filter(site[a], widen * np.sqrt(npix / np.pi))
    total = site.sum(axis=(1, 2), keepdims=True)
    site = np.where(total > 0, site / np.maximum(total, 1e-12), 0.0)
    return site.astype(np.float32)


def heaviest_component(m: np.ndarray) -> np.ndarray:
    """``m`` (shape (H, W), non-negative) kept on its connected component (8-neighbours) of
    largest mass: an action acts in one place; scattered residue elsewhere is not its."""
    lab, n = ndimage.label(m > 0, structure=np.ones((3, 3)))
    if n <= 1:
        return m
    mass = ndimage.sum(m, lab, index=np.arange(1, n + 1))
    return np.where(lab == 1 + int(np.argmax(mass)), m, 0.0)


def action_classes(trace: Trace) -> np.ndarray:
    """Task class of every action, int64 array of shape (A,), from the trace's structure.

    What a pick lifts is what the next place puts down: a pick and the place that follows it
    (the two actions around one place-role observation) move an object of one class. The
    classes are the connected components of that relation (union-find); an action never
    followed or preceded that way is a class of its own. Names are not read.
    """
    parent = np.arange(trace.n_actions)

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return int(a)

    kinds = trace.action_kinds()
    acts = trace.actions
    prev, nxt = acts[:-1], acts[1:]
    link = (prev >= 0) & (nxt >= 0)
    for a, b in zip(prev[link], nxt[link]):
        if kinds[a] == PICK and kinds[b] == PLACE:
            ra, rb = find(int(a)), find(int(b))
            if ra != rb:
                parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(a) for a in range(trace.n_actions)], dtype=np.int64)
    return np.unique(roots, return_inverse=True)[1].astype(np.int64)


def colour_classes(points: list[np.ndarray], floor: float, quantile: float,
                   apart: float = 2.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pool task classes whose colours cannot be told apart.

    Parameters
    ----------
    points : list of ndarray, shape (n_k, 2)
        Chroma of each task class's occupied observations.
    floor, quantile : float
        A class's spread ``s_k`` is the ``quantile`` of its points' distances from their
        median, at least ``floor``.
    apart : float
        Two classes whose medians are closer than ``apart`` times the larger spread are one
        colour (e.g. an action the trace never links to a class, or two classes of one colour).

    Returns
    -------
    group : ndarray of int, shape (K,)
        Colour of every task class.
    mu : ndarray, shape (C, 2)
    sd : ndarray, shape (C,)
    """
    group = np.arange(len(points))

    def stats(members):
        pts = np.concatenate([points[k] for k in members])
        m = np.median(pts, axis=0)
        return m, max(float(np.quantile(np.linalg.norm(pts - m, axis=1), quantile)), floor)

    while True:
        ids = np.unique(group)
        st = {g: stats(np.flatnonzero(group == g)) for g in ids}
        close = [(np.linalg.norm(st[g][0] - st[h][0]) / max(st[g][1], st[h][1]), g, h)
                 for i, g in enumerate(ids) for h in ids[i + 1:]]
        close = [c for c in close if c[0] < apart]
        if not close:
            break
        _, g, h = min(close)
        group[group == h] = g
    ids, group = np.unique(group, return_inverse=True)
    mu = np.array([st[g][0] for g in ids]).reshape(-1, 2)
    sd = np.array([st[g][1] for g in ids])
    return group, mu, sd


def action_colours(chroma: np.ndarray, counts: np.ndarray, classes: np.ndarray,
                   occupied: dict[int, np.ndarray], floor: float, quantile: float
                   ) -> tuple[np.ndarray, list[np.ndarray]]:
    """Colour of every action, and every colour's examples.

    The task classes (:func:`action_classes`) with observations are pooled into colours
    (:func:`colour_classes`); a colour's examples are the chroma of its actions' occupied
    observations, each seen in its own action's footprint. Returns ``(colour, examples)``:
    shape (A,) (-1 for an action never taken) and one (n_c, 2) array per colour.
    """
    colour = np.full(len(counts), -1, dtype=np.int64)
    known = [k for k in np.unique(classes)
             if any(counts[a] > 0 for a in np.flatnonzero(classes == k))]
    if not known:
        return colour, []
    points = [np.concatenate([chroma[occupied[a], a]
                              for a in np.flatnonzero((classes == k) & (counts > 0))])
              for k in known]
    group, _, _ = colour_classes(points, floor, quantile)
    for k, g in zip(known, group):
        colour[(classes == k) & (counts > 0)] = g
    examples = [np.concatenate([p for p, g in zip(points, group) if g == c])
                for c in range(int(group.max()) + 1)]
    return colour, examples


def colour_posteriors(chroma: np.ndarray, examples: list[np.ndarray], bandwidth: float,
                      chunk: int = 256) -> np.ndarray:
    """Posterior of every colour for the colour seen in every footprint, shape (N, A, C).

    Each colour's likelihood is a kernel density over its examples (Gaussian kernel of width
    ``bandwidth``): a class of several looks (an apple and a strawberry are both red) keeps
    every look, which one prototype and spread would not. Equal priors. One colour (or
    none): all ones, colour carries no information.
    """
    n, n_act = chroma.shape[:2]
    if len(examples) <= 1:
        return np.ones((n, n_act, 1))
    flat = chroma.reshape(-1, 2)
    logp = np.empty((len(flat), len(examples)))
    for c, ex in enumerate(examples):
        for s in range(0, len(flat), chunk):
            d2 = ((flat[s:s + chunk, None, :] - ex[None]) ** 2).sum(-1) / bandwidth ** 2
            m = (-0.5 * d2).max(axis=1)
            logp[s:s + chunk, c] = m + np.log(np.exp(-0.5 * d2 - m[:, None]).mean(axis=1))
    w = np.exp(logp - logp.max(axis=1, keepdims=True))
    return (w / w.sum(axis=1, keepdims=True)).reshape(n, n_act, len(examples))


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
    ov = overlaps(maps)
    seen = site_maps(maps, ov, params.widen) if params.site else maps
    kinds = trace.action_kinds()
    counts = np.bincount(act, minlength=n_act).astype(np.int64)
    mag = np.zeros((trace.n_obs, n_act))
    lo = np.zeros(n_act)
    chroma = np.zeros((trace.n_obs, n_act, 2))
    spread = np.ones(n_act)
    occupied_of: dict[int, np.ndarray] = {}
    for a in np.flatnonzero(counts):
        sel = act == a
        empty, occupied = (dst[sel], src[sel]) if kinds[a] == PICK else (src[sel], dst[sel])
        occupied_of[int(a)] = occupied
        support = seen[a] > 0
        if not support.any():
            continue
        weight = seen[a][support]                       # (P,)
        pixels = x[:, support]                          # (N, P, 3)
        dev = np.abs(pixels - pixels[empty].mean(axis=0)).sum(axis=-1)  # (N, P)
        mag[:, a] = dev @ weight
        lo[a] = np.median(mag[empty, a])
        wdev = dev * weight
        mean = np.einsum("np,npc->nc", wdev, pixels) / np.maximum(wdev.sum(1), 1e-12)[:, None]
        chroma[:, a] = mean[:, :2] / np.maximum(mean.sum(axis=1, keepdims=True), 1e-12)
        own = chroma[occupied, a]
        spread[a] = max(float(np.quantile(np.linalg.norm(own - np.median(own, axis=0), axis=1),
                                          params.spread_quantile)), params.spread_floor)
    colour, examples = action_colours(chroma, counts, action_classes(trace), occupied_of,
                                      params.spread_floor, params.spread_quantile)
    presence = np.zeros((trace.n_obs, n_act))
    for a in occupied_of:
        # objects of another colour at this place (another shape and contrast) count as
        # present as fully as the action's own: the faintest typical object there sets 1
        mates = [b for b in occupied_of
                 if b == a or (ov[a, b] >= params.site_overlap and colour[b] != colour[a])]
        hi = min(np.median(mag[occupied_of[b], a]) for b in mates)
        presence[:, a] = np.clip((mag[:, a] - lo[a]) / max(params.saturation * (hi - lo[a]),
                                                           1e-9), 0, 1)
    posterior = (colour_posteriors(chroma, examples, params.spread_floor)
                 if params.colour == "classes" else None)
    fp = Footprints(maps, presence, chroma, spread, counts, posterior=posterior)
    if not params.calibrate:
        return fp
    return replace(fp, nuisance=footprint_nuisance(fp, src, act, dst, params))


def footprint_differences(p: np.ndarray, q: np.ndarray, c: np.ndarray, e: np.ndarray,
                          spread: np.ndarray, params: FootprintParams) -> np.ndarray:
    """``d_a(o, o')`` of aligned descriptors (module docstring), broadcasting.

    Parameters
    ----------
    p, q : ndarray, shape (..., A)
        Presence of ``o`` and ``o'``.
    c, e : ndarray, shape (..., A, 2)
        Chroma of ``o`` and ``o'``.
    spread : ndarray, shape (A,)

    Returns
    -------
    ndarray, shape (..., A), values in [0, 1].
    """
    if params.colour == "classes":
        other = 0.5 * np.abs(c - e).sum(axis=-1)
    else:
        free = params.chroma * spread
        dc = np.sqrt(((c - e) ** 2).sum(axis=-1))
        other = np.clip((dc - free) / free, 0.0, 1.0)
    return np.minimum(np.abs(p - q) + np.minimum(p, q) * other, 1.0)


def footprint_distance_matrix(presence: np.ndarray, chroma: np.ndarray, spread: np.ndarray,
                              taken: np.ndarray, params: FootprintParams | None = None,
                              nuisance: np.ndarray | None = None) -> np.ndarray:
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
        p, c = presence[:, a], chroma[:, a]
        da = footprint_differences(p[:, None], p[None, :], c[:, None, :], c[None, :, :],
                                   spread[a], params)
        if nuisance is not None and nuisance[a] > 0:
            da = np.clip((da - nuisance[a]) / max(1.0 - nuisance[a], 1e-9), 0.0, 1.0)
        d += da
    d /= len(taken)
    np.fill_diagonal(d, 0.0)
    return d


def footprint_nuisance(fp: Footprints, src: np.ndarray, act: np.ndarray, dst: np.ndarray,
                       params: FootprintParams) -> np.ndarray:
    """``nu_b``: how much footprint ``b`` differs across a transition that does not act on it.

    ``d_b(o_t, o_{t+1})`` over the transitions of action ``a``, at the ``nuisance_quantile``,
    then the median over the actions: most actions act elsewhere, so the median is what noise,
    the gripper and lighting leave in ``b``. Returns shape (A,).
    """
    col = fp.colour
    dif = footprint_differences(fp.presence[src], fp.presence[dst], col[src], col[dst],
                                fp.spread, params)          # (T, A)
    per_action = np.stack([np.quantile(dif[act == a], params.nuisance_quantile, axis=0)
                           for a in fp.taken])                            # (A_taken, A)
    nu = np.median(per_action, axis=0)
    out = np.zeros(len(fp.counts))
    out[fp.taken] = nu[fp.taken]
    return out


def footprint_distances(trace: Trace, params: FootprintParams | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Within-role footprint distances of ``trace``: ``(dist_pick, dist_place)``, rows in the
    order of ``flatnonzero(roles == PICK)`` and ``flatnonzero(roles == PLACE)``."""
    params = params or FootprintParams()
    fp = action_footprints(trace, params)
    roles = trace.roles()
    return tuple(footprint_distance_matrix(fp.presence[roles == role], fp.colour[roles == role],
                                           fp.spread, fp.taken, params, fp.nuisance)
                 for role in (PICK, PLACE))
