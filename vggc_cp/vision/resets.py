"""What a recording's resets and refusals state about a site (beyond the paper).

A reset (:mod:`vggc_cp.recorded`) says that an episode's first observation shows the state of
an earlier one. At one site, the episodes that no action acts at hold one thing throughout,
so a reset makes such episodes hold the same thing, and carries to them what the actions
state at the other end (:func:`reset_labels`). A refused action rules out what it needs at
its site (a place: a free place, where the hand holds its colour); where one value is left,
that is what the site holds, and where several are, the values it ruled out are what the
site's reading may not take (a refused red pick where red and yellow are played: the place
holds nothing or a yellow, whatever the images read). Unstated runs of observations
that a reset joins hold one thing too, and are read as one (:func:`joined_runs`). What the
refusals rule out keeps a reading off it (:func:`ruled_out_reading`).

Groups are the connected components of the reset pairs (as
:mod:`vggc_cp.vision.support` groups the slots of a stack).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from vggc_cp.recorded import RecordedFacts
from vggc_cp.trace import PICK, roles_of
from vggc_cp.vision.conservation import held_colours
from vggc_cp.vision.slots import EMPTY, UNLABELLED


def components(n: int, pairs) -> np.ndarray:
    """Component of each of ``n`` items under the links ``pairs``, numbered by their
    smallest member (items in order).

    >>> components(4, [(3, 1)]).tolist()
    [0, 1, 2, 1]
    """
    pairs = np.asarray(list(pairs), dtype=np.int64).reshape(-1, 2)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def reset_labels(labels: np.ndarray, actions: np.ndarray, episodes: list[tuple[int, int]],
                 untouched: np.ndarray, is_acting: np.ndarray, kinds: np.ndarray,
                 colour: np.ndarray, facts: RecordedFacts, refusals: bool,
                 ruled_out: dict[int, set[int]] | None = None) -> None:
    """:func:`~vggc_cp.vision.occupancy.site_labels`' resets and refusals, in place on
    ``labels``.

    Episodes without an action at the site (``untouched``) that resets join hold one value;
    a group takes the value a reset from a labelled observation states, or, with
    ``refusals``, the one value the refused actions leave. Values that disagree leave the
    group unlabelled. Where the refusals leave several values, ``ruled_out`` (when given)
    gets, per untouched episode of the group, the values they rule out (filled in place).
    """
    episode = np.empty(len(labels), dtype=np.int64)
    for e, (first, last) in enumerate(episodes):
        episode[first:last + 1] = e
    group = components(len(episodes), [(episode[a], episode[b]) for a, b in facts.resets
                                       if untouched[episode[a]] and untouched[episode[b]]])
    values: dict[int, set[int]] = {}
    for a, b in facts.resets:
        for x, y in ((a, b), (b, a)):
            if untouched[episode[x]] and labels[y] != UNLABELLED and \
                    not untouched[episode[y]]:
                values.setdefault(int(group[episode[x]]), set()).add(int(labels[y]))
    if refusals:
        acted = {int(c) for c in colour[np.flatnonzero(is_acting)] if c >= 0}
        # a refused pick rules out its colour only where no other pick at the site shares it
        # (two shapes of one colour: the other may be what the site holds)
        picks = np.flatnonzero(is_acting & (kinds == PICK))
        shared = {int(c) for c in colour[picks] if np.sum(colour[picks] == c) > 1}
        # the hand's reason rules nothing out: a refusal counts in the role it was met in,
        # and a place only where the hand holds its colour (holding another, the hand is
        # reason enough: `vggc-cp suggest` probes a red place from a node that may hold a
        # yellow, multifruit-2x3 robot s175, and the refusal says what the hand holds)
        role = roles_of(actions, kinds)
        hand = held_colours(actions, kinds, colour)
        options: dict[int, set[int]] = {}
        for o, k in facts.refusals:
            if not (is_acting[k] and untouched[episode[o]]) or role[o] != kinds[k] or \
                    (kinds[k] == PICK and int(colour[k]) in shared) or \
                    (kinds[k] != PICK and (colour[k] < 0 or hand[o] != colour[k])):
                continue
            options.setdefault(int(group[episode[o]]), {EMPTY, *acted}).discard(
                int(colour[k]) if kinds[k] == PICK else EMPTY)
        for g, left in options.items():
            if len(left) == 1:
                values.setdefault(g, set()).update(left)
            elif len(left) > 1 and ruled_out is not None:
                gone = {EMPTY, *acted} - left
                for e in np.flatnonzero(untouched & (group == g)):
                    ruled_out.setdefault(int(e), set()).update(gone)
    for e in np.flatnonzero(untouched):
        held = values.get(int(group[e]), set())
        if len(held) == 1:
            first, last = episodes[e]
            labels[first:last + 1] = next(iter(held))


def ruled_out_reading(presence: np.ndarray, posterior: np.ndarray, idx: np.ndarray,
                      values: set[int]) -> None:
    """The reading of one site at the observations ``idx``, in place, kept off ``values``
    (:data:`EMPTY` and colours) that a recorded refusal rules out there: a ruled-out colour
    loses its share of the colour posterior (what is left is renormalised, or shared evenly
    where nothing is), no colour left reads empty, and a ruled-out empty reads occupied.

    >>> p, post = np.array([1.0, 0.2]), np.array([[0.9, 0.1], [0.5, 0.5]])
    >>> ruled_out_reading(p, post, np.array([0, 1]), {0})
    >>> p.tolist(), post.tolist()
    ([1.0, 0.2], [[0.0, 1.0], [0.0, 1.0]])
    >>> ruled_out_reading(p, post, np.array([1]), {EMPTY})
    >>> p.tolist()
    [1.0, 1.0]
    """
    if not len(idx):
        return
    n_col = posterior.shape[1]
    cols = sorted(c for c in values if 0 <= c < n_col)
    if cols:
        keep = np.ones(n_col, dtype=bool)
        keep[cols] = False
        if not keep.any():
            presence[idx] = 0.0
        else:
            post = posterior[idx] * keep
            total = post.sum(axis=1, keepdims=True)
            posterior[idx] = np.where(total > 0, post / np.where(total > 0, total, 1.0),
                                      keep / keep.sum())
    if EMPTY in values:
        presence[idx] = 1.0


def joined_runs(run: np.ndarray, known: np.ndarray, resets) -> np.ndarray:
    """``run`` with the unstated runs that a reset ``(a, b)`` joins made one.

    Observation ``b`` shows the state of ``a``, and a run holds one thing from one action at
    the site to the next, so the run of ``a`` and the run of ``b`` hold the same thing: their
    frames are read together. Runs are renumbered by their first frame.

    >>> joined_runs(np.array([0, 0, 1, 1, 2, 2]), np.zeros(6, bool), [(0, 4)]).tolist()
    [0, 0, 1, 1, 0, 0]
    >>> known = np.array([1, 1, 0, 0, 0, 0], bool)          # a stated run is not joined
    >>> joined_runs(np.array([0, 0, 1, 1, 2, 2]), known, [(0, 4)]).tolist()
    [0, 0, 1, 1, 2, 2]
    """
    n = int(run.max()) + 1 if len(run) else 0
    links = [(run[a], run[b]) for a, b in resets if not (known[a] or known[b])]
    return components(n, links).astype(run.dtype)[run]
