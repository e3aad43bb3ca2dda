"""Image to plan: localize a start and a goal image on a solution's graph, then plan (BFS)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.graph import Plan, TaskGraph, format_plan, shortest_plan
from vggc_cp.localize.localizer import Localizer, solution_digest
from vggc_cp.solution import Solution


def solution_graph(solution: Solution, action_names: tuple[str, ...] | None = None) -> TaskGraph:
    """The task graph of a solution file alone (:meth:`Solution.edge_graph`); ``action_names``
    fixes the action indices (e.g. the trace's), by default the sorted names on the edges."""
    return solution.edge_graph(action_names)


def check_model_matches(localizer: Localizer, solution: Solution, source: str) -> None:
    """Refuse a localizer trained on another solution (another labelling or graph)."""
    want = (localizer.meta.get("solution") or {}).get("digest")
    if want is not None and want != solution_digest(solution):
        trained = (localizer.meta.get("solution") or {}).get("path") or "another solution"
        raise VggcError(f"{source}: the localizer was trained on {trained}, whose labels or "
                        f"edges differ from this solution's")
    nodes = set(int(u) for u in np.unique(solution.labels))
    if set(localizer.node_ids) != nodes:
        raise VggcError(f"{source}: the localizer's {len(localizer.node_ids)} nodes are not the "
                        f"solution's {len(nodes)} nodes")


@dataclass(frozen=True)
class ImagePlan:
    """A plan from a start image to a goal image.

    Attributes
    ----------
    start, goal : int
        Localized nodes.
    start_confidence, goal_confidence : float
        Softmax probabilities of those nodes.
    plan : list of (u, action, v) or None
        A shortest plan (``[]`` when start == goal), None when the goal is unreachable.
    steps : tuple of str
        ``'u --action--> v'`` per step.
    actions : tuple of str
        The plan's action names.
    """

    start: int
    goal: int
    start_confidence: float
    goal_confidence: float
    plan: Plan | None
    steps: tuple[str, ...]
    actions: tuple[str, ...]

    @property
    def found(self) -> bool:
        return self.plan is not None


def plan_between(graph: TaskGraph, start: int, goal: int, start_conf: float = float("nan"),
                 goal_conf: float = float("nan")) -> ImagePlan:
    """A shortest plan between two localized nodes (the first in sorted order)."""
    plan = shortest_plan(graph, start, goal)
    steps = tuple(format_plan(graph, plan)) if plan is not None else ()
    actions = tuple(graph.action_names[a] for _, a, _ in plan) if plan is not None else ()
    return ImagePlan(int(start), int(goal), float(start_conf), float(goal_conf), plan, steps,
                     actions)


def plan_images(localizer: Localizer, solution: Solution, start: np.ndarray, goal: np.ndarray,
                *, start_source: str = "<start>", goal_source: str = "<goal>",
                solution_source: str = "<solution>") -> ImagePlan:
    """Localize ``start`` and ``goal`` (uint8 ``[H, W, 3]``) and plan between their nodes."""
    check_model_matches(localizer, solution, solution_source)
    localizer.check_image(start, start_source)
    localizer.check_image(goal, goal_source)
    pred = localizer.predict(np.stack([start, goal]))
    graph = solution_graph(solution, tuple(localizer.meta.get("action_names") or ()) or None)
    return plan_between(graph, int(pred.nodes[0]), int(pred.nodes[1]),
                        float(pred.confidence[0]), float(pred.confidence[1]))
