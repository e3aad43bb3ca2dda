"""The exact CP-SAT cell model against brute force, the task-graph checker and its hint."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vggc_cp.errors import VggcError
from vggc_cp.graph import check
from vggc_cp.solvers.base import FEASIBLE, INFEASIBLE, OPTIMAL, Problem
from vggc_cp.solvers.brute import (
    BruteSolver,
    CellConstraints,
    count_partitions,
    enumerate_cell,
    fit_colouring,
    restricted_growth_strings,
    split_colours,
    violations,
)
from vggc_cp.solvers.cpsat import (
    CpSatConfig,
    CpSatSolver,
    build_cell_model,
    enumerate_colourings,
    parse_cpsat_params,
)
from vggc_cp.trace import PICK, PLACE

FAST = "max_time_in_seconds:20,num_workers:1"


def chain_problem(episodes, action_names, dist=None, seed=0) -> Problem:
    """A :class:`Problem` from episodes of action names (observations are anonymous).

    ``episodes`` is a list of lists of action names; every episode starts with a pick.
    Distances are ``dist(role, i, j)`` or random in [0, 1).
    """
    names = tuple(action_names)
    roles, src, act, dst = [], [], [], []
    for ep in episodes:
        roles.append(PICK)
        for a in ep:
            src.append(len(roles) - 1)
            act.append(names.index(a))
            dst.append(len(roles))
            roles.append(PLACE if a.startswith("pick") else PICK)
    roles = np.array(roles, dtype=np.int8)
    rng = np.random.default_rng(seed)
    mats = []
    for r in (PICK, PLACE):
        n = int(np.count_nonzero(roles == r))
        if dist is None:
            d = rng.random((n, n))
            d = (d + d.T) / 2
        else:
            d = np.array([[dist(r, i, j) for j in range(n)] for i in range(n)], dtype=float)
        np.fill_diagonal(d, 0.0)
        mats.append(d)
    return Problem(roles, np.array(src), np.array(act), np.array(dst), names, mats[0], mats[1])


@st.composite
def tiny_problems(draw):
    """Random valid pick/place problems with at most 5 observations per role."""
    n_pa = draw(st.integers(1, 3))
    n_qa = draw(st.integers(1, 3))
    names = [f"pick_{i}" for i in range(n_pa)] + [f"place_{i}" for i in range(n_qa)]
    episodes = []
    n_pick = n_place = 0
    for _ in range(draw(st.integers(1, 4))):
        if n_pick >= 5 or n_place >= 5:
            break
        ep = []
        n_pick += 1
        for t in range(draw(st.integers(1, 5))):
            if t % 2 == 0:
                if n_place >= 5:
                    break
                ep.append(f"pick_{draw(st.integers(0, n_pa - 1))}")
                n_place += 1
            else:
                if n_pick >= 5:
                    break
                ep.append(f"place_{draw(st.integers(0, n_qa - 1))}")
                n_pick += 1
        episodes.append(ep)
    seed = draw(st.integers(0, 2**16))
    values = draw(st.sampled_from(["random", "levels"]))
    if values == "levels":  # coarse distances: many ties
        rng = np.random.default_rng(seed)
        table = rng.integers(0, 4, size=(2, 12, 12)) / 4.0
        problem = chain_problem(episodes, names,
                                lambda r, i, j: table[r][min(i, j), max(i, j)], seed)
    else:
        problem = chain_problem(episodes, names, None, seed)
    return problem


# ---------------------------------------------------------------- brute force itself


def test_restricted_growth_strings_count_partitions():
    for n in range(6):
        for k in range(5):
            strings = list(restricted_growth_strings(n, k))
            assert len(strings) == count_partitions(n, k)
            assert len(set(strings)) == len(strings)
            assert all(max(s, default=-1) < k for s in strings)


def test_violations_flag_exactly_one_and_determinism():
    p = chain_problem([["pick_0"], ["pick_1"]], ["pick_0", "pick_1", "place_0"])
    # both pick obs one colour, both place obs one colour: two labels on one pair
    assert violations(p, np.array([0, 0]), np.array([0, 0]))
    assert not violations(p, np.array([0, 0]), np.array([0, 1]))
    q = chain_problem([["pick_0"], ["pick_0"]], ["pick_0", "place_0"])
    assert not violations(q, np.array([0, 0]), np.array([0, 1]))
    assert violations(q, np.array([0, 0]), np.array([0, 1]), CellConstraints(deterministic=True))
    assert violations(p, np.array([0, 0]), np.array([0, 1]), CellConstraints(max_actions=1))


# ---------------------------------------------------------------- parameters


def test_parse_cpsat_params():
    text = parse_cpsat_params("max_time_in_seconds:30, num_workers:2")
    assert "max_time_in_seconds: 30" in text and "num_workers: 2" in text
    assert parse_cpsat_params("") == ""
    for bad in ("no_such_field:1", "num_workers:abc", "num_workers", "max_time_in_seconds:x"):
        with pytest.raises(VggcError, match="cpsat-params"):
            parse_cpsat_params(bad)
    with pytest.raises(VggcError):
        CpSatSolver(params="foo:1")
    with pytest.raises(VggcError):
        CpSatSolver(objective="median")
    with pytest.raises(VggcError):
        CpSatSolver(max_actions=0)


def test_user_params_override_defaults():
    opts = CpSatConfig(params="max_time_in_seconds:3")
    text = opts.sat_parameters_text()
    assert "max_time_in_seconds: 3" in text and "num_workers" in text


# ---------------------------------------------------------------- exactness


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tiny_problems(), st.integers(1, 3), st.integers(1, 3), st.booleans(),
       st.sampled_from([None, 1, 2]), st.booleans(), st.sampled_from([0, 20_000]))
@pytest.mark.slow
def test_cpsat_agrees_with_brute_force(problem, k_pick, k_place, deterministic, max_actions,
                                       symmetry, enumerate_limit):
    cons = CellConstraints(deterministic, max_actions)
    brute = enumerate_cell(problem, k_pick, k_place, cons)
    solver = CpSatSolver(deterministic=deterministic, max_actions=max_actions, params=FAST,
                         hint="none", symmetry=symmetry, enumerate_limit=enumerate_limit)
    res = solver.solve(problem, k_pick, k_place)
    enumerated = symmetry and enumerate_limit > 0
    assert (res.stats.get("method") == "enumeration") == enumerated
    if not brute.feasible:
        assert res.status == INFEASIBLE and not res.found
        return
    assert res.status == OPTIMAL, res.stats
    assert check(problem.graph(res.labels)).ok
    pc, qc = split_colours(problem, res.labels)
    assert pc.max() < k_pick and qc.max() < k_place
    assert not violations(problem, pc, qc, cons)
    margin = res.stats["quantization_margin"]
    assert brute.J - 1e-9 <= res.J <= brute.J + margin
    assert res.bound is not None and res.bound <= res.J + margin
    if enumerated:  # exact on the float J, no quantization
        assert res.J == pytest.approx(brute.J, abs=1e-9) and res.bound == res.J
        assert res.stats["enumerated"] == brute.n_valid


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tiny_problems(), st.integers(1, 3), st.integers(1, 3), st.booleans(),
       st.sampled_from([None, 1, 2]))
def test_enumeration_visits_each_valid_colouring_once(problem, k_pick, k_place, deterministic,
                                                      max_actions):
    """One model solution per valid colouring up to renaming: the counts of brute force."""
    cons = CellConstraints(deterministic, max_actions)
    brute = enumerate_cell(problem, k_pick, k_place, cons)
    opts = CpSatConfig(deterministic=deterministic, max_actions=max_actions)
    e = enumerate_colourings(problem, k_pick, k_place, opts, limit=10**6, max_seconds=20)
    assert e.complete and e.count == brute.n_valid
    if brute.feasible:
        assert e.J == pytest.approx(brute.J, abs=1e-9)
        assert not violations(problem, e.pick_colour, e.place_colour, cons)
        labels = problem.labels_from_colours(e.pick_colour, e.place_colour)
        assert problem.visual_score(labels) == pytest.approx(e.J, abs=1e-9)
    else:
        assert e.pick_colour is None and math.isnan(e.J)
    if brute.n_valid > 1:  # a limit below the count stops early
        short = enumerate_colourings(problem, k_pick, k_place, opts, limit=1, max_seconds=20)
        assert not short.complete and short.count == 1


@pytest.mark.slow
def test_incomplete_enumeration_hands_over_to_the_model():
    """Over the limit, the model optimizes, hinted by the best enumerated colouring."""
    p = chain_problem(EPISODES * 2, NAMES, seed=1)
    brute = enumerate_cell(p, 2, 3)
    assert brute.n_valid > 50
    res = CpSatSolver(params=FAST, hint="none", enumerate_limit=50).solve(p, 2, 3)
    assert res.stats["method"] == "cpsat" and res.stats["enumerated"] == 50
    assert res.stats["hint_source"] == "enumeration"
    assert res.J <= res.stats["hint_J"] + 1e-12
    assert res.status == OPTIMAL
    assert brute.J - 1e-9 <= res.J <= brute.J + res.stats["quantization_margin"]
    full = CpSatSolver(params=FAST, hint="none").solve(p, 2, 3)
    assert full.stats["method"] == "enumeration" and full.stats["enumerated"] == brute.n_valid
    assert full.J == pytest.approx(brute.J, abs=1e-12) and full.status == OPTIMAL


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tiny_problems(), st.integers(1, 3), st.integers(1, 3))
def test_feasibility_only_agrees_with_brute_force(problem, k_pick, k_place):
    brute = enumerate_cell(problem, k_pick, k_place)
    res = CpSatSolver(objective="none", params=FAST, hint="none").solve(problem, k_pick, k_place)
    assert res.found == brute.feasible
    assert res.status == (FEASIBLE if brute.feasible else INFEASIBLE)
    if res.found:
        assert check(problem.graph(res.labels)).ok
        assert res.bound is None


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tiny_problems(), st.integers(1, 3), st.integers(1, 3), st.booleans())
def test_hint_is_complete_and_consistent(problem, k_pick, k_place, deterministic):
    """Fixing every variable to its hinted value leaves a feasible model of the same objective."""
    cons = CellConstraints(deterministic=deterministic)
    valid = [(np.array(a), np.array(b))
             for a in restricted_growth_strings(problem.n_pick, k_pick)
             for b in restricted_growth_strings(problem.n_place, k_place)
             if not violations(problem, np.array(a), np.array(b), cons)]
    if not valid:
        return
    pc, qc = valid[len(valid) // 2]
    # scramble colour names: the hint must be renamed into value-precedence form
    pc = (pc + 1) % k_pick
    cm = build_cell_model(problem, k_pick, k_place, CpSatConfig(deterministic=deterministic))
    assert cm.model is not None
    values = cm.hint_assignment(pc, qc)
    assert len(values) == cm.n_variables
    from ortools.sat.python import cp_model

    for var, value in values.values():
        cm.model.add(var == value)
    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1
    code = solver.solve(cm.model)
    assert code == cp_model.OPTIMAL
    assert round(solver.objective_value) == cm.integer_objective(*cm.canonical(pc, qc))


# ---------------------------------------------------------------- hand-made cases

NAMES = ("pick_L", "pick_R", "place_L", "place_R")
#  L -pick_L-> H1 -place_R-> R -pick_R-> H2 -place_L-> L,   L -pick_L-> H3 -place_L-> L
EPISODES = [["pick_L", "place_R", "pick_R", "place_L"], ["pick_L", "place_L"]]


def test_infeasible_when_too_few_colours():
    p = chain_problem(EPISODES, NAMES)
    assert not enumerate_cell(p, 1, 2).feasible
    res = CpSatSolver(params=FAST, hint="none").solve(p, 1, 2)
    assert res.status == INFEASIBLE and not res.found
    assert res.stats["status_name"] == "PRESOLVE_INFEASIBLE"  # the conflict clique has 3 > 2
    # without the clique, CP-SAT's search proves it
    res = CpSatSolver(params=FAST, hint="none", symmetry=False).solve(p, 1, 2)
    assert res.status == INFEASIBLE and res.stats["status_name"] == "INFEASIBLE"
    assert res.stats["variables"] > 0 and res.stats["constraints"] > 0
    # one more place colour suffices
    res = CpSatSolver(params=FAST, hint="none").solve(p, 1, 3)
    assert res.status == OPTIMAL and check(p.graph(res.labels)).ok


def test_pair_capacity_presolve():
    names = [f"pick_{i}" for i in range(5)] + ["place_0"]
    p = chain_problem([[f"pick_{i}"] for i in range(5)], names)
    res = CpSatSolver(params=FAST, hint="none").solve(p, 2, 2)
    assert res.status == INFEASIBLE and "ordered colour pairs" in res.stats["notes"][-1]
    assert not enumerate_cell(p, 2, 2).feasible


def test_deterministic_excludes_nondeterministic_colouring():
    # two pick observations that look alike, both pick_0, followed by place observations
    # that look very different: the best colouring splits the place side (non-deterministic)
    def dist(role, i, j):
        return 0.0 if role == PICK else 1.0

    p = chain_problem([["pick_0"], ["pick_0"]], ["pick_0", "place_0"], dist)
    free = CpSatSolver(params=FAST, hint="none").solve(p, 1, 2)
    assert free.status == OPTIMAL
    report = check(p.graph(free.labels))
    assert report.ok and not report.deterministic and free.J == pytest.approx(0.0)
    det = CpSatSolver(params=FAST, hint="none", deterministic=True).solve(p, 1, 2)
    assert det.status == OPTIMAL
    report = check(p.graph(det.labels))
    assert report.ok and report.deterministic and det.J == pytest.approx(1.0)


def test_max_actions_bounds_action_variety():
    p = chain_problem([["pick_0"], ["pick_1"]], ["pick_0", "pick_1", "place_0"],
                      lambda r, i, j: 0.0 if r == PICK else 1.0)
    free = CpSatSolver(params=FAST, hint="none").solve(p, 1, 2)
    assert free.status == OPTIMAL
    res = CpSatSolver(params=FAST, hint="none", max_actions=1).solve(p, 1, 2)
    assert res.status == INFEASIBLE
    res = CpSatSolver(params=FAST, hint="none", max_actions=1).solve(p, 2, 2)
    assert res.status == OPTIMAL
    graph = p.graph(res.labels)
    for u in graph.nodes:
        assert len({a for a, _ in graph.successors(u)}) <= 1


def test_hint_floor_and_fallback():
    """The result is never worse than the hint, even when CP-SAT has no time to search."""
    p = chain_problem(EPISODES + [["pick_R", "place_R"]], NAMES, seed=3)
    best = BruteSolver().solve(p, 2, 2)
    assert best.status == OPTIMAL
    # a valid but poor hint: every observation its own colour is not allowed (k = 2), so take
    # the worst valid colouring of the cell
    worst = None
    for a in restricted_growth_strings(p.n_pick, 2):
        for b in restricted_growth_strings(p.n_place, 2):
            a_, b_ = np.array(a), np.array(b)
            if not violations(p, a_, b_):
                labels = p.labels_from_colours(a_, b_)
                J = p.visual_score(labels)
                if worst is None or J > worst[0]:
                    worst = (J, labels)
    solver = CpSatSolver(params=FAST, hint="none", enumerate_limit=0)
    res = solver.solve_hinted(p, 2, 2, [("worst", worst[1])])
    assert res.stats["hint_source"] == "worst" and res.stats["hint_J"] == pytest.approx(worst[0])
    assert res.J <= worst[0] + 1e-12
    assert res.J <= best.J + res.stats["quantization_margin"]
    # no search at all: the result is the hint itself, reported as feasible
    starved = CpSatSolver(params="max_time_in_seconds:0.0,num_workers:1", hint="none",
                          enumerate_limit=0)
    res = starved.solve_hinted(p, 2, 2, [("worst", worst[1])])
    assert res.found and res.J <= worst[0] + 1e-12
    assert res.status in (FEASIBLE, OPTIMAL)
    assert check(p.graph(res.labels)).ok
    # an invalid hint is rejected, not used
    bad = p.labels_from_colours(np.zeros(p.n_pick, int), np.zeros(p.n_place, int))
    res = solver.solve_hinted(p, 2, 2, [("bad", bad)])
    assert res.stats["hint_source"] is None and res.stats["hints_rejected"]


def test_large_models_drop_the_objective():
    p = chain_problem(EPISODES * 3, NAMES, seed=1)
    res = CpSatSolver(params=FAST, hint="none", max_pair_terms=10,
                      enumerate_limit=0).solve(p, 3, 3)
    assert res.status == FEASIBLE and res.bound is None
    assert res.stats["objective_mode"] == "none"
    assert any("objective dropped" in n for n in res.stats["notes"])
    assert check(p.graph(res.labels)).ok and math.isfinite(res.J)


def test_fit_colouring_squeezes_a_larger_cells_colouring():
    rng = np.random.default_rng(5)
    names = [f"pick_{r}" for r in (1, 2, 3)] + [f"place_{r}" for r in (1, 2, 3)]
    eps = [[names[int(rng.integers(3)) + 3 * (t % 2)] for t in range(4)] for _ in range(3)]
    problem = chain_problem(eps, names)
    own = np.arange(problem.n_obs)  # every observation its own node: valid in any big cell
    pc, qc, bad = fit_colouring(problem, own, problem.n_pick, problem.n_place)
    assert bad == 0 and len(set(pc)) == problem.n_pick  # nothing to merge
    for kp, kq in [(3, 3), (2, 2), (1, 3), (1, 1)]:
        pc, qc, bad = fit_colouring(problem, own, kp, kq)
        assert len(set(pc.tolist())) <= kp and len(set(qc.tolist())) <= kq
        assert bad == len(violations(problem, pc, qc))


@pytest.mark.parametrize("cell", [(1, 1), (1, 2), (2, 1), (2, 2), (3, 2), (2, 3)])
def test_repair_hint_never_changes_the_verdict(cell):
    """A colouring of the next larger cell, offered to a cell it does not fit, is only a start
    for CP-SAT: the verdict is the brute force's, and a found colouring passes the checker."""
    rng = np.random.default_rng(11)
    names = [f"pick_{r}" for r in (1, 2, 3)] + [f"place_{r}" for r in (1, 2, 3)]
    eps = [[names[int(rng.integers(3)) + 3 * (t % 2)] for t in range(4)] for _ in range(2)]
    problem = chain_problem(eps, names)
    larger = BruteSolver().solve(problem, cell[0] + 1, cell[1] + 1)
    assert larger.found
    truth = BruteSolver().solve(problem, *cell)
    res = CpSatSolver(objective="none", hint="none", params=FAST,
                      hints=[("larger cell", larger.labels)]).solve(problem, *cell)
    assert res.found == truth.found
    assert res.status in (FEASIBLE, INFEASIBLE)
    if res.found:
        assert check(problem.graph(res.labels)).ok
    if fit_colouring(problem, larger.labels, *cell)[2] > 0 and res.stats.get("variables"):
        assert "violated constraints" in res.stats["repair_hint"]


