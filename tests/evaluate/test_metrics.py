"""Ground-truth metrics on a hand-built trace whose values are worked out by hand below."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import make_trace

from vggc_cp.cli import main
from vggc_cp.evaluate import GroundTruth, evaluate_labels, evaluate_trace, sample_queries
from vggc_cp.graph import TaskGraph
from vggc_cp.solution import labels_solution, write_solution
from vggc_cp.trace import save_trace

NAMES = ("pick_a", "pick_c", "pick_e", "place_b", "place_d", "place_f")
# Pick states P1 P2 P3, place states Q1 Q2 Q3. True transitions:
#   P1 -a-> Q1 -b-> P2 ;  P3 -c-> Q2 -d-> P1 ;  P1 -e-> Q3 -b-> P2 ;  Q2 -f-> P2
EPISODES = [
    ["P1", "pick_a", "Q1", "place_b", "P2"],
    ["P3", "pick_c", "Q2", "place_d", "P1"],
    ["P1", "pick_e", "Q3", "place_b", "P2"],
    ["P3", "pick_c", "Q2", "place_f", "P2"],
]

# Labelling that merges Q1 and Q2 into one node "Q". Worked by hand for every ordered pair of
# distinct states (s, g) with g reachable from s in G* (14 pairs; P2 is a sink):
#   (AnyPath, OptPath, Exec)
MERGED_TABLE = {
    ("P1", "Q1"): (1, 1, 1),
    ("P1", "Q3"): (1, 1, 1),
    # plans a-b, a-f, e-b: a-f fails validation (Q1 has no f); from P1, 2 of 3 plans execute
    ("P1", "P2"): (1, 0, 2 / 3),
    ("P3", "Q2"): (1, 1, 1),
    ("P3", "P1"): (1, 1, 1),
    # plans c-b (invalid: Q2 has no b) and c-f (valid)
    ("P3", "P2"): (1, 0, 1 / 2),
    # plan c "validates" because Q2 is consistent with Q, but a robot ends in Q2, not Q1
    ("P3", "Q1"): (1, 1, 0),
    ("P3", "Q3"): (1, 1, 1),
    # plans b and f both validate (b via Q1, f via Q2); from Q1 only b executes
    ("Q1", "P2"): (1, 1, 1 / 2),
    ("Q2", "P1"): (1, 1, 1),
    ("Q2", "P2"): (1, 1, 1 / 2),
    # start and goal share node Q: the empty plan validates and executes nowhere
    ("Q2", "Q1"): (1, 1, 0),
    ("Q2", "Q3"): (1, 1, 1),
    ("Q3", "P2"): (1, 1, 1),
}


@pytest.fixture
def trace():
    return make_trace(EPISODES, NAMES)


def labelling(trace, merge=False):
    names = sorted(set(trace.states))
    ids = {s: i for i, s in enumerate(names)}
    if merge:
        ids["Q2"] = ids["Q1"]
    return np.array([ids[s] for s in trace.states])


def graph_for(trace, labels):
    src, act, dst = trace.transitions()
    return TaskGraph.from_labels(labels, trace.roles(), src, act, dst, trace.action_names)


def test_queries_cover_exactly_the_reachable_pairs(trace):
    gt = GroundTruth.from_trace(trace)
    q = sample_queries(gt, 3000, seed=1)
    pairs = {(gt.state_names[s], gt.state_names[g]) for s, g in q[:, :2].tolist()}
    assert pairs == set(MERGED_TABLE)
    assert np.all(gt.obs_state[q[:, 2]] == q[:, 0]) and np.all(gt.obs_state[q[:, 3]] == q[:, 1])
    assert np.array_equal(q, sample_queries(gt, 3000, seed=1))


def test_ground_truth_labelling_scores_100(trace):
    labels = labelling(trace)
    m = evaluate_labels(graph_for(trace, labels), labels, GroundTruth.from_trace(trace),
                        n_queries=500, seed=3)
    assert (m.trans_prec, m.trans_cov, m.opt_path, m.any_path, m.exec) == (1, 1, 1, 1, 1)
    assert m.nodes == 6 and m.true_states == 6 and m.edges == 7 and m.true_edges == 7


def test_merged_labelling_scores_hand_computed_values(trace):
    labels = labelling(trace, merge=True)
    gt = GroundTruth.from_trace(trace)
    m = evaluate_labels(graph_for(trace, labels), labels, gt, n_queries=1500, seed=0)
    queries = sample_queries(gt, 1500, seed=0)
    rows = [MERGED_TABLE[(gt.state_names[s], gt.state_names[g])] for s, g in queries[:, :2].tolist()]
    any_, opt, exe = (np.mean([r[i] for r in rows]) for i in range(3))
    assert m.trans_prec == 1 and m.trans_cov == 1  # every edge is realised by some merged state
    assert m.any_path == pytest.approx(any_) == 1
    assert m.opt_path == pytest.approx(opt)
    assert m.exec == pytest.approx(exe)
    assert m.nodes == 5
    # over uniform pairs: OptPath 12/14, Exec (61/6)/14 — lower, and Exec < AnyPath
    assert abs(opt - 12 / 14) < 0.05 and abs(exe - (61 / 6) / 14) < 0.05
    assert m.exec < m.any_path and m.opt_path < 1


def test_evaluate_cli_ground_truth_and_refusals(tmp_path, trace, capsys):
    tpath, spath = tmp_path / "t.npz", tmp_path / "s.json"
    save_trace(trace, tpath)
    write_solution(spath, labels_solution(trace, labelling(trace)))
    assert main(["evaluate", str(tpath), str(spath), "--json", "-Q", "200"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("trans_prec", "trans_cov", "opt_path", "any_path", "exec"):
        assert out[key] == 1.0
    assert out["dynamics"] == "trace" and out["true_states"] == 6
    assert main(["evaluate", str(tpath), str(spath)]) == 0
    text = capsys.readouterr().out
    assert "Exec" in text and "100.00 %" in text and "6 states" in text

    def refused(data, needle):
        bad = tmp_path / "bad.json"
        write_solution(bad, data)
        assert main(["evaluate", str(tpath), str(bad)]) == 2
        err = capsys.readouterr().err
        assert needle in err and err.count("\n") == 1, err

    # the merged labelling puts place_b and place_f between Q and P2: Exactly-One is violated
    refused(labels_solution(trace, labelling(trace, merge=True)), "exactly_one")
    good = labels_solution(trace, labelling(trace))
    refused(good | {"labels": good["labels"][:-1], "roles": good["roles"][:-1]}, "has 11 entries")
    refused(good | {"edges": good["edges"][1:]}, "field 'edges'")
    refused(good | {"edges": good["edges"] + [[0, "pick_a", 5]]}, "not induced")
    refused({k: v for k, v in good.items() if k != "labels"}, "missing field 'labels'")
    roles = list(good["roles"])
    roles[0] = "place"
    refused(good | {"roles": roles}, "roles[0]")


def test_evaluate_trace_requires_states(trace):
    labels = labelling(trace)
    with pytest.raises(Exception, match="no ground-truth"):
        evaluate_trace(trace.without_states(), graph_for(trace, labels), labels)
