"""The default pipeline: evidence, selection and confidence decided from the trace alone."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import shuffled_within_roles

from vggc_cp.errors import VggcError
from vggc_cp.learned import LearnConfig
from vggc_cp.pipeline import choose, learn_graph, learned_doubts, threshold_grid
from vggc_cp.solvers.doubts import DoubtRule
from vggc_cp.trace import Trace, load_trace

DATA = Path(__file__).resolve().parents[1] / "data" / "fruit-2x3.npz"


@pytest.fixture(scope="module")
def shipped():
    return load_trace(DATA)


def test_the_footprint_problem_carries_the_colours_and_what_the_actions_state(shipped):
    from vggc_cp.pipeline import evidence_problem
    from vggc_cp.solvers.mdl import description_length, reading_length

    for candidates in ("codes", "dense"):
        problem = evidence_problem(shipped.without_states(), "footprints",
                                   LearnConfig(candidates=candidates))
        assert problem.action_colour is not None and len(problem.action_colour) == \
            shipped.n_actions
        assert problem.readings is not None and len(problem.readings.codes) == shipped.n_obs
        _, truth = np.unique(shipped.states, return_inverse=True)
        merged = problem.labels_from_colours(np.zeros(problem.n_pick, int),
                                             np.zeros(problem.n_place, int))
        assert reading_length(problem.readings, merged) > reading_length(problem.readings,
                                                                         truth)
        assert description_length(problem, truth) > reading_length(problem.readings, truth)


def test_the_shipped_trace_gives_its_true_graph_without_a_warning(shipped):
    learned = learn_graph(shipped.without_states(), LearnConfig(evidence="footprints"))
    same = learned.labels[:, None] == learned.labels[None, :]
    np.testing.assert_array_equal(same, shipped.states[:, None] == shipped.states[None, :])
    conf = learned.confidence
    assert not conf.suspect and conf.plateau >= 3 and conf.margin > 0
    # no re-run with a fifth of the episodes left out changes it: five folds, chance 0
    assert (conf.p_change, conf.runs, conf.changed, conf.unstable) == (0.0, 5, 0, ())
    again = learn_graph(shipped.without_states(), LearnConfig(evidence="footprints"))
    assert again.confidence.as_dict() == conf.as_dict()   # same trace, same number
    assert conf.heldout is not None and conf.heldout.contradicted < 0.05
    assert learned.chosen.evidence == "footprints" and len(learned.candidates) == 1
    ts = learned.chosen.path.thresholds
    assert list(ts) == sorted(ts) and learned.threshold in ts


def _first_episodes(trace: Trace, k: int) -> Trace:
    """The first ``k`` episodes of ``trace``."""
    n = trace.episodes()[k - 1][1] + 1
    return Trace(trace.observations[:n], trace.actions[:n - 1], trace.action_names,
                 trace.states[:n], trace.meta)


def test_images_that_say_nothing_leave_what_the_actions_say_and_a_wrong_graph_is_flagged(
        shipped):
    """Images shuffled within each role carry nothing; the actions still do. On fruit-2x3 the
    sequence pairs each pick with the place that refills its slot and the episodes' actions
    state what nearly every slot holds, so the true graph can be learned from them alone (the
    whole shipped trace: right for every shuffle); in its first three episodes (28
    observations) the sequence leaves some of it to the images, and where the graph comes
    out wrong, the tool says so."""
    for seed in (0, 1):
        noise = shuffled_within_roles(shipped, seed, keep_states=False)
        labels = learn_graph(noise, LearnConfig(evidence="footprints")).labels
        np.testing.assert_array_equal(labels[:, None] == labels[None, :],
                                      shipped.states[:, None] == shipped.states[None, :])
    short = _first_episodes(shipped, 3)
    truth = short.states[:, None] == short.states[None, :]
    right = 0
    for seed in (0, 1, 2):
        noise = shuffled_within_roles(short, seed, keep_states=False)
        learned = learn_graph(noise, LearnConfig(evidence="footprints"))
        same = learned.labels[:, None] == learned.labels[None, :]
        if (same == truth).all():
            right += 1
        else:
            assert learned.confidence.suspect and learned.confidence.reasons
    assert 0 < right < 3       # some right from the actions alone, one wrong and flagged


def test_auto_keeps_the_footprints_when_they_are_not_suspect(shipped):
    learned = learn_graph(shipped.without_states())
    assert learned.chosen.evidence == "footprints" and len(learned.candidates) == 1


def test_choose_keeps_the_first_evidence_unless_only_a_later_one_passes_its_checks(shipped):
    from dataclasses import replace

    from vggc_cp.pipeline import _with_disagreement, run_candidate

    options = LearnConfig()
    fp = run_candidate(shipped.without_states(), "footprints", options)
    assert not fp.confidence.suspect
    suspect = replace(fp, evidence="footprints", confidence=replace(
        fp.confidence, suspect=True, reasons=("made up",)))
    later = replace(fp, evidence="keypoints")
    assert choose([fp, later]) is fp                      # the first passes: kept
    assert choose([suspect, later]) is later              # only the later one passes
    worse = replace(later, confidence=suspect.confidence)
    assert choose([suspect, worse]) is suspect            # none passes: the first
    # another evidence with another node count flags the chosen one, suspect or not
    other_labels = np.arange(shipped.n_obs)
    other_path = replace(fp.path, results=tuple(replace(r, labels=other_labels)
                                                for r in fp.path.results))
    for other in (replace(fp, evidence="keypoints", path=other_path),
                  replace(worse, path=other_path)):
        flagged = _with_disagreement(fp, [fp, other])
        assert flagged.confidence.suspect and "disagree" in flagged.confidence.reasons[-1]
    assert _with_disagreement(fp, [fp, later]) is fp      # same size: no reason added


def test_threshold_grid_and_errors(shipped):
    from vggc_cp.solvers.base import Problem
    from vggc_cp.vision.footprints import footprint_distances

    dp, dq = footprint_distances(shipped)
    grid = threshold_grid(Problem.from_trace(shipped, dp, dq), steps=10)
    assert len(grid) == 10 and np.all(np.diff(grid) > 0)
    empty = Trace(shipped.observations[:1], np.zeros(0, dtype=np.int64), shipped.action_names)
    with pytest.raises(VggcError):
        learn_graph(empty)


def _toy_problem(trace: Trace):
    """``trace``'s problem under distances that are 0 within a true state, 1 across."""
    from vggc_cp.solvers.base import Problem

    roles, states = trace.roles(), np.asarray(trace.states)
    dists = []
    for r in (0, 1):
        s = states[roles == r]
        dists.append((s[:, None] != s[None, :]).astype(np.float64))
    return Problem.from_trace(trace, *dists)


