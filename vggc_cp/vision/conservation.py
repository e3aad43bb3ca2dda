"""Objects are conserved: what the untouched slots of an episode hold, as the counts require.

A pick lifts an object and the next place puts it down; nothing else creates or removes one.
So in every observation the number of objects of each colour on the slots, plus the one in the
hand, is the same, ``K_c`` (objects at places no action of the trace touches never change
and are left out of the count alike). ``K_c`` is the count under which the episodes'
readings are most likely (:func:`best_counts`), searched from the count most observations
show (:func:`object_counts`): a slot an arm hides in most frames can make the most frequent
count wrong, and the episodes whose actions state where the objects are outweigh it. Where
the recording does not settle the counts (a count one object away at least 1/20 as likely:
a slot above another read full where nothing stands, in a short recording), nothing is
assigned.

In an episode the actions state what every slot they touch holds (:func:`settle
<vggc_cp.vision.occupancy.settle>`); every other slot holds one thing for the whole episode,
and that is read from the images, well where a reading reaches it and not at all where an arm
hides it in every frame. The untouched slots together hold ``K_c`` less what the touched slots
and the hand hold, ``n_c`` objects of colour ``c``: the assignment of ``n_c`` slots to each
colour (the rest empty) that the readings make most likely is what they hold
(:func:`episode_assignment`, the Hungarian method on log-likelihoods).

A reading counts as far as it can be trusted: with settled presence ``p`` of a reading whose
agreement with the stated frames beyond chance is ``kappa`` (its held-out Cohen's kappa,
:func:`vggc_cp.vision.trust.reading_kappa`; 0 for a run no reading reaches), the
probability that the slot holds something is ``m + kappa (p - m)``, and of colour ``c``
that times the run's colour posterior, with ``m`` what is known of the slot without the
reading: how often it holds something when an episode starts, as the first frames of the
episodes whose actions state it say, shrunk toward how often all its stated frames do by two
frames (:func:`start_rates`; :func:`base_rates`, Laplace's rule of succession). An untouched
slot holds all episode long what it held at the start, so that is its prior: where episodes
start alike (a robot reset to one home), an arm that hides a place and a weaker reading of
an empty one elsewhere no longer move an object between them (multifruit-4x6 robot s134: in
one episode both places read empty, the count put the missing red at the weaker reading of
the two, and the episode's three frames made nodes of their own). A slot nothing can read
is decided by the counts, the other slots and ``m``; at ``m = 1/2`` it was free room for
any object the counts had left over, and a count one too many could win (random-705 randomized: a level-2 place taken once, read by nothing,
held a fourth red in every episode). Where they cannot decide (two unread slots, one
object), the reading's low kappa is what the read doubts report
(:mod:`vggc_cp.solvers.read_doubts`).

Stacks are facts too (a block on a block, where the actions state which slot is above
which): an untouched slot under one the actions fill in any frame of the episode holds
something, and one above a slot they empty holds nothing (:func:`stack_forced`); the other
value costs as much as a reading that rules it out.

Objects rest on something: where the trace stacks slots, an episode takes the most likely
assignment that puts no object above an empty slot in any of its frames (:func:`grounded`,
ranking the assignments with Murty's method, :func:`ranked_assignments`): a slot above one
the counts leave full may read full because it sees the object below, and then the object
stands on the slot below, not in the air (blocks-3 randomized s94: a block read on top of a
two-block stack made three nodes of their own). The counts are weighed on such assignments
too (:func:`counted_loglik`): an object they could put only in the air is no evidence for a
count (blocks-2 randomized s243: an unread level-1 slot with a start prior of 2/3 favoured a
third block in each of twelve episodes, and the count came out three for two).

A slot whose contents the counts set against its reading is trusted no more than their choice
is sure (:func:`count_trust`), so that a doubt may name it (multifruit-2x3 robot s242).

The counts decide only where they do: an episode whose best assignment changes a reading
but ties with another assignment (two slots read full with equal certainty and one object
to place: the counts would toss a coin) keeps its readings (:func:`runner_up`, or the next
grounded assignment). So do an episode none of whose first :data:`MAX_RANKED` assignments
stands and one whose counts the stated slots already contradict (fewer objects left than
they need, or more than the untouched slots can hold). Nothing reads action names or
ground-truth states.
"""