def test_a_far_away_hint_is_not_squeezed():
    rng = np.random.default_rng(11)
    names = [f"pick_{r}" for r in (1, 2, 3)] + [f"place_{r}" for r in (1, 2, 3)]
    eps = [[names[int(rng.integers(3)) + 3 * (t % 2)] for t in range(6)] for _ in range(3)]
    problem = chain_problem(eps, names)
    own = np.arange(problem.n_obs)  # every observation its own node: many merges from (3, 3)
    res = CpSatSolver(objective="none", hint="none", params=FAST,
                      hints=[("own nodes", own)]).solve(problem, 3, 3)
    assert "repair_hint" not in res.stats
    assert any("merges from the cell" in r for r in res.stats["hints_rejected"])


def test_exact_sweep_passes_offered_hints_to_its_feasibility_solves():
    from vggc_cp.solvers.cpsat import exact_sweep

    rng = np.random.default_rng(11)
    names = [f"pick_{r}" for r in (1, 2, 3)] + [f"place_{r}" for r in (1, 2, 3)]
    eps = [[names[int(rng.integers(3)) + 3 * (t % 2)] for t in range(4)] for _ in range(2)]
    problem = chain_problem(eps, names)
    larger = BruteSolver().solve(problem, 3, 3)
    solver = CpSatSolver(objective="none", params=FAST, hints=[("larger cell", larger.labels)])
    sweep = exact_sweep(problem, [2], [2], solver, greedy=())
    (res,) = sweep.results
    assert res.found == BruteSolver().solve(problem, 2, 2).found
    assert "larger cell" in res.stats.get("repair_hint", "")
