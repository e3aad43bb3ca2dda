"""Reference metric computation by enumerating every shortest plan.

Exponential in the worst case (a chain of k diamonds has 2**k plans); kept as the ground truth
for tests of the exact product-graph computation in :mod:`vggc_cp.evaluate.metrics` and as the
baseline of ``vggc-cp bench evaluate``.
"""

from __future__ import annotations

from vggc_cp.evaluate.groundtruth import GroundTruth, StepFn
from vggc_cp.graph import ShortestPathDAG, iter_shortest_plans


def plan_validates(plan, gt: GroundTruth, cons: dict[int, frozenset], start: int) -> bool:
    """The paper's check: some chain of consistent states realises every step of ``plan``."""
    current = set(cons[start])
    for _, a, v in plan:
        current = {d for s in current for d in gt.succ.get((s, a), ()) if d in cons[v]}
        if not current:
            return False
    return bool(current)


def plan_executes(plan, start_state: int, goal_state: int, step: StepFn) -> bool:
    """Run the plan's actions from the true start state; True iff it ends in the true goal."""
    s: int | None = start_state
    for _, a, _ in plan:
        s = step(s, a)
        if s is None:
            return False
    return s == goal_state


def enumerate_outcomes(dag: ShortestPathDAG, gt: GroundTruth, cons: dict[int, frozenset],
                       start_state: int, goal_state: int, step: StepFn) -> tuple[bool, bool, float]:
    """(AnyPath, OptPath, Exec) of one query by enumerating all shortest plans."""
    plans = list(iter_shortest_plans(dag))
    if not plans:
        return False, False, 0.0
    valid = [plan_validates(p, gt, cons, dag.start) for p in plans]
    executes = [plan_executes(p, start_state, goal_state, step) for p in plans]
    return any(valid), all(valid), sum(executes) / len(plans)
