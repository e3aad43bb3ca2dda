"""Action footprints: visual evidence localized by the trace's own actions (beyond the paper).

A pick or a place changes the scene in one place, and the trace says which action changed
what. Everything below is learned from the trace's observations and actions; nothing reads
ground-truth states and nothing needs weights, so the same code adapts to another table,
camera, lighting or object set. Frames are first divided by their per-channel gain against
the recording (:func:`vggc_cp.vision.working.frame_gains`), so a per-frame lighting gain and
tint cancel, and moved back by their camera shake
(:mod:`vggc_cp.vision.registration`).

**Footprints.** The mean ``|o_{t+1} - o_t|`` over the transitions of action ``a``, less the
per-pixel median over all actions, gives the area ``a`` acts on, its footprint ``F_a``
(shape ``(H, W)``, summing to 1). The gripper is removed from every footprint: it changes in
*every* transition alike (pixels whose median change over the actions exceeds ``gripper``
times their largest one; an arm that rests above the place it last acted on changes that
place's pixels most under that place's actions, so it is not removed there), and what it holds varies only while holding (pixels whose spread over the
place-role observations exceeds ``held`` times their spread over the hand-empty pick-role
observations, plus the typical such spread), with a fringe of ``fringe`` of the image size.
The edges a shaking camera moved out of view in some frame go too
(:func:`~vggc_cp.vision.registration.unseen_margin`): moved back, a frame repeats its edge
there, so those pixels change with the shake, and an action taken once or twice would take
that change for its footprint. The faint floor that sensor noise leaves
everywhere (``support`` of the peak) goes too, and an action keeps only its heaviest connected
component: it acts in one place.

**Classes and colours.** What a pick lifts is what the next place puts down, so a pick and
the place that follows it move one task class (:func:`~vggc_cp.vision.colours.action_classes`,
names are not read). Classes whose colours cannot be told apart are one colour: the chroma
``(r, g) / (r + g + b)`` of their objects, each seen in its own action's footprint, must be
clearly likelier under its own class's kernel density than under another's
(:func:`~vggc_cp.vision.colours.colour_classes`); where the footprints pool classes, the
windows the labels teach read them again (:func:`~vggc_cp.vision.colours.window_colours`).
An action the sequence links to no other (a pick that ends every episode it is in) takes its
twin's colour where its own chroma does not clearly contradict it
(:func:`~vggc_cp.vision.colours.twin_colours`).

**Sites.** Objects of another colour may stand where ``a`` acts (an apple where a banana was
picked) and have another shape. The site of ``a`` widens ``F_a`` by the footprints of the
other colours' actions that overlap it, ``G_a = F_a + sum_b ov(a, b) F_b`` with
``ov(a, b) = sum_p min(F_a(p), F_b(p))``, normalized. Footprints of one colour keep apart
(a block on a block is another place than the block below it).

**Descriptors.** After a pick of ``a`` (before a place of ``a``) the site is empty; with
``e_a`` the mean of those observations, every observation ``o`` is described in every site by

* its **presence** ``p_a(o)``: the deviation ``m_a(o) = sum_p G_a(p) |x_o(p) - e_a(p)|_1``
  scaled so that the median over the empty observations is 0 and ``saturation`` times the
  faintest typical object at the site (the median over the occupied observations of ``a`` and
  of every other colour's action whose footprint overlaps by ``site_overlap`` or more) is 1,
  clipped to ``[0, 1]``: any object of any class, size or shape counts as present. A
  *stacked* site (one that shares its pixels with another slot of its own colour: a block on
  a block) is empty in several looks, and one mean describes none of them; its presence
  compares ``o`` with its nearest empty and occupied looks instead, as the trace's actions
  label them (:mod:`vggc_cp.vision.occupancy`);
* its **colour** ``pi_a(o)``: the posterior of each colour given the chroma of the deviating
  pixels (weights ``G_a(p) |x_o(p) - e_a(p)|_1``) under a kernel density of that colour's
  examples (bandwidth ``bandwidth``), equal priors: a class of several looks (an apple and a
  strawberry are both red) keeps every look. With one colour, colour carries no information.

**Settled by the actions.** Between two actions at one place nothing changes there: where
an episode's actions state what a site holds, that is its presence and colour, and elsewhere a
run of observations between actions at the site takes one presence (its median, or where the
labelled frames show it reads better, a reading per pose of the hand that they teach,
:mod:`vggc_cp.vision.untouched`) and its mean colour (:func:`vggc_cp.vision.occupancy.settle`),
so a frame in which an arm, the object it holds or a distractor hides the site cannot mislead.
Objects are conserved: the slots an episode never touches hold what the touched slots and the
hand leave of the trace's object counts, assigned as their readings make most likely
(:mod:`vggc_cp.vision.conservation`), so a place hidden in every frame of an episode is
decided by the count.
Which pick and place share a slot is read from the sequence where it settles it (they
alternate in every episode, :func:`vggc_cp.vision.slots.sequence_twins`), so footprints
that lie on an arm do not pair the wrong actions; where the frames right after each action
name the sequence's sure twins better than the footprints do (a hand that rests above the
place it acted on), the slots are read from those frames instead
(:mod:`vggc_cp.vision.places`).

**Nuisance.** Across a transition of an action that acts elsewhere, a site should not change;
what it does change there is noise, lighting and gripper residue. ``nu_a`` is the
``nuisance_quantile`` of ``d_a(o_t, o_{t+1})`` over the transitions of each action, then the
median over the actions (most act elsewhere); differences up to it do not count.

**Distance.** Two renders of one state agree in every site; two states differ by an object
present in one and absent in the other, or of another colour::

    d_a(o, o') = min(1, |p_a(o) - p_a(o')| + min(p_a(o), p_a(o')) TV(pi_a(o), pi_a(o')))
    d(o, o')   = mean over the actions a the trace takes of clip((d_a - nu_a) / (1 - nu_a), 0, 1)

with ``TV`` the total-variation distance. Cost: a few passes over the observations and
``O(A N^2)`` for the distances (fruit-6x8, |D| = 1500: seconds).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from vggc_cp.errors import EvidenceNotApplicable, VggcError
from vggc_cp.trace import PICK, PLACE, Trace
from vggc_cp.vision.blobs import heaviest_component
from vggc_cp.vision.colours import (
    action_classes,
    action_colours,
    class_points,
    colour_posteriors,
    colours_in_windows,
    trace_twin_colours,
)
from vggc_cp.vision.occupancy import refine_presence, settle
from vggc_cp.vision.places import trace_slots
from vggc_cp.vision.registration import steady
from vggc_cp.vision.working import (
    FOOTPRINT_SIDE,
    WorkingResolution,
    finest_factor,
    working_factor,
    working_frames,
)


@dataclass(frozen=True)
class FootprintConfig:
    """Settings of the footprint evidence (module docstring).

    Attributes
    ----------
    gripper : float
        Pixels whose median change over the actions exceeds this share of their largest
        change are the gripper's (every transition changes it alike).
    held : float
        Pixels whose spread while holding exceeds this multiple of their spread with the hand
        empty (plus the median such spread) are the gripper's (what it holds varies).
    fringe : float
        The gripper's area grows by this share of the image size (at least one pixel when
        positive; 0: none): what it holds has soft edges that vary with the object.
    support : float
        Share of a footprint's peak subtracted from it (sensor noise leaves a faint floor of
        changes over the whole image).
    saturation : float
        Share of the faintest typical object at a site at which presence reaches 1.
    site_overlap : float
        Overlap ``ov(a, b)`` from which another colour's action ``b`` stands at ``a``'s place.
    bandwidth : float
        Width of the colour kernel (chromaticity units).
    nuisance_quantile : float
        Quantile of a site's change across one action's transitions that is nuisance.
    """

    gripper: float = 0.8
    held: float = 2.0
    fringe: float = 1 / 64
    support: float = 0.2
    saturation: float = 0.5
    site_overlap: float = 0.2
    bandwidth: float = 0.02
    nuisance_quantile: float = 0.9

    def __post_init__(self) -> None:
        for name in ("gripper", "support", "site_overlap", "fringe"):
            v = getattr(self, name)
            if not 0 <= v < 1:
                raise VggcError(f"footprint {name} must lie in [0, 1), got {v}")
        if not 0 < self.nuisance_quantile <= 1:
            raise VggcError(f"footprint nuisance_quantile must lie in (0, 1], got "
                            f"{self.nuisance_quantile}")
        for name in ("held", "saturation", "bandwidth"):
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
    sites : ndarray of float32, shape (A, H, W)
        ``G_a``, each summing to 1.
    presence : ndarray of float64, shape (N, A)
        ``p_a(o)`` in ``[0, 1]``.
    chroma : ndarray of float64, shape (N, A, 2)
        Chromaticity of what deviates from empty in every site.
    posterior : ndarray of float64, shape (N, A, C)
        ``pi_a(o)`` over the trace's ``C`` colours (``C = 1``: all ones).
    colour : ndarray of int64, shape (A,)
        Colour of every action (-1 for an action never taken).
    nuisance : ndarray of float64, shape (A,)
        ``nu_a``.
    counts : ndarray of int64, shape (A,)
        Transitions of every action.
    resolution : WorkingResolution or None
        The working resolution of ``maps`` and ``sites`` and what chose it
        (:mod:`vggc_cp.vision.working`).
    stated : ndarray of bool, shape (N, A), or None
        Where the trace's actions state what a site holds
        (:func:`vggc_cp.vision.occupancy.settle`): the facts
        :func:`vggc_cp.vision.holdings.site_readings` offers the description length, whatever
        the site's own reading says. A stated fact rests on which actions act at one slot
        (:mod:`vggc_cp.vision.slots`); on a robot's camera the site's own reading is mostly
        the arm, and leaving out the facts it contradicted left out right ones (the tuning
        split at e16e1a8: 172,010 right and 1,053 wrong, 17 % of all stated facts), and
        counted a slot once per pattern of such gaps instead of once (calibration.md,
        session 55).
    kappa : ndarray of float64, shape (A,), or None
        How far the reading of every site's unstated observations can be trusted: its
        agreement with the stated ones beyond chance
        (:func:`vggc_cp.vision.trust.reading_kappa`); NaN where nothing is read.
    trust : ndarray of float64, shape (N, A), or None
        How far the reading that set each observation's presence can be trusted (the
        ``trust`` of :func:`vggc_cp.vision.occupancy.settle`): 1 where the actions state
        it, else the kappa of the reading its run took (0 for a guess).
    trust_low : ndarray of float64, shape (N, A), or None
        Where a pose reading set the run, how far it can be trusted for sure, as the poses
        of its frames show (``trust_low`` of :func:`vggc_cp.vision.occupancy.settle`); NaN
        elsewhere.
    stacked : ndarray of bool, shape (A,), or None
        The sites of slots the actions stack (``stacked`` of
        :func:`vggc_cp.vision.occupancy.settle`).
    """

    maps: np.ndarray
    sites: np.ndarray
    presence: np.ndarray
    chroma: np.ndarray
    posterior: np.ndarray
    colour: np.ndarray
    nuisance: np.ndarray
    counts: np.ndarray
    resolution: WorkingResolution | None = None
    stated: np.ndarray | None = None
    kappa: np.ndarray | None = None
    trust: np.ndarray | None = None
    trust_low: np.ndarray | None = None
    stacked: np.ndarray | None = None

    @property
    def taken(self) -> np.ndarray:
        """Indices of the actions the trace takes at least once."""
        return np.flatnonzero(self.counts > 0)


