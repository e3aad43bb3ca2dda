"""The (k_pick, k_place) sweep, the default grid and the selection registry."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import TOY_NAMES, make_trace
from hypothesis import given, settings
from test_greedy import image_distances, random_traces, state_distances, two_by_three_trace

from vggc_cp.errors import UnknownNameError, VggcError
from vggc_cp.graph import check
from vggc_cp.solvers import FEASIBLE, UNKNOWN, Problem, SolveResult
from vggc_cp.solvers.greedy import GreedySolver
from vggc_cp.solvers.sweep import (
    SELECTIONS,
    Sweep,
    action_counts,
    default_grid,
    get_selection,
    parse_range,
    register_selection,
    run_sweep,
    select_fewest,
)


def fake(k_pick, k_place, n_nodes, J, status=FEASIBLE):
    labels = None if n_nodes is None else np.arange(n_nodes)
    return SolveResult(labels, k_pick, k_place, float("nan") if J is None else J, status,
                       "fake")


def test_fewest_picks_fewest_nodes_then_lowest_J():
    results = [fake(2, 4, 6, 0.9), fake(3, 3, 6, 0.5), fake(4, 4, 8, 0.1),
               fake(1, 1, None, None, UNKNOWN), fake(5, 1, 7, 0.0)]
    assert select_fewest(results) == 1
    assert get_selection("fewest") is select_fewest
    assert select_fewest([fake(1, 1, None, None, UNKNOWN)]) is None
    # equal nodes and J: the smaller cell wins
    assert select_fewest([fake(4, 4, 6, 0.5), fake(3, 3, 6, 0.5)]) == 1


def test_unknown_selection_lists_the_known_ones():
    with pytest.raises(UnknownNameError, match="fewest"):
        get_selection("prettiest")


def test_register_selection_adds_a_rule():
    name = "test-most-nodes"
    try:
        @register_selection(name)
        def most(results, problem=None):
            found = [i for i, r in enumerate(results) if r.found]
            return max(found, key=lambda i: results[i].n_nodes) if found else None

        assert get_selection(name)([fake(1, 1, 2, 0.0), fake(2, 2, 4, 0.0)], None) == 1
    finally:
        SELECTIONS.pop(name, None)


def test_parse_range():
    assert parse_range("2:20") == range(2, 21)
    assert parse_range("3") == range(3, 4)
    for bad in ("0:3", "5:2", "a:b", "1:2:3", ""):
        with pytest.raises(VggcError):
            parse_range(bad, "--k-pick")


@settings(max_examples=40, deadline=None)
@given(trace=random_traces())
def test_default_grid_holds_the_always_feasible_cell(trace):
    problem = Problem.from_trace(trace, *state_distances(trace, 0.1, 0))
    kp, kq = default_grid(problem)
    a_pick, a_place = action_counts(problem)
    assert len(kp) >= 1 and len(kq) >= 1
    assert min(problem.n_pick, max(a_place, 1)) in kp
    assert min(problem.n_place, max(a_pick, 1)) in kq
    # the rows and columns left out below the grid hold only cells the bound proves infeasible
    need = max(a_pick, a_place, 1)
    assert (kp.start - 1) * (kq.stop - 1) < need
    assert (kq.start - 1) * (kp.stop - 1) < need


@settings(max_examples=25, deadline=None)
@given(trace=random_traces())
def test_no_colouring_below_the_action_lower_bound(trace):
    problem = Problem.from_trace(trace, *state_distances(trace, 0.1, 1))
    need = max(action_counts(problem))
    sweep = run_sweep(problem, GreedySolver(), range(1, 5), range(1, 5))
    for r in sweep.results:
        if r.k_pick * r.k_place < need:
            assert not r.found
        if r.found:
            assert check(problem.graph(r.labels)).ok


def toy_problem(toy_trace):
    return Problem.from_trace(toy_trace, *image_distances(toy_trace))


def test_sweep_keeps_every_cell_and_selects(toy_trace):
    problem = toy_problem(toy_trace)
    sweep = run_sweep(problem, GreedySolver(), range(1, 4), range(1, 3))
    assert isinstance(sweep, Sweep)
    assert [(r.k_pick, r.k_place) for r in sweep.results] == \
        [(a, b) for a in range(1, 4) for b in range(1, 3)]
    best = sweep.best
    assert best is not None and (best.k_pick, best.k_place) == (2, 1)
    assert best.n_nodes == 3 and sweep.rule == "fewest" and sweep.solver == "greedy"
    assert sweep.cell(2, 1) is best
    with pytest.raises(KeyError):
        sweep.cell(9, 9)
    table = sweep.table()
    assert list(table.columns[:6]) == ["k_pick", "k_place", "feasible", "status", "J", "seconds"]
    assert table["selected"].sum() == 1 and len(table) == 6
    records = sweep.records()
    assert all({"k_pick", "k_place", "status", "J", "seconds", "nodes"} <= set(r)
               for r in records)
    kp, kq, J = sweep.j_matrix()
    assert kp == [1, 2, 3] and kq == [1, 2] and J.shape == (3, 2)
    assert np.isnan(J[0, 0]) and J[1, 0] == best.J


def test_sweep_jobs_2_equals_jobs_1():
    trace = two_by_three_trace(noise=30, seed=1)
    problem = Problem.from_trace(trace, *image_distances(trace))
    a = run_sweep(problem, GreedySolver(), range(2, 5), range(2, 5), jobs=1)
    b = run_sweep(problem, GreedySolver(), range(2, 5), range(2, 5), jobs=2)
    assert a.selected == b.selected and b.jobs == 2
    for x, y in zip(a.results, b.results):
        assert (x.k_pick, x.k_place, x.status) == (y.k_pick, y.k_place, y.status)
        if x.found:
            np.testing.assert_array_equal(x.labels, y.labels)
            assert x.J == y.J


def test_two_by_three_selects_the_true_three_by_three():
    # (2,4) and (4,2) colourings also have 6 nodes; the visual score must choose (3,3)
    trace = two_by_three_trace()
    problem = Problem.from_trace(trace, *image_distances(trace))
    sweep = run_sweep(problem, GreedySolver(), range(1, 7), range(1, 7))
    best = sweep.best
    assert (best.k_pick, best.k_place, best.n_nodes) == (3, 3, 6)
    same = best.labels[:, None] == best.labels[None, :]
    np.testing.assert_array_equal(same, trace.states[:, None] == trace.states[None, :])


def test_sweep_refuses_bad_arguments(toy_trace):
    problem = toy_problem(toy_trace)
    with pytest.raises(VggcError, match="empty"):
        run_sweep(problem, GreedySolver(), range(1, 1), range(1, 3))
    with pytest.raises(VggcError, match="jobs"):
        run_sweep(problem, GreedySolver(), range(1, 2), range(1, 2), jobs=0)
    with pytest.raises(UnknownNameError):
        run_sweep(problem, GreedySolver(), range(1, 2), range(1, 2), select="nope")


def test_action_counts():
    trace = make_trace([["L", "pick_L", "H", "place_R", "R"]], TOY_NAMES)
    problem = Problem.from_trace(trace, np.zeros((2, 2)), np.zeros((1, 1)))
    assert action_counts(problem) == (1, 1)


def _fabricated_sweep(kp, kq) -> Sweep:
    """A grid whose cells have a colouring (J = k_pick + k_place / 100) when k_place >= 3."""
    results = tuple(SolveResult(np.zeros(1, dtype=np.int64) if b >= 3 else None, a, b,
                                a + b / 100 if b >= 3 else float("nan"),
                                FEASIBLE if b >= 3 else UNKNOWN, "greedy", 0.0, None, {})
                    for a in kp for b in kq)
    return Sweep(results, 1, "fewest", "greedy", 0.0, 1)


def test_pivot_text_fits_120_characters_and_keeps_every_cell():
    small = _fabricated_sweep(range(2, 5), range(2, 6))
    assert small.pivot_text() == small.pivot().to_markdown(stralign="right",
                                                           disable_numparse=True)
    big = _fabricated_sweep(range(2, 21), range(2, 21))
    text = big.pivot_text()
    assert max(map(len, text.splitlines())) <= 120
    assert max(map(len, big.pivot().to_markdown().splitlines())) > 120
    blocks = text.split("\n\n")
    assert len(blocks) == 2
    headers = [b.splitlines()[0].split("|")[2:-1] for b in blocks]
    assert [int(h) for hs in headers for h in hs] == list(range(2, 21))  # each column once
    for block in blocks:  # every block has every k_pick row
        assert [int(line.split("|")[1]) for line in block.splitlines()[2:]] == list(range(2, 21))
    assert "2.030*" in blocks[0] and "20.200" in blocks[1]
