"""Decisions of a graph that what the recording states rules out (beyond the paper).

A recording can state facts no image has to be read for (:mod:`vggc_cp.recorded`): an
episode was started in the state of an earlier observation (a **reset**), an action was tried
there and refused (a **refusal**). A graph breaks them where

* a reset's two observations lie on two nodes: one state, two nodes, so one of the two is
  misplaced (or the state is split);
* a refused action leaves the node of the observation where it was refused in the graph (an
  observation of that node took it): two states, one node;
* an undo pair (:func:`vggc_cp.recorded.undo_pairs`, ``meta["undo"]``) comes back elsewhere:
  one action of the pair takes node ``u`` to ``v`` and the other, which puts back what it
  changed, takes ``v`` to ``w != u``: ``u`` and ``w`` are one state on two nodes, or ``v``
  holds two states. A right graph never does this, whatever the recording (of 1,401 stored
  runs of the suite, sessions 55-57, no passing graph did and 30 of 60 wrong ones did,
  notebooks/calibration.md, session 57);
* a node takes two picks, or two places, of one site (:func:`vggc_cp.recorded.site_groups`,
  ``meta["sites"]``): a state offers one of each there (the top object; onto the top, of the
  class in the hand), so the node holds two states. On the 381 runs of session 57 no passing
  graph did and 5 of 25 wrong ones did (random-1297 robot of draw 58 among them, which no
  other check flagged).

All four are certain errors, not doubts about the evidence: :func:`broken_facts` lists each as a
doubt (the nodes and the observations, the fact as evidence) and :func:`facts_check` flags
the graph, naming the first one and what to record next.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.solvers.confidence import Confidence
from vggc_cp.solvers.doubt_text import broken_fact_note
from vggc_cp.solvers.doubts import MERGE, SPLIT, Doubt
from vggc_cp.trace import action_kind


def broken_undo(undo, actions: np.ndarray, action_names, labels: np.ndarray
                ) -> tuple[Doubt, ...]:
    """The undo pairs that ``labels`` break (module docstring), as merge doubts of the node
    left and the node come back to, most breaks first; evidence ``undo``: the two actions in
    the order taken, ``via``: the node between, ``transitions``: ``[[o, o'], [p, p']]`` (the
    first action from ``o`` to ``o'``, the second from ``p`` to ``p'``), ``breaks``: how
    many edges of the two nodes break it.

    Parameters
    ----------
    undo : sequence of (int, int)
        ``(pick, place)`` action indices (:attr:`vggc_cp.recorded.RecordedFacts.undo`).
    actions : ndarray of int, shape (N-1,)
    action_names : sequence of str
    labels : ndarray of int, shape (N,)

    >>> names = ("pick_a", "place_a")
    >>> acts = np.array([0, 1, -1, 1, 0])          # 0 -pick-> 1 -place-> 2; 3 -place-> 4 -pick-> 5
    >>> [d.nodes for d in broken_undo([(0, 1)], acts, names, np.array([0, 1, 0, 1, 0, 1]))]
    []
    >>> found = broken_undo([(0, 1)], acts, names, np.array([0, 1, 2, 1, 0, 3]))
    >>> [f.nodes for f in found]                  # 0 -> 1 -> 2 and, from 1 -> 0, 0 -> 3
    [(0, 2), (1, 3)]
    >>> d = found[0]
    >>> d.kind, d.nodes, d.observations, d.evidence["undo"], d.evidence["via"]
    ('merge', (0, 2), ((0,), (2,)), ['pick_a', 'place_a'], 1)
    """
    labels = np.asarray(labels, dtype=np.int64)
    actions = np.asarray(actions)
    twin = {}
    for p, q in undo:
        twin[int(p)], twin[int(q)] = int(q), int(p)
    # every edge of the graph, with the first transition that shows it
    edges: dict[tuple[int, int], dict[int, int]] = {}
    for t in np.flatnonzero(actions >= 0):
        edges.setdefault((int(labels[t]), int(actions[t])), {}).setdefault(
            int(labels[t + 1]), int(t))
    found: dict[tuple[int, int], list] = {}
    for (u, a), out in edges.items():
        if a not in twin:
            continue
        for v, t in out.items():
            for w, t2 in edges.get((v, twin[a]), {}).items():
                if w != u:
                    found.setdefault((min(u, w), max(u, w)), []).append((u, a, v, w, t, t2))
    doubts = []
    for key in sorted(found, key=lambda k: (-len(found[k]), k)):
        u, a, v, w, t, t2 = found[key][0]
        doubts.append(Doubt(MERGE, (u, w), ((t,), (t2 + 1,)),
                            {"undo": [str(action_names[a]), str(action_names[twin[a]])],
                             "via": v, "transitions": [[t, t + 1], [t2, t2 + 1]],
                             "breaks": len(found[key])}, -1.0))
    return tuple(doubts)


def broken_sites(sites, actions: np.ndarray, action_names, labels: np.ndarray
                 ) -> tuple[Doubt, ...]:
    """The declared sites that ``labels`` break (module docstring): a split doubt of every node
    that takes two actions of one kind at one site, the first observation that takes each
    on its two sides; evidence ``site``: the two actions (in the order the node first takes
    them).

    Parameters
    ----------
    sites : sequence of sequence of int
        Action indices per site (:attr:`vggc_cp.recorded.RecordedFacts.sites`).
    actions : ndarray of int, shape (N-1,)
    action_names : sequence of str
    labels : ndarray of int, shape (N,)

    >>> names = ("pick_a_0", "pick_a_1", "place_a_0", "place_a_1")
    >>> acts = np.array([0, 2, -1, 1, 3])     # pick at 0 and place back; pick at 1 and back
    >>> sites = [(0, 2), (1, 3)]
    >>> broken_sites(sites, acts, names, np.array([0, 1, 0, 2, 3, 2]))
    ()
    >>> found = broken_sites([(0, 1, 2, 3)], acts, names, np.array([0, 1, 0, 0, 1, 0]))
    >>> [f.nodes for f in found]                  # node 0 two picks, node 1 two places
    [(0,), (1,)]
    >>> d = found[0]
    >>> d.kind, d.nodes, d.observations, d.evidence["site"]
    ('split', (0,), ((0,), (3,)), ['pick_a_0', 'pick_a_1'])
    """
    labels = np.asarray(labels, dtype=np.int64)
    actions = np.asarray(actions)
    site_of = {int(a): k for k, group in enumerate(sites) for a in group}
    kind = [action_kind(str(n)) for n in action_names]
    first: dict[tuple[int, int, int], dict[int, int]] = {}
    for t in np.flatnonzero(actions >= 0):
        a = int(actions[t])
        if a in site_of:
            first.setdefault((int(labels[t]), site_of[a], kind[a]), {}).setdefault(a, int(t))
    out = []
    for (u, _, _), taken in sorted(first.items()):
        if len(taken) > 1:
            (a, o), (b, p) = list(taken.items())[:2]
            out.append(Doubt(SPLIT, (u,), ((o,), (p,)),
                             {"site": [str(action_names[a]), str(action_names[b])]}, -1.0))
    return tuple(out)


def broken_facts(facts, actions: np.ndarray, action_names, labels: np.ndarray
                 ) -> tuple[Doubt, ...]:
    """The resets, refusals, undo pairs and sites of ``facts`` that ``labels`` break (module
    docstring), as doubts: a merge doubt of the two nodes of a reset (evidence ``reset``:
    ``[a, b]``), a split doubt of the node where an action was refused (evidence ``refused``:
    the action, ``observation``: where; its other side: an observation of the node that took
    it), a merge doubt per pair of nodes an undo pair leaves and comes back to
    (:func:`broken_undo`), and a split doubt per node that takes two picks or two places of
    one site (:func:`broken_sites`).

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
    return (*out, *broken_undo(facts.undo, actions, action_names, labels),
            *broken_sites(facts.sites, actions, action_names, labels))


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
