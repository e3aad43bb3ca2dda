"""Decisions of a graph that what the recording states rules out (beyond the paper).

A recording can state facts no image has to be read for (:mod:`vggc_cp.recorded`): an
episode was started in the state of an earlier observation (a **reset**), an action was tried
there and refused (a **refusal**). A graph breaks them where

* a reset's two observations lie on two nodes: one state, two nodes, so one of the two is
  misplaced (or the state is split);
* a refused action leaves the node of the observation where it was refused in the graph (an
  observation of that node took it): two states, one node.

Both are certain errors, not doubts about the evidence: :func:`broken_facts` lists each as a
doubt (the nodes and the observations, the fact as evidence) and :func:`facts_check` flags
the graph, naming the first one and what to record next.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.solvers.confidence import Confidence
from vggc_cp.solvers.doubt_text import broken_fact_note
from vggc_cp.solvers.doubts import MERGE, SPLIT, Doubt


def broken_facts(facts, actions: np.ndarray, action_names, labels: np.ndarray
                 ) -> tuple[Doubt, ...]:
    """The resets and refusals of ``facts`` that ``labels`` break (module docstring), as
    doubts: a merge doubt of the two nodes of a reset (evidence ``reset``: ``[a, b]``), a
    split doubt of the node where an action was refused (evidence ``refused``: the action,
    ``observation``: where; its other side: an observation of the node that took it).

    Parameters
    ----------
    facts : RecordedFacts
    actions : ndarray of int, shape (N-1,)
    action_names : sequence of str
    labels : ndarray of int, shape (N,)

    >>> from vggc_cp.recorded import RecordedFacts
    >>> acts, names = np.array([0, 1, -1, 0]), ("pick_a", "place_a")
    >>> labels = np.array([0, 1, 0, 2, 1])
    >>> [d.nodes for d in broken_facts(RecordedFacts(((0, 3),), ()), acts, names, labels)]
    [(0, 2)]
    >>> d, = broken_facts(RecordedFacts((), ((2, 0),)), acts, names, labels)
    >>> d.kind, d.nodes, d.observations, d.evidence["refused"]
    ('split', (0,), ((2,), (0,)), 'pick_a')
    """
    labels = np.asarray(labels, dtype=np.int64)
    out = []
    for a, b in facts.resets:
        if labels[a] != labels[b]:
            out.append(Doubt(MERGE, (int(labels[a]), int(labels[b])), ((int(a),), (int(b),)),
                             {"reset": [int(a), int(b)]}, -1.0))
    taken: dict[tuple[int, int], int] = {}
    for t in np.flatnonzero(np.asarray(actions) >= 0):
        taken.setdefault((int(labels[t]), int(actions[t])), int(t))
    for o, k in facts.refusals:
        u = int(labels[o])
        if (u, k) in taken:
            out.append(Doubt(SPLIT, (u,), ((int(o),), (taken[(u, k)],)),
                             {"refused": str(action_names[k]), "observation": int(o)}, -1.0))
    return tuple(out)


def facts_check(conf: Confidence, broken) -> Confidence:
    """``conf`` flagged where the graph breaks what the recording states (``broken``, from
    :func:`broken_facts`): the reason names the first broken fact and how many there are.

    >>> c = Confidence("mdl", 1.0, 5, None, 4.0, False, ())
    >>> d = Doubt(MERGE, (0, 2), ((0,), (3,)), {"reset": [0, 3]})
    >>> facts_check(c, [d]).reasons[0][:60]
    'the graph breaks 1 fact the recording states: observation 3 '
    >>> facts_check(c, []) is c
    True
    """
    if not broken:
        return conf
    n = len(broken)
    return conf.flagged(
        f"the graph breaks {n} fact{'s' if n > 1 else ''} the recording states: "
        f"{broken_fact_note(broken[0])}; one of them is misplaced: `vggc-cp doubts SOLUTION TRACE "
        f"-o doubts.png` shows them and `vggc-cp suggest SOLUTION TRACE -o next.json` the "
        f"episodes to record next")