def footprint_maps(x: np.ndarray, roles: np.ndarray, src: np.ndarray, act: np.ndarray,
                   dst: np.ndarray, n_actions: int, params: FootprintConfig,
                   margin: tuple[int, int] = (0, 0)) -> np.ndarray:
    """``F_a`` of every action (module docstring), shape ``(A, H, W)``.

    Parameters
    ----------
    x : ndarray of float32, shape (N, H, W, 3)
        Normalised frames (:func:`normalise_frames`), their shake undone.
    roles : ndarray, shape (N,)
    src, act, dst : ndarray of int, shape (T,)
        The transitions.
    params : FootprintConfig
    margin : (int, int)
        Rows and columns at each edge that some frame's camera shake moved out of view
        (:func:`~vggc_cp.vision.registration.unseen_margin`): no footprint there.
    """
    h, w = x.shape[1:3]
    maps = np.zeros((n_actions, h, w), dtype=np.float32)
    counts = np.bincount(act, minlength=n_actions)
    for a in np.flatnonzero(counts):
        sel = act == a
        maps[a] = np.abs(x[dst[sel]] - x[src[sel]]).sum(axis=-1).mean(axis=0)
    taken = counts > 0
    shared = np.median(maps[taken], axis=0)
    gripper = shared > params.gripper * np.maximum(maps[taken].max(axis=0), 1e-12)
    if (roles == PICK).sum() > 1 and (roles == PLACE).sum() > 1:
        holding = x[roles == PLACE].std(axis=0).sum(axis=-1)
        empty = x[roles == PICK].std(axis=0).sum(axis=-1)
        gripper |= holding > params.held * empty + np.median(empty)
    fringe = max(1, int(round(params.fringe * max(h, w)))) if params.fringe > 0 else 0
    if fringe > 0:
        # what the gripper holds has soft, varying edges: its fringe goes with it
        gripper = ndimage.binary_dilation(gripper, iterations=fringe)
    maps = np.maximum(maps - shared, 0.0)
    maps[:, gripper] = 0.0
    # the edges a shaking camera moved out of view repeat the frame's edge: not the scene's
    rows, cols = margin
    if rows:
        maps[:, :rows] = 0.0
        maps[:, h - rows:] = 0.0
    if cols:
        maps[:, :, :cols] = 0.0
        maps[:, :, w - cols:] = 0.0
    maps[~taken] = 0.0
    maps = np.maximum(maps - params.support * maps.max(axis=(1, 2), keepdims=True), 0.0)
    for a in np.flatnonzero(taken):
        maps[a] = heaviest_component(maps[a])
    return normalised(maps)


