"""What an episode's untouched slots hold given the counts: the most likely assignment, the
assignments ranked, the most likely that stands (:mod:`vggc_cp.vision.assignment`)."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.vision import assignment as asg


def test_the_assignment_respects_the_counts_and_follows_the_readings():
    # two red objects and one blue among four slots; readings of the first three only
    p = np.array([0.9, 0.8, 0.95, 0.5])
    post = np.array([[0.9, 0.1], [0.2, 0.8], [0.6, 0.4], [0.5, 0.5]])
    got, loglik = asg.episode_assignment(p, post, np.array([2, 1]))
    assert sorted(got.tolist()) == [-1, 0, 0, 1]
    assert loglik == pytest.approx(np.log(0.9 * 0.9 * 0.8 * 0.8 * 0.95 * 0.6 * 0.5))
    assert got[1] == 1                    # the bluest reading takes the blue object
    assert got[3] == -1                   # the unread slot is left empty: three are seen
    # one object only: the most certain reading holds it
    assert asg.episode_assignment(p, post, np.array([1, 0]))[0].tolist() == [-1, -1, 0, -1]


def test_counts_no_assignment_meets_cost_as_much_as_a_reading_that_rules_them_out():
    p, post = np.array([0.9, 0.9]), np.ones((2, 1))
    _, fits = asg.episode_assignment(p, post, np.array([2]))
    _, too_many = asg.episode_assignment(p, post, np.array([3]))
    _, too_few = asg.episode_assignment(p, post, np.array([-1]))
    assert too_many == pytest.approx(fits + np.log(asg.FLOOR))
    assert too_few == pytest.approx(np.log(0.1 * 0.1) + np.log(asg.FLOOR))


def test_ranked_assignments_come_best_first_and_once_each():
    """Murty's ranking gives every assignment of contents once, from the most likely down,
    as the brute force over all of them does; a stack with every assignment in the air
    leaves nothing grounded."""
    import itertools

    rng = np.random.default_rng(3)
    p = rng.uniform(0.05, 0.95, 5)
    post = rng.dirichlet(np.ones(2), 5)
    need = np.array([1, 2])
    ranked = list(asg.ranked_assignments(p, post, need, limit=1000))
    every = {c for c in itertools.product([-1, 0, 1], repeat=5)
             if c.count(0) == 1 and c.count(1) == 2}
    assert len(ranked) == len(every) == 30
    assert {tuple(c.tolist()) for c, _ in ranked} == every
    lls = [ll for _, ll in ranked]
    assert all(a >= b - 1e-12 for a, b in zip(lls, lls[1:]))
    assert abs(lls[0] - asg.episode_assignment(p, post, need)[1]) < 1e-9
    assert len(list(asg.ranked_assignments(p, post, need, limit=4))) == 4
    assert asg.grounded(p, post, need, None, lambda c: True)[0] is None
