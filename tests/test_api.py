"""The package's face (``import vggc_cp as vg``): its doctests, its light import, the bytes of
``Learned.save`` against ``vggc-cp solve``, the networkx graph, and settings that refuse
wrong values at once."""

from __future__ import annotations

import doctest
import json
import subprocess
import sys
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

import vggc_cp as vg
from vggc_cp import api, pipeline
from vggc_cp import learned as learned_module
from vggc_cp.cli import main
from vggc_cp.errors import EvidenceNotApplicable, VggcError
from vggc_cp.vision.evidence import EVIDENCE_REGISTRY, Evidence

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data" / "fruit-2x3.npz"
HEAVY = ("torch", "ortools", "pybullet", "matplotlib", "pandas", "ot", "networkx")


@pytest.fixture(scope="module")
def trace():
    return vg.load_trace(DATA)


@pytest.fixture(scope="module")
def learned(trace):
    return vg.learn_graph(trace)


@pytest.mark.parametrize("module", [api, learned_module])
def test_docstring_examples_run(module, monkeypatch):
    monkeypatch.chdir(ROOT)  # the examples name data/fruit-2x3.npz
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_importing_the_package_imports_nothing_heavy():
    code = (f"import sys, vggc_cp; heavy = {HEAVY!r}; "
            "print([m for m in heavy if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"


def test_the_face_names_resolve_and_evaluate_stays_the_function():
    import vggc_cp.evaluate.metrics  # noqa: F401  (binds the subpackage on the package)

    assert vg.evaluate is api.evaluate and callable(vg.evaluate)
    assert sys.modules["vggc_cp.evaluate"].evaluate_trace is not None
    assert vg.learn_graph is api.learn_graph and vg.LearnConfig is pipeline.LearnConfig
    assert set(vg.FACE) <= set(dir(vg))
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        vg.nope  # noqa: B018


def test_save_writes_the_bytes_of_solve(tmp_path, monkeypatch, learned):
    monkeypatch.chdir(ROOT)
    cli_out, lib_out = tmp_path / "cli.json", tmp_path / "lib.json"
    assert main(["solve", "data/fruit-2x3.npz", "-o", str(cli_out), "--quiet"]) == 0
    vg.learn_graph(vg.load_trace("data/fruit-2x3.npz")).save(lib_out)
    assert lib_out.read_bytes() == cli_out.read_bytes()
    assert json.loads(lib_out.read_text())["trace"] == "data/fruit-2x3.npz"


def test_to_networkx(learned):
    g = learned.to_networkx()
    graph = learned.graph
    assert isinstance(g, nx.MultiDiGraph)
    assert sorted(g.nodes) == graph.nodes
    for u, attrs in g.nodes(data=True):
        members = graph.members[u]
        assert attrs["size"] == len(members) and attrs["medoid"] in members
        assert attrs["role"] == ("pick" if graph.node_role[u] == 0 else "place")
    edges = sorted((u, k, v) for u, v, k in g.edges(keys=True))
    assert edges == sorted(graph.edge_list())
    for _u, _v, k, attrs in g.edges(keys=True, data=True):
        assert attrs["action"] == k and attrs["support"] >= 1


def test_medoid_is_the_least_total_distance_member(learned):
    p = learned.problem
    p = p.dense() if hasattr(p, "dense") else p   # a problem of descriptor codes
    for u, m in learned.medoids().items():
        members = np.flatnonzero(learned.labels == u)
        d = p.dist_pick if p.roles[m] == 0 else p.dist_place
        loc = p.local[members]
        totals = d[np.ix_(loc, loc)].sum(axis=1)
        assert totals[list(members).index(m)] == totals.min()


@pytest.mark.parametrize("settings, message", [
    ({"rule": "MDL"}, "unknown path selection rule 'MDL'; known: cascade, fewest, mdl"),
    ({"evidence": "atention"}, "unknown evidence 'atention'; known: attention, auto, "),
    ({"steps": 0}, "field 'steps'"),
    ({"steps": 2.5}, "field 'steps'"),
    ({"folds": -1}, "field 'folds'"),
    ({"folds": 1}, "field 'folds'"),
    ({"thresholds": (0.1, -0.2)}, "field 'thresholds'[1]"),
    ({"thresholds": ()}, "field 'thresholds'"),
    ({"thresholds": (float("nan"),)}, "field 'thresholds'[0]"),
    ({"distance": "saliency"}, "field 'distance'"),
    ({"stepz": 3}, "unknown LearnConfig setting 'stepz'; known: "),
])
def test_wrong_settings_fail_at_once_naming_the_field_or_choices(trace, settings, message):
    with pytest.raises(VggcError) as err:
        vg.learn_graph(trace, **settings)
    assert message in str(err.value)


def test_a_negative_warning_threshold_is_refused():
    from vggc_cp.solvers.confidence import WarningRule

    with pytest.raises(VggcError, match="WarningRule field 'max_change'"):
        vg.LearnConfig(warning=WarningRule(max_change=-1.0))


def test_the_cli_word_attention_is_the_distance_backend():
    from vggc_cp.vision.distances import DistanceConfig

    assert vg.LearnConfig(evidence="attention").evidence == "saliency"
    cfg = vg.LearnConfig(evidence="attention", distance=DistanceConfig(backend="keypoints"))
    assert cfg.evidence == "keypoints"
    assert vg.LearnConfig(thresholds=[0.1, 0.2]).thresholds == (0.1, 0.2)


def _toy(dp_value: float = 1.0):
    def distances(trace, options, progress=False):
        roles = trace.roles()
        x = trace.observations.reshape(trace.n_obs, -1).astype(np.float64) / 255
        out = []
        for r in (0, 1):
            f = x[roles == r]
            sq = (f * f).sum(1)
            out.append(np.sqrt(np.maximum(sq[:, None] + sq[None, :] - 2 * f @ f.T, 0)))
        return tuple(out)
    return distances


def test_auto_passes_over_only_an_evidence_that_does_not_apply(trace, monkeypatch):
    def not_applicable(trace, options, progress=False):
        raise EvidenceNotApplicable("no footprints here")

    def broken(trace, options, progress=False):
        raise VggcError("a real failure")

    monkeypatch.setitem(EVIDENCE_REGISTRY, "keypoints",
                        Evidence("keypoints", _toy(), lambda o: o.distance))
    monkeypatch.setitem(EVIDENCE_REGISTRY, "footprints",
                        Evidence("footprints", not_applicable, lambda o: o.footprint))
    learned = vg.learn_graph(trace.without_states())
    assert learned.chosen.evidence == "keypoints"
    assert learned.skipped == ("footprints: no footprints here",)
    monkeypatch.setitem(EVIDENCE_REGISTRY, "footprints",
                        Evidence("footprints", broken, lambda o: o.footprint))
    with pytest.raises(VggcError, match="^a real failure$"):
        vg.learn_graph(trace.without_states())


def test_plan_and_evaluate(trace, learned, tmp_path):
    steps = vg.plan(learned, 0, 4)
    assert [a for _, a, _ in steps] == ["pick_red_1", "place_red_2"]
    assert vg.plan(learned, 0, 0) == []
    with pytest.raises(VggcError, match="goal_obs 56 is out of range"):
        vg.plan(learned, 0, 56)
    learned.save(tmp_path / "s.json")
    solution = vg.load_solution(tmp_path / "s.json")
    assert vg.plan(solution, 0, 4) == steps
    metrics = vg.evaluate(trace, solution)
    assert metrics.exec == 1.0 and metrics.nodes == 6
    with pytest.raises(VggcError, match="no field 'states'"):
        vg.evaluate(trace.without_states(), learned)


def test_the_readme_example_runs_as_written(tmp_path, monkeypatch, capsys):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## From Python", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    (tmp_path / "data").symlink_to(ROOT / "data")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {})
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("6 ") and "no warning" in out[0]
    assert out[2] == "[(0, 'pick_red_1', 4), (4, 'place_red_2', 1)]" and out[3] == "1.0"
    assert json.loads((tmp_path / "s.json").read_text())["trace"] == "data/fruit-2x3.npz"
