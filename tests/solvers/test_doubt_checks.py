"""The plan risk an episode doubt leaves (:mod:`vggc_cp.solvers.doubt_checks`)."""

from __future__ import annotations

from types import SimpleNamespace

import networkx as nx
import numpy as np
import pytest

from vggc_cp.solvers.confidence import Confidence
from vggc_cp.solvers.doubt_checks import (
    MAX_PLAN_RISK,
    START_ODDS,
    doubt_readings,
    misplaced_share,
    plan_risk,
    plans_through,
    sole_edges,
    start_odds,
)
from vggc_cp.solvers.doubts import SPLIT, Doubt


def test_plans_through_counts_the_shortest_plans_as_networkx_lists_them():
    rng = np.random.default_rng(3)
    n = 12
    edges = {(int(u), int(rng.integers(4)), int(v)) for u, v in rng.integers(0, n, (40, 2))
             if u != v}
    sole = set(list(sorted(edges))[::5])
    share = plans_through(sorted(edges), sole, n)
    g = nx.MultiDiGraph()
    g.add_nodes_from(range(n))
    for u, a, v in edges:
        g.add_edge(u, v, key=a)
    checked = 0
    for u in range(n):
        for v in range(n):
            if u == v or not nx.has_path(g, u, v):
                assert share[u, v] == 0.0
                continue
            # every shortest plan: a node path times the actions joining each step
            plans = risky = 0
            for path in nx.all_shortest_paths(g, u, v):
                steps = [[(a, (x, a, y) in sole) for a in g[x][y]] for x, y in zip(path, path[1:])]
                for choice in np.array(np.meshgrid(*[range(len(s)) for s in steps])).T.reshape(
                        -1, len(steps)):
                    plans += 1
                    risky += any(steps[i][c][1] for i, c in enumerate(choice))
            assert share[u, v] == pytest.approx(risky / plans)
            checked += 1
    assert checked > 30


def _chain(n_nodes: int = 6, reps: int = 10):
    """A walk 0 -> 1 -> ... -> n-1 and back, repeated (one episode per pass), then one short
    episode, the doubtful one, that alone shows a shortcut 0 -> n-1 by action 9."""
    labels, src, act, dst = [], [], [], []
    for _ in range(reps):
        first = len(labels)
        path = list(range(n_nodes)) + list(range(n_nodes - 2, -1, -1))
        labels += path
        for i in range(len(path) - 1):
            src.append(first + i)
            dst.append(first + i + 1)
            act.append(path[i] * 2 + (path[i + 1] < path[i]))
    first = len(labels)
    labels += [0, n_nodes - 1]
    src.append(first)
    act.append(9)
    dst.append(first + 1)
    arr = (np.array(v, dtype=np.int64) for v in (labels, src, act, dst))
    return (*arr, [first, first + 1])


def test_a_doubtful_episode_that_alone_shows_a_shortcut_risks_the_plans_that_take_it():
    labels, src, act, dst, episode = _chain()
    d = Doubt(SPLIT, (0,), ((0,), (episode[0],)), {
        "episode": episode, "moved_to": 1, "moved_path": [1, 2], "read_sites": ["pick_3"],
        "read_kappa": 0.3})
    assert sole_edges([d], labels, src, act, dst) == {(0, 9, 5)}
    renders_only = 1 - (1 - misplaced_share([d], labels)) ** 2
    risk = plan_risk([d], labels, src, act, dst)
    assert renders_only < MAX_PLAN_RISK < risk
    quiet = Confidence("mdl", 0.0, 5, None, 4.0, False, ())
    problem = SimpleNamespace(src=src, act=act, dst=dst)
    assert not doubt_readings(quiet, [d], labels).suspect        # the renders alone: a note
    flagged = doubt_readings(quiet, [d], labels, problem)
    assert flagged.suspect and "transition only such episodes show" in flagged.reasons[0]
    assert f"{100 * risk:.1f} % of plans" in flagged.reasons[0]


def test_an_edge_other_episodes_show_too_is_not_at_risk():
    labels, src, act, dst, episode = _chain()
    d = Doubt(SPLIT, (2,), ((2,), (0,)), {"episode": [0, 3], "moved_path": [3, 4, 3, 2]})
    assert sole_edges([d], labels, src, act, dst) == set()
    # only the renders: each node's share moved to it, over the 30 ordered pairs of 6 nodes
    sizes = np.bincount(labels)
    moved = np.bincount([3, 4, 3, 2], minlength=6)
    m = moved / (sizes + moved)
    want = np.mean([1 - (1 - m[u]) * (1 - m[v]) for u in range(6) for v in range(6) if u != v])
    assert plan_risk([d], labels, src, act, dst) == pytest.approx(want)


