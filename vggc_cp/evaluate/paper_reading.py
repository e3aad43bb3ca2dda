"""The paper's reading of TransPrec, TransCov, OptPath and AnyPath, beside ours.

:mod:`vggc_cp.evaluate.metrics` computes the *exact* reading: consistency ``C(u)`` from the
solution's own labels, OptPath = every shortest plan validates, AnyPath = some shortest plan
validates (the Latent Space Roadmap's "all" / "any shortest path" figures). The VGGC paper
(A. Ajith, C. Chamzas, arXiv:2509.14460) states its metrics differently; this module computes
them as the paper states them, with the assignment map ``f`` made explicit.

Notation: ``f`` assigns every trace observation ``o`` a learned node ``f(o)`` (the solution's
labels, or the localizer ``f_theta``'s prediction on the trace's own images); ``s(o)`` is the
observation's true state; ``E`` the learned edges, ``E*`` the true (observed) transitions.

* **Consistency** — a state ``s`` is consistent with a node ``u`` when some trace
  observation ``o`` has ``s(o) = s`` and ``f(o) = u``:
  ``C_f(u) = {s(o) : f(o) = u}``. The *majority* variant keeps one state per node,
  ``C(u) = {argmax_s |{o : f(o) = u, s(o) = s}|}`` (ties: the smaller state id), as a
  roadmap evaluation that classifies one image per node would.
* **TransPrec** — share of learned edges ``(u, a, u')`` for which some ``v in C(u)``,
  ``v' in C(u')`` have ``(v, a, v') in E*``.
* **TransCov** — share of true transitions ``(v, a, v') in E*`` for which some ``u, u'`` with
  ``v in C(u)``, ``v' in C(u')`` carry ``(u, a, u') in E``.
* A plan ``u_0 -a_1-> u_1 ... -a_L-> u_L`` *validates* when some state sequence
  ``v_0 .. v_L`` has ``v_i in C(u_i)`` and ``(v_{i-1}, a_i, v_i) in E*`` for every step.
* **OptPath** — some *shortest* plan from the localized start node to the localized goal
  node validates (the exact reading's AnyPath).
* **AnyPath** — some plan of *any* length from the start node to the goal node validates:
  the goal node is reachable in the product of the learned graph and G*,
  ``(u, v) -a-> (u', v')`` iff ``(u, a, u') in E``, ``(v, a, v') in E*``, ``v in C(u)``,
  ``v' in C(u')``, from some ``(start, v_0)`` with ``v_0 in C(start)``.

Queries are the exact reading's (:func:`vggc_cp.evaluate.metrics.sample_queries`, same seed,
same pairs); start and goal observations are localized by ``f``.
"""

from __future__ import annotations

from collections import deque
from dataclasses import asdict, dataclass

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.evaluate.groundtruth import GroundTruth
from vggc_cp.evaluate.i2p import majority_states
from vggc_cp.evaluate.metrics import sample_queries, transition_precision_coverage, validate_dag
from vggc_cp.graph import TaskGraph, shortest_path_dag

READINGS = ("exact", "paper")
CONSISTENCY = ("all", "majority")


@dataclass(frozen=True)
class PaperMetrics:
    """The paper's four figures under one assignment map; rates are fractions in [0, 1].

    Attributes
    ----------
    trans_prec, trans_cov, opt_path, any_path : float
        As defined in the module docstring.
    queries : int
        Q, the start/goal queries.
    assignment : str
        What ``f`` was: ``labels`` (the solution's) or ``localizer`` (its predictions).
    consistency : str
        ``all`` (every state ``f`` maps to a node) or ``majority`` (one state per node).
    agreement : float
        Share of trace observations where ``f`` equals the solution's label (1 for labels).
    """

    trans_prec: float
    trans_cov: float
    opt_path: float
    any_path: float
    queries: int
    assignment: str
    consistency: str
    agreement: float

    def as_dict(self) -> dict:
        return asdict(self)


def consistency_sets(gt: GroundTruth, assigned: np.ndarray, nodes, kind: str = "all"
                     ) -> dict[int, frozenset]:
    """``C(u)`` for every node of ``nodes`` (empty where ``f`` maps no observation to it).

    Parameters
    ----------
    gt : GroundTruth
    assigned : ndarray of int, shape (N,)
        ``f(o)`` for every trace observation.
    nodes : iterable of int
        The learned graph's nodes; each gets an entry.
    kind : {'all', 'majority'}
        Every consistent state, or the majority state of each node only.
    """
    if kind == "all":
        cons = gt.consistent(assigned)
    elif kind == "majority":
        cons = {u: frozenset([s]) for u, s in majority_states(gt, assigned).items()}
    else:
        raise VggcError(f"unknown consistency {kind!r}; known: {', '.join(CONSISTENCY)}")
    return {u: cons.get(u, frozenset()) for u in set(nodes) | set(cons)}


