"""The solution JSON of ``FORMATS.md``: build, write (atomically), read, and verify against a trace."""

from __future__ import annotations

import json
import math
import re
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


def jsonable(obj):
    """``obj`` as plain JSON values: dict keys as strings, tuples as lists, numpy scalars as
    Python numbers, paths as strings and NaN as None (``null``), all the way down.

    The one converter of every JSON file the package writes from computed values (solution
    fields, benchmark and study rows, cache keys).
    """
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, float) and math.isnan(obj):
        return None
    if hasattr(obj, "item"):
        return jsonable(obj.item())
    return obj


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


def settings_record(cfg) -> dict | str:
    """A settings dataclass as the solution file's ``distances`` field: plain values kept,
    anything else written as its ``repr``."""
    import dataclasses

    if dataclasses.is_dataclass(cfg):
        return {k: v if isinstance(v, (int, float, str, bool, type(None))) else repr(v)
                for k, v in dataclasses.asdict(cfg).items()}
    return repr(cfg)


#: keys of wall-clock timings, left out of solution files unless asked for
TIMING_KEY = re.compile(r"(^|_)seconds$|^(wall|user)_time$")


def _strip_seconds(obj):
    """``obj`` without wall-clock timings (keys ``seconds``, ``*_seconds``, ``wall_time``)."""
    if isinstance(obj, dict):
        return {k: _strip_seconds(v) for k, v in obj.items()
                if not (isinstance(k, str) and TIMING_KEY.search(k))}
    if isinstance(obj, list):
        return [_strip_seconds(v) for v in obj]
    return obj


def write_solution(path: str | Path, data: dict, timings: bool = False) -> None:
    """Write a solution JSON atomically (temporary file, then rename).

    Wall-clock timings (keys matching :data:`TIMING_KEY`) are left out unless ``timings``, so the
    same inputs give the same bytes (``solve --timings`` keeps them).
    """
    if not timings:
        data = _strip_seconds(data)
    write_text(path, json.dumps(data, indent=1, allow_nan=False) + "\n")


#: labels and node ids are below this (int64 arrays; ``2**70`` is refused)
MAX_ID = 2**31 - 1


def _is_int(x) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _bad_field(src: str, name: str, value, want: str) -> SolutionError:
    from vggc_cp.safeio import NonFinite

    if isinstance(value, NonFinite):
        shown = value.text
    else:
        shown = repr(value)
        if len(shown) > 40:
            shown = shown[:37] + "..."
    return SolutionError(f"{src}: field {name!r} is {shown}, expected {want}")


def read_solution(path: str | Path) -> Solution:
    """Read and structurally check a solution JSON; :class:`SolutionError` names file and field.

    Types, ranges and finiteness of every required field are checked (a label of ``2**70``,
    ``true``, ``J: Infinity``, ``edges: null`` are refused naming the field and index).
    """
    from vggc_cp.errors import VggcError
    from vggc_cp.safeio import NonFinite, read_json

    path = Path(path)
    src = str(path)
    try:
        data = read_json(path, src, allow_nan=False)
    except SolutionError:
        raise
    except VggcError as exc:
        raise SolutionError(str(exc)) from None
    if not isinstance(data, dict):
        raise SolutionError(f"{src}: expected a JSON object")
    for key in REQUIRED:
        if key not in data:
            raise SolutionError(f"{src}: missing field {key!r}")
    if data["format"] != FORMAT:
        raise _bad_field(src, "format", data["format"], repr(FORMAT))
    labels = data["labels"]
    if not isinstance(labels, list):
        raise _bad_field(src, "labels", labels, "a list of non-negative integers")
    if not labels:
        raise SolutionError(f"{src}: field 'labels' is empty")
    for i, x in enumerate(labels):
        if not (_is_int(x) and 0 <= x <= MAX_ID):
            raise _bad_field(src, f"labels[{i}]", x, f"an integer in [0, {MAX_ID}]")
    roles = data["roles"]
    if not isinstance(roles, list) or len(roles) != len(labels):
        raise SolutionError(f"{src}: field 'roles' must be a list as long as 'labels'")
    for i, r in enumerate(roles):
        if not isinstance(r, str) or r not in ROLE_NAMES:
            raise SolutionError(f"{src}: roles[{i}] = {r!r}, expected 'pick' or 'place'")
    if not isinstance(data["edges"], list):
        raise _bad_field(src, "edges", data["edges"], "a list of [u, action_name, v]")
    edges = []
    for i, e in enumerate(data["edges"]):
        if not (isinstance(e, list) and len(e) == 3 and _is_int(e[0]) and 0 <= e[0] <= MAX_ID
                and isinstance(e[1], str) and _is_int(e[2]) and 0 <= e[2] <= MAX_ID):
            raise SolutionError(f"{src}: edges[{i}] is not [u, action_name, v] "
                                f"(node ids in [0, {MAX_ID}])")
        edges.append((e[0], e[1], e[2]))
    for key in ("k_pick", "k_place"):
        if not (_is_int(data[key]) and 0 <= data[key] <= MAX_ID):
            raise _bad_field(src, key, data[key], "a non-negative integer")
    J = data["J"]
    if J is not None and (isinstance(J, (bool, NonFinite)) or not isinstance(J, (int, float))
                          or not math.isfinite(J)):
        raise _bad_field(src, "J", J, "a finite number or null")
    for key in ("solver", "status"):
        if not isinstance(data[key], str):
            raise _bad_field(src, key, data[key], "a string")
    sha = data.get("trace_sha256")
    if sha is not None and not (isinstance(sha, str) and re.fullmatch(r"[0-9a-f]{64}", sha)):
        raise _bad_field(src, "trace_sha256", sha, "64 hexadecimal digits")
    bad = _find_nonfinite(data)
    if bad is not None:
        raise SolutionError(f"{src}: field {bad!r} is NaN or Infinity, which JSON does not allow")
    extra = {k: v for k, v in data.items() if k not in REQUIRED}
    return Solution(np.array(labels, dtype=np.int64),
                    np.array([ROLE_NAMES.index(r) for r in roles], dtype=np.int8),
                    edges, int(data["k_pick"]), int(data["k_place"]),
                    float("nan") if J is None else float(J), data["solver"],
                    data["status"], extra)