def test_starts_that_back_the_images_settle_nothing():
    # ten passes from node 0, each an episode; the doubtful one starts at node 0 too, and
    # the other path would start it at node 1, where no episode starts: 10.5 / 0.5 = 21 for
    # where it is -- and the plan risk still decides (a home node may hold misread renders)
    labels, src, act, dst, episode = _chain(reps=10)
    d = Doubt(SPLIT, (0,), ((0,), (episode[0],)), {
        "episode": episode, "moved_to": 1, "moved_path": [1, 2], "read_sites": ["pick_3"],
        "read_kappa": 0.3})
    assert start_odds(d, labels, dst) == pytest.approx(21.0)
    assert 21.0 > START_ODDS
    risk = plan_risk([d], labels, src, act, dst)
    assert risk > MAX_PLAN_RISK
    quiet = Confidence("mdl", 0.0, 5, None, 4.0, False, ())
    conf = doubt_readings(quiet, [d], labels, SimpleNamespace(src=src, act=act, dst=dst))
    assert conf.suspect and f"{100 * risk:.1f} % of plans" in conf.reasons[0]


def test_starts_spread_over_both_nodes_settle_nothing():
    labels, src, act, dst, episode = _chain(reps=10)
    labels = labels.copy()
    # half the passes start at node 1 instead (relabel their first observation)
    starts = np.setdiff1d(np.arange(len(labels)), dst)
    labels[starts[:5]] = 1
    d = Doubt(SPLIT, (0,), ((0,), (episode[0],)), {"episode": episode, "moved_path": [1, 2]})
    assert start_odds(d, labels, dst) == pytest.approx(5.5 / 5.5)
    same = Doubt(SPLIT, (0,), ((0,), (episode[0],)), {"episode": episode, "moved_path": [0, 2]})
    assert start_odds(same, labels, dst) == 1.0
    assert start_odds(Doubt(SPLIT, (0,), ((0,), (1,)), {"episode": episode}), labels, dst) == 1.0


def test_an_episode_starting_where_no_other_does_flags_whatever_its_plan_risk():
    # ten passes from node 0; the doubtful episode starts at node 1, where none does, and
    # the other path would start it at node 0
    labels, src, act, dst, episode = _chain(reps=10)
    labels = labels.copy()
    labels[episode[0]] = 1
    d = Doubt(SPLIT, (1,), ((1,), (episode[0],)), {
        "episode": episode, "moved_to": 0, "moved_path": [0, 5], "read_sites": ["pick_3"],
        "read_kappa": 0.3})
    assert start_odds(d, labels, dst) == pytest.approx(0.5 / 10.5)
    problem = SimpleNamespace(src=src, act=act, dst=dst)
    quiet = Confidence("mdl", 0.0, 5, None, 4.0, False, ())
    conf = doubt_readings(quiet, [d], labels, problem)
    assert conf.suspect and "the other episodes start there 21 times as often" in conf.reasons[0]
    # the same doubt judged without the transitions: its renders' risk alone, a note
    assert not doubt_readings(quiet, [d], labels).suspect


def test_contradicted_episodes_leave_room_for_the_next_within_the_limit():
    labels, src, act, dst, episode = _chain(reps=10)
    labels = labels.copy()
    labels[episode[0]] = 1
    problem = SimpleNamespace(src=src, act=act, dst=dst)
    against = Doubt(SPLIT, (1,), ((1,), (episode[0],)), {
        "episode": episode, "moved_to": 0, "moved_path": [0, 5], "read_kappa": 0.3})
    # an episode of the passes, moved from node 2 to node 3 mid-walk: its start stays
    open_ = Doubt(SPLIT, (2,), ((2,), (2,)), {
        "episode": [0, 10], "moved_to": 3, "moved_path": [0, 1, 3, 4, 3, 4, 3, 2, 1, 0, 1],
        "read_kappa": 0.3})
    quiet = Confidence("mdl", 0.0, 5, None, 4.0, False, ())
    one = doubt_readings(quiet, [against, open_], labels, problem, limit=1)
    said = (*one.notes, *one.reasons)
    assert one.suspect and "times as often" in said[0]
    assert any("observations 0-10" in n for n in said)
