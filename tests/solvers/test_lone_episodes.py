"""Episodes none of whose nodes another episode visits (:mod:`vggc_cp.solvers.lone_episodes`)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import make_trace

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.confidence import Confidence
from vggc_cp.solvers.doubt_checks import doubt_lone, doubt_lone_starts
from vggc_cp.solvers.doubt_text import format_doubts
from vggc_cp.solvers.doubts import MERGE
from vggc_cp.solvers.episodes import (
    LONE_ALPHA,
    lone_episodes,
    lone_starts,
    poisson_tail,
)
from vggc_cp.solvers.lone_episodes import lone_doubts
from vggc_cp.solvers.merge import threshold_path

NAMES = ("pick_1", "place_1", "pick_2", "place_2")


def _problem(episodes):
    """The problem of ``episodes`` (lists of states and actions) whose images tell every
    state apart, its merge path and the labels of the true partition."""
    trace = make_trace(episodes, NAMES)
    src, act, dst = trace.transitions()
    states, roles = trace.states, trace.roles()
    apart = {r: 1.0 - (states[roles == r][:, None] == states[roles == r][None, :])
             for r in (0, 1)}
    problem = Problem(roles, src, act, dst, NAMES, apart[0], apart[1])
    _, labels = np.unique(states, return_inverse=True)
    return problem, threshold_path(problem, (0.1, 0.2), "mdl"), labels.astype(np.int64)


HOME = ["A", "pick_1", "HA", "place_1", "A", "pick_2", "HB", "place_2", "A"]


def test_poisson_tail_is_one_minus_the_sum_below_the_count():
    assert poisson_tail(0, 2.0) == 1.0
    assert poisson_tail(1, 2.0) == pytest.approx(1 - np.exp(-2.0))
    assert poisson_tail(3, 2.0) == pytest.approx(1 - np.exp(-2.0) * (1 + 2.0 + 2.0))


def test_one_long_walk_is_lone_by_chance():
    problem, _, labels = _problem([HOME + ["pick_1", "HA", "place_1", "A"]])
    lone = lone_episodes(problem, labels)
    assert len(lone.chains) == 1 and lone.share == 1.0
    assert lone.chance == pytest.approx(1 - np.exp(-1.0)) and not lone.doubtful
    assert not doubt_lone(Confidence("mdl", 0.0, 5, None, 4.0, False, ()), lone).suspect


def test_episodes_through_disjoint_parts_seen_twice_each_are_not_lone():
    problem, _, labels = _problem([["A", "pick_1", "HA"], ["A", "pick_1", "HA"],
                                   ["C", "pick_2", "HC"], ["C", "pick_2", "HC"]])
    lone = lone_episodes(problem, labels)
    assert lone.chains == () and lone.share == 0.0 and lone.chance == 1.0


def test_an_episode_read_as_states_of_its_own_is_a_doubt_and_its_walk_the_path_it_took():
    """Six episodes from 'A'; a seventh takes pick_1 then place_1 as the others do, but its
    images were read as states 'X' and 'HX' that nothing else visits (a misread: a swap, an
    arm over a site). One such episode among seven is unlikely by chance; walked from 'A',
    its actions are the path 'A' -pick_1-> 'HA' -place_1-> 'A' of the other episodes."""
    misread = ["X", "pick_1", "HX", "place_1", "X"]
    problem, path, labels = _problem([HOME] * 6 + [misread])
    lone = lone_episodes(problem, labels)
    (chain,) = lone.chains
    assert chain.tolist() == [30, 31, 32]
    assert lone.share == pytest.approx(2 / (6 * 3 + 2))
    assert lone.chance < LONE_ALPHA and lone.doubtful
    (d,) = lone_doubts(problem, path, labels, lone)
    a, ha = int(labels[0]), int(labels[1])
    assert d.kind == MERGE and d.nodes == (int(labels[30]), a)
    assert d.evidence["lone_episode"] == [30, 32] and d.evidence["moved_to"] == a
    assert d.evidence["moved_path"] == [a, ha, a]
    assert d.evidence["dl_nats"] < 0            # the actions favour the walk
    assert "visits only nodes of its own" in format_doubts([d])[1]
    conf = doubt_lone(Confidence("mdl", 0.0, 5, None, 4.0, False, ()), lone)
    assert conf.suspect and "observations 30-32" in conf.reasons[0]
    assert "suggest" in conf.reasons[0]
    # seen twice, the same states are no longer lone
    problem, _, labels = _problem([HOME] * 6 + [misread] * 2)
    assert lone_episodes(problem, labels).chains == ()


def test_a_lone_episode_off_home_is_a_doubt_named_with_the_home_and_walked_from_it():
    """Twenty-two episodes from 'A' (twenty through states each sees alone, so a lone
    episode is no surprise by the count), and one read wrong from its first frame: it starts
    at 'X', where none of the others does. 22 of 22 start at 'A' (odds 23 to 1): the graph is
    flagged naming the home, and the doubt's walk starts there, not at 'B', where the same
    actions walk too."""
    own = [["A", "pick_1", "HA", "place_1", "A", "pick_2", f"H{i}", "place_2", f"S{i}"]
           for i in range(20)]
    also = [["A", "pick_2", "HB", "place_2", "B", "pick_1", "HB1", "place_1", "B"]] * 2
    problem, path, labels = _problem(own + also + [["X", "pick_1", "HX", "place_1", "X2"]])
    lone = lone_episodes(problem, labels)
    a, ha = int(labels[0]), int(labels[1])
    assert not lone.surprising and lone.doubtful and lone.home == a
    conf = doubt_lone(Confidence("mdl", 0.0, 5, None, 4.0, False, ()), lone)
    assert conf.suspect and "observations 110-112" in conf.reasons[0]
    assert f"does not start at node {a}, where 22 of the other 22 episodes start" in \
        conf.reasons[0]
    assert "odds of 23 to 1" in conf.reasons[0]
    (d,) = lone_doubts(problem, path, labels, lone)
    assert d.evidence["moved_to"] == a and d.evidence["moved_path"] == [a, ha, a]


def test_a_lone_episode_no_walk_fits_still_names_a_doubt_the_nearest_merge():
    """The misread episode takes pick_1 then place_2 back to its first node: no walk fits
    (place_2 from 'HA' back to 'A' would be a second label between them). The graph is
    flagged, and each of its nodes is a merge doubt with the node of its role the images
    leave closest (blocks-3 clean s386, draw 42: warned with no doubt, nothing for `suggest`
    to probe)."""
    misread = ["X", "pick_1", "HX", "place_2", "X"]
    problem, path, labels = _problem([HOME] * 6 + [misread])
    lone = lone_episodes(problem, labels)
    assert lone.doubtful
    doubts = lone_doubts(problem, path, labels, lone)
    mine = {int(labels[30]), int(labels[31])}
    assert {d.nodes[0] for d in doubts} == mine          # one per node of the episode
    for d in doubts:
        assert d.kind == MERGE and d.nodes[1] not in mine
        assert d.evidence["nearest"] is True and d.evidence["lone_episode"] == [30, 32]
        assert d.evidence["moved_to"] == d.nodes[1]
    assert "no walk fits" in format_doubts(doubts)[1]


@pytest.mark.slow
def test_multifruit_4x6_robot_s2_episode_read_swapped_is_moved_onto_the_path_it_took():
    """multifruit-4x6 robot, trace seed 2 (tuning split, 400 transitions): one episode of
    seven frames was read with a red and a yellow object swapped at two regions, at kappa
    1.0 -- no bound on the readings questioned it, and its five states became five nodes of
    their own (69 nodes for 64 states, flagged by this check until session 44). Its actions
    walk the nodes of the states it really visited, 35 nats shorter: the merge moves it
    there (:func:`~vggc_cp.solvers.episodes.move_lone_episodes`), the graph has the true
    64 nodes, no episode is lone, and every frame of the episode is in the node of its true
    state (the true states are read by the test only)."""
    from collections import Counter

    from vggc_cp.pipeline import learn_graph
    from vggc_cp.sim.explore import generate

    trace = generate("multifruit-4x6", 400, 2, size=64, look="robot").trace
    learned = learn_graph(trace.without_states())
    labels = learned.labels
    truth = [str(s) for s in trace.states]
    assert len(np.unique(labels)) == len(set(truth)) == 64
    assert learned.chosen.best.stats["lone_moves"] == 1
    assert any(r["selected"] and r["lone_moves"] == 1 for r in learned.path_records())
    assert lone_episodes(learned.problem, labels).chains == ()
    assert not any("visits only nodes no other episode visits" in r
                   for r in learned.confidence.reasons)
    for node in np.unique(labels):
        held = Counter(truth[o] for o in np.flatnonzero(labels == node))
        assert len(held) == 1, (int(node), held)


# an episode whose first frames were read as states nothing else visits ('X', 'HX', 'Y')
# and which then joins the others' path at 'HB' (the arm where the last episode left it)
MISREAD_START = ["X", "pick_1", "HX", "place_1", "Y", "pick_2", "HB", "place_2", "A"]


def test_an_episode_whose_first_frames_are_its_own_is_a_surprising_lone_start():
    problem, _, labels = _problem([HOME] * 8 + [MISREAD_START])
    starts = lone_starts(problem, labels)
    ((chain, j),) = starts.starts
    assert chain.tolist() == list(range(40, 45)) and j == 3
    # three of the episodes' 8 * 3 + 5 node visits are their own; only the last episode
    # has more than three nodes
    assert starts.share == pytest.approx(3 / 29)
    assert starts.expected == pytest.approx((3 / 29) ** 3)
    assert starts.chance == pytest.approx(poisson_tail(1, starts.expected))
    assert starts.chance < LONE_ALPHA and starts.surprising
    # not a lone episode: it shares nodes 'HB' and 'A' with the others
    assert lone_episodes(problem, labels).chains == ()
    conf = doubt_lone_starts(Confidence("mdl", 0.0, 5, None, 4.0, False, ()), starts)
    assert conf.suspect and "observations 40-44 starts on nodes no other" in conf.reasons[0]
    assert "first 3 observation(s)" in conf.reasons[0] and "suggest" in conf.reasons[0]


def test_lone_starts_as_many_as_chance_gives_are_quiet():
    """Two episodes, one starting on states of its own: four of their eight node visits are
    lone (the first episode alone visits HA), so such a start is what chance gives
    (``0.5 ** 3`` expected)."""
    problem, _, labels = _problem([HOME, MISREAD_START])
    starts = lone_starts(problem, labels)
    assert len(starts.starts) == 1
    assert starts.expected == pytest.approx(0.5 ** 3)
    assert starts.chance > LONE_ALPHA and not starts.surprising
    assert not doubt_lone_starts(Confidence("mdl", 0.0, 5, None, 4.0, False, ()),
                                 starts).suspect


def test_a_start_of_two_nodes_or_one_visited_again_is_no_lone_start():
    # two frames of its own: a start state the others never saw and its first outcome, as
    # a random start gives (blocks-3 clean s47 in tests/test_pipeline.py)
    two = ["X", "pick_1", "HX", "place_1", "A", "pick_2", "HB", "place_2", "A"]
    problem, _, labels = _problem([HOME] * 8 + [two])
    assert lone_starts(problem, labels).starts == ()
    # its own nodes visited again after it joins: not a start only
    again = MISREAD_START + ["pick_1", "HX", "place_1", "Y"]
    problem, _, labels = _problem([HOME] * 8 + [again])
    assert lone_starts(problem, labels).starts == ()


def test_the_verdict_flags_a_surprising_lone_start_and_lists_a_doubt():
    from vggc_cp.solvers.mdl import description_length
    from vggc_cp.solvers.verdict import verdict

    problem, path, labels = _problem([HOME] * 8 + [MISREAD_START])
    dls = [description_length(problem, r.labels) for r in path.results]
    quiet = Confidence("mdl", 0.0, 5, None, 4.0, False, ())
    conf, doubts = verdict(problem, path, labels, quiet, dls)
    assert conf.suspect
    assert any("observations 40-44 starts on nodes no other" in r for r in conf.reasons)
    # a warned graph names what is doubtful: a node of the start and its nearest
    first = doubts[0]
    assert first.kind == MERGE and first.evidence["lone_start"] == [40, 42]
    assert first.nodes[0] in {int(labels[o]) for o in (40, 41, 42)}
    assert "episode start 40-42 is on nodes of its own" in format_doubts([first])[1]
    # the same recording without the misread start: quiet
    problem, path, labels = _problem([HOME] * 8)
    dls = [description_length(problem, r.labels) for r in path.results]
    conf, _ = verdict(problem, path, labels, quiet, dls)
    assert not conf.suspect
