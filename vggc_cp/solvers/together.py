"""Colours never seen together: one class seen two ways (beyond the paper).

The footprints give every action a colour (:mod:`vggc_cp.vision.colours`): a pick and the
place after it move one class, and classes whose objects look alike are one colour. Two
objects of one class that look different (a red apple and a red strawberry) are two
colours where no action sequence joins them -- where the recording falls into parts that
move one of them each. Then the hand rule keeps the place observations that hold one apart
from those that hold the other (:func:`~vggc_cp.solvers.base.hand_colours`), and a state
that both parts visit takes a node per part (multifruit-2x3 clean s453, draw 53: 14 nodes for
12, Exec 51.5 %, quiet).

Two classes of a task are both somewhere in every frame: objects are conserved, and an object
the recording moves is on a slot or in the hand. So two colours that no observation shows
together (on a site, as the footprints settle it, or in the hand) are no two classes of
objects present at once; the likelier reading is one class seen two ways
(:func:`never_together`). Nothing reads action names or ground-truth states.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.solvers.base import hand_colours
from vggc_cp.solvers.doubts import MERGE, DoubtRule, Flips
from vggc_cp.solvers.read_doubts import dense_problem, node_majority


def never_together(problem) -> tuple[tuple[int, int], ...]:
    """The pairs of action colours ``(c, d)``, ``c < d``, that no observation shows together,
    each shown by some observation: on a site (the problem's site reads, ``1 + c`` where a
    site holds colour ``c``) or in the hand. Empty where the problem reads no site or has no
    colours.

    >>> from types import SimpleNamespace
    >>> sites = SimpleNamespace(held=np.array([[1, 0], [0, 2], [3, 0], [3, 2]]))
    >>> p = SimpleNamespace(readings=SimpleNamespace(sites=sites), action_colour=np.array([0, 1, 2]),
    ...                     roles=np.zeros(4, np.int8), src=np.zeros(0, np.int64),
    ...                     act=np.zeros(0, np.int64), dst=np.zeros(0, np.int64), n_obs=4)
    >>> never_together(p)
    ((0, 1), (0, 2))
    """
    sites = getattr(getattr(problem, "readings", None), "sites", None)
    colour = getattr(problem, "action_colour", None)
    if sites is None or colour is None:
        return ()
    held = np.asarray(sites.held)
    hand = hand_colours(problem)
    colours = sorted({int(c) for c in np.asarray(colour) if c >= 0})
    shown = {c: (held == 1 + c).any(axis=1) | (hand == c) for c in colours}
    return tuple((c, d) for i, c in enumerate(colours) for d in colours[i + 1:]
                 if shown[c].any() and shown[d].any() and not (shown[c] & shown[d]).any())


def doubt_never_together(conf, pairs):
    """``conf`` (:class:`~vggc_cp.solvers.confidence.Confidence`) flagged where two action
    colours are never seen together (:func:`never_together`), naming them and what to record.

    >>> from vggc_cp.solvers.confidence import Confidence
    >>> c = Confidence("mdl", 4.0, 5, None, 4.0, False, ())
    >>> doubt_never_together(c, ((0, 1),)).suspect, doubt_never_together(c, ()).suspect
    (True, False)
    """
    if not pairs:
        return conf
    c, d = pairs[0]
    more = f" (and {len(pairs) - 1} more such pair(s))" if len(pairs) > 1 else ""
    return conf.flagged(
        f"colours {c} and {d} are never seen together{more}: no observation shows both, on a "
        f"site or in the hand, where two classes of objects would both be somewhere in every "
        f"frame; they may be one class seen two ways that no action sequence joins, and a "
        f"state that holds one or the other may have two nodes; record an episode that moves "
        f"an object of each look (`vggc-cp suggest SOLUTION TRACE -o next.json`)")


def together_doubts(problem, path, labels: np.ndarray, pairs, rule=None) -> tuple:
    """Merge doubts for the first pair of colours never seen together
    (:func:`never_together`): every two place nodes whose hands hold the one colour and the
    other and whose sites hold alike (what most of each node's observations hold at every
    site, the pair's colours taken as one), with ``never_together`` (the two colours) in the
    evidence; at most ``rule.limit``, in order of the nodes. What `suggest` probes."""
    rule = rule or DoubtRule()
    if not pairs or rule.limit == 0:
        return ()
    c, d = pairs[0]
    labels = np.asarray(labels, dtype=np.int64)
    held = np.asarray(problem.readings.sites.held).copy()
    held[held == 1 + d] = 1 + c
    n = int(labels.max()) + 1
    rows = node_majority(held, labels, n)
    hand = hand_colours(problem)
    holds = np.full(n, -1, dtype=np.int64)
    for u in np.unique(labels[hand >= 0]):
        holds[u] = np.bincount(hand[(labels == u) & (hand >= 0)]).argmax()
    ones, others = np.flatnonzero(holds == c), np.flatnonzero(holds == d)
    flips, found = None, []
    for u in ones.tolist():
        for v in others.tolist():
            if len(found) >= rule.limit or not np.array_equal(rows[u], rows[v]):
                continue
            if flips is None:
                flips = Flips(dense_problem(problem), path, labels)
            flipped = np.where(labels == v, u, labels)
            found.append(flips.doubt(MERGE, (u, v), np.flatnonzero(labels == u),
                                     np.flatnonzero(labels == v), flipped, rule.typical,
                                     never_together=[int(c), int(d)]))
    return tuple(found)
