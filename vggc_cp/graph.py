"""The action-labelled task graph induced by a labelling, its constraint checker, and planning.

Given one node label per observation, every transition ``(o_t, a, o_{t+1})`` induces the edge
``(label[o_t], a, label[o_{t+1}])``. A valid abstraction (the paper's structural constraints) is

* **bipartite** — every node holds observations of one role only (pick or place), so edges
  alternate pick node -> place node -> pick node;
* **Exactly-One** — between an ordered pair of nodes there is at most one action label.

**Determinism** (one node and one action lead to one node) is reported but not enforced here.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from vggc_cp.trace import ROLE_NAMES

Edge = tuple[int, int, int]  # (u, action index, v)


@dataclass(frozen=True)
class Violation:
    """One violated constraint: ``kind`` in {'role', 'bipartite', 'exactly_one', 'determinism'}."""

    kind: str
    detail: str


@dataclass(frozen=True)
class CheckReport:
    """Every violation found by :func:`check`. ``ok`` ignores determinism (not enforced)."""

    violations: tuple[Violation, ...]

    @property
    def ok(self) -> bool:
        return not any(v.kind != "determinism" for v in self.violations)

    @property
    def deterministic(self) -> bool:
        return not any(v.kind == "determinism" for v in self.violations)

    def of_kind(self, kind: str) -> list[Violation]:
        return [v for v in self.violations if v.kind == kind]

    def __str__(self) -> str:
        if not self.violations:
            return "ok"
        return "; ".join(f"{v.kind}: {v.detail}" for v in self.violations)


@dataclass(frozen=True, eq=False)
class TaskGraph:
    """Action-labelled graph over abstract nodes.

    Attributes
    ----------
    node_role : dict[int, int]
        Role of each node (:data:`~vggc_cp.trace.PICK` / ``PLACE``); -1 when mixed.
    members : dict[int, ndarray]
        Observation indices of each node.
    edges : dict[(u, a, v), ndarray]
        Each induced edge with the indices (into the transition list) that support it.
    action_names : tuple of str
    """

    node_role: dict[int, int]
    members: dict[int, np.ndarray]
    edges: dict[Edge, np.ndarray]
    action_names: tuple[str, ...]
    _out: dict[int, list[tuple[int, int]]] = field(default_factory=dict, repr=False)
    _in: dict[int, list[tuple[int, int]]] = field(default_factory=dict, repr=False)

    @classmethod
    def from_labels(cls, labels, roles, src, act, dst, action_names) -> TaskGraph:
        """Build the graph induced by ``labels`` (shape (N,)) on transitions ``(src, act, dst)``."""
        labels = np.asarray(labels, dtype=np.int64)
        roles = np.asarray(roles)
        node_role: dict[int, int] = {}
        members: dict[int, np.ndarray] = {}
        order = np.argsort(labels, kind="stable")
        uniq, starts = np.unique(labels[order], return_index=True)
        for i, u in enumerate(uniq):
            end = starts[i + 1] if i + 1 < len(starts) else len(order)
            mem = order[starts[i]:end]
            members[int(u)] = mem
            r = np.unique(roles[mem])
            node_role[int(u)] = int(r[0]) if len(r) == 1 else -1
        triples = np.stack([labels[src], np.asarray(act), labels[dst]], axis=1) if len(src) else \
            np.zeros((0, 3), dtype=np.int64)
        edges: dict[Edge, np.ndarray] = {}
        if len(triples):
            uniq_e, inverse = np.unique(triples, axis=0, return_inverse=True)
            inverse = inverse.reshape(-1)
            order_e = np.argsort(inverse, kind="stable")
            bounds = np.searchsorted(inverse[order_e], np.arange(len(uniq_e) + 1))
            for j, (u, a, v) in enumerate(uniq_e):
                edges[(int(u), int(a), int(v))] = order_e[bounds[j]:bounds[j + 1]]
        out: dict[int, list[tuple[int, int]]] = {u: [] for u in members}
        inn: dict[int, list[tuple[int, int]]] = {u: [] for u in members}
        for u, a, v in edges:
            out[u].append((a, v))
            inn[v].append((a, u))
        return cls(node_role, members, edges, tuple(action_names), out, inn)

    @property
    def nodes(self) -> list[int]:
        return sorted(self.members)

    @property
    def n_nodes(self) -> int:
        return len(self.members)

    @property
    def n_edges(self) -> int:
        return len(self.edges)

    def successors(self, u: int) -> list[tuple[int, int]]:
        """``[(action, v), ...]`` leaving node ``u``."""
        return self._out.get(u, [])

    def predecessors(self, v: int) -> list[tuple[int, int]]:
        """``[(action, u), ...]`` entering node ``v``."""
        return self._in.get(v, [])

    def edge_list(self) -> list[tuple[int, str, int]]:
        """Edges as ``[u, action_name, v]`` sorted, the solution-JSON form."""
        return [(u, self.action_names[a], v) for (u, a, v) in sorted(self.edges)]

    def count_by_role(self) -> dict[str, int]:
        out = {"pick": 0, "place": 0, "mixed": 0}
        for r in self.node_role.values():
            out[ROLE_NAMES[r] if r >= 0 else "mixed"] += 1
        return out


def to_networkx(graph: TaskGraph, medoids: dict[int, int] | None = None,
                support: bool = True):
    """``graph`` as a :class:`networkx.MultiDiGraph`.

    One node per learned node, with attributes ``role`` (``pick``, ``place`` or ``mixed``),
    ``size`` (its number of observations) and, when ``medoids`` is given, ``medoid`` (the index
    of its most typical observation); one edge per ``(u, action, v)``, keyed by the action's
    name, with attribute ``action`` (the name) and, when ``support``, ``support`` (the number of
    transitions behind it). The graph's ``action_names`` attribute lists every action name.
    """
    import networkx as nx

    g = nx.MultiDiGraph(action_names=list(graph.action_names))
    for u in graph.nodes:
        r = graph.node_role[u]
        attrs = {"role": ROLE_NAMES[r] if r >= 0 else "mixed", "size": int(len(graph.members[u]))}
        if medoids is not None and u in medoids:
            attrs["medoid"] = int(medoids[u])
        g.add_node(int(u), **attrs)
    for (u, a, v) in sorted(graph.edges):
        name = graph.action_names[a]
        attrs = {"action": name}
        if support:
            attrs["support"] = int(len(graph.edges[(u, a, v)]))
        g.add_edge(int(u), int(v), key=name, **attrs)
    return g


def check(graph: TaskGraph) -> CheckReport:
    """Report every violation of bipartiteness, Exactly-One and (not enforced) determinism.

    Every solver test runs its colourings through this checker.
    """
    out: list[Violation] = []
    for u, r in sorted(graph.node_role.items()):
        if r < 0:
            out.append(Violation("role", f"node {u} holds both pick and place observations"))
    for (u, a, v) in sorted(graph.edges):
        ru, rv = graph.node_role[u], graph.node_role[v]
        if ru >= 0 and rv >= 0 and ru == rv:
            out.append(Violation("bipartite", f"edge {u} -{graph.action_names[a]}-> {v} joins two "
                                              f"{ROLE_NAMES[ru]} nodes"))
    labels_on: dict[tuple[int, int], list[int]] = {}
    targets: dict[tuple[int, int], list[int]] = {}
    for (u, a, v) in graph.edges:
        labels_on.setdefault((u, v), []).append(a)
        targets.setdefault((u, a), []).append(v)
    for (u, v), acts in sorted(labels_on.items()):
        if len(acts) > 1:
            names = ", ".join(graph.action_names[a] for a in sorted(acts))
            out.append(Violation("exactly_one", f"nodes {u} -> {v} carry {len(acts)} labels: {names}"))
    for (u, a), vs in sorted(targets.items()):
        if len(vs) > 1:
            out.append(Violation("determinism", f"node {u} with {graph.action_names[a]} leads to "
                                                f"{len(vs)} nodes {sorted(vs)}"))
    return CheckReport(tuple(out))


# ---------------------------------------------------------------- planning


def bfs_distances(graph: TaskGraph, source: int, reverse: bool = False) -> dict[int, int]:
    """Hop distance from ``source`` to every reachable node (to ``source`` if ``reverse``)."""
    step = graph.predecessors if reverse else graph.successors
    dist = {source: 0}
    queue = deque([source])
    while queue:
        u = queue.popleft()
        for _, v in step(u):
            if v not in dist:
                dist[v] = dist[u] + 1
                queue.append(v)
    return dist


def reachable(graph: TaskGraph, source: int) -> set[int]:
    """Nodes reachable from ``source`` (``source`` included)."""
    return set(bfs_distances(graph, source))


@dataclass(frozen=True)
class ShortestPathDAG:
    """All shortest plans from ``start`` to ``goal``.

    ``length`` is -1 when ``goal`` is unreachable; ``edges`` maps a node to its DAG successors
    ``[(action, v), ...]`` (every DAG path from start to goal is a shortest plan).
    """

    start: int
    goal: int
    length: int
    edges: dict[int, list[tuple[int, int]]]
    layers: list[list[int]]

    @property
    def found(self) -> bool:
        return self.length >= 0

    def count_plans(self) -> int:
        """Number of distinct shortest plans (paths in the DAG), exactly."""
        if not self.found:
            return 0
        count = {self.start: 1}
        for layer in self.layers:
            for u in layer:
                for _, v in self.edges.get(u, []):
                    count[v] = count.get(v, 0) + count[u]
        return count.get(self.goal, 0)


def shortest_path_dag(graph: TaskGraph, start: int, goal: int) -> ShortestPathDAG:
    """The DAG of all shortest plans between two nodes (two BFS sweeps)."""
    if start not in graph.members or goal not in graph.members:
        return ShortestPathDAG(start, goal, -1, {}, [])
    d_from = bfs_distances(graph, start)
    if goal not in d_from:
        return ShortestPathDAG(start, goal, -1, {}, [])
    d_to = bfs_distances(graph, goal, reverse=True)
    length = d_from[goal]
    on = {u for u in d_from if u in d_to and d_from[u] + d_to[u] == length}
    edges: dict[int, list[tuple[int, int]]] = {}
    layers: list[list[int]] = [[] for _ in range(length + 1)]
    for u in sorted(on):
        layers[d_from[u]].append(u)
        succ = [(a, v) for a, v in graph.successors(u) if v in on and d_from[v] == d_from[u] + 1]
        if succ:
            edges[u] = sorted(succ)
    return ShortestPathDAG(start, goal, length, edges, layers)


Plan = list[tuple[int, int, int]]  # [(u, action, v), ...]


def iter_shortest_plans(dag: ShortestPathDAG, cap: int | None = None) -> Iterator[Plan]:
    """Enumerate shortest plans lazily (depth first, sorted), at most ``cap`` of them."""
    if not dag.found:
        return
    produced = 0
    stack: list[tuple[int, Plan]] = [(dag.start, [])]
    while stack:
        u, plan = stack.pop()
        if u == dag.goal and len(plan) == dag.length:
            yield plan
            produced += 1
            if cap is not None and produced >= cap:
                return
            continue
        for a, v in reversed(dag.edges.get(u, [])):
            stack.append((v, plan + [(u, a, v)]))


def shortest_plan(graph: TaskGraph, start: int, goal: int) -> Plan | None:
    """One shortest plan (the first in sorted order), ``[]`` if start == goal, None if none."""
    dag = shortest_path_dag(graph, start, goal)
    for plan in iter_shortest_plans(dag, cap=1):
        return plan
    return None


def format_plan(graph: TaskGraph, plan: Plan) -> list[str]:
    """Human-readable steps ``'u --pick_x--> v'``."""
    return [f"{u} --{graph.action_names[a]}--> {v}" for u, a, v in plan]