from __future__ import annotations

import heapq

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from vggc_cp.trace import PICK, Trace, hand_colours_along
from vggc_cp.vision.slots import acting_at

#: Floor of a probability in the log-likelihoods (a reading never rules a value out).
FLOOR = 1e-3
#: Log-likelihoods closer than this are a tie: the counts do not decide between them.
TIE = 1e-6
#: The object counts are used only where they are at least 20 times as likely as any count
#: one object away (the odds the sequence's twins are taken at, :mod:`vggc_cp.vision.slots`).
COUNT_ODDS = float(np.log(20.0))
#: Assignments of an episode ranked at most in search of one that puts no object in the air
#: (:func:`grounded`).
MAX_RANKED = 64


def slot_groups(ov: np.ndarray, colour: np.ndarray, counts: np.ndarray, twin: np.ndarray,
                mates: np.ndarray | None, site_overlap: float) -> np.ndarray:
    """Slot of every action, int64 shape (A,): actions that act at one slot (an action, its
    twin and its mates, :func:`~vggc_cp.vision.slots.acting_at`, transitively) share one;
    -1 for an action never taken or of no colour.

    >>> ov = np.eye(4); colour = np.array([0, 0, 1, 1]); twin = np.array([1, 0, 3, 2])
    >>> slot_groups(ov, colour, np.ones(4, int), twin, None, 0.5).tolist()
    [0, 0, 1, 1]
    """
    n = len(colour)
    taken = np.flatnonzero((counts > 0) & (colour >= 0))
    rows, cols = [], []
    for a in taken:
        for b in acting_at(int(a), ov, colour, twin, site_overlap, mates):
            rows.append(int(a))
            cols.append(int(b))
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, comp = connected_components(graph, directed=False)
    out = np.full(n, -1, dtype=np.int64)
    _, out[taken] = np.unique(comp[taken], return_inverse=True)
    return out


def slots_below(above: dict[int, list[int]], slot: np.ndarray) -> dict[int, set[int]]:
    """Slot -> the other slots that must hold something where it does, from the sites stacked
    on each site (:func:`vggc_cp.vision.stacks.slots_above`).

    >>> slots_below({0: [2, 3], 2: [4]}, np.array([0, 0, 1, 1, 2]))
    {1: {0}, 2: {1}}
    """
    out: dict[int, set[int]] = {}
    for a, tops in above.items():
        for b in tops:
            if slot[a] >= 0 and slot[b] >= 0 and slot[a] != slot[b]:
                out.setdefault(int(slot[b]), set()).add(int(slot[a]))
    return out


def trusted(presence: np.ndarray, trust: np.ndarray, base: np.ndarray | float = 0.5
            ) -> np.ndarray:
    """The probability that a site holds something, a reading counted as far as its kappa
    trusts it: ``m + kappa (p - m)`` (module docstring), with ``m`` (``base``) what is
    known without the reading: 1/2, or the share of the site's stated frames in which it
    holds something (:func:`base_rates`; :func:`conserve` gives it :func:`start_rates`).

    >>> trusted(np.array([1.0, 0.0, 1.0]), np.array([1.0, 0.5, 0.0])).tolist()
    [1.0, 0.25, 0.5]
    >>> trusted(np.array([1.0]), np.array([0.0]), np.array([0.1])).tolist()
    [0.1]
    """
    return base + np.clip(trust, 0.0, 1.0) * (presence - base)


def base_rates(presence: np.ndarray, stated: np.ndarray) -> np.ndarray:
    """Share of each site's stated frames in which it holds something, shape (A,), shrunk
    toward 1/2 by one frame of each kind (Laplace's rule of succession); 1/2 where nothing
    is stated.

    >>> base_rates(np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]]),
    ...            np.array([[True, False], [True, False], [True, False]])).round(2).tolist()
    [0.4, 0.5]
    """
    full = (presence * stated).sum(axis=0)
    return (full + 1.0) / (stated.sum(axis=0) + 2.0)


