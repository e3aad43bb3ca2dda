"""Task graph: induced edges, the constraint checker, and planning."""

from __future__ import annotations

import numpy as np

from vggc_cp.graph import (
    TaskGraph,
    bfs_distances,
    check,
    iter_shortest_plans,
    reachable,
    shortest_path_dag,
    shortest_plan,
)

NAMES = ("pick_a", "pick_b", "place_a", "place_b")


def graph_of(labels, roles, transitions):
    src, act, dst = (np.array(x) for x in zip(*transitions))
    return TaskGraph.from_labels(np.array(labels), np.array(roles), src, act, dst, NAMES)


def test_induced_edges_and_support():
    # observations 0..3: pick, place, pick, place ; transitions 0-a->1, 2-a->3
    g = graph_of([0, 1, 0, 1], [0, 1, 0, 1], [(0, 0, 1), (2, 0, 3)])
    assert g.n_nodes == 2 and g.n_edges == 1
    assert g.edges[(0, 0, 1)].tolist() == [0, 1]
    assert g.edge_list() == [(0, "pick_a", 1)]
    assert check(g).ok and check(g).deterministic


def test_checker_reports_every_violation():
    # node 0 mixes roles; pick node 1 has two labels to node 2; node 3 -place_a-> two nodes;
    # pick node 4 -pick_a-> pick node 5 breaks bipartiteness
    roles = [0, 1, 0, 1, 1, 0, 1, 0, 0]
    labels = [0, 0, 1, 2, 2, 4, 3, 4, 5]
    transitions = [(0, 0, 1), (2, 0, 3), (2, 1, 4), (6, 2, 7), (6, 2, 8), (5, 0, 8)]
    g = graph_of(labels, roles, transitions)
    report = check(g)
    assert not report.ok
    kinds = sorted(v.kind for v in report.violations)
    assert kinds == ["bipartite", "determinism", "exactly_one", "role"]
    assert "node 0" in report.of_kind("role")[0].detail
    assert "pick_a, pick_b" in report.of_kind("exactly_one")[0].detail
    assert not report.deterministic


def test_determinism_is_reported_not_enforced():
    roles = [0, 1, 0, 1]
    g = graph_of([0, 1, 0, 2], roles, [(0, 0, 1), (2, 0, 3)])
    report = check(g)
    assert report.ok and not report.deterministic


def diamond():
    # 0 -a-> 1 -a-> 3, 0 -b-> 2 -b-> 3, 3 -a-> 4 ; plus 1 -b-> 4 (shortcut of length 2)
    edges = [(0, 0, 1), (1, 2, 3), (0, 1, 2), (2, 3, 3), (3, 0, 4), (1, 3, 4)]
    roles = [0, 1, 1, 0, 1]
    labels = list(range(5))
    # make one observation per node and one transition per edge
    obs_roles, obs_labels, trans = [], [], []
    for u, a, v in edges:
        i = len(obs_roles)
        obs_roles += [roles[u], roles[v]]
        obs_labels += [labels[u], labels[v]]
        trans.append((i, a, i + 1))
    return graph_of(obs_labels, obs_roles, trans)


def test_bfs_reachability_and_plans():
    g = diamond()
    assert bfs_distances(g, 0) == {0: 0, 1: 1, 2: 1, 3: 2, 4: 2}
    assert reachable(g, 3) == {3, 4}
    dag = shortest_path_dag(g, 0, 3)
    assert dag.length == 2 and dag.count_plans() == 2
    plans = list(iter_shortest_plans(dag))
    assert plans == [[(0, 0, 1), (1, 2, 3)], [(0, 1, 2), (2, 3, 3)]]
    assert list(iter_shortest_plans(dag, cap=1)) == plans[:1]
    assert shortest_plan(g, 0, 4) == [(0, 0, 1), (1, 3, 4)]
    assert shortest_plan(g, 4, 0) is None
    assert shortest_plan(g, 2, 2) == []
    assert not shortest_path_dag(g, 4, 0).found and shortest_path_dag(g, 4, 0).count_plans() == 0


def test_plan_count_is_exact_on_a_wide_dag():
    # a chain of k diamonds has 2**k shortest plans; counting must not enumerate them
    k = 40
    obs_roles, obs_labels, trans = [], [], []
    node = 0
    for _ in range(k):
        for a, mid in ((0, node + 1), (1, node + 2)):
            for u, v, act in ((node, mid, a), (mid, node + 3, a + 2)):
                i = len(obs_roles)
                obs_roles += [0 if u == node or u % 3 == 0 else 1, 1 if v != node + 3 else 0]
                obs_labels += [u, v]
                trans.append((i, act, i + 1))
        node += 3
    g = graph_of(obs_labels, obs_roles, trans)
    dag = shortest_path_dag(g, 0, 3 * k)
    assert dag.length == 2 * k and dag.count_plans() == 2**k
    assert len(list(iter_shortest_plans(dag, cap=5))) == 5
