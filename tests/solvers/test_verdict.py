"""The verdict stage (:mod:`vggc_cp.solvers.verdict`): the one place the chosen graph's doubts
are gathered and its confidence checked against them; ``learn_graph`` is that stage applied
to the evidence it chose. (Recorded facts the graph breaks, listed first and flagging it, are
tested end to end in ``test_broken_facts.py``; lone episodes in ``test_lone_episodes.py``.)"""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.pipeline import learn_graph
from vggc_cp.sim.explore import generate
from vggc_cp.solvers.base import FEASIBLE, SolveResult
from vggc_cp.solvers.merge import ThresholdPath
from vggc_cp.solvers.verdict import runner_up, verdict


@pytest.fixture(scope="module")
def learned():
    trace = generate("fruit-2x3", 40, seed=1, size=24).trace
    return trace, learn_graph(trace.without_states())


def test_learn_graph_is_the_verdict_on_the_chosen_graph(learned):
    trace, got = learned
    c = got.chosen
    conf, doubts = verdict(c.problem, c.path, c.best.labels, c.confidence,
                           c.description_lengths, trace.without_states())
    assert conf == got.confidence and doubts == got.doubts


def test_doubts_toward_the_runner_up_need_the_description_lengths(learned):
    from vggc_cp.solvers.verdict import graph_doubts

    c = learned[1].chosen
    with pytest.raises(ValueError, match="toward_runner_up needs dls"):
        graph_doubts(c.problem, c.path, c.best.labels, toward_runner_up=True)
    assert isinstance(graph_doubts(c.problem, c.path, c.best.labels, c.description_lengths,
                                   toward_runner_up=True), tuple)


def test_runner_up_is_the_least_description_length_of_another_size():
    def result(n):
        return SolveResult(np.arange(8) % n, n, n, 0.0, FEASIBLE, "merge")

    path = ThresholdPath((0.1, 0.2, 0.3, 0.4), (result(4), result(4), result(3), result(2)),
                         1, "mdl", 0.0)
    assert runner_up(path, [9.0, 5.0, 7.0, 6.0]) == 3          # the least of sizes 3 and 2
    assert runner_up(path, [9.0, 5.0, 6.0, 6.0]) == 2          # a tie: the nearer on the path
    flat = ThresholdPath((0.1, 0.2), (result(4), result(4)), 0, "mdl", 0.0)
    assert runner_up(flat, [1.0, 2.0]) is None