def any_plan_validates(graph: TaskGraph, gt: GroundTruth, cons: dict[int, frozenset],
                       start: int, goal: int) -> bool:
    """Whether some plan of any length from ``start`` to ``goal`` validates.

    Breadth-first search on the product of the learned graph and G* (module docstring);
    the empty plan validates when ``start == goal`` and ``C(start)`` is not empty.
    """
    frontier = deque((start, s) for s in cons.get(start, ()))
    seen = set(frontier)
    while frontier:
        u, s = frontier.popleft()
        if u == goal:
            return True
        for a, w in graph.successors(u):
            target = cons.get(w, frozenset())
            for s2 in gt.succ.get((s, a), frozenset()) & target:
                if (w, s2) not in seen:
                    seen.add((w, s2))
                    frontier.append((w, s2))
    return False


def evaluate_paper(graph: TaskGraph, assigned: np.ndarray, gt: GroundTruth, *,
                   n_queries: int = 1500, seed: int = 0, consistency: str = "all",
                   labels: np.ndarray | None = None, assignment: str = "labels"
                   ) -> PaperMetrics:
    """The paper's TransPrec, TransCov, OptPath and AnyPath for one assignment map ``f``.

    Parameters
    ----------
    graph : TaskGraph
        The learned graph ``E`` (the solution's; its edges are not rebuilt from ``f``).
    assigned : ndarray of int, shape (N,)
        ``f(o)`` for every trace observation: defines ``C(u)`` and localizes the queries.
    gt : GroundTruth
        G* of the trace.
    n_queries, seed : int
        Q and the query sampler's seed (the same queries as the exact reading's).
    consistency : {'all', 'majority'}
        See :func:`consistency_sets`.
    labels : ndarray of int, shape (N,), optional
        The solution's labels, only to report how often ``f`` agrees with them.
    assignment : str
        Name of ``f`` (``labels`` or ``localizer``), reported as is.
    """
    assigned = np.asarray(assigned, dtype=np.int64)
    if assigned.shape != gt.obs_state.shape:
        raise VggcError(f"the assignment has {assigned.size} entries for "
                        f"{gt.obs_state.size} trace observations")
    cons = consistency_sets(gt, assigned, graph.nodes, consistency)
    prec, cov = transition_precision_coverage(graph, gt, cons)
    queries = sample_queries(gt, n_queries, seed)
    verdicts: dict[tuple[int, int], tuple[bool, bool]] = {}
    n_opt = n_any = 0
    for _, _, obs_start, obs_goal in queries.tolist():
        key = (int(assigned[obs_start]), int(assigned[obs_goal]))
        if key not in verdicts:
            dag = shortest_path_dag(graph, *key)
            some_shortest = validate_dag(dag, gt, cons)[0] if dag.found else False
            verdicts[key] = (some_shortest, some_shortest or
                             any_plan_validates(graph, gt, cons, *key))
        n_opt += verdicts[key][0]
        n_any += verdicts[key][1]
    q = len(queries)
    agree = 1.0 if labels is None else float(np.mean(np.asarray(labels) == assigned))
    return PaperMetrics(prec, cov, n_opt / q if q else 0.0, n_any / q if q else 0.0, q,
                        assignment, consistency, agree)


def evaluate_trace_paper(trace, graph: TaskGraph, labels: np.ndarray, *, n_queries: int = 1500,
                         seed: int = 0, consistency: str = "all", localizer=None
                         ) -> PaperMetrics:
    """The paper's reading for a solution of ``trace``.

    ``f`` is the localizer's prediction on every trace image when ``localizer`` (a
    :class:`vggc_cp.localize.Localizer` trained on this solution) is given, else the
    solution's ``labels``.
    """
    gt = GroundTruth.from_trace(trace)
    labels = np.asarray(labels, dtype=np.int64)
    if localizer is None:
        return evaluate_paper(graph, labels, gt, n_queries=n_queries, seed=seed,
                              consistency=consistency, labels=labels, assignment="labels")
    assigned = localizer.predict(trace.observations).nodes
    return evaluate_paper(graph, assigned, gt, n_queries=n_queries, seed=seed,
                          consistency=consistency, labels=labels, assignment="localizer")
