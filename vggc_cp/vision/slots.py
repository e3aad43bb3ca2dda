"""Slots: which of a trace's actions act at one place, read from the sequence and the footprints.

A slot holds one object at a time. Its actions are a pick and a place of each colour that can
stand there: for action ``a``, its *twin* (the other kind, the same colour: the place that
refills the slot ``a`` empties, or the pick that empties the slot ``a`` fills) and its *mates*
(the actions of the other colours at the slot). The footprints of :mod:`vggc_cp.vision.footprints`
say where an action acts, but a footprint may lie on a robot arm, and a block's footprint
overlaps the block's below it; the trace's own sequence says what it can:

* **twins** (:func:`sequence_twins`): a pick and the place at its slot alternate in every
  episode; a candidate that breaks this once is not the twin, one that never does is taken at
  odds of :data:`TWIN_ODDS`; the footprints decide the rest (:func:`twins`), but not for a
  candidate never met in an episode with the action while another was seen alternating
  with it (:data:`MIN_TWIN_AGREEMENTS`). A slot has one
  pick and one place of a colour, so an action whose nearest candidate pairs with another
  action both ways has no twin in the trace (:func:`exclusive_twins`); being twins is
  mutual, so an action that names none takes the one action that names it
  (:func:`mutual_twins`);
* **mates** (:func:`sequence_mates`): what one action leaves at a slot is what the next one
  there finds; a candidate that breaks this once is ruled out, one that always agrees is taken
  at :data:`TWIN_ODDS`, the footprints decide the rest; one mate of each colour and kind
  (:func:`one_per_colour`), and none that the other side gives to another action
  (:func:`exclusive_mates`); and since a slot is every action its mates reach, no chain of
  mates may put two actions of one colour and kind, or two the sequence rules apart, in
  one slot, and every action of another colour that the chains reach is a mate
  (:func:`consistent_mates`).

:func:`acting_at` gathers them: the actions that change what site ``a`` holds. Nothing here
reads action names or ground-truth states.
"""

from __future__ import annotations

import math

import numpy as np

from vggc_cp.trace import PICK, Trace

