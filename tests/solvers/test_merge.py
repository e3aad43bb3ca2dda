"""Congruence-closure merging: recovers states, respects constraints, vetoes bad closures."""

from __future__ import annotations

import numpy as np
from conftest import make_trace

from vggc_cp.graph import check
from vggc_cp.solvers import Problem, get_solver
from vggc_cp.solvers.merge import congruence_merge

NAMES = ("pick_1", "pick_2", "pick_3", "place_1", "place_2", "place_3")


def fruit_episode(rng, length):
    """One fruit, three regions: pick states '1','2','3' (fruit there), place state 'H'."""
    r = int(rng.integers(1, 4))
    ep = [str(r)]
    for _ in range(length):
        ep += [f"pick_{r}", "H"]
        r = int(rng.integers(1, 4))
        ep += [f"place_{r}", str(r)]
    return ep


def problem_with_distances(trace, noise, between, seed=0):
    rng = np.random.default_rng(seed)
    roles = trace.roles()
    mats = []
    for role in (0, 1):
        st = trace.states[roles == role]
        same = st[:, None] == st[None, :]
        d = np.where(same, rng.uniform(0, noise, same.shape), rng.uniform(between, 1, same.shape))
        d = np.triu(d, 1)
        mats.append(d + d.T)
    return Problem.from_trace(trace.without_states(), *mats)


def test_recovers_states_and_is_valid():
    rng = np.random.default_rng(1)
    trace = make_trace([fruit_episode(rng, 6) for _ in range(4)], NAMES)
    problem = problem_with_distances(trace, noise=0.05, between=0.5)
    labels, stats = congruence_merge(problem, threshold=0.1)
    graph = problem.graph(labels)
    report = check(graph)
    assert report.ok and report.deterministic
    # one node per state
    for s in set(trace.states):
        assert len(set(labels[trace.states == s])) == 1
    assert len(set(labels)) == len(set(trace.states))
    assert stats.accepted > 0


def test_threshold_zero_merges_nothing_and_solver_wraps_it():
    rng = np.random.default_rng(2)
    trace = make_trace([fruit_episode(rng, 3)], NAMES)
    problem = problem_with_distances(trace, noise=0.05, between=0.5)
    labels, stats = congruence_merge(problem, threshold=0.0)
    assert len(set(labels)) == trace.n_obs and stats.attempts == 0
    res = get_solver("merge", threshold=0.1).solve(problem, 0, 0)
    assert res.status == "feasible" and res.n_nodes == len(set(trace.states))
    assert res.J == problem.visual_score(res.labels)


def test_forced_merge_beyond_threshold_is_vetoed():
    # two pick observations look alike but lead by the same action to place observations that
    # look very different: determinism would force those together, so the merge is refused
    trace = make_trace([["A", "pick_1", "X"], ["B", "pick_1", "Y"]], NAMES)
    roles = trace.roles()
    assert roles.tolist() == [0, 1, 0, 1]
    dist_pick = np.array([[0, 0.01], [0.01, 0]])
    dist_place = np.array([[0, 0.9], [0.9, 0]])
    problem = Problem.from_trace(trace, dist_pick, dist_place)
    labels, stats = congruence_merge(problem, threshold=0.1)
    assert len(set(labels)) == 4 and stats.vetoed_distance == 1
    # with similar successors the closure merges both pairs
    problem = Problem.from_trace(trace, dist_pick, np.array([[0, 0.05], [0.05, 0]]))
    labels, _ = congruence_merge(problem, threshold=0.1)
    assert len(set(labels)) == 2


def test_exactly_one_veto():
    # A -pick_1-> X and B -pick_2-> Y, everything alike: A and B merge first (different
    # actions force nothing); merging X and Y then would put pick_1 and pick_2 between one
    # ordered pair of nodes, which Exactly-One forbids
    trace = make_trace([["A", "pick_1", "X"], ["B", "pick_2", "Y"]], NAMES)
    near = np.array([[0, 0.01], [0.01, 0]])
    problem = Problem.from_trace(trace, near, near)
    labels, stats = congruence_merge(problem, threshold=0.1)
    assert check(problem.graph(labels)).ok
    assert len(set(labels)) == 3 and stats.vetoed_exactly_one == 1
