"""Presence of many looks: what a site holds, as the trace's actions state it, and nearest looks.

The presence of :mod:`vggc_cp.vision.footprints` measures how far a site is from *one* empty
look, the mean of the observations right after its pick. A site above another (a block on a
block) is empty in several looks: with the block below it, or with nothing there at all, and
the second is far from the mean of the first. This module gives such a site a presence that
knows every look, taught by the trace itself.

**Labels.** Between two actions at one place nothing changes there, so the actions of an
episode state what a site holds for every observation of that episode: before a pick of a
class at the site, an object of the class's colour; after it, nothing; before a place,
nothing; after it, that colour (:func:`site_labels`). The actions at site ``a`` are ``a``, its
*twin* and every action of another colour at its slot, with their twins, as
:mod:`vggc_cp.vision.slots` reads them from the sequence and the footprints. An episode whose
actions contradict each other at the site (two picks with no place between) is not labelled;
an episode with no action at the site is not either.

**Nearest looks.** With ``D_e(o)`` and ``D_o(o)`` the mean of the ``k`` smallest site-weighted
Euclidean differences between ``o`` and the observations labelled empty and occupied, from
*other episodes* (so that a labelled observation is judged on looks it did not teach),
``r(o) = D_e / (D_e + D_o)`` is 1/2 where ``o`` is as near the one kind of look as the other
(the nearest-neighbour rule's boundary); the presence maps ``r`` linearly on each side of 1/2
so that the median of the empty-labelled observations is 0 and that of the occupied ones 1
(:func:`look_presence`).

**Which sites.** A site is *stacked* when a slot of its own colour other than its twin shares
its pixels (footprints overlapping by ``site_overlap`` or more): there its empty look depends
on what the other slot holds, and it takes the nearest-look presence (:func:`refine_presence`).
Every other site (side-by-side regions, one object per place, objects of other colours at one
place, which the site already covers) keeps the hand-made presence: one empty look describes
it, and on such sites the hand-made presence was the better one on the tuning traces. Colour
is left to the hand-made posterior.

**Covered slots.** While a slot above holds something, the slot below it is read from pixels
the object on top covers, and its colour reads the top object's. Which slot is above which
is what the actions state (:func:`vggc_cp.vision.stacks.slots_above`: the one above holds
something only when the one below does, where their footprints overlap or the sequence alone
makes it 20 to 1); an unlabelled run of the slot below takes the colour its uncovered frames
read (:func:`~vggc_cp.vision.covered.uncovered_colour`): nothing acts at the slot during the
run, so it holds one object throughout. A run covered throughout takes the colour of the
nearest stated looks of covered stacks where those read the stated runs better than the
covered pixels, and is trusted only as far as its reading agrees with them
(:mod:`vggc_cp.vision.covered`).

**Colours no pixel reads.** A site's pixels are judged on its colour the way its presence
is, one vote a stated run (:func:`~vggc_cp.vision.trust.run_colour_kappa`); where they agree
with the actions no more often than the colour most stated runs hold, the unread runs take
the stated shares of the colours (:func:`~vggc_cp.vision.run_colours.majority_colour`), as a
presence no better than the majority takes the majority (:func:`majority_guess`). Nothing
reads action names or ground-truth states.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.recorded import NO_FACTS, RecordedFacts, recorded_facts
from vggc_cp.trace import PICK, Trace
from vggc_cp.vision.conservation import conserve, slot_groups
from vggc_cp.vision.covered import covered_trust, nearest_covered, uncovered_colour
from vggc_cp.vision.resets import joined_runs, reset_labels, ruled_out_reading
from vggc_cp.vision.run_colours import majority_colour, window_colour
from vggc_cp.vision.slots import (
    EMPTY,
    UNLABELLED,
    acting_at,
    action_mates,
    action_twins,
)
from vggc_cp.vision.stacks import column_steps, slots_above, stacked_sites
from vggc_cp.vision.support import supported
from vggc_cp.vision.trust import READ_Z, pose_bounds, reading_kappa
from vggc_cp.vision.untouched import (
    agreement,
    held_out_frames,
    placed_starts,
    pose_groups,
    pose_readings,
    poses,
    reads_better,
    run_presence,
    share_right,
    site_window,
    window_chroma,
)

#: Nearest looks averaged in ``D_e`` and ``D_o``.
NEAREST = 3


def site_labels(actions: np.ndarray, episodes: list[tuple[int, int]], acting: np.ndarray,
                kinds: np.ndarray, colour: np.ndarray, facts: RecordedFacts = NO_FACTS,
                refusals: bool = False, ruled_out: dict[int, set[int]] | None = None
                ) -> np.ndarray:
    """What a site holds at every observation, as its actions state it.

    With ``facts`` (:func:`vggc_cp.recorded.recorded_facts`), an episode with no action at
    the site holds one thing there throughout, and a reset states that it is what the
    observation it restarts from holds: the value the actions state in one episode carries
    over every reset to episodes without an action at the site
    (:func:`vggc_cp.vision.resets.reset_labels`).
    With ``refusals`` too, a refused action at the site rules out what it needs there (a
    pick: the class's colour, where no other pick at the site shares it; a place: nothing,
    where the hand holds the place's colour -- holding another explains the refusal):
    where one value is left, that is what the site holds. A refusal says that only where the
    site is in no stack (a block on top forbids a pick below it, an empty slot below a place
    above it), which the caller knows. Where several values are left, ``ruled_out`` (when
    given) gets, per episode (its index in ``episodes``), the values the refusals ruled out
    (:func:`~vggc_cp.vision.resets.reset_labels`).

    Parameters
    ----------
    actions : ndarray of int, shape (N-1,)
        The trace's actions (-1 between episodes).
    episodes : list of (first, last)
    acting : ndarray of int
        Actions that change what the site holds.
    kinds, colour : ndarray, shape (A,)

    Returns
    -------
    ndarray of int64, shape (N,)
        :data:`EMPTY`, a colour, or :data:`UNLABELLED` (no action at the site in the
        episode, or the episode's actions contradict each other there).
    """
    n = len(actions) + 1
    labels = np.full(n, UNLABELLED, dtype=np.int64)
    is_acting = np.zeros(len(kinds), dtype=bool)
    is_acting[acting] = True
    untouched = np.zeros(len(episodes), dtype=bool)
    for e, (first, last) in enumerate(episodes):
        steps = [t for t in range(first, last) if actions[t] >= 0 and is_acting[actions[t]]]
        if not steps:
            untouched[e] = True
            continue
        events = []                        # (t, held before, held after)
        for t in steps:
            a = actions[t]
            c = int(colour[a])
            events.append((t, c, EMPTY) if kinds[a] == PICK else (t, EMPTY, c))
        if any(prev[2] != nxt[1] for prev, nxt in zip(events, events[1:])):
            continue                       # contradiction: this site is not one slot here
        labels[first:events[0][0] + 1] = events[0][1]
        for prev, nxt in zip(events, events[1:]):
            labels[prev[0] + 1:nxt[0] + 1] = prev[2]
        labels[events[-1][0] + 1:last + 1] = events[-1][2]
    if facts.appended:
        reset_labels(labels, actions, episodes, untouched, is_acting, kinds, colour, facts,
                     refusals, ruled_out)
    return labels


def nearest_looks(features: np.ndarray, ref: np.ndarray, episode: np.ndarray,
                  k: int = NEAREST, chunk: int = 256) -> np.ndarray:
    """Mean of the ``k`` smallest Euclidean distances to the reference observations of other
    episodes.

    Parameters
    ----------
    features : ndarray of float64, shape (N, F)
        Every observation's site pixels, each scaled by the square root of its site weight
        (:func:`site_features`).
    ref : ndarray of int, shape (R,)
        Reference observations.
    episode : ndarray of int, shape (N,)

    Returns
    -------
    ndarray of float64, shape (N,)
        ``inf`` where fewer than ``k`` references lie in other episodes.
    """
    sq = (features ** 2).sum(axis=1)
    refs, ref_sq, ref_ep = features[ref], sq[ref], episode[ref]
    out = np.empty(len(features))
    for s in range(0, len(features), chunk):
        d2 = sq[s:s + chunk, None] + ref_sq[None] - 2.0 * features[s:s + chunk] @ refs.T
        d = np.sqrt(np.maximum(d2, 0.0))
        d = np.where(episode[s:s + chunk, None] == ref_ep[None], np.inf, d)
        kk = min(k, d.shape[1])
        out[s:s + chunk] = np.sort(d, axis=1)[:, :kk].mean(axis=1) if kk else np.inf
    return out


def site_features(px: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Site pixels ``px`` (N, P, 3) scaled by ``sqrt(weight)`` (P,), flattened to (N, 3P)
    float64: their Euclidean distance is the site-weighted one."""
    f = px * np.sqrt(weight.astype(np.float32))[None, :, None]
    return f.reshape(len(px), -1).astype(np.float64)


def look_presence(features: np.ndarray, labels: np.ndarray, episode: np.ndarray
                  ) -> np.ndarray | None:
    """Nearest-look presence of one site (module docstring), shape (N,), in ``[0, 1]``.

    Parameters
    ----------
    features : ndarray, shape (N, F)
        :func:`site_features`.
    labels : ndarray of int, shape (N,)
        :func:`site_labels`.
    episode : ndarray of int, shape (N,)

    Returns
    -------
    ndarray or None
        None when fewer than :data:`NEAREST` observations are labelled empty or occupied, or
        when the medians do not lie on either side of 1/2.
    """
    empty, occupied = np.flatnonzero(labels == EMPTY), np.flatnonzero(labels >= 0)
    if min(len(empty), len(occupied)) < NEAREST:
        return None
    de = nearest_looks(features, empty, episode)
    do = nearest_looks(features, occupied, episode)
    # no look of one kind in another episode: the other kind decides; of neither: undecided
    ratio = np.full(len(de), 0.5)
    both = np.isfinite(de) & np.isfinite(do)
    ratio[both] = de[both] / np.maximum(de[both] + do[both], 1e-12)
    ratio[np.isfinite(do) & ~np.isfinite(de)] = 1.0
    ratio[np.isfinite(de) & ~np.isfinite(do)] = 0.0
    lo, hi = np.median(ratio[empty]), np.median(ratio[occupied])
    if not lo < 0.5 < hi:
        return None                        # the looks do not tell the two apart
    up = 0.5 + 0.5 * (ratio - 0.5) / (hi - 0.5)
    down = 0.5 - 0.5 * (0.5 - ratio) / (0.5 - lo)
    return np.clip(np.where(ratio >= 0.5, up, down), 0.0, 1.0)


def stacked(ov: np.ndarray, colour: np.ndarray, twin: np.ndarray, site_overlap: float
            ) -> np.ndarray:
    """Sites shared with another slot of their own colour, boolean shape (A,).

    Action ``a`` is stacked when an action ``b`` of ``a``'s colour, neither ``a`` nor its twin,
    overlaps ``a``'s footprint by ``site_overlap`` or more: a block on a block, whose empty
    look depends on what the other slot holds.
    """
    same = (colour[:, None] == colour[None, :]) & (colour[:, None] >= 0) & (ov >= site_overlap)
    np.fill_diagonal(same, False)
    has = np.flatnonzero(twin >= 0)
    same[has, twin[has]] = False
    return same.any(axis=1)


def refine_presence(trace: Trace, x: np.ndarray, sites: np.ndarray, ov: np.ndarray,
                    colour: np.ndarray, counts: np.ndarray, presence: np.ndarray,
                    site_overlap: float, twin: np.ndarray | None = None,
                    mates: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Give every stacked site (:func:`stacked`) the nearest-look presence.

    Parameters
    ----------
    trace : Trace
        Its actions and episodes (never its states).
    x : ndarray of float32, shape (N, H, W, 3)
        Normalised frames.
    sites : ndarray, shape (A, H, W)
    ov : ndarray, shape (A, A)
    colour, counts : ndarray, shape (A,)
    presence : ndarray, shape (N, A)
        The hand-made presence.
    site_overlap : float
    twin : ndarray of int, shape (A,), optional
        :func:`action_twins` (computed when not given).
    mates : ndarray of bool, shape (A, A), optional
        :func:`action_mates` (computed when not given).

    Returns
    -------
    presence : ndarray, shape (N, A)
        A copy with the refined sites replaced.
    refined : ndarray of bool, shape (A,)
        Sites given the nearest-look presence (a stacked site keeps the hand-made one when
        its labels hold too few looks of either kind, or the looks do not separate).
    """
    presence = presence.copy()
    refined = np.zeros(len(counts), dtype=bool)
    kinds = trace.action_kinds()
    twin = action_twins(trace, ov, colour) if twin is None else twin
    mates = action_mates(trace, ov, colour, twin, site_overlap) if mates is None else mates
    episodes, episode = trace.episodes(), trace.episode_index()
    for a in np.flatnonzero(stacked(ov, colour, twin, site_overlap) & (counts > 0)):
        labels = site_labels(trace.actions, episodes,
                             acting_at(int(a), ov, colour, twin, site_overlap, mates), kinds,
                             colour)
        support = sites[a] > 0
        look = look_presence(site_features(x[:, support], sites[a][support]), labels, episode)
        if look is not None:
            presence[:, a] = look
            refined[a] = True
    return presence, refined


def settle(trace: Trace, presence: np.ndarray, posterior: np.ndarray, ov: np.ndarray,
           colour: np.ndarray, counts: np.ndarray, site_overlap: float,
           x: np.ndarray | None = None, support: float = 0.2, saturation: float = 0.5,
           twin: np.ndarray | None = None, mates: np.ndarray | None = None,
           bandwidth: float = 0.02, rests: bool = False, z: float = READ_Z,
           maps: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every site's presence and colour as the trace's actions settle them.

    Between two actions at one place nothing changes there (module docstring), so:

    * where the actions of an episode state what a site holds (:func:`site_labels`), that is
      its presence (0 empty, 1 occupied) and its colour (the colour of the class that was put
      there or is about to be picked); the pixels are not needed there, and whatever hides the
      site in a frame (a robot arm resting above the place it last acted on, the object it
      holds, a passing distractor) cannot mislead;
    * elsewhere (an episode that never acts at the site, or whose actions contradict each
      other there) the site holds one thing from one action at it to the next: every
      observation of such a run takes one presence and the run's mean colour posterior.
      With the frames ``x``, the presence may be read per pose of the hand from a window the
      labelled frames teach (:mod:`vggc_cp.vision.untouched`), so that a frame in which the
      arm hides the site weighs nothing: where that reading agrees with the labelled frames
      more often than the footprint presence does, beyond the noise of the two agreements
      (each fifth of the episodes judged on what the other four teach;
      :func:`~vggc_cp.vision.untouched.reads_better`). Otherwise (or where no pose can read
      the site, or without ``x``) the run's median presence, so a frame in which the site
      is hidden is outvoted by the frames in which it is seen; or, where the footprint
      presence does no better on the labelled frames than saying what most of them hold,
      that (:func:`majority_guess`).
      A run read per pose also takes the colour its window shows
      (:func:`~vggc_cp.vision.run_colours.window_colour`);
      a run of a slot that another slot covers in some of its frames takes the colour of its
      uncovered frames (:func:`~vggc_cp.vision.covered.uncovered_colour`), and one covered
      in all of them that of the nearest stated looks of covered stacks, where they read
      better than the covered pixels (:func:`~vggc_cp.vision.covered.nearest_covered`).
      A site whose pixels read its colour no better than the stated majority gives its other
      unread runs the stated shares of the colours
      (:func:`~vggc_cp.vision.run_colours.majority_colour`).

    Then objects rest on something: where a frame's readings put something above an empty
    slot of a stack, the stack takes its most likely filling with nothing in the air
    (:func:`vggc_cp.vision.support.supported`), before the uncovered colours are read.

    Where the trace records resets and refusals (:mod:`vggc_cp.recorded`), unstated runs a
    reset joins are read as one (:func:`~vggc_cp.vision.resets.joined_runs`), and what the
    facts state is written after the reading, before the stacks and the counts
    (:func:`recorded_labels`).

    Last, objects are conserved: what the slots an episode never touches hold is assigned as
    the trace's object counts require and the readings, each as far as its kappa trusts it,
    make most likely (:func:`vggc_cp.vision.conservation.conserve`); in one episode's
    assignment a run the poses read weighs as far as its bound (``trust_low``) trusts it.

    The actions at a site are found with the twins and slot mates the trace's sequence
    allows (:func:`action_twins`, :func:`action_mates`).

    Parameters
    ----------
    trace : Trace
        Its actions and episodes (never its states).
    presence : ndarray, shape (N, A)
    posterior : ndarray, shape (N, A, C)
    ov : ndarray, shape (A, A)
    colour, counts : ndarray, shape (A,)
    site_overlap : float
    x : ndarray of float32, shape (N, H, W, 3), optional
        Working frames (:func:`~vggc_cp.vision.working.working_frames`).
    support, saturation : float
        Of :class:`~vggc_cp.vision.footprints.FootprintConfig`: the share of a window's peak
        subtracted, and the share of the way to an occupied look at which presence is 1.
    twin : ndarray of int, shape (A,), optional
        :func:`action_twins` (computed when not given).
    mates : ndarray of bool, shape (A, A), optional
        :func:`action_mates` (computed when not given).
    bandwidth : float
        Width of the colour kernel (:func:`~vggc_cp.vision.run_colours.window_colour`).
    rests : bool
        The slots were read from where the hand rests after each action
        (:func:`vggc_cp.vision.places.trace_slots`): a pose may then also pool every pick
        (or place) at one slot (:func:`~vggc_cp.vision.untouched.pose_groups`), and an
        episode's first frame takes the pose it looks like
        (:func:`~vggc_cp.vision.untouched.placed_starts`).
    z : float
        The normal quantile of the lower confidence bounds on the readings' kappas.
    maps : ndarray, shape (A, H, W), optional
        The action footprints (at ``x``'s size): the window in which a covered slot's run
        is compared with the stated looks of covered stacks
        (:func:`~vggc_cp.vision.covered.nearest_covered`; not without ``x`` and ``maps``),
        and the steps by which a known stack is continued upward where no frame states its
        top slot with the level below (:func:`~vggc_cp.vision.stacks.column_steps`).

    Returns
    -------
    presence, posterior : ndarray
        Settled copies.
    stated : ndarray of bool, shape (N, A)
        Where the actions state what the site holds (:func:`site_labels`): there the
        settled presence and colour are facts, not readings.
    kappa : ndarray of float64, shape (A,)
        How far the reading that set each site's unstated runs can be trusted
        (:func:`~vggc_cp.vision.trust.reading_kappa`): its agreement with the stated frames
        beyond chance; NaN for a site stated everywhere (nothing read) or never acted at; at most 0 where all its
        stated frames lie in one episode (the footprint presence learns its empty look from
        them, so agreeing with them says nothing of other episodes: a site above another
        stated only with a block below it reads a bare region as full), and its runs are
        then trusted as no reading (the object counts decide them).
    trust : ndarray of float64, shape (N, A)
        How far the reading that set every observation's presence can be trusted: 1 where
        the actions state it, else the kappa (at least 0) of the reading its run took -- the
        pose reading, the footprint presence, or 0 for the majority guess -- which may be
        less than the site's ``kappa`` where some runs no pose reads; where the object counts
        overruled the reading, no more than their choice is sure
        (:func:`~vggc_cp.vision.conservation.count_trust`); for a run covered throughout,
        no more than the kappa of the reading of its colour
        (:func:`~vggc_cp.vision.covered.covered_trust`).
    trust_low : ndarray of float64, shape (N, A)
        Where a pose reading set the run, how far it can be trusted for sure: the lower
        confidence bound at ``z`` (:func:`~vggc_cp.vision.trust.kappa_lower`) of the kappa
        of the run's poses, judged on their held-out frames alone
        (:func:`~vggc_cp.vision.trust.pose_bounds`) -- a pose that few stated frames show
        reading right counts for little, however well the site's other poses read; for a
        run covered throughout, no more than the bound on the reading of its colour
        (:func:`~vggc_cp.vision.covered.covered_trust`); NaN elsewhere. (random-782 robot:
        a run of yellow_3 that one frame of a pose seen in nine stated frames read full took
        the site's kappa, 0.98, and outweighed the right reading of yellow_2 where the
        object counts decide.)
    stacked : ndarray of bool, shape (A,)
        The sites of slots the actions stack, above another or under one
        (:func:`~vggc_cp.vision.stacks.slots_above`).
    """
    seen = posterior
    presence, posterior = presence.copy(), posterior.copy()
    stated = np.zeros(presence.shape, dtype=bool)
    kappa = np.full(presence.shape[1], np.nan)
    trust = np.zeros(presence.shape)
    trust_low = np.full(presence.shape, np.nan)
    kinds = trace.action_kinds()
    twin = action_twins(trace, ov, colour) if twin is None else twin
    mates = action_mates(trace, ov, colour, twin, site_overlap) if mates is None else mates
    episode = trace.episode_index()
    # the hand's pose: the action that led to a frame, or, where the hand rests at the place
    # it acted on (``rests``), pooling more frames, the slot and kind of that action; each
    # site takes the one whose reading agrees best with labels it did not learn from
    pose_sets = [poses(trace.actions)]
    if rests:
        grouped = pose_groups(kinds, twin, mates)
        if len(np.unique(grouped)) < len(grouped):
            pose_sets.append(poses(trace.actions, grouped))
        if x is not None:
            pose_sets = [placed_starts(x, p) for p in pose_sets]
    episodes = trace.episodes()
    actions = trace.actions
    n_col = posterior.shape[2]
    start = np.zeros(trace.n_obs, dtype=bool)
    start[0] = True
    start[1:] = actions < 0
    examples: list[list[np.ndarray]] = [[] for _ in range(n_col)]
    looks: dict = {}
    runs: dict = {}                                  # site -> (labels, run, loose, acting)
    facts = recorded_facts(trace)
    for a in np.flatnonzero((counts > 0) & (colour >= 0)):
        acting = acting_at(int(a), ov, colour, twin, site_overlap, mates)
        labels = site_labels(actions, episodes, acting, kinds, colour)
        known = labels != UNLABELLED
        stated[:, a] = known
        trust[known, a] = 1.0
        raw = presence[:, a].copy()
        presence[known, a] = (labels[known] >= 0).astype(np.float64)
        full = np.flatnonzero(labels >= 0)
        if n_col > 1 and len(full):
            posterior[full, a] = np.eye(n_col)[labels[full]]
        # runs of observations between actions at the site (episodes start runs too)
        is_acting = np.zeros(len(kinds), dtype=bool)
        is_acting[acting] = True
        cut = start.copy()
        cut[1:] |= (actions >= 0) & is_acting[np.maximum(actions, 0)]
        run = np.cumsum(cut) - 1
        if facts.resets:
            run = joined_runs(run, known, facts.resets)
        loose = np.flatnonzero(~known)
        runs[int(a)] = (labels, run, loose, acting)
        if not len(loose):
            continue
        read = {}
        bounds: dict[int, float] = {}
        own = agreement(raw, np.ones(len(raw)), labels, EMPTY)
        used = own                                   # agreement of the reading the runs take
        # a footprint presence that agrees with every label cannot be bettered: not read again
        if x is not None and own < 1.0:
            best = None
            for pose in pose_sets:
                window = site_window(x, labels, pose, EMPTY, support)
                if window is None:
                    continue
                # the held-out agreement (held_out_agreement), frame by frame for the bounds
                right, weight = held_out_frames(x, labels, pose, episode, EMPTY, support,
                                                saturation)
                held = share_right(right, weight)
                if held > (own if best is None else best[0]):
                    best = (held, pose, window, right, weight)
            if best is not None and not reads_better(best[0], int((best[4] > 0).sum()), own,
                                                     int(known.sum()), z):
                best = None                          # no surer than the footprint presence
            if best is not None:
                used, pose, window, right, weight = best
                reading, strength = pose_readings(x, labels, pose, window, EMPTY, saturation,
                                                  episode)
                read = run_presence(reading, strength, run, loose)
                bounds = pose_bounds(right, weight, labels, pose, strength, run, loose, z)
                if n_col > 1:
                    chroma = window_chroma(x, labels, pose, window, EMPTY)
                    shows = (strength > 0) & (reading > 0.5) & np.isfinite(chroma[:, 0])
                    for c in range(n_col):
                        examples[c].append(chroma[shows & (labels == c)])
                    looks[int(a)] = (chroma, strength, shows, run, loose)
        guess = majority_guess(own, labels)
        # the reading the runs took: the pose's, else the footprint presence, else the guess
        kappa[a] = reading_kappa(used if read else own if guess is None else None, labels)
        own_kappa = max(reading_kappa(own, labels), 0.0) if guess is None else 0.0
        read_kappa = max(reading_kappa(used, labels), 0.0) if read else 0.0
        if len(np.unique(episode[known])) < 2:
            # judged on the one episode that taught it: nothing says how it reads the others
            kappa[a] = min(kappa[a], 0.0)
            own_kappa = read_kappa = 0.0
        ids, inv = np.unique(run[loose], return_inverse=True)
        for k in range(len(ids)):
            members = loose[inv == k]
            fallback = np.median(presence[members, a]) if guess is None else guess
            presence[members, a] = read.get(int(ids[k]), fallback)
            trust[members, a] = read_kappa if int(ids[k]) in read else own_kappa
            if int(ids[k]) in bounds:
                trust_low[members, a] = min(bounds[int(ids[k])], read_kappa)
            posterior[members, a] = posterior[members, a].mean(axis=0)
    windowed = window_colour(posterior, looks, examples, bandwidth) if looks else {}
    above = slots_above(runs, ov, site_overlap, presence, trust)
    if maps is not None:
        # a column's top slot that no frame states with the level below: one more step
        above = column_steps(above, runs, ov, site_overlap, maps, presence, trust)
    if facts:
        recorded_labels(runs, above, facts, actions, episodes, kinds, colour, presence,
                        posterior, stated, trust)
    slot = slot_groups(ov, colour, counts, twin, mates, site_overlap)
    # objects rest on something: nothing above an empty slot
    presence, _ = supported(presence, trust, stated, slot, above, trace.episodes())
    if n_col > 1:
        uncovered_colour(presence, posterior, seen, runs, ov, site_overlap, above)
        looked = nearest_covered(x, maps, presence, posterior, seen, runs, above, z=z)
        # a colour the pixels read no better than saying the stated majority: that majority
        majority_colour(posterior, seen, presence, runs, above, windowed)
    # objects are conserved: the counts decide what the readings leave open
    # each episode's assignment weighs a run the poses read as far as its bound trusts it
    sure = np.where(np.isfinite(trust_low), np.clip(trust_low, 0.0, None), trust)
    presence, posterior, _, counted = conserve(trace, presence, posterior, stated, trust,
                                               slot, colour, above, sure=sure)
    # where the counts overruled a pose reading, its bound is no surer than their choice
    moved = counted != trust
    trust_low = np.where(moved & np.isfinite(trust_low), np.minimum(trust_low, counted),
                         trust_low)
    # a run covered throughout reads its colour from the object on top: trusted only as far
    # as such reads agree with what the actions state
    if n_col > 1:
        covered_trust(presence, seen, runs, above, counted, trust_low, z, looked)
    return (presence, posterior, stated, kappa, counted, trust_low,
            stacked_sites(above, presence.shape[1]))


def recorded_labels(runs: dict, above: dict, facts: RecordedFacts, actions: np.ndarray,
                    episodes: list[tuple[int, int]], kinds: np.ndarray, colour: np.ndarray,
                    presence: np.ndarray, posterior: np.ndarray, stated: np.ndarray,
                    trust: np.ndarray) -> None:
    """What a recording's resets and refusals state (:func:`site_labels` with ``facts``;
    refusals on the sites in no stack: ``above``,
    :func:`~vggc_cp.vision.stacks.slots_above`, names none of their slots), written in place
    as facts where the actions alone left a site unstated.

    They are written after the sites were read, not taught to the readers: a few recorded
    episodes start where a doubt lies, and labels carried over their resets would weigh
    those few states in every site's reading of the rest of the trace (on multifruit-4x6
    robot s82, after one round of suggested episodes, the 1,193 site frames they state were
    all right, yet as teachers they moved the readings of other episodes enough for the
    object counts to place two reds wrongly: 68 nodes for 66 became 58).

    Where the refusals rule out some values but leave several (a refused red pick where red
    and yellow are played), the unstated frames of those episodes may not read a ruled-out
    one (:func:`~vggc_cp.vision.resets.ruled_out_reading`): the object counts then choose
    among what is left."""
    in_stack = stacked_sites(above, presence.shape[1])
    n_col = posterior.shape[2]
    for a, (labels, _run, _loose, acting) in runs.items():
        free = not in_stack[a] and not in_stack[np.asarray(acting, dtype=np.int64)].any()
        gone: dict[int, set[int]] = {}
        now = site_labels(actions, episodes, acting, kinds, colour, facts, refusals=free,
                          ruled_out=gone)
        for e, values in gone.items():
            first, last = episodes[e]
            idx = np.arange(first, last + 1)
            idx = idx[(labels[idx] == UNLABELLED) & (now[idx] == UNLABELLED)]
            ruled_out_reading(presence[:, a], posterior[:, a], idx, values)
        new = np.flatnonzero((now != UNLABELLED) & (labels == UNLABELLED))
        if not len(new):
            continue
        labels[new] = now[new]
        stated[new, a] = True
        trust[new, a] = 1.0
        presence[new, a] = (now[new] >= 0).astype(np.float64)
        full = new[now[new] >= 0]
        if n_col > 1 and len(full):
            posterior[full, a] = np.eye(n_col)[now[full]]


def majority_guess(own: float, labels: np.ndarray) -> float | None:
    """What the unread runs of a site hold when its footprint presence is no reading.

    A presence that agrees with the labelled frames (``own``, :func:`agreement`) no more
    often than saying what most of them hold does is not a reading of the site (on a stacked
    site of several colours, or under an arm): the runs no pose reading reaches take what
    most labelled frames hold (1.0 occupied, 0.0 empty). Otherwise None: the run's median
    footprint presence stands.

    >>> majority_guess(0.55, np.array([-1, -1, -1, 0, -2]))     # 3 of 4 labelled empty
    0.0
    >>> majority_guess(0.9, np.array([-1, -1, -1, 0, -2])) is None
    True
    """
    known = labels != UNLABELLED
    if not known.any():
        return None
    full = float(np.mean(labels[known] >= 0))
    return None if own > max(full, 1.0 - full) else float(full > 0.5)
