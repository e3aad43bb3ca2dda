"""Episodes on a learned graph (:mod:`vggc_cp.solvers.episodes`): lone episodes moved onto the
path their actions walk. Chains, walks and the lone count are tested in ``test_doubts.py`` and
``test_lone_episodes.py``; the merge's use of the move end to end on multifruit-4x6 robot s2
in ``test_lone_episodes.py`` (slow)."""

from __future__ import annotations

import numpy as np
from conftest import make_trace

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.episodes import lone_episodes, lone_walks, move_lone_episodes
from vggc_cp.solvers.mdl import description_length

NAMES = ("pick_1", "place_1", "pick_2", "place_2")
HOME = ["A", "pick_1", "HA", "place_1", "A", "pick_2", "HB", "place_2", "A"]


def _problem(episodes):
    """The problem of ``episodes`` (states and actions) and the labels of its states."""
    trace = make_trace(episodes, NAMES)
    src, act, dst = trace.transitions()
    states, roles = trace.states, trace.roles()
    apart = {r: 1.0 - (states[roles == r][:, None] == states[roles == r][None, :])
             for r in (0, 1)}
    _, labels = np.unique(states, return_inverse=True)
    return Problem(roles, src, act, dst, NAMES, apart[0], apart[1]), labels.astype(np.int64)


def test_a_lone_episode_is_moved_onto_the_path_its_actions_walk():
    """Six episodes from 'A'; a seventh takes pick_1 then place_1 as they do, but was read as
    states 'X' and 'HX' of its own (a misread). One lone episode among seven is unlikely by
    chance, its actions walk 'A' -pick_1-> 'HA' -place_1-> 'A', and the graph without two
    nodes is shorter: the episode's frames go to 'A', 'HA', 'A', and its nodes are empty."""
    misread = ["X", "pick_1", "HX", "place_1", "X"]
    problem, labels = _problem([HOME] * 6 + [misread])
    a, ha, x = int(labels[0]), int(labels[1]), int(labels[30])
    ((length, start, path, moved_labels),) = lone_walks(problem, labels, np.array([30, 31, 32]))
    assert start == a and path.tolist() == [a, ha, a]
    assert length < description_length(problem, labels)
    moved, n = move_lone_episodes(problem, labels)
    assert n == 1 and moved.tolist() == moved_labels.tolist()
    assert moved[30:].tolist() == [a, ha, a] and x not in moved
    assert moved[:30].tolist() == labels[:30].tolist()
    assert lone_episodes(problem, moved).chains == ()


def test_lone_episodes_as_many_as_chance_gives_are_not_moved():
    """Two episodes through disjoint parts, each with nodes of its own: every episode is
    lone (share 1), as chance gives, so nothing moves, though the second's actions would
    walk the first's path."""
    problem, labels = _problem([["A", "pick_1", "HA", "place_1", "A"],
                                ["X", "pick_1", "HX", "place_1", "X"]])
    lone = lone_episodes(problem, labels)
    assert len(lone.chains) == 2 and not lone.doubtful
    moved, n = move_lone_episodes(problem, labels)
    assert n == 0 and moved.tolist() == labels.tolist()


def test_a_lone_episode_whose_actions_walk_nowhere_stays():
    """The misread episode takes pick_1 then place_2 back to its first node: from 'A',
    pick_1 leads to 'HA', and place_2 back to 'A' would be a second label between 'HA' and
    'A' (place_1 joins them): no walk, nothing moved (the verdict's lone check names it)."""
    misread = ["X", "pick_1", "HX", "place_2", "X"]
    problem, labels = _problem([HOME] * 6 + [misread])
    assert lone_episodes(problem, labels).doubtful
    assert lone_walks(problem, labels, np.array([30, 31, 32])) == []
    moved, n = move_lone_episodes(problem, labels)
    assert n == 0 and moved.tolist() == labels.tolist()


def test_a_walk_ends_where_the_episode_goes_on_to_a_state_nobody_saw():
    """The misread episode runs 'X' -pick_1-> 'HX' -place_1-> 'X' -pick_2-> 'HX2'
    -place_1-> 'Y'. From 'A' its actions walk 'A', 'HA', 'A', 'HB' as the other episodes
    do; place_1 from 'HB' is an edge nowhere and leads into a node the episode has not
    visited ('Y'): the walk ends there, and 'Y' keeps its node (a state the rest of the graph
    has not seen). The move drops three nodes and shortens the code. Where the walk re-places
    only one pick and its place ('X' -pick_2-> 'HX' -place_1-> 'Y'), the new edge costs more
    than the two nodes save: the walk is listed, and nothing moves."""
    misread = ["X", "pick_1", "HX", "place_1", "X", "pick_2", "HX2", "place_1", "Y"]
    problem, labels = _problem([HOME] * 6 + [misread])
    a, ha, hb, y = (int(labels[i]) for i in (0, 1, 3, 34))
    chain = np.arange(30, 35)
    assert lone_episodes(problem, labels).doubtful
    walks = lone_walks(problem, labels, chain)
    assert [(w[1], w[2].tolist()) for w in walks] == [(a, [a, ha, a, hb, y])]
    moved, n = move_lone_episodes(problem, labels)
    assert n == 1 and moved[30:].tolist() == [a, ha, a, hb, y]
    assert description_length(problem, moved) < description_length(problem, labels)

    short = ["X", "pick_2", "HX", "place_1", "Y"]
    problem, labels = _problem([HOME] * 6 + [short])
    ((length, start, path, _),) = lone_walks(problem, labels, np.arange(30, 33))
    assert start == a and path.tolist() == [a, hb, int(labels[32])]
    assert length > description_length(problem, labels)
    assert move_lone_episodes(problem, labels)[1] == 0


