"""Tests of vggc_cp.vision.run_colours: the colour of a site's unlabelled runs."""

from __future__ import annotations

import numpy as np

from vggc_cp.vision import run_colours
from vggc_cp.vision.slots import UNLABELLED


def test_unlabelled_runs_take_the_colour_their_window_shows():
    """Two sites read per pose: the labelled frames of each colour teach what red and yellow
    look like in the windows, and a run no action labels takes the colour its frames show
    (weighted by strength); a run whose frames show nothing keeps its posterior."""
    rng = np.random.default_rng(0)
    n = 12
    posterior = np.full((n, 2, 2), 0.5)
    red = [0.7, 0.15] + 0.005 * rng.standard_normal((n, 2))
    yellow = [0.5, 0.4] + 0.005 * rng.standard_normal((n, 2))
    chroma = np.where((np.arange(n) % 2 == 0)[:, None], red, yellow)
    strength = np.ones(n)
    shows = np.ones(n, dtype=bool)
    shows[9:] = False                                         # run 3 shows nothing
    run = np.repeat(np.arange(4), 3)
    loose = np.arange(6, 12)
    chroma[6:9] = yellow[6:9]                                 # run 2: yellow
    examples = [[chroma[[0, 2, 4]]], [chroma[[1, 3, 5]]]]
    run_colours.window_colour(posterior, {0: (chroma, strength, shows, run, loose)}, examples, 0.02)
    assert posterior[6:9, 0, 1].min() > 0.99                  # yellow
    assert np.all(posterior[9:12, 0] == 0.5)                  # nothing to read there
    assert np.all(posterior[:6] == 0.5)                       # labelled frames untouched
    assert np.all(posterior[:, 1] == 0.5)                     # the other site was not read
    # a colour without two examples teaches nothing
    before = posterior.copy()
    run_colours.window_colour(posterior, {0: (chroma, strength, shows, run, loose)},
                      [[chroma[[0, 2]]], [chroma[[1]]]], 0.02)
    np.testing.assert_array_equal(posterior, before)


def test_a_colour_the_pixels_read_no_better_than_the_majority_is_not_a_reading():
    """Site 0's pixels read red for every run (a footprint on an arm's grey, a hair redder
    than yellow) while the actions state yellow in three runs of four: no reading (kappa
    below 0), so its unlabelled run takes the stated shares; the run a window read keeps its
    colour, and so does a run some slot above covers. Site 1's pixels read every stated run
    right: its unlabelled run keeps what they read."""
    labels = np.array([0, 1, 1, 1, UNLABELLED, UNLABELLED, UNLABELLED,
                       UNLABELLED, UNLABELLED])
    run = np.array([0, 1, 2, 3, 4, 4, 5, 6, 6])
    loose = np.arange(4, 9)
    grey = np.tile([[0.52, 0.48]], (9, 1))
    right = np.eye(2)[[0, 1, 1, 1, 0, 0, 0, 0, 0]]
    seen = np.stack([grey, right], axis=1)
    posterior = seen.copy()
    presence = np.ones((9, 3))
    presence[:, 2] = 0.0
    presence[7:, 2] = 1.0                     # a slot above site 0 holds something in run 6
    runs = {0: (labels, run, loose, None), 1: (labels, run, loose, None)}
    out = run_colours.majority_colour(posterior, seen, presence, runs, {0: [2]}, {0: {5}})
    np.testing.assert_allclose(out[0], [1.5 / 5, 3.5 / 5])
    np.testing.assert_allclose(posterior[4:6, 0], [[0.3, 0.7]] * 2)   # the stated shares
    np.testing.assert_array_equal(posterior[6:, 0], grey[6:])         # window-read, covered
    assert 1 not in out
    np.testing.assert_array_equal(posterior[:, 1], right)
    # one colour stated everywhere judges nothing: the pixels stand
    one = np.where(labels >= 0, 1, labels)
    post = seen.copy()
    assert run_colours.majority_colour(post, seen, presence, {0: (one, run, loose, None)}) == {}
    np.testing.assert_array_equal(post, seen)
