"""Places read from where the hand rests: slots for a robot's own camera (beyond the paper).

Which actions act at one slot (:mod:`vggc_cp.vision.slots`) is read from two things: the
trace's sequence, which rules candidates out, and a picture of where each action acts. The
footprints (:mod:`vggc_cp.vision.footprints`) are that picture on a scene where only the
objects move. A robot's own camera also sees its arm, which rests above the place it last
acted on: then most of what an action changes is the arm, footprints of one place disagree,
and the place shows better in what the scene looks like *after* the action.

**The after-look cue.** With ``mu_a`` the mean of the working frames right after action ``a``,
two actions after which the hand rests at one place look alike everywhere but at that place::

    D(a, b) = mean_p |mu_a(p) - mu_b(p)|_1

(smaller: likelier one place). Where nothing rests at the place (a fixed gripper), ``D`` says
little about places: the scene right after two actions differs at both of their places alike.

**Which cue.** The sequence names some twins for sure (a pick and the place that alternate
with it in every episode, at odds of :data:`~vggc_cp.vision.slots.TWIN_ODDS`,
:func:`sure_twins`). Each cue is asked for every sure twin's partner (the action of the same
colour and the other kind it puts nearest); the after-look cue is used only where it names
strictly more of them than the footprints do (:func:`after_look_wins`): the sequence, not a
setting, says which picture of the places to believe on this trace.

**Slots.** Where it is used, the actions are grouped by average linkage on ``D``, nearest
groups first (:func:`place_groups`), starting from the sequence's sure twins (each pair one
group from the outset), never two actions of one colour and kind in a group
(a slot has one pick and one place of each colour) and never a group its episodes
contradict: in the actions of an episode restricted to the group, what one leaves must be what
the next finds, unless an action the group lacks can have acted in between
(:func:`hard_breaks`). A group's twins and mates follow (:func:`group_slots`).

Nothing here reads action names or ground-truth states.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.trace import PICK, PLACE, Trace
from vggc_cp.vision.slots import (
    EMPTY,
    MIN_TWIN_AGREEMENTS,
    action_episodes,
    action_mates,
    action_twins,
    alternations,
    qualifies,
)


def after_distances(x: np.ndarray, act: np.ndarray, dst: np.ndarray, n_actions: int
                    ) -> np.ndarray:
    """``D(a, b)`` of the module docstring, shape (A, A); ``inf`` where an action is not taken.

    Parameters
    ----------
    x : ndarray of float32, shape (N, H, W, 3)
        Working frames.
    act, dst : ndarray of int, shape (T,)
        Every transition's action and the observation after it.
    n_actions : int

    >>> x = np.zeros((4, 1, 2, 3), np.float32); x[1, 0, 0] = 1; x[3, 0, 0] = 1
    >>> after_distances(x, np.array([0, 1, 2]), np.array([1, 2, 3]), 3).round(2).tolist()
    [[0.0, 1.5, 0.0], [1.5, 0.0, 1.5], [0.0, 1.5, 0.0]]
    """
    out = np.full((n_actions, n_actions), np.inf)
    taken = np.flatnonzero(np.bincount(act, minlength=n_actions) > 0)
    if not len(taken):
        return out
    flat = x.reshape(len(x), -1)
    mu = np.stack([flat[dst[act == a]].mean(axis=0, dtype=np.float64) for a in taken])
    for i, a in enumerate(taken):
        out[a, taken] = np.abs(mu[i] - mu).mean(axis=-1) * x.shape[-1]
    return out


def sure_twins(actions: np.ndarray, episodes: list[tuple[int, int]], colour: np.ndarray,
               kinds: np.ndarray) -> list[tuple[int, int]]:
    """Pairs ``(pick, place)`` the sequence names twins by itself.

    For every pick, its candidates are the places of its colour; a candidate that never
    breaks alternation with it, ``k`` times seen alternating, qualifies at odds of
    :data:`~vggc_cp.vision.slots.TWIN_ODDS` against the chance ``q`` that an unrelated pair
    alternates (estimated from all its candidates together: ``k ln(1/q) >= ln 20``), as in
    :func:`~vggc_cp.vision.slots.sequence_twins`. A pick with exactly one qualifying
    candidate (and at least one candidate that breaks it, so that ``q`` is measured) gives a
    pair.

    >>> kinds = np.array([PICK, PICK, PLACE, PLACE])
    >>> actions = np.array([0, 2] * 6 + [0, 3, 1, 3])
    >>> sure_twins(actions, [(0, 16)], np.zeros(4, int), kinds)
    [(0, 2)]
    """
    actions = np.asarray(actions)
    episode_of = action_episodes(len(actions), episodes)
    taken = np.zeros(len(kinds), dtype=bool)
    taken[actions[actions >= 0]] = True
    pairs = []
    for a in np.flatnonzero(taken & (kinds == PICK) & (colour >= 0)):
        cand = np.flatnonzero(taken & (colour == colour[a]) & (kinds != PICK))
        ok = cand[qualifies(alternations(actions, episode_of, kinds, int(a), cand))]
        if len(ok) == 1:
            pairs.append((int(a), int(ok[0])))
    return pairs


def named_twins(pairs: list[tuple[int, int]], near: np.ndarray, colour: np.ndarray,
                kinds: np.ndarray, taken: np.ndarray) -> int:
    """How many sure pairs a cue names: the pick's nearest place of its colour by ``near``
    (larger: nearer) is its twin.

    >>> near = np.array([[0, 0, .9, .1], [0, 0, .2, .3], [.9, .2, 0, 0], [.1, .3, 0, 0]])
    >>> named_twins([(0, 2), (1, 3)], near, np.zeros(4, int),
    ...             np.array([PICK, PICK, PLACE, PLACE]), np.ones(4, bool))
    2
    """
    hits = 0
    for a, b in pairs:
        cand = np.flatnonzero(taken & (colour == colour[a]) & (kinds != kinds[a]))
        hits += int(cand[np.argmax(near[a, cand])]) == b
    return hits


def after_look_wins(pairs: list[tuple[int, int]], ov: np.ndarray, dist: np.ndarray,
                    colour: np.ndarray, kinds: np.ndarray, taken: np.ndarray) -> bool:
    """Whether the after-look cue (``dist``, smaller nearer) names strictly more of the
    sequence's sure twins than the footprint overlaps ``ov`` do (module docstring)."""
    if not pairs:
        return False
    return (named_twins(pairs, -dist, colour, kinds, taken)
            > named_twins(pairs, ov, colour, kinds, taken))


