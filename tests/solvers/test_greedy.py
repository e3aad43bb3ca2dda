"""The paper's three-stage vision-guided DSATUR (``vggc_cp.solvers.greedy``)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import TOY_NAMES, make_trace
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from vggc_cp.errors import UnknownNameError, VggcError
from vggc_cp.graph import TaskGraph, check
from vggc_cp.solvers import FEASIBLE, UNKNOWN, Problem, get_solver
from vggc_cp.solvers.greedy import (
    GreedySolver,
    SideLinks,
    conflict_clique,
    conflict_degree,
    default_tau,
    seed_colours,
)
from vggc_cp.trace import PICK, PLACE, Trace

# ---------------------------------------------------------------- random worlds and traces


def state_distances(trace: Trace, noise: float, seed: int, scale: float = 1.0):
    """Synthetic within-role distances from the hidden states (the solver never sees states).

    Same state: ``noise``-sized; different states: ``scale`` times the distance between random
    state embeddings, plus noise. Returns ``(dist_pick, dist_place)``.
    """
    rng = np.random.default_rng(seed)
    roles = trace.roles()
    uniq = sorted(set(trace.states))
    emb = {s: rng.normal(size=4) for s in uniq}
    out = []
    for r in (PICK, PLACE):
        s = trace.states[roles == r]
        x = np.stack([emb[v] for v in s]) if len(s) else np.zeros((0, 4))
        d = scale * np.linalg.norm(x[:, None] - x[None], axis=2)
        e = rng.uniform(0, noise, d.shape)
        d = d + (e + e.T) / 2
        np.fill_diagonal(d, 0.0)
        out.append(d)
    return out[0], out[1]


@st.composite
def random_traces(draw, max_states: int = 4, max_actions: int = 3):
    """A valid trace from random deterministic pick/place dynamics (states are hidden truth)."""
    n_ps = draw(st.integers(1, max_states))
    n_qs = draw(st.integers(1, max_states))
    n_pa = draw(st.integers(1, max_actions))
    n_qa = draw(st.integers(1, max_actions))
    pick_next = draw(st.lists(st.lists(st.integers(0, n_qs - 1), min_size=n_pa, max_size=n_pa),
                              min_size=n_ps, max_size=n_ps))
    place_next = draw(st.lists(st.lists(st.integers(0, n_ps - 1), min_size=n_qa, max_size=n_qa),
                               min_size=n_qs, max_size=n_qs))
    names = tuple([f"pick_{a}" for a in range(n_pa)] + [f"place_{a}" for a in range(n_qa)])
    episodes = []
    for _ in range(draw(st.integers(1, 4))):
        pick_side = draw(st.booleans())
        state = draw(st.integers(0, (n_ps if pick_side else n_qs) - 1))
        ep = [f"P{state}" if pick_side else f"Q{state}"]
        for _ in range(draw(st.integers(1, 8))):
            if pick_side:
                a = draw(st.integers(0, n_pa - 1))
                state = pick_next[state][a]
                ep += [f"pick_{a}", f"Q{state}"]
            else:
                a = draw(st.integers(0, n_qa - 1))
                state = place_next[state][a]
                ep += [f"place_{a}", f"P{state}"]
            pick_side = not pick_side
        episodes.append(ep)
    return make_trace(episodes, names, size=2)


def assert_valid(problem: Problem, result, k_pick: int, k_place: int) -> None:
    """What every colouring must satisfy (graph.check is the one checker)."""
    labels = result.labels
    assert labels.shape == (problem.n_obs,)
    assert labels.min() >= 0
    graph = problem.graph(labels)
    report = check(graph)
    assert report.ok, str(report)
    roles = problem.roles
    assert len(np.unique(labels[roles == PICK])) <= k_pick
    assert len(np.unique(labels[roles == PLACE])) <= k_place
    assert not set(labels[roles == PICK]) & set(labels[roles == PLACE])
    # the edges are exactly those the transitions induce
    induced = {(int(labels[s]), int(a), int(labels[d]))
               for s, a, d in zip(problem.src, problem.act, problem.dst)}
    assert set(graph.edges) == induced
    assert result.J == pytest.approx(problem.visual_score(labels))


# ---------------------------------------------------------------- properties


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trace=random_traces(), noise=st.sampled_from([0.0, 0.05, 0.5]),
       seed=st.integers(0, 2**16), k_pick=st.integers(1, 5), k_place=st.integers(1, 5))
def test_every_colouring_passes_the_checker(trace, noise, seed, k_pick, k_place):
    problem = Problem.from_trace(trace, *state_distances(trace, noise, seed))
    res = GreedySolver().solve(problem, k_pick, k_place)
    assert res.status in (FEASIBLE, UNKNOWN)
    assert res.seconds >= 0
    if res.found:
        assert res.status == FEASIBLE
        assert_valid(problem, res, k_pick, k_place)
    else:
        assert res.status == UNKNOWN and np.isnan(res.J)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trace=random_traces(), seed=st.integers(0, 2**16))
def test_the_true_cell_has_a_colouring_when_vision_is_clean(trace, seed):
    # distinct states far apart, identical images within a state: the cell of the true sizes
    # (a valid colouring exists there: the truth) is solved
    problem = Problem.from_trace(trace, *state_distances(trace, 0.0, seed, scale=10.0))
    roles = trace.roles()
    truth = np.unique(trace.states, return_inverse=True)[1].reshape(-1)
    assume(check(problem.graph(truth)).ok)  # random dynamics may break Exactly-One themselves
    kp = len(set(trace.states[roles == PICK]))
    kq = len(set(trace.states[roles == PLACE]))
    res = GreedySolver().solve(problem, kp, kq)
    assert res.found
    assert_valid(problem, res, kp, kq)


@settings(max_examples=30, deadline=None)
@given(trace=random_traces(), seed=st.integers(0, 2**16))
def test_states_removed_gives_the_identical_solution(trace, seed):
    dist = state_distances(trace, 0.1, seed)
    a = GreedySolver().solve(Problem.from_trace(trace, *dist), 3, 3)
    b = GreedySolver().solve(Problem.from_trace(trace.without_states(), *dist), 3, 3)
    assert a.status == b.status
    if a.found:
        np.testing.assert_array_equal(a.labels, b.labels)
        assert a.J == b.J


@settings(max_examples=30, deadline=None)
@given(trace=random_traces())
def test_last_action_colouring_is_always_valid(trace):
    # the always-feasible cell of the default grid (see vggc_cp.solvers.sweep)
    src, act, dst = trace.transitions()
    colour = np.zeros(trace.n_obs, dtype=np.int64)
    colour[dst] = act + 1  # by the action that entered the observation; 0 at episode starts
    roles = trace.roles()
    labels = colour + np.where(roles == PLACE, 10_000, 0)
    graph = TaskGraph.from_labels(labels, roles, src, act, dst, trace.action_names)
    assert check(graph).ok


# ---------------------------------------------------------------- hand-built traces


def image_distances(trace: Trace):
    """Pixel L2 distances within each role (real, if crude, vision)."""
    roles = trace.roles()
    x = trace.observations.reshape(trace.n_obs, -1).astype(float)
    out = []
    for r in (PICK, PLACE):
        y = x[roles == r]
        out.append(np.linalg.norm(y[:, None] - y[None], axis=2))
    return out[0], out[1]


def test_recovers_the_toy_structure(toy_trace):
    # L --pick_L--> H --place_R--> R --pick_R--> H --place_L--> L: 2 pick nodes, 1 place node
    problem = Problem.from_trace(toy_trace, *image_distances(toy_trace))
    res = GreedySolver().solve(problem, 2, 1)
    assert res.status == FEASIBLE
    assert_valid(problem, res, 2, 1)
    truth = toy_trace.states
    for i in range(toy_trace.n_obs):
        for j in range(toy_trace.n_obs):
            assert (res.labels[i] == res.labels[j]) == (truth[i] == truth[j])
    assert res.J == 0.0


def two_by_three_trace(noise: int = 6, seed: int = 0) -> Trace:
    """Two identical objects on three regions (fruit-2x3 by hand): 3 pick, 3 place states.

    Pick states name the free region (``F0`` .. ``F2``), place states the two free regions
    while one object is held (``H01`` = regions 0 and 1 free).
    """
    rng = np.random.default_rng(seed)
    names = tuple([f"pick_{r}" for r in range(3)] + [f"place_{r}" for r in range(3)])
    episodes = []
    for _ in range(8):
        free = {int(rng.integers(3))}
        ep = [f"F{min(free)}"]
        for _ in range(int(rng.integers(3, 9))):
            occupied = sorted({0, 1, 2} - free)
            r = int(rng.choice(occupied))
            free = free | {r}
            ep += [f"pick_{r}", "H" + "".join(map(str, sorted(free)))]
            r = int(rng.choice(sorted(free)))
            free = free - {r}
            ep += [f"place_{r}", f"F{min(free)}"]
        episodes.append(ep)
    return make_trace(episodes, names, size=6, noise=noise, seed=seed)


def test_recovers_a_two_by_three_world_in_its_true_cell():
    trace = two_by_three_trace()
    problem = Problem.from_trace(trace, *image_distances(trace))
    res = GreedySolver().solve(problem, 3, 3)
    assert res.status == FEASIBLE
    assert_valid(problem, res, 3, 3)
    truth = trace.states
    same_label = res.labels[:, None] == res.labels[None, :]
    same_state = truth[:, None] == truth[None, :]
    np.testing.assert_array_equal(same_label, same_state)


# ---------------------------------------------------------------- parts


def test_default_tau_is_the_median_off_diagonal_distance():
    d = np.array([[0, 1, 2], [1, 0, 4], [2, 4, 0]], dtype=float)
    assert default_tau(d) == 2.0
    assert default_tau(np.zeros((3, 3))) == 1.0
    assert default_tau(np.zeros((1, 1))) == 1.0


def test_seed_colours_finds_separated_clusters_and_respects_k():
    rng = np.random.default_rng(0)
    centres = np.array([0.0, 10.0, 20.0])
    x = np.concatenate([c + rng.normal(0, 0.1, 5) for c in centres])
    aff = np.exp(-np.abs(x[:, None] - x[None, :]))
    colour = seed_colours(aff, 3)
    assert len(set(colour)) == 3
    for c in range(3):
        assert len(set(colour[c * 5:(c + 1) * 5])) == 1
    assert len(set(seed_colours(aff, 2))) == 2
    assert len(set(seed_colours(aff, 50))) == 15  # at most one colour per observation


def test_side_links_and_conflicts(toy_trace):
    problem = Problem.from_trace(toy_trace, *image_distances(toy_trace))
    place = SideLinks.of(problem, PLACE)
    # place observations 1, 3, 6 (local 0, 1, 2): entered by pick_L, pick_R, pick_R
    np.testing.assert_array_equal(place.in_act, [0, 1, 1])
    np.testing.assert_array_equal(place.out_act, [3, 2, 3])
    one_pick_colour = np.zeros(problem.n_pick, dtype=np.int64)
    in_col, out_col = place.signatures(one_pick_colour)
    # all three share the pick colour: 0 conflicts with 1 and 2 (entering), 1 with 0 and 2
    # (leaving by place_L vs place_R)
    deg = conflict_degree(in_col, place.in_act, out_col, place.out_act)
    np.testing.assert_array_equal(deg, [2, 2, 2])
    assert conflict_clique(in_col, place.in_act, out_col, place.out_act) == 3


def test_a_stage_below_its_clique_fails_without_search(toy_trace):
    problem = Problem.from_trace(toy_trace, *image_distances(toy_trace))
    res = GreedySolver().solve(problem, 1, 2)  # one pick colour forces 3 place colours
    assert res.status == UNKNOWN and not res.found
    assert res.stats["stage2"]["clique"] == 3 and res.stats["stage2"]["nodes"] == 0


def test_node_limit_is_reported():
    trace = two_by_three_trace(noise=60, seed=3)
    problem = Problem.from_trace(trace, *image_distances(trace))
    res = GreedySolver(node_limit=5).solve(problem, 3, 3)
    assert res.status == UNKNOWN
    assert res.stats["limit_hit"] == "nodes"


def test_open_when_stuck_is_plain_dsatur_and_still_valid():
    trace = two_by_three_trace()
    problem = Problem.from_trace(trace, *image_distances(trace))
    res = GreedySolver(open_when="stuck").solve(problem, 3, 3)
    if res.found:
        assert_valid(problem, res, 3, 3)


def test_registry_and_options():
    solver = get_solver("greedy", tau=0.5)
    assert isinstance(solver, GreedySolver) and solver.tau == 0.5
    with pytest.raises(UnknownNameError, match="greedy"):
        get_solver("no-such-solver")
    with pytest.raises(UnknownNameError, match="dissimilar"):
        GreedySolver(open_when="sometimes")
    for bad in (0.0, float("nan"), float("inf")):
        with pytest.raises(VggcError, match="--tau"):
            GreedySolver(tau=bad)
    with pytest.raises(ValueError):
        GreedySolver().solve(Problem.from_trace(
            make_trace([["L", "pick_L", "H"]], TOY_NAMES), np.zeros((1, 1)), np.zeros((1, 1))),
            0, 1)