def test_grid_sweep_is_the_one_grid_path(toy_trace):
    """solve's grid solvers and table1's methods both call grid_sweep: the default grid and
    run_sweep for a heuristic; for CP-SAT the greedy sweep first, then the exact sweep it
    warm-starts, both kept and both timed."""
    from vggc_cp.pipeline import grid_sweep
    from vggc_cp.solvers.cpsat import CpSatSolver
    from vggc_cp.solvers.greedy import GreedySolver
    from vggc_cp.solvers.sweep import default_grid, run_sweep

    problem = _toy_problem(toy_trace)
    kp, kq = default_grid(problem)
    grid = grid_sweep(problem, GreedySolver())
    plain = run_sweep(problem, GreedySolver(), kp, kq)
    assert (grid.k_pick, grid.k_place, grid.greedy) == (kp, kq, None)
    assert [(r.k_pick, r.k_place, r.status, r.n_nodes) for r in grid.sweep.results] == \
        [(r.k_pick, r.k_place, r.status, r.n_nodes) for r in plain.results]
    assert np.array_equal(grid.best.labels, plain.best.labels)
    exact = grid_sweep(problem, CpSatSolver(params="num_workers:1"), range(1, 3), range(1, 3))
    assert exact.greedy is not None and exact.sweep.solver == "cpsat"
    assert len(exact.sweep.results) == len(exact.greedy.results) == 4
    assert exact.seconds == exact.sweep.seconds + exact.greedy.seconds
    assert exact.best.n_nodes == 3  # L, R and H: the toy's true states


@pytest.mark.slow
def test_the_fallback_runs_only_where_the_policy_says(shipped):
    """A trace whose images say nothing and whose actions do not settle it (the shipped
    trace's first three episodes, shuffled): the footprint graph is suspect. By default (refused)
    the keypoint evidence does not run for it; with ``fallback="suspect"`` it does; with
    ``never`` a trace the footprints refuse is refused."""
    noise = shuffled_within_roles(_first_episodes(shipped, 3), 0, keep_states=False)
    default = learn_graph(noise)
    assert [c.evidence for c in default.candidates] == ["footprints"]
    assert default.confidence.suspect
    again = learn_graph(noise, LearnConfig(fallback="suspect"))
    assert [c.evidence for c in again.candidates] == ["footprints", "keypoints"]
    with pytest.raises(VggcError, match="fallback"):
        LearnConfig(fallback="sometimes")
    flat = Trace(np.zeros_like(shipped.observations), shipped.actions, shipped.action_names)
    with pytest.raises(VggcError, match="no visual evidence"):
        learn_graph(flat, LearnConfig(fallback="never"))