def hard_breaks(seq: np.ndarray, same_episode: np.ndarray, colour: np.ndarray,
                kinds: np.ndarray, keys: set) -> int:
    """Neighbours in a group's restricted sequence that no missing action explains.

    ``seq`` are the group's actions in order and ``same_episode[i]`` whether ``seq[i]`` and
    ``seq[i + 1]`` lie in one episode. A pair whose first leaves ``L`` and whose second finds
    ``F != L`` breaks the slot only if the action that would have changed it in between is
    in the group (``keys``: its ``(colour, kind)`` pairs): a pick of ``L`` (when ``L`` is a
    colour) or a place of ``F`` (when ``F`` is one).

    >>> kinds, colour = np.array([PICK, PLACE, PLACE]), np.array([0, 0, 1])
    >>> seq = np.array([1, 2])                      # red placed, then yellow placed
    >>> hard_breaks(seq, np.array([True]), colour, kinds, {(0, PLACE), (1, PLACE)})
    0
    >>> hard_breaks(seq, np.array([True]), colour, kinds, {(0, PICK), (0, PLACE), (1, PLACE)})
    1
    """
    if len(seq) < 2:
        return 0
    finds = np.where(kinds == PICK, colour, EMPTY)
    leaves = np.where(kinds == PICK, EMPTY, colour)
    n = 0
    for left, found, same in zip(leaves[seq[:-1]], finds[seq[1:]], same_episode):
        if not same or left == found:
            continue
        if (left != EMPTY and (int(left), PICK) in keys) or \
                (found != EMPTY and (int(found), PLACE) in keys):
            n += 1
    return n