def test_a_lone_episode_off_home_is_walked_from_home_however_few_lone_are_surprising():
    """Twenty-two episodes from the home 'A' through many states each of them sees alone
    (so lone episodes are no surprise by their count), and one that starts at 'X': read
    wrong from its first frame, it runs 'X' -pick_1-> 'HX' -place_1-> 'X2' on nodes of its
    own, where the others' actions walk 'A' -pick_1-> 'HA' -place_1-> 'A'. 22 of 22 other
    episodes start at 'A' (odds 23 to 1): the episode is off home, a doubt, and moved onto
    the walk from 'A' (not from 'B', where pick_1 leads too)."""
    own = [["A", "pick_1", "HA", "place_1", "A", "pick_2", f"H{i}", "place_2", f"S{i}"]
           for i in range(20)]
    also = [["A", "pick_2", "HB", "place_2", "B", "pick_1", "HB1", "place_1", "B"]] * 2
    misread = ["X", "pick_1", "HX", "place_1", "X2"]
    problem, labels = _problem(own + also + [misread])
    first = 5 * 22
    a, ha, b = int(labels[0]), int(labels[1]), int(labels[5 * 20 + 2])
    lone = lone_episodes(problem, labels)
    assert not lone.surprising and lone.home == a and lone.home_starts == 22
    assert [c.tolist() for c in lone.off_home] == [[first, first + 1, first + 2]]
    assert lone.doubtful and lone.starts_for(lone.off_home[0]) == {a}
    anywhere = {w[1] for w in lone_walks(problem, labels, lone.off_home[0])}
    assert {a, b} <= anywhere
    moved, n = move_lone_episodes(problem, labels)
    assert n == 1 and moved[first:].tolist() == [a, ha, a]


def test_a_lone_episode_is_not_off_home_where_episodes_start_anywhere():
    """The same misread episode among episodes that start at three nodes alike: no home at
    20 to 1, so only the count of lone episodes can make it a doubt."""
    starts = ["A", "B", "C"] * 7
    eps = [[s, "pick_1", f"H{s}", "place_1", s] for s in starts]
    problem, labels = _problem(eps + [["X", "pick_1", "HX", "place_1", "X2"]])
    lone = lone_episodes(problem, labels)
    assert lone.off_home == () and lone.doubted == (lone.chains if lone.surprising else ())


def test_episodes_a_reset_starts_do_not_hide_a_lone_one():
    """multifruit-4x6 robot s2 after a suggested round: twenty one-action episodes, each
    started by a reset in the state of an earlier observation, raised the lone episodes
    expected by chance (each adds ``q ** 2``) until the misread episode was no surprise, and
    the graph was quiet with 69 nodes for 64. A reset pins an episode's first node to one
    another episode visits: such episodes count in no figure of the test but the visits."""
    from dataclasses import replace

    misread = ["X", "pick_1", "HX", "place_1", "X"]
    # two of the probes reach states nobody else saw, as probes do
    probes = [["A", "pick_1", "HA"]] * 18 + [["A", "pick_2", "Z1"], ["A", "pick_2", "Z2"]]
    problem, labels = _problem([HOME] * 6 + [misread] + probes)
    starts = [33 + 2 * i for i in range(20)]
    assert all(labels[o] == labels[0] for o in starts)
    unpinned = lone_episodes(problem, labels)
    assert len(unpinned.chains) == 1 and not unpinned.surprising
    # (since session 50 the home catches it all the same: 26 of 26 others start at 'A')
    assert [c.tolist() for c in unpinned.off_home] == [[30, 31, 32]]
    pinned = replace(problem, resets=tuple((0, o) for o in starts))
    lone = lone_episodes(pinned, labels)
    assert [c.tolist() for c in lone.chains] == [[30, 31, 32]] and lone.surprising
    assert lone.expected < unpinned.expected
    moved, n = move_lone_episodes(pinned, labels)
    assert n == 1 and moved[30:33].tolist() == [labels[0], labels[1], labels[0]]