@pytest.mark.slow  # a PyBullet trace
def test_a_tie_the_surely_right_readings_settle_is_not_a_margin_warning():
    """random-3 clean, seed 0, |D| = 176 (the tuning split). The right 49 nodes. In the
    actions' code a graph of another size ties with it (two states seen once each: one node
    or two cost the same edges), which warned it until session 52 (a false alarm). The images
    tell the two apart at sites read at kappa 1.0 over hundreds of stated frames, surely
    right, so their code joins the margin and the graph is quiet. (Until session 52 this
    test asserted the warning and the close call it rests on; blocks-3 clean seed 47 until
    session 35, multifruit-2x3 randomized seed 12 until session 20.)"""
    from vggc_cp.sim.explore import generate
    from vggc_cp.solvers.mdl import TIE_NATS, sure_reading_gap
    from vggc_cp.solvers.verdict import runner_up

    trace = generate("random-3", 176, seed=0, look="clean").trace
    learned = learn_graph(trace.without_states())
    assert learned.chosen.best.n_nodes == 49
    same = learned.labels[:, None] == learned.labels[None, :]
    np.testing.assert_array_equal(same, trace.states[:, None] == trace.states[None, :])
    cand = learned.chosen
    dls = cand.description_lengths
    k, other = cand.path.selected, runner_up(cand.path, dls)
    assert dls[other] - dls[k] < TIE_NATS                     # the actions tie
    gap = sure_reading_gap(cand.problem, cand.path.merged_labels(k),
                           cand.path.merged_labels(other))
    assert dls[other] - dls[k] + gap >= TIE_NATS              # the readings settle it
    conf = learned.confidence
    assert conf.margin * len(cand.problem.act) == pytest.approx(dls[other] - dls[k] + gap)
    assert not conf.suspect and not any("margin" in r for r in conf.reasons)


@pytest.mark.slow  # a PyBullet trace
def test_a_warning_from_held_out_contradictions_lists_the_nodes_they_dispute():
    """fruit-2x3 clean, seed 28, |D| = 50 (drawn after the method of session 13 was frozen):
    the right 6 nodes, warned only because 6 % of held-out transitions contradict the
    graph, with no close call near t* nor toward the runner-up. The doubt then names the
    pair the contradicted transitions dispute, with their count; here the two nodes are
    two states and the evidence says so (far apart, the actions against joining them)."""
    from vggc_cp.sim.explore import generate

    trace = generate("fruit-2x3", 50, seed=28, look="clean").trace
    learned = learn_graph(trace.without_states())
    conf = learned.confidence
    assert conf.suspect and [r for r in conf.reasons if "contradict" in r] == list(conf.reasons)
    assert learned_doubts(learned.chosen) == ()
    assert learned_doubts(learned.chosen, toward_runner_up=True) == ()
    assert len(learned.doubts) >= 1
    d = learned.doubts[0]
    assert d.kind == "merge" and d.evidence["contradicted"] >= 1
    assert list(d.nodes) in [sorted(p[:2]) for p in conf.heldout.disputed]
    assert d.evidence["dl_nats"] > 0 and d.evidence["steps"] > DoubtRule().window
    record = learned.solution_record()
    assert record["doubts"][0]["evidence"]["contradicted"] == d.evidence["contradicted"]
    assert record["confidence"]["heldout"]["disputed"][0][2] >= 1



@pytest.mark.slow  # a PyBullet trace of 156 transitions, learned once
def test_a_chance_of_change_alone_warns():
    """random-1268 clean, |D| = 156 (draw 55, a silent miss at session 56's first package):
    25 nodes for 25, but two states share a node twice (a stack in one region or in the
    other, seen in two episodes only), and nothing but the re-runs questions it: they change
    the graph 7 times in 20 (35 %). Alone that was a note until session 56; now it warns,
    naming the changed nodes."""
    from vggc_cp.sim.explore import generate

    trace = generate("random-1268", 156, 0, look="clean").trace
    conf = learn_graph(trace.without_states()).confidence
    assert conf.p_change > 0.3 and conf.suspect and conf.notes == ()
    assert any("re-runs" in r for r in conf.reasons)

