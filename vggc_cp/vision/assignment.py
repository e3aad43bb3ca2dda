"""What an episode's untouched slots hold, given how many objects of each colour they hold.

An untouched slot holds one thing all episode long. Given the number ``need[c]`` of objects
of colour ``c`` the untouched slots hold together (what the counts leave once the touched
slots and the hand are counted, :mod:`vggc_cp.vision.conservation`), the readings of each
slot -- the probability ``p`` that it holds something and the colour posterior of what it
holds -- make every assignment of contents to slots a log-likelihood: ``log p + log
post[c]`` for a slot given colour ``c``, ``log (1 - p)`` for one left empty, each probability
floored at :data:`FLOOR` (a reading never rules a value out). Here:

* the most likely assignment, by the Hungarian method (:func:`episode_assignment`), and the
  most likely that differs from it in a slot (:func:`runner_up`);
* the assignments from the most likely down (:func:`ranked_assignments`, Murty's method),
  and the most likely of them that stands -- no object above an empty slot in any frame
  (:func:`grounded`, with :func:`in_the_air` for one episode's frames);
* the readings' log-likelihood under a count, weighed on an assignment that stands where the
  trace stacks slots (:func:`counted_loglik`);
* what stacks require of an untouched slot, whatever its reading (:func:`stack_forced`):
  full under an object the actions put on it, empty above a slot they empty.

Nothing reads action names or ground-truth states.
"""

from __future__ import annotations

import heapq

import numpy as np
from scipy.optimize import linear_sum_assignment

#: Floor of a probability in the log-likelihoods (a reading never rules a value out).
FLOOR = 1e-3
#: Assignments of an episode ranked at most in search of one that puts no object in the air
#: (:func:`grounded`).
MAX_RANKED = 64


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
        Slot -> slots that must hold something where it does
        (:func:`~vggc_cp.vision.conservation.slots_below`).

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