#: Label of an empty slot (colours are numbered from 0).
EMPTY = -1
#: Label of an observation whose site nothing states
#: (:func:`vggc_cp.vision.occupancy.site_labels`).
UNLABELLED = -2
#: Odds from which a candidate that always alternates with an action is taken for its twin
#: (:func:`sequence_twins`): 20 to 1, the bar of the warning's description-length margin.
TWIN_ODDS = 20.0
#: Agreements a mate of another colour needs before the sequence alone names it
#: (:func:`sequence_mates`): the one kind of pair that agrees, a pick then a place, can
#: follow by the order of an episode alone, and one such pair is one coincidence.
MIN_MATE_AGREEMENTS = 2
#: Alternations, never broken, from which a candidate takes the twin's place from a pixels'
#: choice that never met the action in an episode (:func:`sequence_twins`): two, as for a
#: mate; one alternation is what any pick and place of one episode give.
MIN_TWIN_AGREEMENTS = 2


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
    apart), the footprints decide (:func:`twins`) among the candidates that never break it
    (a robot arm's footprint overlapping the wrong place's most is not taken), unless their
    choice never met ``a`` in an episode while another candidate was seen alternating with
    it :data:`MIN_TWIN_AGREEMENTS` times or more: then the candidate seen alternating most
    often is the twin (some evidence against none; an action taken once or twice under a
    robot arm has the arm's move for its footprint: multifruit-4x6 robot s377, a pick taken
    twice, paired by the pixels with a place one region off taken once, made the red count
    one too many and a whole episode another state's nodes; on the tuning split every
    pixels' choice so overruled was wrong); where none of
    those overlaps ``a``'s footprint, the one candidate the sequence leaves (seen
    alternating, every other one broken) is the twin, and none where it leaves several.

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
    twin of 0 (and 0 of 2). 1 and 3 alternate once, too little for 20 to 1, but 2 comes six
    times with no 1 between, so the pixels' pairing of 1 with 2 is ruled out and the
    footprints choose among what is left: 3 (and 1 for 3, as 0 comes six times with no 3
    between):

    >>> from vggc_cp.trace import PLACE
    >>> kinds = np.array([PICK, PICK, PLACE, PLACE])
    >>> ov = np.array([[1, 0, .1, .5], [0, 1, .5, .1], [.1, .5, 1, 0], [.5, .1, 0, 1]])
    >>> actions = np.array([0, 2] * 6 + [-1, 1, 3])
    >>> sequence_twins(actions, [(0, 12), (13, 15)], ov, np.zeros(4, int), kinds).tolist()
    [2, 3, 0, 1]
    """
    out = twins(ov, colour, kinds)
    actions = np.asarray(actions)
    episode_of = action_episodes(len(actions), episodes)
    for a in np.flatnonzero(colour >= 0):
        cand = np.flatnonzero((colour == colour[a]) & (kinds != kinds[a]))
        counts = alternations(actions, episode_of, kinds, int(a), cand)
        sure = qualifies(counts)
        allowed = [(float(ov[a, b]), int(counts[i, 1]), int(b))
                   for i, b in enumerate(cand) if sure[i]]
        if allowed:
            out[a] = max(allowed)[2]
            continue
        kept = counts[:, 0] == 0                        # never seen to break the rule
        if out[a] < 0 or not kept[cand == out[a]].all():
            near = kept & (ov[a, cand] > 0)
            if near.any():                              # the nearest footprint kept
                out[a] = int(max(zip(ov[a, cand[near]], cand[near]))[1])
            elif kept.sum() == 1 and len(cand) > 1 and counts[kept, 1].sum() > 0:
                out[a] = int(cand[kept][0])             # the one the sequence leaves
            else:
                out[a] = -1
        seen = kept & (counts[:, 1] >= MIN_TWIN_AGREEMENTS)
        if out[a] >= 0 and seen.any() and not counts[cand == out[a]].any():
            # the pixels' choice never met ``a`` in an episode: the sequence has nothing for
            # it, and something for a candidate seen alternating, never broken
            out[a] = int(max(zip(counts[seen, 1], ov[a, cand[seen]], cand[seen]))[2])
    return out


def alternations(actions: np.ndarray, episode_of: np.ndarray, kinds: np.ndarray, a: int,
                 cand: np.ndarray) -> np.ndarray:
    """For every candidate ``b``: how often, in the actions restricted to ``a`` and ``b``,
    two neighbours of one episode are of one kind (broken) and of two (alternated); int64
    shape (len(cand), 2).

    >>> from vggc_cp.trace import PLACE
    >>> kinds = np.array([PICK, PLACE, PLACE])
    >>> counts = alternations(np.array([0, 1, 0, 2, 2]), np.zeros(5, int), kinds, 0,
    ...                       np.array([1, 2]))
    >>> counts.tolist()
    [[0, 2], [2, 1]]
    """
    counts = np.zeros((len(cand), 2), dtype=np.int64)
    for i, b in enumerate(cand):
        at = np.flatnonzero((actions == a) | (actions == b))
        neighbours = episode_of[at[1:]] == episode_of[at[:-1]]       # within one episode
        same = kinds[actions[at[1:]]] == kinds[actions[at[:-1]]]
        counts[i] = ((neighbours & same).sum(), (neighbours & ~same).sum())
    return counts


def odds_met(k, q: float):
    """Whether ``k`` agreements that each happen by chance with probability ``q`` make a
    relation :data:`TWIN_ODDS` (20 to 1) likelier than chance: ``k ln(1/q) >= ln 20``
    (elementwise for an array ``k``).

    >>> odds_met(np.array([2, 3]), 0.25).tolist()
    [False, True]
    """
    return np.asarray(k) * math.log(1.0 / q) >= math.log(TWIN_ODDS)


def qualifies(counts: np.ndarray) -> np.ndarray:
    """Which candidates the sequence takes for the twin (:func:`sequence_twins`), bool shape
    (len(counts),): never broken, and alternated ``k`` times with ``k ln(1/q) >= ln 20``,
    ``q`` the share of alternations over all candidates together. None qualifies where no
    candidate ever breaks it (nothing to tell them apart) or nothing alternates.

    >>> qualifies(np.array([[0, 12], [7, 1]])).tolist()
    [True, False]
    """
    total = counts.sum()
    if total == 0 or counts[:, 0].sum() == 0:
        return np.zeros(len(counts), dtype=bool)
    # how often an unrelated pair alternates, from the candidates together
    p_alt = counts[:, 1].sum() / total
    if p_alt <= 0:
        return np.zeros(len(counts), dtype=bool)
    return (counts[:, 0] == 0) & odds_met(counts[:, 1], p_alt)


def action_twins(trace: Trace, ov: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """:func:`sequence_twins` of ``trace`` (its actions and episodes, never its states), each
    :func:`exclusive_twins`, then :func:`mutual_twins`."""
    return mutual_twins(exclusive_twins(sequence_twins(trace.actions, trace.episodes(), ov,
                                                       colour, trace.action_kinds())))


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
    candidates together, as for :func:`sequence_twins`, and from two agreements at least
    (:data:`MIN_MATE_AGREEMENTS`: the only pair that agrees is a pick then a place, which
    the order of an episode can give at any two slots; random-1100 clean, draw 39: one such
    pair of the blue pick at region 1's top and the green place at region 2's, at a 3 % rate
    of agreeing, named them mates 23 pixels apart, the green top of region 2 lost its slot,
    and three episodes read it as another state, quietly). For the others (too few
    neighbours to tell, or no candidate ever breaking it: nothing to tell them apart), the
    footprints decide: an action of another colour overlapping ``a``'s footprint by
    ``site_overlap`` or more acts at its slot. A slot has one pick and one place of each
    colour, so at most one of each is kept (:func:`one_per_colour`), and only where the
    other side does not give its own mate of ``a``'s colour and kind to another action
    (:func:`exclusive_mates`): a block on top of ``a``'s overlaps it, but it is not at its
    slot. Last, no chain of mates may join what the sequence rules apart or two actions of
    one colour and kind, and what the chains join are mates (:func:`consistent_mates`).

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
    named = np.zeros((n, n), dtype=bool)               # taken by the sequence at TWIN_ODDS
    broken = np.zeros((n, n), dtype=bool)              # ruled out by the sequence
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
        ruled = cand[counts[:, 0] > 0]
        out[a, ruled] = False                          # ruled out by the sequence
        broken[a, ruled] = True
        if p_agree <= 0:
            continue
        sure = ((counts[:, 0] == 0) & odds_met(counts[:, 1], p_agree)
                & (counts[:, 1] >= MIN_MATE_AGREEMENTS))
        out[a, cand[sure]] = True
        named[a, cand[sure]] = True
    seen = out & (ov >= site_overlap)                  # the pixels put them at the slot too
    kept = exclusive_mates(one_per_colour(out, seen, ov, colour, kinds), colour, kinds)
    return consistent_mates(kept, twin, colour, kinds, ov + (named | named.T),
                            broken | broken.T)


def consistent_mates(mates: np.ndarray, twin: np.ndarray, colour: np.ndarray,
                     kinds: np.ndarray, strength: np.ndarray,
                     apart: np.ndarray | None = None) -> np.ndarray:
    """The slots mates and twins make, each with one pick and one place of each colour and
    no two actions the sequence rules out of one slot, as mates: boolean shape (A, A), true
    for two actions of different colours in one slot.

    Mates are chosen action by action, so a chain of them can join two slots: level 0 and
    level 1 of a region overlap as much as two objects at one level do, and where the
    sequence never puts an action of one beside an action of the other, the pixels join
    them (random-14 clean: the green pick at level 1 of region 0 a mate of the red pick
    below it, which never met it in an episode, while the sequence ruled it out of the
    yellow pick's slot, the red one's mate, 12 times). The slots are grown as a forest,
    strongest link first (twins, then mates by ``strength``); a link that would put two
    actions of one colour and kind, or two actions ``apart``, in one slot is left out, and
    every mate outside its action's slot with it. What a slot holds is every action its
    links reach: where only a red and a yellow pick overlap by the site bar (the two
    objects' shapes differ) and each has its twin, the red place's mates are the yellow
    pick and place too (multifruit-2x3 randomized s262: without them, the place's site ran
    on past the yellow pick that emptied it).

    Parameters
    ----------
    mates : ndarray of bool, shape (A, A)
    twin : ndarray of int, shape (A,)
        -1 for none.
    colour, kinds : ndarray, shape (A,)
    strength : ndarray, shape (A, A)
        How sure each link is (footprint overlap, plus 1 where the sequence names it).
    apart : ndarray of bool, shape (A, A), optional
        Pairs the sequence rules out of one slot (:func:`sequence_mates`).

    >>> kinds, colour = np.array([PICK, PICK, PICK]), np.array([0, 1, 2])
    >>> m = np.zeros((3, 3), bool); m[0, 1] = m[1, 0] = m[0, 2] = m[2, 0] = True
    >>> apart = np.zeros((3, 3), bool); apart[1, 2] = apart[2, 1] = True
    >>> strength = np.full((3, 3), 0.7); strength[0, 2] = strength[2, 0] = 0.5
    >>> out = consistent_mates(m, np.full(3, -1), colour, kinds, strength, apart)
    >>> np.flatnonzero(out[0]).tolist(), np.flatnonzero(out[2]).tolist()
    ([1], [])
    """
    n = len(colour)
    apart = np.zeros((n, n), dtype=bool) if apart is None else apart
    slot = np.arange(n)
    members = {a: [a] for a in range(n)}
    keys = {a: {(int(colour[a]), int(kinds[a]))} for a in range(n)}

    def join(a: int, b: int) -> None:
        ra, rb = int(slot[a]), int(slot[b])
        if ra == rb or keys[ra] & keys[rb] or apart[np.ix_(members[ra], members[rb])].any():
            return
        slot[members[rb]] = ra
        members[ra] += members.pop(rb)
        keys[ra] |= keys.pop(rb)

    for a in np.flatnonzero(twin >= 0):
        join(int(a), int(twin[a]))
    links = np.argwhere(np.triu(mates | mates.T, k=1))
    order = np.argsort(-strength[links[:, 0], links[:, 1]], kind="stable")
    for a, b in links[order]:
        join(int(a), int(b))
    coloured = colour >= 0
    return ((slot[:, None] == slot[None, :]) & (colour[:, None] != colour[None, :])
            & coloured[:, None] & coloured[None, :])


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


def mutual_twins(twin: np.ndarray) -> np.ndarray:
    """Twins in return, int shape (A,) (-1 when none).

    Being twins is mutual: the pick that empties a slot and the place that refills it. Where
    ``b`` names ``a`` its twin and ``a`` names none (its own choice was another slot's twin,
    :func:`exclusive_twins`, or nothing the footprints could tell), and no other action names
    ``a``, ``a``'s twin is ``b``. Otherwise the site of ``a`` would not count ``b``'s
    actions (:func:`acting_at`) while ``b``'s counts ``a``'s, and the actions would state
    that ``a``'s slot holds what ``b`` has just taken from it.

    >>> mutual_twins(np.array([-1, 0, -1, 2, 2])).tolist()  # 1 names 0; 3 and 4 both name 2
    [1, 0, -1, 2, 2]
    """
    out = twin.copy()
    for a in np.flatnonzero(twin < 0):
        claims = np.flatnonzero(twin == a)
        if len(claims) == 1:
            out[a] = int(claims[0])
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
