"""The paper's reading of the metrics on tiny hand-made traces whose answers are worked by hand."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import make_trace

from vggc_cp.cli import main
from vggc_cp.evaluate import GroundTruth, evaluate_labels, sample_queries
from vggc_cp.evaluate.paper_reading import any_plan_validates, consistency_sets, evaluate_paper
from vggc_cp.graph import TaskGraph
from vggc_cp.solution import labels_solution, write_solution
from vggc_cp.trace import save_trace

NAMES = ("pick_a", "pick_c", "place_b", "place_d")
# One chain of five states, pick states P1 P2 P3, place states Q1 Q2:
#   P1 -a-> Q1 -b-> P2 -c-> Q2 -d-> P3
CHAIN = [["P1", "pick_a", "Q1", "place_b", "P2", "pick_c", "Q2", "place_d", "P3"]]
# Merging Q1 and Q2 into one node Q gives the learned edges P1-a->Q, Q-b->P2, P2-c->Q, Q-d->P3
# (bipartite, Exactly-One holds). Worked by hand for every ordered pair (s, g), g reachable
# from s; the columns are
#   exact: (OptPath = every shortest plan validates, AnyPath = some shortest plan validates)
#   paper: (OptPath = some shortest plan validates, AnyPath = some plan of any length validates)
CHAIN_MERGED = {
    ("P1", "Q1"): ((1, 1), (1, 1)),
    ("P1", "Q2"): ((1, 1), (1, 1)),
    ("P1", "P2"): ((1, 1), (1, 1)),
    # the one shortest plan a-d needs Q1 -d->, which no state does; a-b-c-d is longer and valid
    ("P1", "P3"): ((0, 0), (0, 1)),
    ("Q1", "P2"): ((1, 1), (1, 1)),
    ("Q1", "Q2"): ((1, 1), (1, 1)),  # one node: the empty plan
    ("Q1", "P3"): ((1, 1), (1, 1)),  # plan d validates through Q2, consistent with Q
    ("P2", "Q2"): ((1, 1), (1, 1)),
    ("P2", "P3"): ((1, 1), (1, 1)),
    ("Q2", "P3"): ((1, 1), (1, 1)),
}


@pytest.fixture
def chain():
    return make_trace(CHAIN, NAMES)


def labelling(trace, merge=()):
    names = sorted(set(trace.states))
    ids = {s: i for i, s in enumerate(names)}
    for s in merge:
        ids[s] = ids[merge[0]]
    return np.array([ids[s] for s in trace.states])


def graph_for(trace, labels):
    src, act, dst = trace.transitions()
    return TaskGraph.from_labels(labels, trace.roles(), src, act, dst, trace.action_names)


def expected(gt, column, reading, n_queries=1500, seed=0):
    queries = sample_queries(gt, n_queries, seed)
    rows = [CHAIN_MERGED[(gt.state_names[s], gt.state_names[g])][reading]
            for s, g in queries[:, :2].tolist()]
    return float(np.mean([r[column] for r in rows]))


def test_both_readings_match_the_hand_table_on_a_merged_chain(chain):
    labels = labelling(chain, merge=("Q1", "Q2"))
    gt, graph = GroundTruth.from_trace(chain), graph_for(chain, labels)
    exact = evaluate_labels(graph, labels, gt, n_queries=1500, seed=0)
    paper = evaluate_paper(graph, labels, gt, n_queries=1500, seed=0, labels=labels)
    assert exact.opt_path == pytest.approx(expected(gt, 0, 0))
    assert exact.any_path == pytest.approx(expected(gt, 1, 0))
    assert paper.opt_path == pytest.approx(expected(gt, 0, 1))
    assert paper.any_path == pytest.approx(expected(gt, 1, 1)) == 1
    # the paper's OptPath is our AnyPath; only P1 -> P3 tells the two AnyPaths apart
    assert paper.opt_path == exact.any_path < paper.any_path
    assert abs(paper.opt_path - 9 / 10) < 0.05
    # with consistency from the labels every induced edge is realised: 100 % by construction
    assert (paper.trans_prec, paper.trans_cov) == (1.0, 1.0) == (exact.trans_prec, exact.trans_cov)
    assert paper.agreement == 1.0 and paper.queries == 1500


def test_any_plan_walks_the_product_graph(chain):
    labels = labelling(chain, merge=("Q1", "Q2"))
    gt, graph = GroundTruth.from_trace(chain), graph_for(chain, labels)
    node = {s: int(labels[list(chain.states).index(s)]) for s in ("P1", "Q1", "P2", "P3")}
    cons = consistency_sets(gt, labels, graph.nodes)
    assert any_plan_validates(graph, gt, cons, node["P1"], node["P3"])
    assert not any_plan_validates(graph, gt, cons, node["P3"], node["P1"])  # P3 is a sink
    assert any_plan_validates(graph, gt, cons, node["Q1"], node["Q1"])  # the empty plan
    # without Q2 in C(Q) the only way past Q is b: P3 cannot be reached validly
    cons[node["Q1"]] = frozenset([gt.state_names.index("Q1")])
    assert not any_plan_validates(graph, gt, cons, node["P1"], node["P3"])


def test_majority_consistency_drops_the_minority_state(chain):
    # Q1 and Q2 are seen once each: the tie goes to the smaller state id, Q1, so
    # C(Q) = {Q1}. Edges: P1-a->Q ok, Q-b->P2 ok, P2-c->Q needs (P2, c, Q1): no, Q-d->P3 needs
    # (Q1, d, P3): no -> TransPrec 2/4. E*: (P1,a,Q1), (Q1,b,P2) covered; (P2,c,Q2), (Q2,d,P3)
    # have Q2 in no node's C -> TransCov 2/4. No plan passes Q towards P3.
    labels = labelling(chain, merge=("Q1", "Q2"))
    gt, graph = GroundTruth.from_trace(chain), graph_for(chain, labels)
    m = evaluate_paper(graph, labels, gt, n_queries=1500, seed=0, consistency="majority")
    assert (m.trans_prec, m.trans_cov) == (0.5, 0.5)
    q = sample_queries(gt, 1500, 0)
    names = [(gt.state_names[s], gt.state_names[g]) for s, g in q[:, :2].tolist()]
    # valid under majority: the pairs whose plans stay within P1 -a-> Q1 -b-> P2, plus the
    # empty plan Q1 -> Q2 (one node, Q1 consistent with it)
    ok = {("P1", "Q1"), ("P1", "Q2"), ("P1", "P2"), ("Q1", "P2"), ("Q1", "Q2")}
    share = np.mean([p in ok for p in names])
    assert m.opt_path == pytest.approx(share) and m.any_path == pytest.approx(share)


def test_a_localizer_that_errs_breaks_the_induced_edges(chain):
    # labels are the true states (5 nodes); f puts the Q2 observation into node Q1, so
    # C_f(Q1) = {Q1, Q2} and C_f(Q2) = {}. Learned edges P2-c->Q2 and Q2-d->P3 are realised by
    # no consistent states (TransPrec 2/4); (P2,c,Q2) and (Q2,d,P3) are carried by no edge
    # between nodes consistent with them (TransCov 2/4).
    labels = labelling(chain)
    assigned = labels.copy()
    q2 = list(chain.states).index("Q2")
    assigned[q2] = labels[list(chain.states).index("Q1")]
    gt, graph = GroundTruth.from_trace(chain), graph_for(chain, labels)
    m = evaluate_paper(graph, assigned, gt, labels=labels, assignment="localizer")
    assert (m.trans_prec, m.trans_cov) == (0.5, 0.5)
    assert m.agreement == pytest.approx(4 / 5) and m.assignment == "localizer"
    with pytest.raises(Exception, match="4 entries for 5"):
        evaluate_paper(graph, assigned[:4], gt)


def test_evaluate_cli_reading_paper(tmp_path, chain, capsys):
    tpath, spath = tmp_path / "t.npz", tmp_path / "s.json"
    save_trace(chain, tpath)
    write_solution(spath, labels_solution(chain, labelling(chain, merge=("Q1", "Q2"))))
    assert main(["evaluate", str(tpath), str(spath), "--json"]) == 0
    exact = json.loads(capsys.readouterr().out)
    assert "paper_reading" not in exact
    assert main(["evaluate", str(tpath), str(spath), "--json", "--reading", "paper"]) == 0
    both = json.loads(capsys.readouterr().out)
    assert {k: v for k, v in both.items() if k != "paper_reading"} == exact
    paper = both["paper_reading"]
    assert paper["opt_path"] == exact["any_path"] < paper["any_path"] == 1.0
    assert paper["assignment"] == "labels" and paper["consistency"] == "all"
    assert main(["evaluate", str(tpath), str(spath), "--reading", "paper",
                 "--consistency", "majority", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["paper_reading"]["trans_prec"] == 0.5
    assert main(["evaluate", str(tpath), str(spath), "--reading", "paper"]) == 0
    text = capsys.readouterr().out
    assert "paper" in text and "AnyPath" in text
    assert main(["evaluate", str(tpath), str(spath), "--consistency", "majority"]) == 2
    err = capsys.readouterr().err
    assert "--consistency" in err and err.count("\n") == 1
