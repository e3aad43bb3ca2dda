"""Evaluation against ground truth (the only package that reads a trace's ``states``)."""

from __future__ import annotations

import sys

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.evaluate.groundtruth import GroundTruth, StepFn
from vggc_cp.evaluate.metrics import (
    Metrics,
    evaluate_labels,
    execution_probability,
    sample_queries,
    transition_precision_coverage,
    validate_dag,
)
from vggc_cp.graph import TaskGraph
from vggc_cp.trace import Trace

DYNAMICS = ("auto", "trace", "sim")

__all__ = ["DYNAMICS", "GroundTruth", "Metrics", "evaluate_labels", "evaluate_trace",
           "execution_probability", "resolve_dynamics", "sample_queries", "simulator_step",
           "transition_precision_coverage", "validate_dag"]


def simulator_step(trace: Trace, gt: GroundTruth) -> StepFn | None:
    """The benchmark simulator's true dynamics for ``trace`` (from ``meta['benchmark']``),
    or None when the trace names no known benchmark."""
    name = trace.meta.get("benchmark") if trace.meta else None
    if not name:
        return None
    from vggc_cp.sim import get_benchmark

    try:
        bench = get_benchmark(name)
    except (TypeError, VggcError):  # not a benchmark the simulator knows
        return None
    return gt.step_from_names(bench.step, trace.action_names)


def _sim_mismatch(trace: Trace, gt: GroundTruth) -> str | None:
    """Why the simulator named by ``meta['benchmark']`` cannot run this trace's states and
    actions (state keys written another way, foreign action names), or None when it can."""
    name = trace.meta.get("benchmark")
    src = getattr(trace, "source", None) or "the trace"
    from vggc_cp.sim import get_benchmark

    try:
        bench = get_benchmark(name)
    except (TypeError, VggcError):
        return f"{src}: meta names benchmark {str(name)[:60]!r}, which the simulator does not know"
    known = set(getattr(bench, "action_names", ()))
    for i, a in enumerate(trace.action_names):
        if known and a not in known:
            return f"{src}: action_names[{i}] = {a!r} is not an action of {name}"
    decode = getattr(bench, "decode", None)
    if decode is not None:
        for key in gt.state_names:
            try:
                decode(str(key))
            except VggcError:
                return f"{src}: state key {str(key)!r} is not one of {name}'s"
    return None


def resolve_dynamics(trace: Trace, gt: GroundTruth, dynamics: str) -> tuple[StepFn | None, str]:
    """The true transition function for Exec and its name (``sim`` or ``trace``).

    ``trace``: None (the transitions observed in the trace); ``sim``: the benchmark
    simulator's dynamics (``meta['benchmark']``), an error without one; ``auto``: the simulator
    when the trace names a known benchmark, else the trace.
    """
    if dynamics not in DYNAMICS:
        raise VggcError(f"unknown dynamics {dynamics!r}; known: {', '.join(DYNAMICS)}")
    if dynamics == "trace":
        return None, "trace"
    step = simulator_step(trace, gt)
    if step is not None:
        why = _sim_mismatch(trace, gt)
        if why is None:
            return step, "sim"
        if dynamics == "sim":
            raise VggcError(f"--dynamics sim: {why}")
        print(f"vggc-cp: note: {why}; Exec uses the trace's own transitions (--dynamics trace)",
              file=sys.stderr)
        return None, "trace"
    if dynamics == "sim":
        raise VggcError("--dynamics sim: the trace's meta names no known benchmark")
    name = trace.meta.get("benchmark") if trace.meta else None
    if name:  # a benchmark the simulator does not know: say so, as for foreign states
        print(f"vggc-cp: note: {_sim_mismatch(trace, gt)}; Exec uses the trace's own "
              f"transitions (--dynamics trace)", file=sys.stderr)
    return None, "trace"


def evaluate_trace(trace: Trace, graph: TaskGraph, labels: np.ndarray, *, n_queries: int = 1500,
                   seed: int = 0, dynamics: str = "auto", localize=None) -> tuple[Metrics, str]:
    """Evaluate a labelling of ``trace``; returns the metrics and the dynamics used for Exec.

    ``dynamics``: ``trace`` executes plans on the transitions observed in the trace, ``sim``
    on the benchmark simulator's dynamics (``meta['benchmark']``), ``auto`` the simulator
    when the trace names a known benchmark, else the trace.
    """
    gt = GroundTruth.from_trace(trace)
    step, used = resolve_dynamics(trace, gt, dynamics)
    metrics = evaluate_labels(graph, labels, gt, n_queries=n_queries, seed=seed,
                              localize=localize, step=step)
    return metrics, used