def place_groups(actions: np.ndarray, episodes: list[tuple[int, int]], dist: np.ndarray,
                 colour: np.ndarray, kinds: np.ndarray,
                 sure: list[tuple[int, int]] = ()) -> list[list[int]]:
    """Slots by average linkage on ``dist`` (module docstring), each a sorted list of
    actions; every taken action of a colour is in one. The ``sure`` twins (pick, place) the
    sequence names (:func:`sure_twins`) start in one group each: an arm that rests at one
    place after a pick at level 1 and a place at level 0 of a column makes their after-looks
    the nearest, and linkage alone paired them across the levels (random-1181 robot, draw 47:
    8 of its 16 sure twins parted, the actions stated wrong facts at four slots, 225 nodes
    for 78 states; with them, the true 78). Nor does a merge make twins of a pick and a place
    that never met in an episode while one of them alternates, never broken, with another
    :data:`~vggc_cp.vision.slots.MIN_TWIN_AGREEMENTS` times or more (the rule
    :func:`~vggc_cp.vision.slots.sequence_twins` keeps; random-5 robot after two suggested
    rounds: a pick seen alternating three times with its place was paired by the after-looks
    with a place it never met, the actions stated 994 wrong facts, 99 nodes for 35).

    >>> kinds = np.array([PICK, PLACE, PICK, PLACE])
    >>> dist = np.array([[0, 1, 5, 5], [1, 0, 5, 5], [5, 5, 0, 1], [5, 5, 1, 0.]])
    >>> actions = np.array([0, 1, 2, 3, 0, 1])
    >>> place_groups(actions, [(0, 6)], dist, np.array([0, 0, 0, 0]), kinds)
    [[0, 1], [2, 3]]
    """
    actions = np.asarray(actions)
    episode_of = action_episodes(len(actions), episodes)
    taken = np.zeros(len(kinds), dtype=bool)
    taken[actions[actions >= 0]] = True
    groups = [[int(a)] for a in np.flatnonzero(taken & (colour >= 0))]
    keys = [{(int(colour[a]), int(kinds[a]))} for a in (g[0] for g in groups)]
    # how often every pick and place of one colour alternate and break alternation
    counts: dict[tuple[int, int], np.ndarray] = {}
    for a in np.flatnonzero(taken & (kinds == PICK) & (colour >= 0)):
        cand = np.flatnonzero(taken & (colour == colour[a]) & (kinds != PICK))
        for b, c in zip(cand, alternations(actions, episode_of, kinds, int(a), cand)):
            counts[int(a), int(b)] = c

    def the_one_left(pairs: list[tuple[int, int]]) -> list[tuple[int, int]]:
        # of an action's candidate pairs, the one the sequence leaves: every other broken,
        # this one never, seen alternating MIN_TWIN_AGREEMENTS times or more
        kept = [k for k in pairs if counts[k][0] == 0]
        return kept if len(pairs) > 1 and len(kept) == 1 and \
            counts[kept[0]][1] >= MIN_TWIN_AGREEMENTS else []

    left = [k for a in sorted({a for a, _ in counts})
            for k in the_one_left([p for p in counts if p[0] == a])]
    left += [k for b in sorted({b for _, b in counts})      # and each place's one pick
             for k in the_one_left([p for p in counts if p[1] == b])]
    # the sequence's sure twins start as one slot: no picture of the places parts them; so
    # does a pick and the one place the sequence leaves it, seen alternating (or a place
    # and the one pick)
    for a, b in [*sure, *left]:
        i = next((k for k, g in enumerate(groups) if a in g), None)
        j = next((k for k, g in enumerate(groups) if b in g), None)
        if i is None or j is None or i == j or keys[i] & keys[j]:
            continue
        groups[i] = sorted(groups[i] + groups[j])
        keys[i] |= keys[j]
        del groups[j], keys[j]

    # each action's partners seen alternating, never broken, MIN_TWIN_AGREEMENTS times or more
    partners: dict[int, set[int]] = {}
    for (pick, place), c in counts.items():
        if c[0] == 0 and c[1] >= MIN_TWIN_AGREEMENTS:
            partners.setdefault(pick, set()).add(place)
            partners.setdefault(place, set()).add(pick)

    def seen_elsewhere(a: int, b: int) -> bool:
        # the pair never met in an episode, and one of them alternates, never broken, with
        # another at least MIN_TWIN_AGREEMENTS times (the rule sequence_twins keeps)
        pick, place = (a, b) if kinds[a] == PICK else (b, a)
        if counts.get((pick, place), np.zeros(2)).any():
            return False
        return bool(partners.get(pick, set()) - {place} or partners.get(place, set()) - {pick})

    def unmet_twins(g: list[int], h: list[int]) -> bool:
        return any(colour[a] == colour[b] and kinds[a] != kinds[b] and seen_elsewhere(a, b)
                   for a in g for b in h)

    def breaks(members: list[int], key: set) -> int:
        inside = np.zeros(len(kinds), dtype=bool)
        inside[members] = True
        at = np.flatnonzero((actions >= 0) & inside[np.maximum(actions, 0)])
        return hard_breaks(actions[at], episode_of[at[1:]] == episode_of[at[:-1]], colour,
                           kinds, key)

    while len(groups) > 1:
        link = np.array([[dist[np.ix_(g, h)].mean() if i != j and not keys[i] & keys[j]
                          else np.inf for j, h in enumerate(groups)]
                         for i, g in enumerate(groups)])
        merged = False
        for flat in np.argsort(link, axis=None):
            i, j = np.unravel_index(flat, link.shape)
            if not np.isfinite(link[i, j]):
                break
            if i > j:
                continue
            if breaks(groups[i] + groups[j], keys[i] | keys[j]) == 0 and \
                    not unmet_twins(groups[i], groups[j]):
                groups[i] = sorted(groups[i] + groups[j])
                keys[i] |= keys[j]
                del groups[j], keys[j]
                merged = True
                break
        if not merged:
            break
    return groups