def _find_nonfinite(obj, where: str = ""):
    """The path of the first NaN/Infinity constant in ``obj`` (None if there is none)."""
    from vggc_cp.safeio import NonFinite

    if isinstance(obj, NonFinite):
        return where
    if isinstance(obj, dict):
        items = obj.items()
    elif isinstance(obj, list):
        items = enumerate(obj)
    else:
        return None
    for k, v in items:
        sub = f"{where}[{k}]" if isinstance(k, int) else (f"{where}.{k}" if where else k)
        found = _find_nonfinite(v, sub)
        if found is not None:
            return found
    return None


def check_trace_identity(solution: Solution, trace: Trace, source: str,
                         trace_source: str = "the trace") -> None:
    """Refuse a solution that records the ``trace_sha256`` of another trace."""
    want = solution.extra.get("trace_sha256")
    if want is not None and want != trace.content_hash():
        raise SolutionError(f"{source}: the solution was learned on another trace than "
                            f"{trace_source} (its trace_sha256 {want[:12]}... differs from "
                            f"{trace.content_hash()[:12]}...)")


def verify_standalone(solution: Solution, source: str = "<solution>") -> TaskGraph:
    """Check a solution without its trace (``plan``): every edge names a pick or place action
    leaving a node of that role for a node of the other role, no node holds both roles, and
    the graph is bipartite and Exactly-One (unless ``constraints`` is ``"none"``)."""
    from vggc_cp.trace import action_kind

    try:
        graph = solution.edge_graph()
    except SolutionError as exc:  # an edge to a node no observation has: name the file
        index = next((i for i, (u, _a, v) in enumerate(solution.edges)
                      if u not in set(solution.labels.tolist())
                      or v not in set(solution.labels.tolist())), None)
        where = f"field 'edges[{index}]': " if index is not None else ""
        raise SolutionError(f"{source}: {where}{exc}") from None
    for u, r in graph.node_role.items():
        if r < 0:
            raise SolutionError(f"{source}: node {u} holds both pick and place observations")
    for i, (u, a, v) in enumerate(solution.edges):
        kind = action_kind(a)
        if kind is None or not a.isprintable():
            raise SolutionError(f"{source}: edges[{i}] names an unknown action {a!r} (neither "
                                f"pick nor place)")
        if graph.node_role[u] != kind or graph.node_role[v] != 1 - kind:
            raise SolutionError(f"{source}: edges[{i}] = [{u}, {a!r}, {v}] goes from a "
                                f"{ROLE_NAMES[graph.node_role[u]]} node to a "
                                f"{ROLE_NAMES[graph.node_role[v]]} node (roles swapped)")
    refuse_violations(solution, graph, source)
    return graph


def verify_solution(solution: Solution, trace: Trace, source: str = "<solution>",
                    trace_source: str = "the trace") -> TaskGraph:
    """Check a solution against its trace; return the induced graph.

    Refuses (with :class:`SolutionError`) a wrong number of labels, roles that differ from the
    trace's, a node holding both roles, edges that differ from the induced ones, and any
    violation of bipartiteness or Exactly-One — except Exactly-One when the solution's field
    ``constraints`` is ``"none"`` (a baseline that does not enforce it).
    """
    check_trace_identity(solution, trace, source, trace_source)
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
    refuse_violations(solution, graph, source)
    return graph


def refuse_violations(solution: Solution, graph: TaskGraph, source: str) -> None:
    """Refuse a graph that breaks bipartiteness or Exactly-One. With ``"constraints": "none"``
    (baselines) Exactly-One is not claimed, so its violations are reported by the caller
    (:func:`vggc_cp.graph.check`) instead of refused; roles stay enforced."""
    report = check(graph)
    tolerated = {"determinism"} | ({"exactly_one"} if solution.extra.get("constraints") == "none"
                                   else set())
    bad = [v for v in report.violations if v.kind not in tolerated]
    if bad:
        raise SolutionError(f"{source}: violates {bad[0].kind}: {bad[0].detail}")


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
