"""One selection registry and one solver protocol for the grid solvers and merge."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fruit_episode, make_trace
from test_merge import NAMES, problem_with_distances

from vggc_cp.errors import UnknownNameError
from vggc_cp.solvers import SOLVERS, get_solver
from vggc_cp.solvers.merge import PATH_SELECTIONS, select_cascade, threshold_path
from vggc_cp.solvers.selection import (
    AXES,
    GRID,
    PATH,
    RULES,
    get_selection,
    register_selection,
    select_fewest,
)
from vggc_cp.solvers.sweep import SELECTIONS


def _problem():
    rng = np.random.default_rng(1)
    trace = make_trace([fruit_episode(rng, 6) for _ in range(4)], NAMES)
    return problem_with_distances(trace, noise=0.05, between=0.5)


def test_every_solver_runs_along_an_axis_that_has_rules():
    assert sorted(SOLVERS) == ["brute", "cpsat", "greedy", "merge"]
    axes = {name: cls.axis for name, cls in SOLVERS.items()}
    assert axes == {"brute": GRID, "cpsat": GRID, "greedy": GRID, "merge": PATH}
    assert all(RULES[axis] for axis in AXES)


def test_the_select_names_of_both_axes_are_those_of_the_cli():
    assert sorted(RULES[GRID]) == ["fewest"] and SELECTIONS is RULES[GRID]
    assert sorted(RULES[PATH]) == ["cascade", "fewest", "mdl"] and PATH_SELECTIONS is RULES[PATH]
    assert get_selection("fewest") is select_fewest
    assert get_selection("cascade", PATH) is select_cascade


def test_a_rule_of_one_axis_is_unknown_on_the_other():
    with pytest.raises(UnknownNameError, match="fewest"):
        get_selection("cascade")  # a path rule, not a grid one
    with pytest.raises(UnknownNameError, match="path selection rule"):
        threshold_path(_problem(), [0.1], rule="prettiest")
    with pytest.raises(UnknownNameError, match="grid"):
        register_selection("x", axis="diagonal")


def test_a_path_rule_registered_once_selects_on_the_threshold_path():
    name = "test-last"
    try:
        @register_selection(name, PATH)
        def last(results, problem=None):
            return len(results) - 1 if results else None

        path = threshold_path(_problem(), [0.0, 0.1, 0.3], rule=name)
        assert path.selected == 2 and path.rule == name
    finally:
        RULES[PATH].pop(name, None)


def test_merge_follows_the_protocol_and_reports_the_colours_it_used():
    problem = _problem()
    small = get_solver("merge", threshold=0.1).solve(problem, 1, 1)
    large = get_solver("merge", threshold=0.1).solve(problem, 50, 50)
    assert np.array_equal(small.labels, large.labels) and small.seconds > 0
    pick = len(np.unique(small.labels[problem.pick_obs]))
    place = len(np.unique(small.labels[problem.place_obs]))
    assert (small.k_pick, small.k_place) == (pick, place)
    assert small.n_nodes == pick + place