def start_rates(presence: np.ndarray, stated: np.ndarray, firsts: np.ndarray,
                prior: float = 2.0) -> np.ndarray:
    """Share of the episodes' stated first frames in which each site holds something, shape
    (A,), shrunk toward the share of all its stated frames (:func:`base_rates`) by ``prior``
    frames: where few episodes state a site at their start, what its other frames hold is
    the better guess (a slot stated at the start of one episode, full there, is no 2 to 1
    bet on being full at every start).

    >>> presence = np.array([[1.0], [0.0], [0.0], [0.0], [1.0]])
    >>> stated = np.ones((5, 1), dtype=bool)
    >>> base_rates(presence, stated).round(3).tolist()
    [0.429]
    >>> start_rates(presence, stated, np.array([0])).round(3).tolist()
    [0.619]
    """
    full = (presence[firsts] * stated[firsts]).sum(axis=0)
    return (full + prior * base_rates(presence, stated)) / (stated[firsts].sum(axis=0) + prior)


def held_colours(actions: np.ndarray, kinds: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """Colour of what the hand holds in every observation, int64 shape (N,), -1 for nothing:
    after a pick, what it lifted; before a place, what it puts down
    (:func:`~vggc_cp.trace.hand_colours_along`, as :func:`vggc_cp.solvers.base.hand_colours`
    reads a problem).

    >>> held_colours(np.array([0, 1, -1, 0]), np.array([0, 1]), np.array([2, 2])).tolist()
    [-1, 2, -1, -1, 2]
    """
    src = np.flatnonzero(np.asarray(actions) >= 0)
    act = np.asarray(actions)[src]
    lifted = np.asarray(kinds)[act] == PICK
    return hand_colours_along(len(actions) + 1, src, act, src + 1, lifted, ~lifted, colour)


def object_counts(values: np.ndarray, held: np.ndarray, n_col: int) -> np.ndarray:
    """The number of objects of each colour on the slots and in the hand that most
    observations show, int64 shape (C,): where the search for ``K_c`` starts
    (:func:`best_counts`).

    Parameters
    ----------
    values : ndarray of int, shape (N, S)
        What every slot holds as settled: -1 empty, else a colour.
    held : ndarray of int, shape (N,)
        :func:`held_colours`.

    >>> values = np.array([[0, -1], [-1, -1], [0, -1], [0, 0]])    # one misread frame
    >>> object_counts(values, np.array([-1, 0, -1, -1]), 1).tolist()   # in the hand at 1
    [1]
    """
    out = np.zeros(n_col, dtype=np.int64)
    for c in range(n_col):
        per_frame = (values == c).sum(axis=1) + (held == c)
        out[c] = int(np.bincount(per_frame).argmax())
    return out


def _gains(p_occupied: np.ndarray, colour_post: np.ndarray, need: np.ndarray,
           forced: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Log-likelihood of every slot holding what every column stands for, shape (L, L), and
    the columns: ``need[c]`` of colour ``c``, the rest empty (-1). A slot ``forced`` full
    (1) or empty (-1) by a stack pays ``log FLOOR`` more for the other (:func:`stack_forced`)."""
    p = np.clip(np.nan_to_num(p_occupied, nan=0.5), FLOOR, 1.0 - FLOOR)
    post = np.clip(np.nan_to_num(colour_post, nan=1.0), FLOOR, None)
    post = post / post.sum(axis=1, keepdims=True)
    occupied = np.log(p)[:, None] + np.log(post)                    # (L, C)
    empty = np.log(1.0 - p)                                          # (L,)
    if forced is not None:
        occupied = occupied + np.where(forced < 0, np.log(FLOOR), 0.0)[:, None]
        empty = empty + np.where(forced > 0, np.log(FLOOR), 0.0)
    columns = np.concatenate([np.repeat(np.arange(len(need)), need),
                              np.full(len(p) - int(need.sum()), -1)]).astype(np.int64)
    gain = np.where(columns[None, :] >= 0, occupied[:, np.maximum(columns, 0)], empty[:, None])
    return gain, columns


def episode_assignment(p_occupied: np.ndarray, colour_post: np.ndarray, need: np.ndarray,
                       forced: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """The most likely contents of untouched slots that hold ``need[c]`` objects of colour
    ``c``, and their log-likelihood.

    Parameters
    ----------
    p_occupied : ndarray, shape (L,)
        Probability that each slot holds something.
    colour_post : ndarray, shape (L, C)
        Colour posterior of what each slot holds.
    need : ndarray of int, shape (C,)
    forced : ndarray of int, shape (L,), optional
        1 where a stack requires the slot to hold something, -1 where it requires it empty,
        0 elsewhere (:func:`stack_forced`); the other value costs a reading at ``FLOOR``.

    Returns
    -------
    contents : ndarray of int64, shape (L,)
        -1 empty, else a colour.
    loglik : float
        Of the readings under ``contents``. Counts no assignment meets (a negative need,
        or more objects than slots) cost ``log FLOOR`` per object too many or too few, as
        a reading that rules a value out would: the counts are as much evidence as a
        reading, no more.

    >>> contents, _ = episode_assignment(np.array([0.5, 0.5, 0.9]),
    ...                                  np.array([[1.0], [1.0], [1.0]]), np.array([2]))
    >>> contents.tolist()
    [0, -1, 0]
    """
    need = np.asarray(need, dtype=np.int64)
    short = int(np.maximum(-need, 0).sum())
    need = np.maximum(need, 0)
    excess = max(int(need.sum()) - len(p_occupied), 0)
    for _ in range(excess):                      # drop the most wanted colour's extra ones
        need[int(np.argmax(need))] -= 1
    penalty = (short + excess) * np.log(FLOOR)
    out = np.empty(len(p_occupied), dtype=np.int64)
    if not len(p_occupied):
        return out, float(penalty)
    gain, columns = _gains(p_occupied, colour_post, need, forced)
    rows, picked = linear_sum_assignment(-gain)
    out[rows] = columns[picked]
    return out, float(gain[rows, picked].sum() + penalty)


def runner_up(p_occupied: np.ndarray, colour_post: np.ndarray, need: np.ndarray,
              contents: np.ndarray, forced: np.ndarray | None = None) -> float:
    """Log-likelihood of the most likely assignment (as :func:`episode_assignment`, ``need``
    met) that differs from ``contents`` in at least one slot; ``-inf`` where none does.

    The best assignment that gives slot ``i`` anything but ``contents[i]``, the best over
    ``i`` (the first step of Murty's ranking of assignments).

    >>> p, post = np.array([0.9, 0.9, 0.2]), np.ones((3, 1))
    >>> best, loglik = episode_assignment(p, post, np.array([1]))
    >>> round(loglik - runner_up(p, post, np.array([1]), best), 6)    # a coin toss
    0.0
    """
    gain, columns = _gains(p_occupied, colour_post, np.asarray(need, dtype=np.int64), forced)
    out = -np.inf
    for i in range(len(contents)):
        banned = gain.copy()
        banned[i, columns == contents[i]] = -np.inf
        if not np.isfinite(banned[i]).any():
            continue
        try:
            rows, picked = linear_sum_assignment(-banned)
        except ValueError:                       # no assignment avoids the ban
            continue
        out = max(out, float(banned[rows, picked].sum()))
    return out


def ranked_assignments(p_occupied: np.ndarray, colour_post: np.ndarray, need: np.ndarray,
                       forced: np.ndarray | None = None, limit: int = MAX_RANKED):
    """The assignments of :func:`episode_assignment` (``need`` met, non-negative and at most
    one object a slot) from the most likely down, at most ``limit`` of them: yields
    ``(contents, loglik)``, ``loglik`` never increasing.

    Murty's ranking (Murty 1968) over what each slot holds: the next assignment is the best
    of the ones not yet given, found by splitting the space left by the last one given (the
    best with its first ``k`` slots as in it and slot ``k`` not) and solving each part with
    the Hungarian method. Objects of one colour are interchangeable, so each assignment of
    contents comes once.

    References
    ----------
    K. G. Murty, "An algorithm for ranking all the assignments in order of increasing cost",
    Operations Research 16(3):682-687, 1968.

    >>> p, post = np.array([0.9, 0.6, 0.2]), np.ones((3, 1))
    >>> [c.tolist() for c, _ in ranked_assignments(p, post, np.array([1]))]
    [[0, -1, -1], [-1, 0, -1], [-1, -1, 0]]
    """
    need = np.asarray(need, dtype=np.int64)
    if (need < 0).any() or need.sum() > len(p_occupied) or not len(p_occupied):
        return
    gain, columns = _gains(p_occupied, colour_post, need, forced)

    def solve(rules: tuple) -> tuple[np.ndarray, float] | None:
        g = gain.copy()
        for i, value, kept in rules:
            g[i, (columns != value) if kept else (columns == value)] = -np.inf
        try:
            rows, picked = linear_sum_assignment(-g)
        except ValueError:                       # the rules leave no assignment
            return None
        total = float(g[rows, picked].sum())
        if not np.isfinite(total):
            return None
        contents = np.empty(len(p_occupied), dtype=np.int64)
        contents[rows] = columns[picked]
        return contents, total

    first = solve(())
    if first is None:
        return
    heap = [(-first[1], 0, first[0], ())]
    count = 1
    for _ in range(limit):
        if not heap:
            return
        neg, _, contents, rules = heapq.heappop(heap)
        yield contents, -neg
        kept = {i for i, _, k in rules if k}
        free = [i for i in range(len(contents)) if i not in kept]
        for k, i in enumerate(free):
            part = (*rules, *((j, int(contents[j]), True) for j in free[:k]),
                    (i, int(contents[i]), False))
            found = solve(part)
            if found is not None:
                heapq.heappush(heap, (-found[1], count, found[0], part))
                count += 1


def grounded(p_occupied: np.ndarray, colour_post: np.ndarray, need: np.ndarray,
             forced: np.ndarray | None, floats, limit: int = MAX_RANKED
             ) -> tuple[np.ndarray | None, float, float]:
    """The most likely assignment that puts no object above an empty slot (``floats(contents)``
    False), its log-likelihood and the next such one's (``-inf`` where none is left; where
    the ranking stops at ``limit`` first, the last assignment ranked bounds it from above).
    ``(None, -inf, -inf)`` where none of the first ``limit`` stands.

    >>> p, post = np.array([0.9, 0.8, 0.1]), np.ones((3, 1))
    >>> on_top = lambda c: bool(c[1] >= 0 and c[0] < 0)       # slot 1 stands on slot 0
    >>> best, ll, next_ll = grounded(p, post, np.array([1]), None, on_top)
    >>> best.tolist(), bool(ll > next_ll)
    ([0, -1, -1], True)
    """
    found: list[float] = []
    best, last, ranked = None, -np.inf, 0
    for contents, loglik in ranked_assignments(p_occupied, colour_post, need, forced, limit):
        last, ranked = loglik, ranked + 1
        if floats(contents):
            continue
        if best is None:
            best = contents
        found.append(loglik)
        if len(found) == 2:
            return best, found[0], found[1]
    if best is None:
        return None, -np.inf, -np.inf
    return best, found[0], last if ranked >= limit else -np.inf


def counted_loglik(p_occupied: np.ndarray, colour_post: np.ndarray, need: np.ndarray,
                   forced: np.ndarray | None = None, floats=None) -> float:
    """Log-likelihood of an episode's readings when its untouched slots hold ``need[c]``
    objects of colour ``c``: of the most likely assignment (:func:`episode_assignment`), or,
    with ``floats`` (:func:`in_the_air`), of the most likely one that puts nothing in the
    air (:func:`grounded`); where none of those ranked stands, the most likely one pays
    ``log FLOOR`` for it, as a reading that rules a value out would.

    >>> p, post = np.array([0.0, 0.4]), np.ones((2, 1))       # slot 1 stands on slot 0
    >>> on_top = lambda c: bool(c[1] >= 0 and c[0] < 0)
    >>> round(counted_loglik(p, post, np.array([1])), 2)       # slot 1, in the air
    -0.92
    >>> round(counted_loglik(p, post, np.array([1]), None, on_top), 2)   # slot 0, read empty
    -7.42
    """
    need = np.asarray(need, dtype=np.int64)
    contents, loglik = episode_assignment(p_occupied, colour_post, need, forced)
    if floats is None or (need < 0).any() or need.sum() > len(p_occupied) or \
            not floats(contents):
        return loglik
    _, standing, _ = grounded(p_occupied, colour_post, need, forced, floats)
    return standing if np.isfinite(standing) else loglik + float(np.log(FLOOR))


def best_counts(episodes: list[tuple], start: np.ndarray) -> tuple[np.ndarray, float]:
    """``K_c``: the object counts under which the episodes' readings are most likely, and by
    how much they beat the counts one object away.

    Each episode contributes the log-likelihood of its best assignment
    (:func:`episode_assignment`) given what its touched slots and the hand hold; the counts
    move one object of one colour at a time from ``start`` while that raises the total (a
    slot misread in most frames would make the most frequent count wrong; the episodes
    whose actions state where the objects are outweigh it).

    Parameters
    ----------
    episodes : list of (fixed, p_occupied, colour_post[, forced[, floats]])
        ``fixed`` (C,): objects of each colour the touched slots and the hand hold at the
        episode's start; the rest as for :func:`counted_loglik`.
    start : ndarray of int, shape (C,)

    Returns
    -------
    counts : ndarray of int64, shape (C,)
    margin : float
        Log-likelihood of ``counts`` less the best of the counts one object away (``inf``
        where there is none).

    >>> ones = np.ones((2, 1))
    >>> eps = [(np.array([1]), np.array([0.9, 0.1]), ones)] * 3 + \\
    ...       [(np.array([0]), np.array([0.9, 0.9]), ones)]          # one episode misread
    >>> counts, margin = best_counts(eps, np.array([3]))           # from the wrong start
    >>> counts.tolist(), round(margin, 2)
    ([2], 8.79)
    """
    seen: dict[tuple, float] = {}

    def total(k):
        key = tuple(int(v) for v in k)
        if key not in seen:
            seen[key] = sum(counted_loglik(p, post, k - fixed, *rest)
                            for fixed, p, post, *rest in episodes)
        return seen[key]

    def neighbours(k):
        for c in range(len(k)):
            for step in (-1, 1):
                near = k.copy()
                near[c] += step
                if near[c] >= 0:
                    yield near

    best, score = np.asarray(start, dtype=np.int64).copy(), total(start)
    improved = True
    while improved:
        improved = False
        for k in neighbours(best):
            t = total(k)
            if t > score + 1e-9:
                best, score, improved = k, t, True
                break
    margin = min((score - total(k) for k in neighbours(best)), default=np.inf)
    return best, float(margin)


def stack_forced(full: np.ndarray, loose: np.ndarray, below: dict[int, set[int]]
                 ) -> np.ndarray:
    """What the stacks require of an episode's untouched slots: 1 where one must hold
    something, -1 where one must be empty, 0 where nothing is required; int64 shape
    ``(len(loose),)``.

    An untouched slot holds one thing all episode. Where a slot stacked on it holds something
    in any frame (a block the actions put on it), it holds something too; where a slot it
    stands on is empty in any frame, it is empty. What is required of one untouched slot
    passes down (full) or up (empty) to the untouched slots it is stacked with. A slot
    required both ways (readings that contradict the stack) is required neither way.

    Parameters
    ----------
    full : ndarray of bool, shape (F, S)
        What every slot holds in every frame of the episode, as settled.
    loose : ndarray of int
        The untouched slots.
    below : dict
        Slot -> slots that must hold something where it does (:func:`slots_below`).

    >>> full = np.array([[False, False], [False, True]])    # slot 1 put on slot 0 at frame 1
    >>> stack_forced(full, np.array([0]), {1: {0}}).tolist()
    [1]
    >>> stack_forced(full[:, ::-1], np.array([1]), {1: {0}}).tolist()   # 0 empty: 1 too
    [-1]
    """
    index = {int(s): i for i, s in enumerate(loose)}
    need_full = np.zeros(len(loose), dtype=bool)
    need_empty = np.zeros(len(loose), dtype=bool)
    for top, under in below.items():
        for u in under:
            if u in index and top not in index and full[:, top].any():
                need_full[index[u]] = True
            if top in index and u not in index and (~full[:, u]).any():
                need_empty[index[top]] = True
    changed = True
    while changed:
        changed = False
        for top, under in below.items():
            for u in under:
                if top in index and u in index:
                    if need_full[index[top]] and not need_full[index[u]]:
                        need_full[index[u]] = changed = True
                    if need_empty[index[u]] and not need_empty[index[top]]:
                        need_empty[index[top]] = changed = True
    both = need_full & need_empty
    return np.where(both, 0, need_full.astype(np.int64) - need_empty.astype(np.int64))


def in_the_air(full: np.ndarray, loose: np.ndarray, below: dict[int, set[int]]):
    """``floats(contents)`` of :func:`grounded` for one episode: whether giving its untouched
    slots ``loose`` the ``contents`` (-1 empty, else a colour) puts an object above an empty
    slot in any of its frames ``full`` (bool, shape (F, S): what every slot holds; the
    touched slots change from frame to frame, the untouched do not).

    >>> full = np.array([[True, False, False]])            # slot 2 stands on slot 1
    >>> floats = in_the_air(full, np.array([1, 2]), {2: {1}})
    >>> floats(np.array([-1, 0])), floats(np.array([0, 0]))
    (True, False)
    """
    def floats(contents: np.ndarray) -> bool:
        frames = full.copy()
        frames[:, loose] = np.asarray(contents) >= 0
        return any((frames[:, s] & ~frames[:, sorted(under)].all(axis=1)).any()
                   for s, under in below.items())
    return floats


def count_trust(margin: float) -> float:
    """How far a slot's contents that the counts set against its reading can be trusted at
    most, on the scale of a reading's kappa: ``tanh(margin / 2)`` = ``2 P - 1``, ``P`` the
    chance of the episode's best assignment against the next (``margin`` nats apart), 0 for a
    coin toss and 1 for a sure one. (Two assignments 0.34 nats apart, multifruit-2x3 robot
    s242: an object put on the weaker of two readings of an empty place, 0.17; at the
    counts' own odds of 20 to 1, 0.90.)

    >>> [round(count_trust(m), 2) for m in (0.0, 0.34, float(np.log(20.0)), float("inf"))]
    [0.0, 0.17, 0.9, 1.0]
    """
    return float(np.tanh(max(float(margin), 0.0) / 2.0))


def conserve(trace: Trace, presence: np.ndarray, posterior: np.ndarray, stated: np.ndarray,
             trust: np.ndarray, slot: np.ndarray, colour: np.ndarray,
             above: dict[int, list[int]] | None = None, odds: float = COUNT_ODDS
             ) -> tuple[np.ndarray, np.ndarray, int]:
    """What every episode's untouched slots hold, as the object counts require (module
    docstring).

    Parameters
    ----------
    trace : Trace
        Its actions and episodes (never its states).
    presence, posterior : ndarray, shapes (N, A) and (N, A, C)
        Settled (:func:`vggc_cp.vision.occupancy.settle`).
    stated : ndarray of bool, shape (N, A)
        Where the actions state what a site holds.
    trust : ndarray, shape (N, A)
        How far each settled presence can be trusted, in [0, 1] (kappa of its reading).
    slot : ndarray of int, shape (A,)
        :func:`slot_groups`.
    colour : ndarray of int, shape (A,)
    above : dict, optional
        Site -> sites stacked on it (:func:`vggc_cp.vision.stacks.slots_above`).
    odds : float
        The log-likelihood by which the counts must beat every count one object away
        (:func:`best_counts`) to be used; :data:`COUNT_ODDS` (20 to 1) by default.

    Returns
    -------
    presence, posterior : ndarray
        Copies, the untouched slots of every episode set to 0 / 1 and one-hot colours.
    changed : int
        Slot-episodes whose contents changed.
    trust : ndarray, shape (N, A)
        A copy of ``trust``; where the counts changed what a slot holds, no more than how
        sure their choice is (:func:`count_trust` of the episode's best assignment over the
        next). Never more than before: the choice rests on the other slots' readings, as
        far as their kappas trust them, and a kappa read off few stated frames is surer than
        they show (multifruit-2x3 robot s4: counts set at kappa 1.0, bound 0.20, would
        have hidden the episode that is misplaced).
    """
    presence, posterior, trust = presence.copy(), posterior.copy(), trust.copy()
    n_slots = int(slot.max()) + 1 if len(slot) and slot.max() >= 0 else 0
    if n_slots == 0:
        return presence, posterior, 0, trust
    n_col = posterior.shape[2]
    members = [np.flatnonzero(slot == s) for s in range(n_slots)]
    # an unread slot holds what the stated first frames of episodes say it usually holds
    # when an episode starts, not a coin toss: a slot nobody can read would otherwise take
    # any object the counts have left over, and an untouched slot holds all episode long
    # what it held at the start
    firsts = np.array([first for first, _ in trace.episodes()], dtype=np.int64)
    soft = trusted(presence, trust, start_rates(presence, stated, firsts))
    p = np.stack([presence[:, m].mean(axis=1) for m in members], axis=1)        # (N, S)
    p_soft = np.stack([soft[:, m].mean(axis=1) for m in members], axis=1)
    post = np.stack([posterior[:, m].mean(axis=1) for m in members], axis=1)    # (N, S, C)
    told = np.stack([stated[:, m].any(axis=1) for m in members], axis=1)
    values = np.where(p >= 0.5, post.argmax(axis=-1), -1)
    held = held_colours(trace.actions, trace.action_kinds(), colour)
    below = slots_below(above or {}, slot)
    # every episode: the slots it leaves untouched, what the others and the hand hold
    plans = []
    for first, last in trace.episodes():
        frames = np.arange(first, last + 1)
        acted = np.zeros(n_slots, dtype=bool)
        steps = trace.actions[first:last]
        steps = slot[steps[steps >= 0]]
        acted[steps[steps >= 0]] = True
        loose = np.flatnonzero(~acted & ~told[frames].any(axis=0))
        fixed = np.setdiff1d(np.arange(n_slots), loose)
        holds = np.array([(values[first, fixed] == c).sum() + (held[first] == c)
                          for c in range(n_col)])
        forced = stack_forced(values[frames] >= 0, loose, below)
        plans.append((first, last, loose, holds, p_soft[frames][:, loose].mean(axis=0),
                      post[frames][:, loose].mean(axis=0), forced,
                      in_the_air(values[frames] >= 0, loose, below) if below else None))
    # the counts are weighed on the assignments the stacks allow, as they are then assigned:
    # an object the counts can only put in the air is no evidence for them
    total, margin = best_counts([(h, ps, po, fo, fl) for *_, h, ps, po, fo, fl in plans],
                                object_counts(values, held, n_col))
    if margin < odds:
        return presence, posterior, 0, trust   # the recording does not settle the counts
    changed = 0
    for first, last, loose, holds, p_loose, post_loose, forced, floats in plans:
        need = total - holds
        if not len(loose) or (need < 0).any() or need.sum() > len(loose):
            continue                       # the stated slots already break the counts
        if floats is not None:
            # the most likely assignment with nothing in the air, in any frame of the
            # episode (the touched slots change, the untouched do not)
            new, best, second = grounded(p_loose, post_loose, need, forced, floats)
            if new is None:
                continue                   # every assignment leaves an object in the air
        else:
            new, best = episode_assignment(p_loose, post_loose, need, forced)
            second = runner_up(p_loose, post_loose, need, new, forced)
        if (new != values[first, loose]).any() and best - second < TIE:
            continue                       # another assignment as likely: a coin toss
        sure = count_trust(best - second)
        for i, s in enumerate(loose):
            changed += int(new[i] != values[first, s])
            cols = members[s]
            if new[i] != values[first, s]:
                # set against the reading: no surer than the counts' choice (which rests on
                # the other slots' readings, so never surer than the reading it overruled)
                trust[first:last + 1, cols] = np.minimum(trust[first:last + 1, cols], sure)
            if new[i] < 0:
                presence[first:last + 1, cols] = 0.0
            else:
                presence[first:last + 1, cols] = 1.0
                posterior[first:last + 1, cols] = np.eye(n_col)[new[i]]
    return presence, posterior, changed, trust
