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
*twin* (the action of the other kind and the same colour that refills or empties its slot: read
from the sequence where it settles it, :func:`sequence_twins`, else the one whose footprint
overlaps ``a``'s most; none where that one pairs with another action both ways,
:func:`exclusive_twins`), every action of another colour at its slot (read from the sequence
where it settles it, :func:`sequence_mates`, else those overlapping ``a``'s footprint by
``site_overlap`` or more; one of each colour and kind), and their twins. An episode whose actions contradict
each other at the site (two picks with no place between) is not labelled; an episode with no
action at the site is not either.

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
is left to the hand-made posterior. Nothing reads action names or ground-truth states.
"""

from __future__ import annotations

import math

import numpy as np

from vggc_cp.trace import PICK, Trace
from vggc_cp.vision.density import kernel_posterior
from vggc_cp.vision.untouched import (
    agreement,
    held_out_agreement,
    pose_readings,
    poses,
    run_presence,
    site_window,
    window_chroma,
)

#: Label of an empty site (colours are numbered from 0; -2: unlabelled).
EMPTY = -1
UNLABELLED = -2
#: Odds from which a candidate that always alternates with an action is taken for its twin
#: (:func:`sequence_twins`): 20 to 1, the bar of the warning's description-length margin.
TWIN_ODDS = 20.0
#: Nearest looks averaged in ``D_e`` and ``D_o``.
NEAREST = 3


def twins(ov: np.ndarray, colour: np.ndarray, kinds: np.ndarray) -> np.ndarray:
    """Twin of every taken action, int array of shape (A,) (-1 when none).

    The twin of ``a`` is the action of the other kind (pick / place) and the same colour whose
    footprint overlaps ``a``'s most (positive overlap).
    """
    out = np.full(len(ov), -1, dtype=np.int64)
    for a in np.flatnonzero(colour >= 0):
        cand = np.flatnonzero((colour == colour[a]) & (kinds != kinds[a]))
        if len(cand) and ov[a, cand].max() > 0:
            out[a] = int(cand[np.argmax(ov[a, cand])])
    return out


def action_episodes(n: int, episodes: list[tuple[int, int]]) -> np.ndarray:
    """Episode of each of the ``n`` actions of a trace, int64 of shape (n,) (-1 for the
    separators between episodes).

    >>> action_episodes(5, [(0, 2), (3, 5)]).tolist()
    [0, 0, -1, 1, 1]
    """
    out = np.full(n, -1, dtype=np.int64)
    for i, (first, last) in enumerate(episodes):
        out[first:last] = i
    return out


def sequence_twins(actions: np.ndarray, episodes: list[tuple[int, int]], ov: np.ndarray,
                   colour: np.ndarray, kinds: np.ndarray) -> np.ndarray:
    """Twin of every taken action as the trace's own sequence allows, int array of shape (A,)
    (-1 when none).

    A slot holds one object: between two picks at it comes a place at it, and between two
    places a pick. So the twin ``b`` of ``a`` (the other kind, the same colour) alternates with
    ``a`` in every episode: in the actions of an episode restricted to ``a`` and ``b``, no two
    neighbours are of one kind. A candidate that breaks this once is not the twin, whatever
    the pixels say (a footprint on a robot arm overlaps the wrong place's). One that never
    breaks it may still do so by chance: with ``q`` the share of neighbours that alternate
    over all of ``a``'s candidates together (most are not its twin), ``k`` alternations
    without a break are ``(1/q)^k`` times likelier from the twin, and a candidate qualifies
    at odds of :data:`TWIN_ODDS` (the warning's bar, 20 to 1). Among those that qualify, the
    one whose footprint overlaps ``a``'s most (then the one seen alternating most often) is
    the twin; where none does, or no candidate ever breaks the rule (nothing to tell them
    apart), the footprints decide alone (:func:`twins`).

    Parameters
    ----------
    actions : ndarray of int, shape (N-1,)
        The trace's actions (-1 between episodes).
    episodes : list of (first, last)
    ov : ndarray, shape (A, A)
        Footprint overlaps.
    colour, kinds : ndarray, shape (A,)

    Examples
    --------
    Picks 0, 1 and places 2, 3; the footprints pair 0 with 3 and 1 with 2. In the first
    episode 0 and 2 alternate eleven times, and 0 comes six times with no 3 between: 2 is the
    twin of 0 (and 0 of 2). 1 and 3 alternate once, too little to overrule the pixels:

    >>> from vggc_cp.trace import PLACE
    >>> kinds = np.array([PICK, PICK, PLACE, PLACE])
    >>> ov = np.array([[1, 0, .1, .5], [0, 1, .5, .1], [.1, .5, 1, 0], [.5, .1, 0, 1]])
    >>> actions = np.array([0, 2] * 6 + [-1, 1, 3])
    >>> sequence_twins(actions, [(0, 12), (13, 15)], ov, np.zeros(4, int), kinds).tolist()
    [2, 2, 0, 0]
    """
    out = twins(ov, colour, kinds)
    actions = np.asarray(actions)
    episode_of = action_episodes(len(actions), episodes)
    for a in np.flatnonzero(colour >= 0):
        cand = np.flatnonzero((colour == colour[a]) & (kinds != kinds[a]))
        counts = np.zeros((len(cand), 2), dtype=np.int64)       # broken, alternated
        for i, b in enumerate(cand):
            at = np.flatnonzero((actions == a) | (actions == b))
            neighbours = episode_of[at[1:]] == episode_of[at[:-1]]   # within one episode
            same = kinds[actions[at[1:]]] == kinds[actions[at[:-1]]]
            counts[i] = ((neighbours & same).sum(), (neighbours & ~same).sum())
        total = counts.sum()
        if total == 0 or counts[:, 0].sum() == 0:
            continue                       # no candidate ever breaks it: the pixels decide
        # how often an unrelated pair alternates, from the candidates together
        p_alt = counts[:, 1].sum() / total
        if p_alt <= 0:
            continue                       # nothing ever alternates with it
        allowed = [(float(ov[a, b]), int(k), int(b)) for b, (broken, k) in zip(cand, counts)
                   if broken == 0 and k * math.log(1.0 / p_alt) >= math.log(TWIN_ODDS)]
        if allowed:
            out[a] = max(allowed)[2]
    return out


def action_twins(trace: Trace, ov: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """:func:`sequence_twins` of ``trace`` (its actions and episodes, never its states), each
    :func:`exclusive_twins`."""
    return exclusive_twins(sequence_twins(trace.actions, trace.episodes(), ov, colour,
                                          trace.action_kinds()))


def sequence_mates(actions: np.ndarray, episodes: list[tuple[int, int]], ov: np.ndarray,
                   colour: np.ndarray, kinds: np.ndarray, twin: np.ndarray,
                   site_overlap: float) -> np.ndarray:
    """Which actions of another colour act at each action's slot, boolean shape (A, A).

    A slot holds one thing at a time: a pick there empties it of the colour it lifts, a
    place fills an empty one. So with ``b`` (another colour) at the slot of ``a``, every pair
    of neighbours in an episode's actions restricted to ``a``, ``b`` and their twins, one of
    ``a``'s pair and one of ``b``'s, agrees: what the first leaves is what the second finds.
    A candidate that breaks this once does not act at ``a``'s slot, whatever the pixels say
    (a footprint on a robot arm overlaps other places'). One that never breaks it qualifies
    at odds of :data:`TWIN_ODDS`, the chance of agreeing estimated from all of ``a``'s
    candidates together, as for :func:`sequence_twins`. For the others (too few
    neighbours to tell, or no candidate ever breaking it: nothing to tell them apart), the
    footprints decide: an action of another colour overlapping ``a``'s footprint by
    ``site_overlap`` or more acts at its slot. A slot has one pick and one place of each
    colour, so at most one of each is kept (:func:`one_per_colour`), and only where the
    other side does not give its own mate of ``a``'s colour and kind to another action
    (:func:`exclusive_mates`): a block on top of ``a``'s overlaps it, but it is not at its
    slot.

    Parameters
    ----------
    actions : ndarray of int, shape (N-1,)
    episodes : list of (first, last)
    ov : ndarray, shape (A, A)
    colour, kinds, twin : ndarray, shape (A,)
    site_overlap : float

    Examples
    --------
    A red pick and place (0, 1) and a yellow pick and place (2, 3) at one slot, and a yellow
    pair (4, 5) elsewhere whose footprints overlap the slot's; the sequence says which:

    >>> from vggc_cp.trace import PLACE
    >>> kinds = np.array([PICK, PLACE] * 3)
    >>> colour, twin = np.array([0, 0, 1, 1, 1, 1]), np.array([1, 0, 3, 2, 5, 4])
    >>> on = np.isin(np.arange(6), [0, 1, 4, 5])
    >>> ov = np.eye(6) + 0.5 * (on[:, None] & on[None, :])
    >>> actions = np.array([0, 3, 2, 1, 5, 4, 0, 3, 2, 1] * 4)
    >>> m = sequence_mates(actions, [(0, 40)], ov, colour, kinds, twin, 0.2)
    >>> np.flatnonzero(m[0]).tolist()
    [2, 3]
    """
    n = len(colour)
    other = (colour[:, None] != colour[None, :]) & (colour[:, None] >= 0) & (colour >= 0)
    out = other & (ov >= site_overlap)
    actions = np.asarray(actions)
    episode_of = action_episodes(len(actions), episodes)
    # what each action finds at its slot and what it leaves (-1: empty)
    finds = np.where(kinds == PICK, colour, EMPTY)
    leaves = np.where(kinds == PICK, EMPTY, colour)
    taken = np.zeros(n, dtype=bool)
    taken[actions[actions >= 0]] = True
    for a in np.flatnonzero(taken & (colour >= 0)):
        own = np.zeros(n, dtype=bool)
        own[[a, twin[a]] if twin[a] >= 0 else [a]] = True
        cand = np.flatnonzero(taken & other[a])
        counts = np.zeros((len(cand), 2), dtype=np.int64)       # broken, agreed
        for i, b in enumerate(cand):
            group = own.copy()
            group[[b, twin[b]] if twin[b] >= 0 else [b]] = True
            at = np.flatnonzero((actions >= 0) & group[np.maximum(actions, 0)])
            seq = actions[at]
            cross = (episode_of[at[1:]] == episode_of[at[:-1]]) & (own[seq[1:]] != own[seq[:-1]])
            agree = leaves[seq[:-1]] == finds[seq[1:]]
            counts[i] = ((cross & ~agree).sum(), (cross & agree).sum())
        total = counts.sum()
        if total == 0 or counts[:, 0].sum() == 0:
            continue                       # no candidate ever breaks it: the pixels decide
        p_agree = counts[:, 1].sum() / total
        out[a, cand[counts[:, 0] > 0]] = False          # ruled out by the sequence
        if p_agree <= 0:
            continue
        sure = (counts[:, 0] == 0) & (counts[:, 1] * math.log(1.0 / p_agree)
                                      >= math.log(TWIN_ODDS))
        out[a, cand[sure]] = True
    seen = out & (ov >= site_overlap)                  # the pixels put them at the slot too
    return exclusive_mates(one_per_colour(out, seen, ov, colour, kinds), colour, kinds)


def one_per_colour(mates: np.ndarray, seen: np.ndarray, ov: np.ndarray, colour: np.ndarray,
                   kinds: np.ndarray) -> np.ndarray:
    """At most one mate of each colour and kind per action, boolean shape (A, A).

    A slot has one pick and one place of each colour: of several candidates of one colour
    and kind (a block on the block at ``a``'s slot overlaps it too), the one the footprints
    put at the slot as well (``seen``: overlapping ``a``'s by the site bar) before one only
    the sequence names (agreements of a pick with a later place are cheap: one leaves the
    slot empty, the other finds its own slot empty), then the one whose footprint overlaps
    ``a``'s most, is the mate.

    >>> kinds, colour = np.array([PICK, PICK, PICK]), np.array([0, 1, 1])
    >>> ov = np.array([[1, .8, .5], [.8, 1, .6], [.5, .6, 1]])
    >>> m = np.array([[0, 1, 1], [1, 0, 0], [1, 0, 0]], dtype=bool)
    >>> one_per_colour(m, np.zeros((3, 3), bool), ov, colour, kinds)[0].tolist()
    [False, True, False]
    """
    out = np.zeros_like(mates)
    for a in range(len(mates)):
        cand = np.flatnonzero(mates[a])
        for key in {(int(colour[b]), int(kinds[b])) for b in cand}:
            group = [b for b in cand if (colour[b], kinds[b]) == key]
            out[a, max(group, key=lambda b: (bool(seen[a, b]), float(ov[a, b])))] = True
    return out


def exclusive_mates(mates: np.ndarray, colour: np.ndarray, kinds: np.ndarray) -> np.ndarray:
    """Mates that the other side does not give to another action, boolean shape (A, A).

    ``b`` is at ``a``'s slot only if ``a`` is at ``b``'s: where ``b``'s mate of ``a``'s
    colour and kind is another action (the slot below a block overlaps the block above, and
    the block above's own mate was never taken), ``b`` is not ``a``'s mate.

    >>> kinds, colour = np.array([PICK, PICK, PICK]), np.array([0, 1, 1])
    >>> m = np.array([[0, 1, 0], [1, 0, 0], [1, 0, 0]], dtype=bool)   # 2 claims 0, 0 has 1
    >>> exclusive_mates(m, colour, kinds)[2].tolist()
    [False, False, False]
    """
    out = mates.copy()
    for a, b in zip(*np.nonzero(mates)):
        others = np.flatnonzero(mates[b] & (colour == colour[a]) & (kinds == kinds[a]))
        if len(others) and a not in others:
            out[a, b] = False
    return out


def exclusive_twins(twin: np.ndarray) -> np.ndarray:
    """Twins that are not another action's twin in return, int shape (A,) (-1 when none).

    A slot has one pick and one place of a colour: where ``a``'s twin ``b`` and another
    action ``c`` are each other's twins, ``b`` is ``c``'s and ``a`` has none in the trace
    (its own was never taken; the nearest of the other kind is the slot below or above).

    >>> exclusive_twins(np.array([2, 2, 1])).tolist()     # 1 and 2 pair; 0 has no twin
    [-1, 2, 1]
    """
    out = twin.copy()
    for a, b in enumerate(twin):
        if b >= 0 and twin[b] != a and twin[b] >= 0 and twin[twin[b]] == b:
            out[a] = -1
    return out


def action_mates(trace: Trace, ov: np.ndarray, colour: np.ndarray, twin: np.ndarray,
                 site_overlap: float) -> np.ndarray:
    """:func:`sequence_mates` of ``trace`` (its actions and episodes, never its states)."""
    return sequence_mates(trace.actions, trace.episodes(), ov, colour, trace.action_kinds(),
                          twin, site_overlap)


def acting_at(a: int, ov: np.ndarray, colour: np.ndarray, twin: np.ndarray,
              site_overlap: float, mates: np.ndarray | None = None) -> np.ndarray:
    """Actions that change what site ``a`` holds (module docstring), sorted int array.

    ``mates`` (:func:`sequence_mates`) names the actions of another colour at the slot;
    without it, those overlapping ``a``'s footprint by ``site_overlap`` or more.
    """
    if mates is None:
        other = np.flatnonzero((colour >= 0) & (colour != colour[a]) & (ov[a] >= site_overlap))
    else:
        other = np.flatnonzero(mates[a])
    acts = {a, *other.tolist()}
    acts |= {int(twin[b]) for b in list(acts) if twin[b] >= 0}
    return np.array(sorted(acts), dtype=np.int64)


def site_labels(actions: np.ndarray, episodes: list[tuple[int, int]], acting: np.ndarray,
                kinds: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """What a site holds at every observation, as its actions state it.

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
    for first, last in episodes:
        steps = [t for t in range(first, last) if actions[t] >= 0 and is_acting[actions[t]]]
        if not steps:
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
           bandwidth: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
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
      more often than the footprint presence does (each half of the episodes judged on what
      the other half teaches). Otherwise (or where no pose can read the site, or without
      ``x``) the run's median presence, so a frame in which the site is hidden is outvoted
      by the frames in which it is seen; or, where the footprint presence does no better on
      the labelled frames than saying what most of them hold, that (:func:`majority_guess`).
      A run read per pose also takes the colour its window shows (:func:`window_colour`).

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
        Width of the colour kernel (:func:`window_colour`).

    Returns
    -------
    presence, posterior : ndarray
        Settled copies.
    """
    presence, posterior = presence.copy(), posterior.copy()
    kinds = trace.action_kinds()
    twin = action_twins(trace, ov, colour) if twin is None else twin
    mates = action_mates(trace, ov, colour, twin, site_overlap) if mates is None else mates
    pose, episode = poses(trace.actions), trace.episode_index()
    episodes = trace.episodes()
    actions = trace.actions
    n_col = posterior.shape[2]
    start = np.zeros(trace.n_obs, dtype=bool)
    start[0] = True
    start[1:] = actions < 0
    examples: list[list[np.ndarray]] = [[] for _ in range(n_col)]
    looks: dict = {}
    for a in np.flatnonzero((counts > 0) & (colour >= 0)):
        acting = acting_at(int(a), ov, colour, twin, site_overlap, mates)
        labels = site_labels(actions, episodes, acting, kinds, colour)
        known = labels != UNLABELLED
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
        loose = np.flatnonzero(~known)
        if not len(loose):
            continue
        read = {}
        own = agreement(raw, np.ones(len(raw)), labels, EMPTY)
        # a footprint presence that agrees with every label cannot be bettered: not read again
        if x is not None and own < 1.0:
            window = site_window(x, labels, pose, EMPTY, support)
            if window is not None and held_out_agreement(x, labels, pose, episode, EMPTY,
                                                         support, saturation) > own:
                reading, strength = pose_readings(x, labels, pose, window, EMPTY, saturation)
                read = run_presence(reading, strength, run, loose)
                if n_col > 1:
                    chroma = window_chroma(x, labels, pose, window, EMPTY)
                    shows = (strength > 0) & (reading > 0.5) & np.isfinite(chroma[:, 0])
                    for c in range(n_col):
                        examples[c].append(chroma[shows & (labels == c)])
                    looks[int(a)] = (chroma, strength, shows, run, loose)
        guess = majority_guess(own, labels)
        ids, inv = np.unique(run[loose], return_inverse=True)
        for k in range(len(ids)):
            members = loose[inv == k]
            fallback = np.median(presence[members, a]) if guess is None else guess
            presence[members, a] = read.get(int(ids[k]), fallback)
            posterior[members, a] = posterior[members, a].mean(axis=0)
    if looks:
        window_colour(posterior, looks, examples, bandwidth)
    return presence, posterior


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


def window_colour(posterior: np.ndarray, looks: dict, examples: list[list[np.ndarray]],
                  bandwidth: float) -> None:
    """Colour of the unlabelled runs of the sites read per pose, in place.

    The colours' examples are what the labelled frames show in the sites' windows
    (:func:`~vggc_cp.vision.untouched.window_chroma`, frames whose pose reads the site and
    that read present); a run takes the mean posterior of its frames that show an object,
    weighted by their strength. Nothing changes where a colour has fewer than two examples
    or a run no such frame.

    Parameters
    ----------
    posterior : ndarray, shape (N, A, C)
    looks : dict
        Site -> (chroma (N, 2), strength (N,), shows (N,) bool, run (N,), loose).
    examples : list of list of ndarray
        Per colour, the chroma arrays of its examples.
    bandwidth : float
    """
    pooled = [np.concatenate(parts) if parts else np.zeros((0, 2)) for parts in examples]
    if min(len(p) for p in pooled) < 2:
        return
    for a, (chroma, strength, shows, run, loose) in looks.items():
        seen = loose[shows[loose]]
        if not len(seen):
            continue
        post = kernel_posterior(chroma[seen], pooled, bandwidth)
        for r in np.unique(run[seen]):
            these = run[seen] == r
            w = strength[seen][these]
            posterior[loose[run[loose] == r], a] = np.average(post[these], axis=0, weights=w)
