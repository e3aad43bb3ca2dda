"""The solution JSON of ``FORMATS.md``: build, write (atomically), read, and verify against a trace."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vggc_cp.atomic import write_text
from vggc_cp.errors import SolutionError
from vggc_cp.graph import TaskGraph, check
from vggc_cp.trace import ROLE_NAMES, Trace

FORMAT = "vggc-solution/1"
REQUIRED = ("format", "labels", "roles", "edges", "k_pick", "k_place", "J", "solver", "status")


@dataclass(frozen=True, eq=False)
class Solution:
    """A parsed solution file.

    Attributes
    ----------
    labels : ndarray of int64, shape (N,)
    roles : ndarray of int8, shape (N,)
    edges : list of (u, action_name, v)
    k_pick, k_place : int
    J : float
    solver, status : str
    extra : dict
        Every other field of the file (``grid``, ``bound``, ``distances``, ...).
    """

    labels: np.ndarray
    roles: np.ndarray
    edges: list[tuple[int, str, int]]
    k_pick: int
    k_place: int
    J: float
    solver: str
    status: str
    extra: dict = field(default_factory=dict)

    def graph(self, trace: Trace) -> TaskGraph:
        """The task graph these labels induce on ``trace``."""
        src, act, dst = trace.transitions()
        return TaskGraph.from_labels(self.labels, trace.roles(), src, act, dst, trace.action_names)

    def edge_graph(self, action_names: tuple[str, ...] | None = None) -> TaskGraph:
        """The task graph of the file alone: nodes from ``labels``/``roles``, edges as listed.

        No trace needed (planning on a solution). Action indices follow ``action_names`` (e.g.
        the trace's) or, by default, the sorted action names found on the edges; edges carry
        no supporting transitions.

        Raises
        ------
        SolutionError
            An edge names a node that no observation has.
        """
        names = tuple(action_names) if action_names else \
            tuple(sorted({a for _, a, _ in self.edges}))
        index = {a: i for i, a in enumerate(names)}
        order = np.argsort(self.labels, kind="stable")
        uniq, starts = np.unique(self.labels[order], return_index=True)
        ends = list(starts[1:]) + [len(order)]
        members = {int(u): order[s:e] for u, s, e in zip(uniq, starts, ends)}
        node_role = {}
        for u, mem in members.items():
            r = np.unique(self.roles[mem])
            node_role[u] = int(r[0]) if len(r) == 1 else -1
        edges: dict = {}
        out: dict = {u: [] for u in members}
        inn: dict = {u: [] for u in members}
        for u, a, v in self.edges:
            if a not in index:
                raise SolutionError(f"edge [{u}, {a!r}, {v}] names an unknown action")
            if u not in members or v not in members:
                raise SolutionError(f"edge [{u}, {a!r}, {v}] names a node without observations")
            key = (int(u), index[a], int(v))
            if key not in edges:
                edges[key] = np.zeros(0, dtype=np.int64)
                out[key[0]].append((key[1], key[2]))
                inn[key[2]].append((key[1], key[0]))
        return TaskGraph(node_role, members, edges, names, out, inn)


def _num(x):
    if x is None:
        return None
    x = float(x)
    return None if math.isnan(x) else x


def solution_dict(labels, roles, graph: TaskGraph, *, k_pick: int, k_place: int, J: float,
                  solver: str, status: str, **extra) -> dict:
    """Assemble the JSON object of a solution (required fields first, then ``extra``)."""
    out = {
        "format": FORMAT,
        "labels": [int(x) for x in labels],
        "roles": [ROLE_NAMES[int(r)] for r in roles],
        "edges": [[int(u), a, int(v)] for u, a, v in graph.edge_list()],
        "k_pick": int(k_pick),
        "k_place": int(k_place),
        "J": _num(J),
        "solver": solver,
        "status": status,
    }
    out.update(extra)
    return out


def write_solution(path: str | Path, data: dict) -> None:
    """Write a solution JSON atomically (temporary file, then rename)."""
    write_text(path, json.dumps(data, indent=1, allow_nan=False) + "\n")


def read_solution(path: str | Path) -> Solution:
    """Read and structurally check a solution JSON; :class:`SolutionError` names file and field."""
    path = Path(path)
    src = str(path)
    if not path.is_file():
        raise SolutionError(f"{src}: no such file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise SolutionError(f"{src}: not JSON ({exc})") from None
    if not isinstance(data, dict):
        raise SolutionError(f"{src}: expected a JSON object")
    for key in REQUIRED:
        if key not in data:
            raise SolutionError(f"{src}: missing field {key!r}")
    if data["format"] != FORMAT:
        raise SolutionError(f"{src}: field 'format' is {data['format']!r}, expected {FORMAT!r}")
    labels = data["labels"]
    if not isinstance(labels, list) or not all(isinstance(x, int) and x >= 0 for x in labels):
        bad = next((i for i, x in enumerate(labels) if not (isinstance(x, int) and x >= 0)), 0) \
            if isinstance(labels, list) else 0
        raise SolutionError(f"{src}: labels[{bad}] is not a non-negative integer")
    roles = data["roles"]
    if not isinstance(roles, list) or len(roles) != len(labels):
        raise SolutionError(f"{src}: field 'roles' must be a list as long as 'labels'")
    for i, r in enumerate(roles):
        if r not in ROLE_NAMES:
            raise SolutionError(f"{src}: roles[{i}] = {r!r}, expected 'pick' or 'place'")
    edges = []
    for i, e in enumerate(data["edges"]):
        if not (isinstance(e, list) and len(e) == 3 and isinstance(e[0], int)
                and isinstance(e[1], str) and isinstance(e[2], int)):
            raise SolutionError(f"{src}: edges[{i}] is not [u, action_name, v]")
        edges.append((e[0], e[1], e[2]))
    extra = {k: v for k, v in data.items() if k not in REQUIRED}
    J = data["J"]
    return Solution(np.array(labels, dtype=np.int64),
                    np.array([ROLE_NAMES.index(r) for r in roles], dtype=np.int8),
                    edges, int(data["k_pick"]), int(data["k_place"]),
                    float("nan") if J is None else float(J), str(data["solver"]),
                    str(data["status"]), extra)


def verify_solution(solution: Solution, trace: Trace, source: str = "<solution>") -> TaskGraph:
    """Check a solution against its trace; return the induced graph.

    Refuses (with :class:`SolutionError`) a wrong number of labels, roles that differ from the
    trace's, a node holding both roles, edges that differ from the induced ones, and any
    violation of bipartiteness or Exactly-One — except Exactly-One when the solution's field
    ``constraints`` is ``"none"`` (a baseline that does not enforce it).
    """
    n = trace.n_obs
    if len(solution.labels) != n:
        raise SolutionError(f"{source}: field 'labels' has {len(solution.labels)} entries, "
                            f"the trace has {n} observations")
    roles = trace.roles()
    diff = np.flatnonzero(roles != solution.roles)
    if diff.size:
        i = int(diff[0])
        raise SolutionError(f"{source}: roles[{i}] = {ROLE_NAMES[solution.roles[i]]!r} but the "
                            f"trace gives {ROLE_NAMES[roles[i]]!r}")
    graph = solution.graph(trace)
    induced = set(graph.edge_list())
    given = set(solution.edges)
    if induced != given:
        extra = sorted(given - induced)
        missing = sorted(induced - given)
        what = f"edge {list(extra[0])} is not induced by the labels" if extra else \
            f"induced edge {list(missing[0])} is missing"
        raise SolutionError(f"{source}: field 'edges': {what} "
                            f"({len(extra)} extra, {len(missing)} missing)")
    report = check(graph)
    # "constraints": "none" (baselines): Exactly-One is not claimed, so its violations are
    # reported by the caller (check(graph)) instead of refused; roles stay enforced.
    tolerated = {"determinism"} | ({"exactly_one"} if solution.extra.get("constraints") == "none"
                                   else set())
    bad = [v for v in report.violations if v.kind not in tolerated]
    if bad:
        raise SolutionError(f"{source}: violates {bad[0].kind}: {bad[0].detail}")
    return graph


def labels_solution(trace: Trace, labels, *, solver: str = "manual", status: str = "feasible",
                    J: float | None = None, **extra) -> dict:
    """A solution JSON object for any labelling of ``trace`` (hand-made, baseline, ground truth).

    ``k_pick``/``k_place`` are the numbers of pick and place nodes the labels use.
    """
    labels = np.asarray(labels, dtype=np.int64)
    roles = trace.roles()
    src, act, dst = trace.transitions()
    graph = TaskGraph.from_labels(labels, roles, src, act, dst, trace.action_names)
    by_role = graph.count_by_role()
    return solution_dict(labels, roles, graph, k_pick=by_role["pick"], k_place=by_role["place"],
                         J=float("nan") if J is None else J, solver=solver, status=status, **extra)
