"""The default path rule, ``stable-mdl`` (vggc_cp.solvers.stable_mdl): the least description
length among the graphs that hold for several thresholds, and the margin's runner-up."""

from __future__ import annotations

import numpy as np
import pytest
from test_selection_confidence import result, walk_problem

from vggc_cp.solvers.confidence import FIXED_CHECKS, fixed_check_reasons
from vggc_cp.solvers.mdl import description_length, select_mdl
from vggc_cp.solvers.selection import PATH, get_selection
from vggc_cp.solvers.stable_mdl import (
    MIN_PLATEAU,
    eligible,
    runner_up,
    select_stable_mdl,
    stable_indices,
)


@pytest.fixture(scope="module")
def collapse():
    """fruit-4x6 walked 150 transitions (33 states): a path that holds the true graph for
    three thresholds and then collapses to one node per role, which the description length
    (it codes the actions, not the observations) finds shorter."""
    problem, truth, _ = walk_problem("fruit-4x6", 150)
    merged = problem.labels_from_colours(np.zeros(problem.n_pick, int),
                                         np.zeros(problem.n_place, int))
    unmerged = np.arange(problem.n_obs)
    path = [result(unmerged), result(truth), result(truth), result(truth), result(merged)]
    return problem, path


def test_the_collapse_is_shorter_and_mdl_takes_it(collapse):
    problem, path = collapse
    dls = [description_length(problem, r.labels) for r in path]
    assert dls[4] < dls[1] < dls[0]  # what the rule is for: the collapse codes the actions shorter
    assert select_mdl(path, problem) == 4


def test_stable_mdl_takes_the_stable_graph_and_its_margin_reads_the_collapse(collapse):
    problem, path = collapse
    assert MIN_PLATEAU == FIXED_CHECKS["min_plateau"] == 3
    assert stable_indices([r.labels for r in path]) == [1, 2, 3] == eligible(path)
    assert get_selection("stable-mdl", PATH) is select_stable_mdl
    assert select_stable_mdl(path, problem) == 1
    dls = [description_length(problem, r.labels) for r in path]
    # the runner-up of the margin: the shorter transient graph, not only the eligible ones
    assert runner_up(path, dls, 1, select_stable_mdl) == 4
    margin = dls[4] - dls[1]
    assert margin < 0
    (reason,) = [r for r in fixed_check_reasons(margin, 3, None, 10.0) if "margin" in r]
    assert "holds for fewer than 3 thresholds" in reason and "shorter" in reason
    # under plain mdl the collapse is chosen and the true graph is its runner-up (the nearest
    # of its equal copies), at a positive margin
    assert runner_up(path, dls, 4, select_mdl) == 3 and dls[3] > dls[4]


def test_without_a_stable_graph_every_graph_is_eligible(collapse):
    problem, path = collapse
    short = [path[0], path[1], path[4]]  # every graph holds for one threshold
    assert eligible(short) == [0, 1, 2]
    assert select_stable_mdl(short, problem) == select_mdl(short, problem) == 2
    assert select_stable_mdl([], problem) is None
    with pytest.raises(ValueError, match="needs the problem"):
        select_stable_mdl(short)


def test_the_runner_up_is_of_another_size_and_none_without_one(collapse):
    problem, path = collapse
    same = [path[1], path[2], path[3]]
    dls = [description_length(problem, r.labels) for r in same]
    assert runner_up(same, dls, 0, select_stable_mdl) is None
    dls = [description_length(problem, r.labels) for r in path]
    # from the unmerged graph (a rule that chose it): every other size is eligible
    assert runner_up(path, dls, 0, select_mdl) == 4
    # the unmerged graph is neither eligible under stable-mdl nor shorter: no runner-up; a
    # rule without an eligible set measures the margin to it
    stable_only = path[:4]
    assert runner_up(stable_only, dls[:4], 1, select_stable_mdl) is None
    assert runner_up(stable_only, dls[:4], 1, select_mdl) == 0
