"""``vggc-cp export``: every format read back (networkx for JSON and GraphML, a structural
parse of DOT), and PDDL solved by a real planner (pyperplan) with plans as long as
``vggc-cp plan``'s."""

from __future__ import annotations

import json
import re
from pathlib import Path

import networkx as nx
import pytest

from vggc_cp.cli import main
from vggc_cp.export import EXPORTERS, ExportRequest, export_texts
from vggc_cp.export.pddl import pddl_names
from vggc_cp.graph import shortest_plan
from vggc_cp.solution import read_solution

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data" / "fruit-2x3.npz"


def solve(trace: Path, out: Path) -> Path:
    assert main(["solve", str(trace), "-o", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="module")
def fruit(tmp_path_factory) -> Path:
    return solve(DATA, tmp_path_factory.mktemp("fruit") / "s.json")


def expected_edges(solution_path: Path) -> list[tuple[int, str, int]]:
    return sorted((int(u), a, int(v)) for u, a, v in json.loads(solution_path.read_text())["edges"])


def test_the_four_formats_are_registered():
    assert set(EXPORTERS) >= {"json", "graphml", "dot", "pddl"}
    assert EXPORTERS["pddl"].needs_start_goal and not EXPORTERS["json"].needs_start_goal


def _check_networkx(g, solution_path: Path):
    data = json.loads(solution_path.read_text())
    labels = data["labels"]
    assert isinstance(g, nx.MultiDiGraph)
    assert sorted(g.nodes) == sorted(set(labels))
    assert sorted((u, k, v) for u, v, k in g.edges(keys=True)) == expected_edges(solution_path)
    for _u, _v, k, attrs in g.edges(keys=True, data=True):
        assert attrs["action"] == k
    for u, attrs in g.nodes(data=True):
        assert attrs["size"] == labels.count(u)
        assert attrs["role"] == data["roles"][labels.index(u)]


def test_node_link_json_reads_back(fruit, tmp_path):
    out = tmp_path / "g.json"
    assert main(["export", str(fruit), "--to", "json", "-o", str(out)]) == 0
    g = nx.node_link_graph(json.loads(out.read_text()), edges="edges")
    _check_networkx(g, fruit)


def test_graphml_reads_back(fruit, tmp_path):
    out = tmp_path / "g.graphml"
    assert main(["export", str(fruit), "--to", "graphml", "-o", str(out)]) == 0
    g = nx.read_graphml(out, node_type=int, force_multigraph=True)
    _check_networkx(g, fruit)


def test_dot_names_every_node_and_edge(fruit, tmp_path):
    out = tmp_path / "g.dot"
    assert main(["export", str(fruit), "--to", "dot", "-o", str(out)]) == 0
    text = out.read_text()
    assert text.startswith("digraph ") and text.rstrip().endswith("}")
    assert text.count("{") == text.count("}") == 1
    nodes = set(re.findall(r"^\s+n(\d+) \[label=", text, re.M))
    edges = sorted((int(u), a, int(v)) for u, v, a in
                   re.findall(r'^\s+n(\d+) -> n(\d+) \[label="([^"]*)"', text, re.M))
    labels = json.loads(fruit.read_text())["labels"]
    assert {int(u) for u in nodes} == set(labels)
    assert edges == expected_edges(fruit)


def test_pddl_names_are_valid_and_unique():
    names = pddl_names(["pick_a", "Pick_A", "3x", "place a/b"])
    assert names == {"pick_a": "pick_a", "Pick_A": "pick_a-2", "3x": "a-3x",
                     "place a/b": "place_a_b"}


def pyperplan_plan(domain: Path, problem: Path) -> list[str]:
    from pyperplan.planner import search_plan
    from pyperplan.search import breadth_first_search

    plan = search_plan(str(domain), str(problem), breadth_first_search, None)
    assert plan is not None
    return [op.name.strip("()").split()[0] for op in plan]


def check_pddl_plans(solution_path: Path, tmp_path: Path, pairs) -> None:
    solution = read_solution(solution_path)
    graph = solution.edge_graph()
    for i, j in pairs:
        out = tmp_path / f"g-{i}-{j}.pddl"
        assert main(["export", str(solution_path), "--to", "pddl", "-o", str(out),
                     "--start-obs", str(i), "--goal-obs", str(j)]) == 0
        ours = shortest_plan(graph, int(solution.labels[i]), int(solution.labels[j]))
        theirs = pyperplan_plan(out, tmp_path / f"g-{i}-{j}-problem.pddl")
        assert ours is not None and len(theirs) == len(ours), (i, j, theirs, ours)
        # and the planner's plan runs on the graph
        u = int(solution.labels[i])
        for name in theirs:
            nxt = [v for a, v in graph.successors(u) if graph.action_names[a].lower() == name]
            assert len(nxt) == 1
            u = nxt[0]
        assert u == int(solution.labels[j])


def test_pyperplan_solves_the_pddl_of_fruit_2x3(fruit, tmp_path, capsys):
    check_pddl_plans(fruit, tmp_path, [(0, 4), (0, 13), (5, 40), (10, 10)])
    assert main(["plan", str(fruit), "--start-obs", "0", "--goal-obs", "13"]) == 0
    n = int(re.search(r"plan\s+(\d+) actions?", capsys.readouterr().out).group(1))
    sol = read_solution(fruit)
    assert n == len(shortest_plan(sol.edge_graph(), int(sol.labels[0]), int(sol.labels[13])))


def test_pyperplan_solves_the_pddl_of_a_multifruit_trace(tmp_path):
    trace = tmp_path / "mf.npz"
    assert main(["generate", "multifruit-2x3", "--seed", "0", "--transitions", "60",
                 "-o", str(trace), "--quiet"]) == 0
    solution = solve(trace, tmp_path / "s.json")
    sol = read_solution(solution)
    n = len(sol.labels)
    assert sol.edge_graph().n_nodes >= 6
    check_pddl_plans(solution, tmp_path, [(0, n - 1), (1, n // 2), (n // 3, 2)])


@pytest.mark.parametrize("argv, message", [
    (["--to", "pddl"], "--to pddl needs --start-obs and --goal-obs"),
    (["--to", "json", "--start-obs", "0"], "--start-obs applies to --to pddl, not to --to json"),
    (["--to", "pddl", "--start-obs", "0", "--goal-obs", "999"], "--goal-obs 999 is out of range"),
    (["--to", "yaml"], "unknown export format 'yaml'; known: dot, graphml, json, pddl"),
])
def test_bad_exports_fail_with_one_line(fruit, tmp_path, capsys, argv, message):
    out = tmp_path / "g.out"
    assert main(["export", str(fruit), *argv, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vggc-cp: error: ") and message in err and err.count("\n") == 1
    assert not out.exists()


def test_a_broken_solution_names_the_file(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "vggc-solution/1"}')
    assert main(["export", str(bad), "--to", "json", "-o", str(tmp_path / "g.json")]) == 2
    assert capsys.readouterr().err.startswith(f"vggc-cp: error: {bad}")


def test_export_texts_refuses_a_node_that_is_not_there(fruit):
    from vggc_cp.errors import VggcError

    graph = read_solution(fruit).edge_graph()
    with pytest.raises(VggcError, match="start node 99"):
        export_texts(graph, "pddl", ExportRequest(start=99, goal=0))
