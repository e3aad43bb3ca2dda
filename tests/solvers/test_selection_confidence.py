"""Description-length selection and the ground-truth-free confidence on small synthetic paths
where the right answer is known."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.sim import get_benchmark
from vggc_cp.sim.explore import random_walk
from vggc_cp.solvers.base import FEASIBLE, Problem, SolveResult
from vggc_cp.solvers.confidence import (
    WarningRule,
    assess,
    changed_nodes,
    plateau_length,
    resample,
    resampling_units,
    same_partition,
)
from vggc_cp.solvers.heldout import heldout_prediction, subproblem
from vggc_cp.solvers.mdl import description_length, reading_length, select_mdl
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


def test_what_the_actions_state_makes_a_merge_of_two_states_cost_and_a_split_never_pay():
    """Readings stated at one site (a symbol per true state, 30 % of the observations not
    stated): the true graph codes them for the cost of saying what each node holds; a graph
    that merges states pays for every mixed reading on top of the action code, and a graph
    that splits states gains nothing (nothing is left to explain) but pays per node."""
    from dataclasses import replace

    from vggc_cp.solvers.base import Readings

    problem, truth, _ = walk_problem("fruit-2x3", 300)
    rng = np.random.default_rng(3)
    rows = np.where(rng.random(problem.n_obs) < 0.3, 0, 1 + truth)[:, None]
    seen = replace(problem, readings=Readings.from_rows(rows))
    half = truth.copy()
    half[problem.pick_obs] = truth[problem.pick_obs] // 2 * 2
    split = np.arange(problem.n_obs)
    cost = {k: reading_length(seen.readings, lab) for k, lab in
            (("truth", truth), ("half", half), ("split", split))}
    assert cost["truth"] == pytest.approx(len(np.unique(truth)) * np.log(len(np.unique(truth))))
    assert cost["half"] > cost["truth"] and cost["split"] > cost["truth"]
    gap = description_length(seen, half) - description_length(seen, truth)
    assert gap > description_length(problem, half) - description_length(problem, truth) + 50
    # nothing stated: nothing coded
    blank = Readings.from_rows(np.zeros((problem.n_obs, 2), dtype=int))
    assert reading_length(blank, half) == 0.0


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


def _read_walk(kappa):
    """fruit-2x3's walk with one read site: every observation's true state (as a symbol)
    read, nothing stated; and the truth with two pick states merged (``half``)."""
    from dataclasses import replace

    from vggc_cp.solvers.base import Readings, SiteReads

    problem, truth, _ = walk_problem("fruit-2x3", 300)
    held = (1 + truth)[:, None].astype(np.int64)
    sites = SiteReads(held, np.zeros(held.shape, bool), np.array([kappa]), np.array([0]))
    seen = replace(problem, readings=Readings.from_rows(np.zeros((problem.n_obs, 1)), sites))
    half = truth.copy()
    half[problem.pick_obs] = truth[problem.pick_obs] // 2 * 2
    return seen, truth, half


def _tie_problem(kappa, stated=False):
    """Four picks alike to the actions (one node or two cost 0.69 nats apart: a tie), two
    read holding one colour and two another at one site of agreement ``kappa``; and the
    graphs with one pick node and with two."""
    from vggc_cp.solvers.base import Readings, SiteReads

    held = np.array([[1], [0], [1], [0], [2], [0], [2], [0]])
    sites = SiteReads(held, np.full((8, 1), stated), np.array([kappa]), np.array([0]))
    problem = Problem(np.array([0, 1] * 4), np.array([0, 2, 4, 6]), np.zeros(4, np.int64),
                      np.array([1, 3, 5, 7]), ("pick_a", "place_a"), np.zeros((4, 4)),
                      np.zeros((4, 4)), readings=Readings.from_rows(np.zeros((8, 1)), sites))
    return problem, result(np.array([0, 1] * 4)), result(np.array([0, 1, 0, 1, 2, 3, 2, 3]))


def test_trusted_readings_break_a_tie_of_the_actions_and_nothing_else():
    """Where the action code leaves two graphs within ln 20 of each other, what a trusted
    site reads chooses: the graph that keeps differently read frames apart. Readings below
    the trust, frames the actions state, and graphs the actions rule out (beyond the tie)
    are left to the actions."""
    from vggc_cp.solvers.mdl import TIE_NATS, choice_lengths

    # beyond the tie: the actions prefer the truth by far, whatever is read
    seen, truth, half = _read_walk(kappa=1.0)
    assert description_length(seen, half) - description_length(seen, truth) > TIE_NATS
    assert select_mdl([result(half), result(truth)], seen) == 1

    # a tie: four picks alike to the actions, two read holding one colour and two another
    for kappa, chosen in ((0.95, 1), (0.5, 0), (np.nan, 0)):
        p, one, two = _tie_problem(kappa)
        assert select_mdl([one, two], p) == chosen, kappa
        assert select_mdl([two, one], p) == 1 - chosen, kappa
    p, one, two = _tie_problem(1.0, stated=True)
    assert select_mdl([one, two], p) == 0                           # not read again
    # the code that chose: the actions' lengths, plus the readings' among the tie
    p, one, two = _tie_problem(1.0)
    dls = [description_length(p, r.labels) for r in (one, two)]
    choice = choice_lengths(p, [one.labels, two.labels])
    assert dls[0] < dls[1] and choice[1] < choice[0]
    assert np.all(choice > np.array(dls))
    # beyond the tie: not a candidate at all
    far = choice_lengths(p, [one.labels, two.labels], [dls[0], dls[0] + TIE_NATS + 1.0])
    assert np.isinf(far[1]) and far[0] == pytest.approx(dls[0])


def test_a_graph_the_readings_chose_keeps_the_margin_of_the_actions():
    """The trusted readings choose among a tie, but the confidence's margin stays in the
    actions' code where they are not surely right (no stated frame judges them here): the
    graph they chose is warned that another size is nearly as probable."""
    from vggc_cp.solvers.mdl import surely_trusted_readings
    from vggc_cp.solvers.merge import ThresholdPath
    from vggc_cp.solvers.verdict import runner_up

    p, one, two = _tie_problem(1.0)
    assert surely_trusted_readings(p.readings) is None
    results = [one, two]
    k = select_mdl(results, p)
    assert k == 1                                   # the readings chose
    dls = [description_length(p, r.labels) for r in results]
    path = ThresholdPath((0.1, 0.2), tuple(results), k, "mdl", 0.0)
    other = runner_up(path, dls)
    assert other == 0
    margin = (dls[other] - dls[k]) / len(p.act)
    conf = assess(margin, 5, None, 4.0, transitions=len(p.act), read_choice=True)
    assert margin < 0 and conf.suspect
    (reason,) = [r for r in conf.reasons if "description-length margin" in r]
    assert "the images read at well-read sites chose this one" in reason
    plain = assess(margin, 5, None, 4.0, transitions=len(p.act))
    assert not any("chose this one" in r for r in plain.reasons)


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


def test_a_right_graph_is_quiet_and_a_merged_one_is_warned():
    """Known answers: distances 0 within a true state and 1 across. At a threshold below 1
    every re-run reproduces the true graph: chance of change 0, no warning. A graph that
    merged two true states (what a threshold above 1 would not give either) changes in
    every re-run: chance 1, warned by default (``change_alone``); with the chance alone a
    note (``change_alone=False``), a note naming the merged node, and warned as soon as
    another check questions it too (here the actions favouring the split by 4 nats; any
    check flagging)."""
    problem, truth, episode = walk_problem()
    right = resample(problem, 0.5, truth, episode, folds=5)
    assert (right.runs, right.changed, right.p_change, right.unstable) == (5, 0, 0.0, ())
    quiet = assess(0.2, 5, right, 10.0)
    assert not quiet.suspect and quiet.reasons == () and quiet.p_change == 0.0
    assert "chance of change 0 %" in quiet.summary() and "no warning" in quiet.summary()
    merged = truth.copy()
    pick = problem.pick_obs
    a, b = np.unique(truth[pick])[:2]
    merged[pick[truth[pick] == b]] = a
    wrong = resample(problem, 0.5, merged, episode, folds=5)
    assert wrong.changed == wrong.runs and wrong.p_change == 1.0
    assert [u for u, _ in wrong.unstable] == [a]
    noted = assess(0.2, 5, wrong, 10.0, WarningRule(change_alone=False))
    assert not noted.suspect and noted.reasons == () and noted.unstable == (a,)
    assert f"nodes {a}" in noted.notes[0] and "vggc-cp suggest" in noted.notes[0]
    assert "note, not a warning" in noted.summary()
    from vggc_cp.solvers.doubt_checks import corroborate
    from vggc_cp.solvers.doubts import Doubt

    split = Doubt("split", (int(a),), ((1,), (2,)), {"dl_nats": -4.0})
    warned = corroborate(noted, [split])
    assert warned.suspect and warned.notes == () and len(warned.reasons) == 2
    assert f"nodes {a}" in warned.reasons[0] and f"node {a} might be two" in warned.reasons[1]
    assert warned.as_dict()["p_change"] == 1.0 and warned.as_dict()["unstable"] == [int(a)]
    alone = assess(0.2, 5, wrong, 10.0)
    assert alone.suspect and alone.reasons == noted.notes and alone.notes == ()
    # with a fixed check failing too (a plateau of 1) the chance of change is a reason again
    both = assess(0.2, 1, wrong, 10.0, WarningRule(change_alone=False))
    assert both.suspect and both.reasons[0] == noted.notes[0] and both.notes == ()


def test_evidence_that_cannot_tell_states_apart_is_warned():
    """Noisy distances: the merge at a threshold within the noise gives another partition
    on every part of the recording."""
    noisy, _, episode = walk_problem(noise=3.0)
    from vggc_cp.solvers.merge import congruence_merge

    labels, _ = congruence_merge(noisy, 2.2)
    res = resample(noisy, 2.2, labels, episode, folds=5)
    assert res.p_change > WarningRule().max_change and assess(0.0, 1, res, 5.0).suspect
    # the verdict was settled before the last re-run: drawing stopped early
    assert res.runs < WarningRule().runs


def test_resampling_is_deterministic_and_its_seed_only_moves_the_random_re_runs():
    problem, truth, episode = walk_problem("fruit-2x3", 120, noise=0.9)
    from vggc_cp.solvers.merge import congruence_merge

    labels, _ = congruence_merge(problem, 0.9)
    one = resample(problem, 0.9, labels, episode, 5, WarningRule(seed=3))
    assert one == resample(problem, 0.9, labels, episode, 5, WarningRule(seed=3))
    # the folds come first and are the held-out prediction, whatever the seed
    other = resample(problem, 0.9, labels, episode, 5, WarningRule(seed=4))
    assert one.heldout == other.heldout
    assert heldout_prediction(problem, 0.9, episode, 5) == one.heldout


def test_resampling_units_cut_a_long_walk_into_blocks():
    units, kind = resampling_units(np.zeros(10, dtype=int), 5)
    assert kind == "blocks" and units.tolist() == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4]
    eps = np.repeat(np.arange(6), 3)
    units, kind = resampling_units(eps, 5)
    assert kind == "episodes" and units is not None and np.array_equal(units, eps)
    problem, truth, _ = walk_problem(transitions=60)
    res = resample(problem, 0.5, truth, np.zeros(problem.n_obs, dtype=int), folds=5)
    assert res is not None and res.units == "blocks" and res.runs >= 5
    assert resample(problem, 0.5, truth, np.zeros(problem.n_obs, dtype=int), folds=0) is None


def test_partitions_compare_as_groupings_and_changed_nodes_are_named():
    a = np.array([0, 0, 1, 1, 2])
    assert same_partition(a, np.array([5, 5, 7, 7, 1]))
    assert not same_partition(a, np.array([0, 0, 0, 1, 2]))
    assert changed_nodes(a, np.array([0, 0, 1, 1, 1])).tolist() == [1, 2]   # 1 and 2 joined
    assert changed_nodes(a, np.array([0, 3, 1, 1, 2])).tolist() == [0]      # 0 split


def test_a_doubt_that_re_runs_change_and_the_actions_reject_flags_the_graph():
    from vggc_cp.solvers.confidence import Confidence
    from vggc_cp.solvers.doubt_checks import corroborate
    from vggc_cp.solvers.doubts import Doubt

    conf = Confidence("mdl", 0.1, 5, None, 10.0, False, (), 0.25, 20, 5, (3, 6))
    strong = Doubt("merge", (3, 6), ((1,), (2,)), {"dl_nats": -3.8})
    weak = Doubt("merge", (3, 6), ((1,), (2,)), {"dl_nats": -2.6})
    elsewhere = Doubt("merge", (1, 2), ((1,), (2,)), {"dl_nats": -9.0})
    flagged = corroborate(conf, [weak, elsewhere, strong])
    assert flagged.suspect and "nodes 3 and 6 might be one state" in flagged.reasons[0]
    assert "3.8 nats" in flagged.reasons[0] and "vggc-cp doubts" in flagged.reasons[0]
    assert corroborate(conf, [weak, elsewhere]) is conf
    stable = Confidence("mdl", 0.1, 5, None, 10.0, False, (), 0.0, 5, 0, ())
    assert corroborate(stable, [strong]) is stable   # no re-run changed it: images settle it


@pytest.mark.parametrize("settings", [{"max_change": 1.0}, {"max_change": -0.1},
                                      {"runs": -1}, {"seed": 1.5}, {"max_change": True},
                                      {"change_alone": 1}])
def test_a_wrong_warning_rule_names_its_field(settings):
    from vggc_cp.errors import VggcError

    with pytest.raises(VggcError, match=f"WarningRule field '{next(iter(settings))}'"):
        WarningRule(**settings)

def test_a_graph_of_one_render_a_node_is_warned_though_every_re_run_reproduces_it():
    """Noisy distances and a threshold below the noise: every observation its own node. Each
    re-run groups what it keeps the same way (all apart), but what it left out lies in nodes
    it never saw: a recording of the same kind would add nodes, so the graph changes."""
    noisy, _, episode = walk_problem(transitions=120, noise=0.5)
    from vggc_cp.solvers.merge import congruence_merge

    labels, _ = congruence_merge(noisy, 1e-6)
    assert len(np.unique(labels)) == noisy.n_obs
    res = resample(noisy, 1e-6, labels, episode, folds=5)
    assert res.changed == res.novel == res.runs and res.p_change == 1.0
    conf = assess(0.0, 1, res, 1.0)
    assert conf.suspect and "nodes the rest never shows" in conf.reasons[0]


def test_the_margin_is_judged_in_nats_over_the_whole_trace():
    # 0.005 nats a transition: 0.5 nats on 100 transitions (odds 1.6 to 1) is flagged,
    # 15 nats on 3,000 (odds e^15) is not; without the transitions it is not checked
    short = assess(0.005, 10, None, 10.0, transitions=100)
    assert short.suspect and any("margin 0.50 nats (< ln 20" in r for r in short.reasons)
    assert not assess(0.005, 10, None, 10.0, transitions=3000).suspect
    assert not assess(0.005, 10, None, 10.0).suspect
    assert not assess(0.005, 10, None, 10.0, WarningRule(fixed_checks=False),
                      transitions=100).suspect
    assert not assess(float("inf"), 10, None, 10.0, transitions=100).suspect


def test_contradicted_transitions_name_the_chosen_nodes_they_dispute():
    """A fold graph's node stands for the chosen node most of its kept observations are in;
    a contradicted transition whose predicted and observed chosen nodes differ names them."""
    from vggc_cp.solvers.heldout import disputed_pairs

    labels = np.array([0, 0, 1, 1, 2, 2, 3])
    kept = np.array([0, 1, 2, 3, 4])                  # 5 and 6 left out
    lab = np.array([7, 7, 8, 8, 8])                   # fold node 8: chosen 1 (2 of 3) and 2
    wrong = [(8, 5), (7, 6), (8, 2), (9, 5)]          # (fold node predicted, observed o')
    assert disputed_pairs(labels, kept, lab, wrong) == [(1, 2), (0, 3)]


def test_a_node_of_one_render_kept_apart_only_by_the_hands_colour_is_warned():
    """Node 1 has one render; the images put it within the threshold of node 0, the actions
    favour the join by 15 nats, and only the hand's colour (read from the images) forbids it:
    warned, naming node 1. Each condition alone missing: quiet."""
    from vggc_cp.solvers.confidence import Confidence
    from vggc_cp.solvers.doubt_checks import doubt_forbidden
    from vggc_cp.solvers.doubts import Doubt

    quiet = Confidence("mdl", 1.0, 5, None, 4.0, False, ())
    labels = np.array([0, 0, 2, 0, 1, 2])
    base = {"forbidden": "hand", "steps": -0.5, "dl_nats": -15.0}
    warned = doubt_forbidden(quiet, [Doubt("merge", (0, 1), ((0, 1), (4,)), base)], labels)
    assert warned.suspect and "node 1 (1 observation(s))" in warned.reasons[0]
    for change in ({"forbidden": None}, {"steps": 0.4}, {"dl_nats": -2.0}):
        d = Doubt("merge", (0, 1), ((0, 1), (4,)), {**base, **change})
        assert not doubt_forbidden(quiet, [d], labels).suspect, change
    big = np.array([0, 0, 2, 0, 1, 1, 1])                            # three renders of 1
    assert not doubt_forbidden(quiet, [Doubt("merge", (0, 1), ((0,), (4,)), base)], big).suspect


def test_a_hand_colour_from_actions_seen_often_does_not_warn():
    """Given the problem's transitions: the node of one render is entered by an action the
    trace takes three times -- its colour comes from three looks, which one misread look does
    not set: quiet. Entered by an action taken once: warned, as without the transitions."""
    from types import SimpleNamespace

    from vggc_cp.solvers.confidence import Confidence
    from vggc_cp.solvers.doubt_checks import doubt_forbidden
    from vggc_cp.solvers.doubts import Doubt

    quiet = Confidence("mdl", 1.0, 5, None, 4.0, False, ())
    labels = np.array([0, 0, 2, 0, 1, 2, 3, 2, 3, 2])
    d = Doubt("merge", (0, 1), ((0, 1), (4,)),
              {"forbidden": "hand", "steps": -0.5, "dl_nats": -15.0})

    def problem(into_1):  # transitions 2->3, 5->4 (into node 1), 7->6 ... by action
        return SimpleNamespace(src=np.array([2, 5, 7, 9]), act=np.array([0, into_1, 0, 0]),
                               dst=np.array([3, 4, 6, 8]), action_names=("a", "b"))

    assert not doubt_forbidden(quiet, [d], labels, problem=problem(0)).suspect
    assert doubt_forbidden(quiet, [d], labels, problem=problem(1)).suspect
    assert doubt_forbidden(quiet, [d], labels).suspect


def test_a_join_exactly_one_forbids_but_images_and_actions_favour_is_warned():
    """Whatever the nodes' sizes: another decision conflicts with the images and the
    actions there. Images against it (steps > 0) or actions not strongly for it: quiet."""
    from vggc_cp.solvers.confidence import Confidence
    from vggc_cp.solvers.doubt_checks import doubt_forbidden
    from vggc_cp.solvers.doubts import Doubt

    quiet = Confidence("mdl", 1.0, 5, None, 4.0, False, ())
    labels = np.array([0, 0, 0, 1, 1, 1])
    base = {"forbidden": "exactly_one", "steps": -0.7, "dl_nats": -10.6}
    warned = doubt_forbidden(quiet, [Doubt("merge", (0, 1), ((0,), (3,)), base)], labels)
    assert warned.suspect and "Exactly-One forbids" in warned.reasons[0]
    for change in ({"steps": 0.1}, {"dl_nats": -2.9}, {"forbidden": None}):
        d = Doubt("merge", (0, 1), ((0,), (3,)), {**base, **change})
        assert not doubt_forbidden(quiet, [d], labels).suspect, change


def test_readings_that_are_surely_right_settle_a_tie_in_the_margin():
    """A tie of the actions (one pick node or two) that the images read apart: judged on
    200 stated frames at kappa 1.0 the reading is surely right (lower bound >= 0.9) and its
    code is part of the margin, beyond ln 20 for enough frames read apart; judged on four
    stated frames, or on none, it adds nothing and the margin stays the actions'."""
    from types import SimpleNamespace

    from vggc_cp.solvers.base import Readings, SiteReads
    from vggc_cp.solvers.mdl import TIE_NATS, sure_reading_gap, surely_trusted_readings

    def problem(n_stated, n_read=24):
        held = np.array([[0], [1]] * (n_stated // 2) + [[1]] * (n_read // 2)
                        + [[2]] * (n_read // 2))
        stated = np.array([[True]] * n_stated + [[False]] * n_read)
        sites = SiteReads(held, stated, np.array([1.0]), np.array([0]))
        return SimpleNamespace(readings=Readings.from_rows(np.zeros((len(held), 1)), sites))

    n = 200 + 24
    apart = np.r_[np.zeros(200, int), np.ones(12, int), np.full(12, 2)]
    together = np.r_[np.zeros(200, int), np.ones(24, int)]
    assert sure_reading_gap(problem(200), apart, together) > TIE_NATS
    assert sure_reading_gap(problem(200), apart, apart) == 0.0
    assert sure_reading_gap(problem(200), apart, None) == 0.0      # no graph at a threshold
    assert sure_reading_gap(problem(4), apart[196:], together[196:]) == 0.0
    assert surely_trusted_readings(problem(4).readings) is None
    unjudged = problem(0)
    assert surely_trusted_readings(unjudged.readings) is None
    assert len(apart) == len(together) == n