@pytest.mark.slow  # a PyBullet trace
def test_the_runner_ups_differences_are_listed_each_side_one_state():
    """blocks-3 clean, seed 47, |D| = 200 (session 18's held-out set). Until session 35 the
    right 16 nodes were warned by the description-length margin alone (0.17 nats toward a
    15-node graph); the read cuts part that graph's join again, so the path's graphs at
    those thresholds are the chosen partition, and the runner-up is a coarser graph far
    behind: no warning. The runner-up's differences are still what
    :func:`runner_up_doubts` lists, and each side of each is one state. (multifruit-2x3
    randomized seed 30 until session 35, whose only coarser merges the cuts make the right
    12 nodes: no graph of another size is left on its path.)"""
    from vggc_cp.sim.explore import generate

    trace = generate("blocks-3", 200, seed=47, look="clean").trace
    learned = learn_graph(trace.without_states())
    assert not learned.confidence.suspect and learned.chosen.best.n_nodes == 16
    rows = learned.path_records()
    assert any(r["read_splits"] and r["merged_nodes"] == 15 and r["nodes"] == 16 for r in rows)
    listed = learned_doubts(learned.chosen, toward_runner_up=True, differences=True)
    assert len(listed) >= 1
    for d in listed:
        assert d.evidence["runner_up"]
        for side in d.observations:
            assert len({str(trace.states[o]) for o in side}) == 1


def test_nodes_an_arm_hidden_reading_splits_are_warned_and_a_right_graph_is_not():
    """A robot camera (an arm resting above the place it last acted on, shake, drift).
    multifruit-2x3, 95 transitions, seed 4 (seed 10 until session 34, whose colour windows
    read its red and yellow apart: 11 nodes for the 11 states it visits, right; seed 4 until
    session 29): regions 0 and 2 are read with a kappa the few stated frames bound only at
    0.20 (95 % lower bound, under 0.6), and observations land in the wrong nodes (one node
    holds `y--|r` and `--y|r`); the read doubts (episode doubts) name those regions' sites,
    first among the doubts. fruit-2x3, 50 transitions, seed 34: the true graph, quiet (seed
    33 until session 27, whose frame gains leave an episode doubt there). (Until
    session 20 the split was fruit-2x3 seed 37, and seed 35 before session 19: both read
    right now, as are 26 of fruit-2x3's seeds 30-59, against 17 before objects were
    conserved.)"""
    from vggc_cp.sim.explore import generate

    split = generate("multifruit-2x3", 95, 4, look="robot").trace
    learned = learn_graph(split.without_states())
    states = np.array([str(s) for s in split.states])
    labels = np.asarray(learned.labels)
    # a node that holds two true states: the reading put observations where they are not
    assert any(len(set(states[labels == n])) > 1 for n in np.unique(labels))
    assert learned.confidence.suspect
    read = [d for d in learned.doubts if "read_kappa" in d.evidence]
    assert read and read == list(learned.doubts[:len(read)])
    assert all(d.evidence["read_kappa_low"] < 0.6 for d in read)
    assert any("beyond chance" in r and "red_2" in r for r in learned.confidence.reasons)
    right = learn_graph(generate("fruit-2x3", 50, 34, look="robot").trace.without_states())
    assert right.graph.n_nodes == 6 and not right.confidence.suspect
    assert not any("read_kappa" in d.evidence for d in right.doubts)


def test_a_noted_graph_lists_the_decisions_its_note_is_about():
    """fruit-2x3 randomized, seed 10, |D| = 50 (blocks-2 randomized s17 until session 28,
    whose re-runs no longer change): the true 6 nodes, re-runs on 4/5 of the recording change
    5 of 20 times, above a bar of 20 % (the default's 30 %: 3 of 17), and no other check
    questions it. With ``change_alone`` off the chance of change alone is a note, not a
    warning, and the solution records it. multifruit-2x3 robot seed 103 (seed 107 until session 28, seed 9 until
    session 27): the true 12 nodes and a note that names an episode only a poor reading puts
    on its path (observations 104-107; in truth it is right there): were it wrong, fewer
    than 10 % of plans would fail, so it is a note too, and the solution lists the decision
    it is about."""
    from vggc_cp.learned import LearnConfig
    from vggc_cp.sim.explore import generate
    from vggc_cp.solvers.confidence import WarningRule

    trace = generate("fruit-2x3", 50, 10, look="randomized").trace
    # its re-runs change 18 % of the time by default; the chance alone a note, as it was
    # by default until session 56
    rule = WarningRule(max_change=0.2, change_alone=False)
    learned = learn_graph(trace.without_states(), LearnConfig(warning=rule))
    conf = learned.confidence
    assert learned.graph.n_nodes == 6 and not conf.suspect and conf.reasons == ()
    assert conf.p_change > 0.2 and len(conf.notes) == 1 and "re-runs" in conf.notes[0]
    assert "note, not a warning" in conf.summary()
    fields = learned.solution_fields()
    assert fields["confidence"]["notes"] == list(conf.notes)
    trace = generate("multifruit-2x3", 95, 103, look="robot").trace
    learned = learn_graph(trace.without_states())
    conf = learned.confidence
    assert learned.graph.n_nodes == 12 and not conf.suspect and conf.reasons == ()
    assert len(conf.notes) == 1 and "episode of observations 104-107" in conf.notes[0]
    assert "note, not a warning" in conf.summary() and learned.doubts