def normalised(maps: np.ndarray) -> np.ndarray:
    """Every map divided by its sum (all-zero maps stay zero), float32."""
    total = maps.sum(axis=(1, 2), keepdims=True)
    return np.where(total > 0, maps / np.maximum(total, 1e-12), 0.0).astype(np.float32)


def overlaps(maps: np.ndarray) -> np.ndarray:
    """``ov(a, b) = sum_p min(F_a(p), F_b(p))`` in ``[0, 1]``, shape (A, A): how much two
    footprints share a place."""
    flat = maps.reshape(len(maps), -1).astype(np.float64)
    return np.stack([np.minimum(flat[a], flat).sum(axis=-1) for a in range(len(flat))])


def site_maps(maps: np.ndarray, ov: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """``G_a = F_a + sum_b ov(a, b) F_b`` over the actions ``b`` of another colour than ``a``
    (module docstring), normalized, shape (A, H, W)."""
    other = (colour[:, None] != colour[None, :]) & (colour[:, None] >= 0) & (colour >= 0)
    weight = np.where(other, ov, 0.0) + np.eye(len(ov))
    flat = maps.reshape(len(maps), -1).astype(np.float64)
    return normalised((weight @ flat).reshape(maps.shape))


def describe(x: np.ndarray, weights: np.ndarray, empty_of: dict[int, np.ndarray]
             ) -> tuple[np.ndarray, np.ndarray]:
    """Deviation from empty and its chroma in every weighted area.

    Parameters
    ----------
    x : ndarray of float32, shape (N, H, W, 3)
    weights : ndarray, shape (A, H, W)
    empty_of : dict
        Action -> indices of the observations where its area is empty.

    Returns
    -------
    mag : ndarray, shape (N, A)
        ``sum_p w_a(p) |x_o(p) - e_a(p)|_1``.
    chroma : ndarray, shape (N, A, 2)
        Chromaticity of the deviating pixels' mean colour (weights ``w_a(p) |x_o - e_a|_1``).
    """
    n, n_act = len(x), len(weights)
    mag = np.zeros((n, n_act))
    chroma = np.zeros((n, n_act, 2))
    for a, empty in empty_of.items():
        support = weights[a] > 0
        if not support.any():
            continue
        weight = weights[a][support]                                      # (P,)
        pixels = x[:, support]                                            # (N, P, 3)
        dev = np.abs(pixels - pixels[empty].mean(axis=0)).sum(axis=-1)    # (N, P)
        mag[:, a] = dev @ weight
        wdev = dev * weight
        mean = np.einsum("np,npc->nc", wdev, pixels) / np.maximum(wdev.sum(1), 1e-12)[:, None]
        chroma[:, a] = mean[:, :2] / np.maximum(mean.sum(axis=1, keepdims=True), 1e-12)
    return mag, chroma


def run_ends(actions: np.ndarray, starts: np.ndarray, touches: np.ndarray) -> np.ndarray:
    """For every observation of ``starts``, the last observation of its run: the episode goes
    on while its actions do not touch the place (``touches``, bool of shape (A,)), so what the
    place holds stays the same and whatever acted there last (a hand at rest) has moved on.

    Parameters
    ----------
    actions : ndarray of int, shape (N-1,)
    starts : ndarray of int
    touches : ndarray of bool, shape (A,)

    Returns
    -------
    ndarray of int, the same shape as ``starts``.
    """
    out = np.asarray(starts, dtype=np.int64).copy()
    for i, t in enumerate(out):
        while t < len(actions) and actions[t] >= 0 and not touches[actions[t]]:
            t += 1
        out[i] = t
    return out


def footprint_side(maps: np.ndarray) -> float:
    """Typical width of the footprints in pixels: the median over the actions taken of
    ``sqrt(1 / sum_p F_a(p)^2)``, the side of a square of as many equally weighted pixels
    (``nan`` when no action has a footprint).

    >>> square = np.zeros((1, 9, 9)); square[0, 2:6, 3:7] = 1 / 16
    >>> footprint_side(square)
    4.0
    """
    mass = (maps.astype(np.float64) ** 2).sum(axis=(1, 2))
    taken = mass > 0
    return float(np.median(np.sqrt(1.0 / mass[taken]))) if taken.any() else float("nan")


def working_footprints(trace: Trace, params: FootprintConfig, executor=None
                       ) -> tuple[np.ndarray, np.ndarray, WorkingResolution]:
    """The working frames (steadied), the footprints ``F_a`` on them and their resolution
    (:mod:`vggc_cp.vision.working`): first the image-size bound; while the footprints there
    are narrower than :data:`~vggc_cp.vision.working.FOOTPRINT_SIDE` pixels, again at the
    finer factor that would make them that wide (at least one step finer), as far as the
    memory cap allows. Frames at the tuned size or smaller are worked as they are.

    Raises
    ------
    EvidenceNotApplicable
        When no action changes the images in one place.
    """
    obs = trace.observations
    src, act, dst = trace.transitions()
    bound = working_factor(*obs.shape[1:3])
    finest = finest_factor(obs.shape)
    factor, reason = bound, "image size"
    while True:
        # a shaking camera held still
        x, margin = steady(working_frames(obs, executor, source=trace.source, factor=factor))
        maps = footprint_maps(x, trace.roles(), src, act, dst, trace.n_actions, params,
                              margin)
        if not maps.any():
            raise EvidenceNotApplicable("no action changes the images in one place of its own "
                                        "(every pixel changes alike): action footprints do "
                                        "not apply to this trace")
        side = footprint_side(maps) if bound > 1 else float("nan")
        if factor == 1 or not side < FOOTPRINT_SIDE:
            break
        finer = max(finest, min(factor - 1, int(factor * side / FOOTPRINT_SIDE)))
        if finer >= factor:
            reason = "memory cap"
            break
        factor, reason = finer, "footprints' scale"
        del x, maps
    return x, maps, WorkingResolution(factor, bound, side, reason, tuple(x.shape[1:3]))


def action_footprints(trace: Trace, params: FootprintConfig | None = None,
                      executor=None) -> Footprints:
    """Footprints, sites and descriptors of every action of ``trace`` (module docstring).

    ``executor`` (:func:`vggc_cp.parallel.open_executor`) converts the frames in blocks
    (:func:`working_frames`); the same numbers either way.

    Raises
    ------
    EvidenceNotApplicable
        When the trace has no transition, or no action changes the images in one place.
    """
    params = params or FootprintConfig()
    src, act, dst = trace.transitions()
    if len(act) == 0:
        raise EvidenceNotApplicable("footprint evidence needs at least one transition")
    x, maps, resolution = working_footprints(trace, params, executor)
    n_act = trace.n_actions
    kinds = trace.action_kinds()
    counts = np.bincount(act, minlength=n_act).astype(np.int64)
    ov = overlaps(maps)
    empty_of, occupied_of = {}, {}
    for a in np.flatnonzero(counts):
        sel = act == a
        # right after an action the hand is still at its place: the site is read where the
        # run of observations it begins ends (no action at the place in between)
        before, after = src[sel], run_ends(trace.actions, dst[sel], ov[a] > 0)
        empty_of[int(a)], occupied_of[int(a)] = ((after, before) if kinds[a] == PICK
                                                 else (before, after))
    _, own_chroma = describe(x, maps, empty_of)
    classes = action_classes(trace)
    points = class_points(own_chroma, counts, classes, occupied_of)
    colour = action_colours(points, counts, classes, params.bandwidth)
    # pooled classes may be a footprint on an arm: the windows the labels teach read them again
    colour = colours_in_windows(trace, x, ov, maps, colour, classes, counts, points,
                                params.site_overlap, params.support, params.saturation,
                                params.bandwidth)
    # an action the sequence links to no other takes its twin's colour, not the pixels' guess
    colour = trace_twin_colours(trace, x, ov, colour, classes, counts, params.site_overlap,
                                points, params.bandwidth)
    sites = site_maps(maps, ov, colour)
    mag, chroma = describe(x, sites, empty_of)
    presence = np.zeros((trace.n_obs, n_act))
    for a, empty in empty_of.items():
        lo = np.median(mag[empty, a])
        mates = [b for b in occupied_of if b == a or (ov[a, b] >= params.site_overlap
                                                      and colour[b] != colour[a])]
        hi = min(np.median(mag[occupied_of[b], a]) for b in mates)
        presence[:, a] = np.clip((mag[:, a] - lo) / max(params.saturation * (hi - lo), 1e-9),
                                 0, 1)
    n_col = int(colour.max()) + 1
    examples = [np.concatenate([chroma[occupied_of[a], a] for a in np.flatnonzero(colour == c)])
                for c in range(n_col)]
    posterior = colour_posteriors(chroma, examples, params.bandwidth)
    # which place refills the slot a pick empties and which actions of other colours act at
    # it: from the sequence where it settles it, and where the hand rests after each action
    # where that names the sequence's sure twins better than the footprints
    twin, mates, rests = trace_slots(trace, x, ov, colour, params.site_overlap)
    # a site that shares its pixels with another slot of its colour has many empty looks
    presence, _ = refine_presence(trace, x, sites, ov, colour, counts, presence,
                                  params.site_overlap, twin, mates)
    # what the actions state a site holds, and one look per run between actions at it
    presence, posterior, stated, kappa, trust, trust_low, stacked = settle(
        trace, presence, posterior, ov, colour, counts, params.site_overlap, x, params.support,
        params.saturation, twin, mates, params.bandwidth, rests=rests, maps=maps)
    nuisance = footprint_nuisance(presence, posterior, counts, src, act, dst, params)
    return Footprints(maps, sites, presence, chroma, posterior, colour, nuisance, counts,
                      resolution, stated, kappa, trust, trust_low, stacked)


def footprint_differences(p: np.ndarray, q: np.ndarray, c: np.ndarray, e: np.ndarray
                          ) -> np.ndarray:
    """``d_a(o, o')`` of aligned descriptors (module docstring), broadcasting.

    Parameters
    ----------
    p, q : ndarray, shape (..., A)
        Presence of ``o`` and ``o'``.
    c, e : ndarray, shape (..., A, C)
        Colour posteriors of ``o`` and ``o'``.

    Returns
    -------
    ndarray, shape (..., A), values in [0, 1].
    """
    other = 0.5 * np.abs(c - e).sum(axis=-1)
    return np.minimum(np.abs(p - q) + np.minimum(p, q) * other, 1.0)


def footprint_nuisance(presence: np.ndarray, posterior: np.ndarray, counts: np.ndarray,
                       src: np.ndarray, act: np.ndarray, dst: np.ndarray,
                       params: FootprintConfig) -> np.ndarray:
    """``nu_a`` (module docstring): how much site ``a`` differs across a transition that does
    not act on it. Returns shape (A,); 0 for an action never taken."""
    taken = np.flatnonzero(counts > 0)
    dif = footprint_differences(presence[src], presence[dst], posterior[src], posterior[dst])
    per_action = np.stack([np.quantile(dif[act == a], params.nuisance_quantile, axis=0)
                           for a in taken])                                # (A_taken, A)
    out = np.zeros(len(counts))
    out[taken] = np.median(per_action, axis=0)[taken]
    return out


def footprint_distance_matrix(presence: np.ndarray, posterior: np.ndarray, taken: np.ndarray,
                              nuisance: np.ndarray | None = None) -> np.ndarray:
    """Pairwise footprint distances of one set of observations.

    Parameters
    ----------
    presence : ndarray, shape (n, A)
    posterior : ndarray, shape (n, A, C)
    taken : ndarray of int
        Actions whose sites count.
    nuisance : ndarray, shape (A,), optional
        ``nu_a``; differences up to it do not count.

    Returns
    -------
    ndarray of float64, shape (n, n), symmetric, zero diagonal, values in [0, 1].
    """
    n = len(presence)
    d = np.zeros((n, n), dtype=np.float64)
    if n == 0 or len(taken) == 0:
        return d
    for a in taken:
        p, c = presence[:, a], posterior[:, a]
        da = footprint_differences(p[:, None], p[None, :], c[:, None, :], c[None, :, :])
        nu = 0.0 if nuisance is None else float(nuisance[a])
        if nu > 0:
            da = np.clip((da - nu) / max(1.0 - nu, 1e-9), 0.0, 1.0)
        d += da
    d /= len(taken)
    np.fill_diagonal(d, 0.0)
    return d


def footprint_distances(trace: Trace, params: FootprintConfig | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Within-role footprint distances of ``trace``: ``(dist_pick, dist_place)``, rows in the
    order of ``flatnonzero(roles == PICK)`` and ``flatnonzero(roles == PLACE)``."""
    fp = action_footprints(trace, params or FootprintConfig())
    roles = trace.roles()
    return tuple(footprint_distance_matrix(fp.presence[roles == role], fp.posterior[roles == role],
                                           fp.taken, fp.nuisance)
                 for role in (PICK, PLACE))


def footprint_codes(fp: Footprints, roles: np.ndarray
                    ) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """Descriptor codes and code distance tables of both roles (issue 27).

    Observations of one role whose descriptors (presence and colour posterior in every taken
    site) are identical to the bit get one code; the distance of two observations is a
    function of their descriptors, so ``footprint_distances(...)[role][o, o'] ==
    table[code(o), code(o')]`` exactly, with tables of the codes' representatives.

    Parameters
    ----------
    fp : Footprints
    roles : ndarray, shape (N,)

    Returns
    -------
    codes : (ndarray of int64 (n_pick,), ndarray of int64 (n_place,))
    tables : (ndarray of float64 (G_pick, G_pick), ndarray of float64 (G_place, G_place))
    """
    taken = fp.taken
    codes, tables = [], []
    for role in (PICK, PLACE):
        sel = np.flatnonzero(roles == role)
        desc = np.concatenate([fp.presence[sel][:, taken],
                               fp.posterior[sel][:, taken].reshape(len(sel), -1)], axis=1)
        if len(sel) == 0:
            codes.append(np.zeros(0, dtype=np.int64))
            tables.append(np.zeros((0, 0)))
            continue
        _, first, inv = np.unique(desc, axis=0, return_index=True, return_inverse=True)
        rep = sel[first]
        codes.append(np.asarray(inv, dtype=np.int64).ravel())
        tables.append(footprint_distance_matrix(fp.presence[rep], fp.posterior[rep], taken,
                                                fp.nuisance))
    return (codes[0], codes[1]), (tables[0], tables[1])
