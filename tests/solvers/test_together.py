"""Colours never seen together (:mod:`vggc_cp.solvers.together`)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from vggc_cp.solvers.confidence import Confidence
from vggc_cp.solvers.together import doubt_never_together, never_together


def _problem(held, hand_place_colour=None):
    """A problem of one pick-role observation per row of ``held`` (no transitions, so no
    hand), with three action colours."""
    sites = SimpleNamespace(held=np.asarray(held))
    n = len(held)
    return SimpleNamespace(readings=SimpleNamespace(sites=sites),
                           action_colour=np.array([0, 1, 2]), roles=np.zeros(n, np.int8),
                           src=np.zeros(0, np.int64), act=np.zeros(0, np.int64),
                           dst=np.zeros(0, np.int64), n_obs=n)


def test_colours_shown_together_anywhere_are_not_a_pair():
    # every row shows colours 0 and 1 on some site: two classes, both present
    p = _problem([[1, 2, 0], [2, 1, 0], [1, 0, 2], [0, 1, 2]])
    assert never_together(p) == ()
    # colour 2 never shown: no pair either
    p = _problem([[1, 2], [2, 1]])
    assert never_together(p) == ()


def test_two_colours_never_shown_together_are_flagged():
    p = _problem([[1, 0], [1, 0], [0, 2], [0, 2], [3, 0]])
    assert never_together(p) == ((0, 1), (0, 2), (1, 2))
    conf = doubt_never_together(Confidence("mdl", 4.0, 5, None, 4.0, False, ()),
                                never_together(p))
    assert conf.suspect and "colours 0 and 1 are never seen together" in conf.reasons[0]
    assert "(and 2 more such pair(s))" in conf.reasons[0] and "suggest" in conf.reasons[0]


def test_a_problem_without_site_reads_or_colours_has_no_pair():
    assert never_together(SimpleNamespace(readings=None, action_colour=None)) == ()


@pytest.mark.slow  # PyBullet traces, learned twice
def test_one_class_in_two_looks_warns_and_names_the_split_states():
    """multifruit-2x3 clean s453, |D| = 95 (draw 53, silent before session 55): the
    recording falls into two parts that meet only in two states with the red object in
    the hand; the red shapes of the parts took two colours, each meeting state a node per
    part (14 nodes for 12). Warned now, and the doubts are exactly those splits; a
    recording of the task that moves every object (seed 0) stays quiet of it."""
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.sim.explore import generate

    trace = generate("multifruit-2x3", 95, seed=453, look="clean").trace
    learned = learn_graph(trace.without_states())
    assert len(set(learned.labels.tolist())) == 14
    assert learned.confidence.suspect
    assert any("never seen together" in r for r in learned.confidence.reasons)
    apart = [d for d in learned.doubts if "never_together" in d.evidence]
    assert len(apart) == 2
    for d in apart:
        u, v = d.nodes
        states = {str(s) for s in trace.states[np.isin(learned.labels, [u, v])]}
        assert len(states) == 1                 # each doubt joins one state's two nodes
    other = generate("multifruit-2x3", 95, seed=0, look="clean").trace
    learned = learn_graph(other.without_states())
    assert not any("never seen together" in r for r in learned.confidence.reasons)
