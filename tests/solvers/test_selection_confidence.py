"""Description-length selection and the ground-truth-free confidence on small synthetic paths
where the right answer is known."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.sim import get_benchmark
from vggc_cp.sim.explore import random_walk
from vggc_cp.solvers.base import FEASIBLE, Problem, SolveResult
from vggc_cp.solvers.confidence import (
    HeldOut,
    WarningRule,
    assess,
    heldout_prediction,
    plateau_length,
    subproblem,
)
from vggc_cp.solvers.mdl import description_length, select_mdl
from vggc_cp.trace import compute_roles


def walk_problem(name="fruit-4x6", transitions=400, seed=0, noise=0.0):
    """A problem from a random walk of a benchmark's true dynamics (no images): distances are
    0 within a state and 1 between states, plus ``noise``; returns it, the true labels and
    the episode of every observation."""
    bench = get_benchmark(name)
    walk = random_walk(bench, transitions, np.random.default_rng(seed))
    names = bench.action_names
    roles = compute_roles(walk.actions, names)
    keep = walk.actions >= 0
    idx = np.arange(len(walk.actions))[keep]
    src, act, dst = idx, walk.actions[keep], idx + 1
    _, truth = np.unique(np.array(walk.states), return_inverse=True)
    rng = np.random.default_rng(seed + 1)
    dists = []
    for role in (0, 1):
        t = truth[roles == role]
        d = (t[:, None] != t[None, :]).astype(float) + noise * rng.random((len(t), len(t)))
        d = (d + d.T) / 2
        np.fill_diagonal(d, 0.0)
        dists.append(d)
    problem = Problem(roles, src, act, dst, names, dists[0], dists[1])
    episode = np.concatenate([[0], np.cumsum(walk.actions < 0)])
    return problem, problem.labels_from_colours(truth[problem.pick_obs],
                                                truth[problem.place_obs]), episode


def result(labels):
    return SolveResult(labels, 0, 0, 0.0, FEASIBLE, "merge")


def test_description_length_prefers_the_true_graph_to_merged_and_unmerged():
    problem, truth, _ = walk_problem("fruit-2x3", 300)
    merged = problem.labels_from_colours(np.zeros(problem.n_pick, int),
                                         np.zeros(problem.n_place, int))
    # merge every pair of true pick states that share a first action: a coarser graph
    half = truth.copy()
    half[problem.pick_obs] = truth[problem.pick_obs] // 2 * 2
    unmerged = np.arange(problem.n_obs)
    dl = {k: description_length(problem, lab) for k, lab in
          (("truth", truth), ("merged", merged), ("half", half), ("unmerged", unmerged))}
    assert dl["truth"] < dl["half"] and dl["truth"] < dl["merged"]
    assert dl["truth"] < dl["unmerged"]
    path = [result(unmerged), result(half), result(truth), result(truth), result(merged)]
    assert select_mdl(path, problem) == 2  # the first of the equal ones
    assert select_mdl([], problem) is None
    with pytest.raises(ValueError):
        select_mdl(path)
    assert description_length(problem, None) == float("inf")


def test_description_length_by_hand():
    # one node taking a twice and b once, 3 transitions, 2 edges
    roles = np.array([0, 1, 0, 1, 0, 1])
    problem = Problem(roles, np.array([0, 2, 4]), np.array([0, 0, 1]), np.array([1, 3, 5]),
                      ("pick_a", "pick_b"), np.zeros((3, 3)), np.zeros((3, 3)))
    labels = np.array([0, 1, 0, 1, 0, 2])
    loglik = 2 * np.log(2 / 3) + np.log(1 / 3)
    assert description_length(problem, labels) == pytest.approx(-loglik + 0.5 * np.log(3) * 2)


def test_equal_description_lengths_go_to_the_graph_with_fewer_nodes():
    """An observation from which no action is taken (here the last place observation) costs
    nothing wherever it goes: splitting it off leaves the code length equal, and the graph
    with fewer nodes is taken, whichever comes first on the path."""
    roles = np.array([0, 1, 0, 1])
    problem = Problem(roles, np.array([0, 2]), np.array([0, 1]), np.array([1, 3]),
                      ("pick_a", "place_a"), np.zeros((2, 2)), np.zeros((2, 2)))
    together = result(np.array([0, 1, 2, 1]))
    apart = result(np.array([0, 1, 2, 3]))
    assert description_length(problem, together.labels) == pytest.approx(
        description_length(problem, apart.labels))
    assert select_mdl([apart, together], problem) == 1
    assert select_mdl([together, apart], problem) == 0


def test_plateau_length_counts_identical_partitions_in_a_row():
    a, b = np.array([0, 0, 1]), np.array([0, 1, 2])
    labs = [b, a, a.copy(), a.copy(), b, None]
    assert plateau_length(labs, 2) == 3 and plateau_length(labs, 1) == 3
    assert plateau_length(labs, 0) == 1 and plateau_length(labs, 5) == 0


def test_heldout_prediction_is_high_on_clean_evidence_and_contradicted_on_noise():
    problem, truth, episode = walk_problem()
    clean = heldout_prediction(problem, 0.5, episode, folds=5)
    assert clean.folds == 5 and clean.transitions == len(problem.act)
    assert clean.contradicted == 0.0 and clean.predicted > 0.8
    assert clean.predicted + clean.contradicted + clean.unseen == pytest.approx(1.0)
    # evidence that cannot tell states apart: held-out renders land in the wrong nodes
    noisy, _, _ = walk_problem(noise=3.0)
    bad = heldout_prediction(noisy, 2.2, episode, folds=5)
    assert bad.contradicted > clean.contradicted + 0.05 and bad.predicted < clean.predicted
    one = np.zeros(problem.n_obs, dtype=int)
    assert heldout_prediction(problem, 0.5, one) is None  # a single episode cannot be split


def test_subproblem_keeps_kept_observations_and_their_transitions():
    problem, truth, episode = walk_problem(transitions=60)
    keep = episode % 2 == 0
    sub, idx = subproblem(problem, keep)
    assert sub.n_obs == keep.sum() and np.array_equal(idx, np.flatnonzero(keep))
    assert len(sub.act) == int((keep[problem.src] & keep[problem.dst]).sum())
    assert sub.dist_pick.shape == (sub.n_pick, sub.n_pick)


def test_assess_flags_each_condition_and_only_those():
    ok = HeldOut(0.95, 0.0, 0.05, 100, 5)
    quiet = assess(0.2, 5, ok, 10.0)
    assert not quiet.suspect and quiet.reasons == ()
    assert "no warning" in quiet.summary()
    rule = WarningRule()
    cases = {
        "threshold": assess(0.2, rule.min_plateau - 1, ok, 10.0),
        "margin": assess(rule.min_margin / 2, 5, ok, 10.0),
        "contradict": assess(0.2, 5, HeldOut(0.7, 0.2, 0.1, 100, 5), 10.0),
        "predicted": assess(0.2, 5, HeldOut(0.3, 0.0, 0.7, 100, 5), 10.0),
        "observations per node": assess(0.2, 5, ok, 1.0),
    }
    for word, conf in cases.items():
        assert conf.suspect and len(conf.reasons) == 1 and word in conf.reasons[0], word
        assert "SUSPECT" in conf.summary()
    assert assess(float("inf"), 5, None, 10.0).as_dict()["margin"] is None
