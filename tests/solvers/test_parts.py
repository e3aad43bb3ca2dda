"""Parts of a learned graph moved onto the rest (:mod:`vggc_cp.solvers.parts`)."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.mdl import description_length
from vggc_cp.solvers.parts import graph_parts, move_lone_parts, part_embeddings


def _problem(episodes):
    """A problem of the given episodes, each a list of action indices (0 a pick, 1 and 2
    places, alternating from a pick node): observations in order, one chain each."""
    roles, src, act, dst = [], [], [], []
    for actions in episodes:
        first = len(roles)
        roles.append(0)
        for k, a in enumerate(actions):
            src.append(first + k)
            dst.append(first + k + 1)
            act.append(a)
            roles.append(1 - roles[-1])
    roles = np.array(roles)
    n_pick, n_place = int((roles == 0).sum()), int((roles == 1).sum())
    return Problem(roles, np.array(src), np.array(act), np.array(dst),
                   ("pick", "place_a", "place_b"), np.zeros((n_pick, n_pick)),
                   np.zeros((n_place, n_place)))


def test_parts_are_the_components_of_the_transitions_largest_first():
    p = _problem([[0, 1], [0, 1], [0]])
    parts = graph_parts(p, np.array([0, 1, 2, 0, 1, 2, 5, 6]))
    assert [g.tolist() for g in parts] == [[0, 1, 2], [5, 6]]
    assert len(graph_parts(p, np.array([0, 1, 2, 0, 1, 2, 0, 1]))) == 1


def test_a_copy_embeds_and_a_part_with_an_action_the_rest_lacks_does_not():
    p = _problem([[0, 1], [0, 1], [0, 1]])
    labels = np.array([0, 1, 2, 0, 1, 2, 3, 4, 5])
    (part,) = graph_parts(p, labels)[1:]
    assert part_embeddings(p, labels, part) == [{3: 0, 4: 1, 5: 2}]
    # the third episode places with action 2, which the rest never takes
    q = _problem([[0, 1], [0, 1], [0, 2]])
    (part,) = graph_parts(q, labels)[1:]
    assert part_embeddings(q, labels, part) == []


def test_a_step_that_could_go_two_ways_is_no_embedding():
    # the rest: pick (0) from node 0 leads to node 1 in one episode and node 3 in another
    p = _problem([[0], [0], [0]])
    labels = np.array([0, 1, 0, 3, 4, 5])
    (part,) = graph_parts(p, labels)[1:]
    assert part_embeddings(p, labels, part) == []


def test_a_copied_part_is_moved_and_the_code_is_shorter():
    p = _problem([[0, 1]] * 4)
    labels = np.array([0, 1, 2] * 3 + [3, 4, 5])
    moved_labels, moved = move_lone_parts(p, labels)
    assert moved == 1 and moved_labels.tolist() == [0, 1, 2] * 4
    assert description_length(p, moved_labels) < description_length(p, labels)


def test_a_part_unlike_the_rest_stays():
    """Two regions of a task that never meet (a right graph of two parts): the second
    part's actions have no counterpart in the first, so nothing moves."""
    p = _problem([[0, 1], [0, 1], [0, 2], [0, 2]])
    labels = np.array([0, 1, 2, 0, 1, 2, 3, 4, 5, 3, 4, 5])
    same, moved = move_lone_parts(p, labels)
    assert moved == 0 and same.tolist() == labels.tolist()


def test_a_single_part_is_left_as_it_is():
    p = _problem([[0, 1], [0, 1]])
    labels = np.array([0, 1, 2, 0, 1, 2])
    same, moved = move_lone_parts(p, labels)
    assert moved == 0 and same is not None and same.tolist() == labels.tolist()


@pytest.mark.slow  # a PyBullet trace of 600 transitions, learned once
def test_two_episodes_on_nodes_of_their_own_join_the_graph():
    """random-1255 randomized, |D| = 600 (draw 54, a silent miss before session 56): two
    episodes ran on three nodes no other episode visits, parallel to three of the graph
    (48 nodes for 45, AnyPath 98.6 %). Their actions fit those three nodes and the code is
    shorter there: the right graph, quiet."""
    import vggc_cp as vg
    from vggc_cp.sim.explore import generate

    trace = generate("random-1255", 600, seed=0, look="randomized").trace
    learned = vg.learn_graph(trace.without_states())
    metrics = vg.evaluate(trace, learned)
    assert metrics.nodes == len(set(trace.states.tolist())) == 45
    assert metrics.exec == 1.0
    assert not learned.confidence.suspect


def test_a_part_as_large_as_the_largest_stays():
    """Two copies of one episode, neither larger: which would be the copy, nothing says."""
    p = _problem([[0, 1], [0, 1]])
    labels = np.array([0, 1, 2, 3, 4, 5])
    same, moved = move_lone_parts(p, labels)
    assert moved == 0 and same.tolist() == labels.tolist()