def group_slots(groups: list[list[int]], colour: np.ndarray, kinds: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Twins (int, shape (A,), -1 for none) and mates (bool, shape (A, A)) of slot groups.

    >>> twin, mates = group_slots([[0, 1, 2]], np.array([0, 0, 1]), np.array([PICK, PLACE, PICK]))
    >>> twin.tolist(), np.flatnonzero(mates[0]).tolist()
    ([1, 0, -1], [2])
    """
    n = len(colour)
    twin = np.full(n, -1, dtype=np.int64)
    mates = np.zeros((n, n), dtype=bool)
    for g in groups:
        for a in g:
            for b in g:
                if a == b:
                    continue
                if colour[a] == colour[b]:
                    twin[a] = b if kinds[a] != kinds[b] else twin[a]
                else:
                    mates[a, b] = True
    return twin, mates


def after_look_slots(trace: Trace, x: np.ndarray, ov: np.ndarray, colour: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray] | None:
    """Twins and mates from where the hand rests, or None where the footprints name the
    sequence's sure twins as well (module docstring).

    Parameters
    ----------
    trace : Trace
        Its actions and episodes (never its states).
    x : ndarray of float32, shape (N, H, W, 3)
        Working frames.
    ov : ndarray, shape (A, A)
        Footprint overlaps.
    colour : ndarray of int, shape (A,)
    """
    _, act, dst = trace.transitions()
    kinds = trace.action_kinds()
    taken = (np.bincount(act, minlength=trace.n_actions) > 0) & (colour >= 0)
    pairs = sure_twins(trace.actions, trace.episodes(), colour, kinds)
    dist = after_distances(x, act, dst, trace.n_actions)
    if not after_look_wins(pairs, ov, dist, colour, kinds, taken):
        return None
    return group_slots(place_groups(trace.actions, trace.episodes(), dist, colour, kinds,
                                    pairs), colour, kinds)


def trace_slots(trace: Trace, x: np.ndarray, ov: np.ndarray, colour: np.ndarray,
                site_overlap: float) -> tuple[np.ndarray, np.ndarray, bool]:
    """Twins and mates of every action, and whether they were read from where the hand rests:
    from the after-looks where that cue names more of the sequence's sure twins
    (:func:`after_look_slots`), else from the sequence and the footprints
    (:func:`~vggc_cp.vision.slots.action_twins`, :func:`~vggc_cp.vision.slots.action_mates`).
    """
    found = after_look_slots(trace, x, ov, colour)
    if found is not None:
        return (*found, True)
    twin = action_twins(trace, ov, colour)
    return twin, action_mates(trace, ov, colour, twin, site_overlap), False
