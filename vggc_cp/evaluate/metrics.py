"""Planning metrics of a learned graph against the ground truth G*.

Notation: ``C(u)`` is the set of true states consistent with learned node ``u``; ``E`` the
learned edges, ``E*`` the true (observed) transitions.

* **TransPrec** — share of learned edges ``(u, a, v)`` realised by some true transition
  ``(s, a, s') in E*`` with ``s in C(u)``, ``s' in C(v)``.
* **TransCov** — share of true transitions ``(s, a, s')`` represented by some learned edge
  ``(u, a, v)`` with ``s in C(u)``, ``s' in C(v)``.
* A query samples two distinct true states ``s != g`` with ``g`` reachable from ``s`` in G*,
  one observation of each, and localizes
  them to nodes ``u``, ``v``. A plan ``u = u_0 -a_1-> u_1 ... -a_k-> u_k = v`` *validates*
  (the paper's check) when there are states ``s_i in C(u_i)`` with ``(s_{i-1}, a_i, s_i) in E*``.
  **AnyPath** — some shortest plan from ``u`` to ``v`` validates; **OptPath** — every shortest
  plan validates (the "all shortest paths correct" metric of the Latent Space Roadmap). Both
  are computed exactly on the product of the shortest-path DAG and G*, propagating the set of
  reachable consistent states, never by enumerating plans.
* **Exec** — probability that a uniformly random shortest plan, executed action by action from
  the *true* start state ``s`` under the true transitions, ends in the true goal ``g``. Exact:
  path counts are propagated over (DAG node, true state) pairs. The paper's validation
  accepts any state consistent with each node, so merged (aliased) states may validate plans
  that a robot cannot execute; Exec is what the robot experiences.

References
----------
G. Lippi et al., *Latent Space Roadmap for Visual Action Planning of Deformable and Rigid
Object Manipulation*, IROS 2020. A. Ajith, C. Chamzas, arXiv:2509.14460, 2025.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from vggc_cp.evaluate.groundtruth import GroundTruth, StepFn
from vggc_cp.graph import ShortestPathDAG, TaskGraph, shortest_path_dag

Localizer = Callable[[int], int]  # observation index -> learned node
#: The Exec a learned graph must reach to count as usable: the acceptance rule of the
#: robustness study (:mod:`vggc_cp.experiments.robustness`) and the dashed line of
#: :func:`vggc_cp.plots.plot_exec`.
MIN_EXEC = 0.90


@dataclass(frozen=True)
class Metrics:
    """All figures of one evaluation; rates are fractions in [0, 1]."""

    trans_prec: float
    trans_cov: float
    opt_path: float
    any_path: float
    exec: float
    queries: int
    nodes: int
    edges: int
    true_states: int
    true_edges: int
    plan_found: float

    def as_dict(self) -> dict:
        return asdict(self)


def transition_precision_coverage(graph: TaskGraph, gt: GroundTruth,
                                  cons: dict[int, frozenset]) -> tuple[float, float]:
    """(TransPrec, TransCov) of ``graph`` given consistency sets ``cons``."""
    valid = 0
    for (u, a, v) in graph.edges:
        cu, cv = cons.get(u, frozenset()), cons.get(v, frozenset())
        if any(gt.succ.get((s, a), frozenset()) & cv for s in cu):
            valid += 1
    prec = valid / len(graph.edges) if graph.edges else 0.0
    nodes_of: dict[int, set[int]] = {}
    for u, states in cons.items():
        for s in states:
            nodes_of.setdefault(s, set()).add(u)
    learned = set(graph.edges)
    covered = 0
    for (s, a, d) in gt.edges:
        if any((u, a, v) in learned for u in nodes_of.get(s, ()) for v in nodes_of.get(d, ())):
            covered += 1
    cov = covered / len(gt.edges) if gt.edges else 0.0
    return prec, cov


def validate_dag(dag: ShortestPathDAG, gt: GroundTruth,
                 cons: dict[int, frozenset]) -> tuple[bool, bool]:
    """(any shortest plan validates, every shortest plan validates) for one node pair.

    Propagates, layer by layer, the distinct sets of consistent states that some plan prefix
    can be in (a subset construction on the product of the DAG and G*).
    """
    if not dag.found:
        return False, False
    reach: dict[int, set[frozenset]] = {dag.start: {cons[dag.start]}}
    for layer in dag.layers:
        for w in layer:
            sets = reach.get(w)
            if not sets:
                continue
            for a, w2 in dag.edges.get(w, []):
                target = cons[w2]
                bucket = reach.setdefault(w2, set())
                for r in sets:
                    nxt: set[int] = set()
                    for s in r:
                        nxt |= gt.succ.get((s, a), frozenset()) & target
                    bucket.add(frozenset(nxt))
    final = reach.get(dag.goal, set())
    any_ok = any(len(r) > 0 for r in final)
    all_ok = bool(final) and all(len(r) > 0 for r in final)
    return any_ok, all_ok


def execution_probability(dag: ShortestPathDAG, start_state: int, goal_state: int,
                          step: StepFn) -> float:
    """Probability that a uniformly random shortest plan, executed from the true start state
    with the true transition function ``step``, ends in the true goal state."""
    if not dag.found:
        return 0.0
    counts: dict[int, dict] = {dag.start: {start_state: 1}}
    for layer in dag.layers:
        for w in layer:
            here = counts.get(w)
            if not here:
                continue
            for a, w2 in dag.edges.get(w, []):
                bucket = counts.setdefault(w2, {})
                for s, c in here.items():
                    s2 = None if s is None else step(s, a)
                    bucket[s2] = bucket.get(s2, 0) + c
    final = counts.get(dag.goal, {})
    total = sum(final.values())
    return final.get(goal_state, 0) / total if total else 0.0


def sample_queries(gt: GroundTruth, n_queries: int, seed: int) -> np.ndarray:
    """Start/goal queries, int64 array of shape (Q, 4): (start state, goal state, start obs,
    goal obs).

    An ordered pair of distinct states ``(s, g)`` with ``g`` reachable from ``s`` in G* is drawn
    uniformly (a query without a true solution says nothing about the learned graph), then one
    observation of each state uniformly.
    """
    pairs = np.array([(s, g) for s in range(gt.n_states) for g in sorted(gt.reachable_from(s))
                      if g != s], dtype=np.int64).reshape(-1, 2)
    if len(pairs) == 0:
        return np.zeros((0, 4), dtype=np.int64)
    rng = np.random.default_rng(seed)
    by_state = gt.observations_of()
    chosen = pairs[rng.integers(0, len(pairs), size=n_queries)]
    out = np.empty((n_queries, 4), dtype=np.int64)
    out[:, :2] = chosen
    for q, (s, g) in enumerate(chosen.tolist()):
        out[q, 2] = by_state[s][rng.integers(len(by_state[s]))]
        out[q, 3] = by_state[g][rng.integers(len(by_state[g]))]
    return out


def evaluate_labels(graph: TaskGraph, labels: np.ndarray, gt: GroundTruth, *,
                    n_queries: int = 1500, seed: int = 0, localize: Localizer | None = None,
                    step: StepFn | None = None) -> Metrics:
    """Every metric for a labelling of the trace that ``gt`` was built from.

    Parameters
    ----------
    graph : TaskGraph
        The learned graph (nodes must be the values of ``labels``).
    labels : ndarray of int, shape (N,)
        Node of every trace observation (defines the consistency sets ``C(u)``).
    gt : GroundTruth
    n_queries : int
        Q, the number of start/goal queries.
    seed : int
        Seed of the query sampler.
    localize : callable, optional
        Observation index -> node for the query images; defaults to ``labels``.
    step : callable, optional
        True transition function on state ids for Exec; defaults to the transitions observed
        in the trace (an action never observed from a state counts as a failed execution).
    """
    cons = gt.consistent(labels)
    prec, cov = transition_precision_coverage(graph, gt, cons)
    step = step or gt.observed_step
    localize = localize or (lambda i: int(labels[i]))
    queries = sample_queries(gt, n_queries, seed)
    dags: dict[tuple[int, int], ShortestPathDAG] = {}
    valid: dict[tuple[int, int], tuple[bool, bool]] = {}
    execs: dict[tuple[int, int, int, int], float] = {}
    n_any = n_opt = n_found = 0
    total_exec = 0.0
    for s, g, os_, og in queries.tolist():
        u, v = localize(os_), localize(og)
        key = (u, v)
        if key not in dags:
            dags[key] = shortest_path_dag(graph, u, v)
            valid[key] = validate_dag(dags[key], gt, cons) if dags[key].found else (False, False)
        any_ok, all_ok = valid[key]
        n_any += any_ok
        n_opt += all_ok
        n_found += dags[key].found
        ekey = (u, v, s, g)
        if ekey not in execs:
            execs[ekey] = execution_probability(dags[key], s, g, step)
        total_exec += execs[ekey]
    q = len(queries)
    rate = (lambda x: x / q) if q else (lambda x: 0.0)
    return Metrics(prec, cov, rate(n_opt), rate(n_any), rate(total_exec), q, graph.n_nodes,
                   graph.n_edges, gt.n_states, gt.n_edges, rate(n_found))
