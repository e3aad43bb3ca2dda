"""``vggc-cp bench evaluate``: exact product-graph metrics against plan enumeration.

Both run on the same queries of the same trace in one process; the ratio is per query.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from vggc_cp.evaluate.groundtruth import GroundTruth
from vggc_cp.evaluate.metrics import (
    evaluate_labels,
    execution_probability,
    sample_queries,
    validate_dag,
)
from vggc_cp.evaluate.reference import enumerate_outcomes
from vggc_cp.graph import TaskGraph, shortest_path_dag
from vggc_cp.trace import Trace


@dataclass(frozen=True)
class EvaluateBench:
    """Timings of one benchmark run (seconds)."""

    transitions: int
    queries: int
    exact_seconds: float
    reference_queries: int
    reference_seconds: float
    agree: bool

    @property
    def exact_per_query(self) -> float:
        return self.exact_seconds / max(self.queries, 1)

    @property
    def reference_per_query(self) -> float:
        return self.reference_seconds / max(self.reference_queries, 1)

    @property
    def ratio(self) -> float:
        return self.reference_per_query / max(self.exact_per_query, 1e-12)


def coarse_labels(gt: GroundTruth, roles: np.ndarray, merge: int) -> np.ndarray:
    """A labelling that merges the states of each role ``merge`` to one (by state id), the
    kind of aliased graph whose many parallel shortest plans enumeration pays for."""
    return (gt.obs_state // merge) * 2 + roles.astype(np.int64)


def bench_evaluate(trace: Trace, labels: np.ndarray, n_queries: int = 1500,
                   reference_queries: int = 100, seed: int = 0, step=None) -> EvaluateBench:
    """Time :func:`evaluate_labels` on all queries and plan enumeration on the first few.

    Parameters
    ----------
    trace : Trace
        With ground-truth ``states``.
    labels : ndarray of int, shape (N,)
        The learned labelling to evaluate.
    """
    gt = GroundTruth.from_trace(trace)
    src, act, dst = trace.transitions()
    t0 = time.perf_counter()
    graph = TaskGraph.from_labels(labels, trace.roles(), src, act, dst, trace.action_names)
    evaluate_labels(graph, labels, gt, n_queries=n_queries, seed=seed, step=step)
    exact = time.perf_counter() - t0
    step = step or gt.observed_step
    cons = gt.consistent(labels)
    all_queries = sample_queries(gt, n_queries, seed)
    queries = all_queries[:reference_queries].tolist()
    dags = [shortest_path_dag(graph, int(labels[o_s]), int(labels[o_g]))
            for _, _, o_s, o_g in queries]
    t0 = time.perf_counter()
    refs = [enumerate_outcomes(dag, gt, cons, s, g, step)
            for dag, (s, g, _, _) in zip(dags, queries)]
    reference = time.perf_counter() - t0
    agree = True
    for dag, (s, g, _, _), ref in zip(dags, queries, refs):
        fast = validate_dag(dag, gt, cons) + (execution_probability(dag, s, g, step),)
        agree = agree and fast[:2] == ref[:2] and abs(fast[2] - ref[2]) < 1e-9
    return EvaluateBench(trace.n_transitions, len(all_queries), exact, len(queries), reference,
                         agree)
