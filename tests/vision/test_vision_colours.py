"""Colours of task classes: classes from the actions, colours pooled by their chroma, read
again in the windows where the footprints pool them (:mod:`vggc_cp.vision.colours`)."""

from __future__ import annotations

import numpy as np

from vggc_cp.trace import Trace
from vggc_cp.vision.colours import (
    action_classes,
    colour_classes,
    colour_posteriors,
    pooled,
    window_colours,
)


def test_classes_come_from_what_a_pick_lifts_and_the_next_place_puts_down():
    names = ("pick_a0", "pick_a1", "pick_b0", "place_a0", "place_a1", "place_b0", "place_b1")
    # pick_a0 -> place_a1, pick_a1 -> place_a0 | pick_a1 -> place_a1 | pick_b0 -> place_b1,
    # pick_b0 -> place_b0: the links join a0, a1 (through place_a1) and b0, b1
    acts = np.array([0, 4, 1, 3, -1, 1, 4, -1, 2, 6, 2, 5], dtype=np.int64)
    obs = np.zeros((len(acts) + 1, 4, 4, 3), dtype=np.uint8)
    cls = action_classes(Trace(obs, acts, names))
    assert cls[0] == cls[1] == cls[3] == cls[4]
    assert cls[2] == cls[5] == cls[6]
    assert cls[0] != cls[2]
    # no names are read: renaming every action changes nothing
    renamed = tuple(f"{n.split('_')[0]}_x{i}" for i, n in enumerate(names))
    assert np.array_equal(action_classes(Trace(obs, acts, renamed)), cls)


def test_classes_of_one_colour_pool_and_of_two_colours_do_not():
    rng = np.random.default_rng(0)
    red = np.array([0.8, 0.1]) + 0.02 * rng.standard_normal((50, 2))
    also_red = np.array([0.81, 0.1]) + 0.02 * rng.standard_normal((3, 2))
    yellow = np.array([0.5, 0.44]) + 0.005 * rng.standard_normal((40, 2))
    group = colour_classes([red, also_red, yellow], bandwidth=0.02)
    assert group[0] == group[1] != group[2]
    # a red of two looks, one of them near yellow, is still not yellow
    dull = np.array([0.52, 0.33]) + 0.01 * rng.standard_normal((20, 2))
    group = colour_classes([np.concatenate([red, dull]), yellow], bandwidth=0.02)
    assert group[0] != group[1]


def test_a_colour_of_two_looks_keeps_both():
    """An apple and a strawberry are both red: the kernel density keeps the second look,
    which a single prototype with one spread would give to the nearer other colour."""
    rng = np.random.default_rng(1)
    red = np.concatenate([np.array([0.8, 0.1]) + 0.01 * rng.standard_normal((60, 2)),
                          np.array([0.55, 0.32]) + 0.01 * rng.standard_normal((20, 2))])
    yellow = np.array([0.49, 0.44]) + 0.005 * rng.standard_normal((60, 2))
    seen = np.array([[0.8, 0.1], [0.55, 0.32], [0.49, 0.44]])[:, None, :]    # (3, 1, 2)
    post = colour_posteriors(seen, [red, yellow], bandwidth=0.02)
    assert post.shape == (3, 1, 2)
    assert post[0, 0, 0] > 0.99 and post[1, 0, 0] > 0.99 and post[2, 0, 1] > 0.99
    assert np.all(colour_posteriors(seen, [red], bandwidth=0.02) == 1.0)


def test_a_class_of_one_example_joins_the_colour_it_looks_like():
    """A pick taken once, at an episode's end, links to no place: its one example must join
    the colour it resembles, not whichever class comes first."""
    rng = np.random.default_rng(2)
    red = np.array([0.8, 0.1]) + 0.02 * rng.standard_normal((40, 2))
    yellow = np.array([0.5, 0.44]) + 0.01 * rng.standard_normal((40, 2))
    lone_yellow = np.array([[0.51, 0.43]])
    group = colour_classes([red, yellow, lone_yellow], bandwidth=0.02)
    assert group[2] == group[1] != group[0]
    group = colour_classes([lone_yellow, red, yellow], bandwidth=0.02)
    assert group[0] == group[2] != group[1]


def test_classes_pooled_by_grey_footprints_are_read_again_in_the_windows():
    """Footprints on a robot arm show every class as the arm's grey and pool them; the
    windows the labels teach tell red from yellow. A class the windows cannot read joins the
    readable class its footprints resemble; without pooling nothing is read again."""
    rng = np.random.default_rng(0)
    classes = np.array([0, 0, 1, 1, 2, 3])
    counts = np.array([5, 5, 5, 5, 2, 0])                 # action 5 never taken
    grey = [0.33 + 0.003 * rng.standard_normal((20, 2)) for _ in range(3)]
    grey[2] = grey[0][:2] + 0.0005                        # class 2 looks like class 0
    grey.append(np.zeros((0, 2)))
    red = [0.75, 0.13] + 0.01 * rng.standard_normal((30, 2))
    yellow = [0.5, 0.4] + 0.01 * rng.standard_normal((30, 2))
    window = [red, yellow, np.zeros((1, 2)), np.zeros((0, 2))]
    one = np.array([0, 0, 0, 0, 0, -1])
    assert pooled(one, classes, counts)
    out = window_colours(one, classes, counts, grey, window, 0.02)
    assert out.tolist() == [0, 0, 1, 1, 0, -1]
    # colours the footprints already tell apart are kept as they are
    apart = np.array([0, 0, 1, 1, 2, -1])
    assert not pooled(apart, classes, counts)
    assert window_colours(apart, classes, counts, grey, window, 0.02) is apart
    # the windows see one colour too: one colour
    same = [red, red + 0.001, np.zeros((0, 2)), np.zeros((0, 2))]
    assert window_colours(one, classes, counts, grey, same, 0.02).tolist() == [0] * 5 + [-1]
