"""Kernel densities of colours."""

from __future__ import annotations

import numpy as np

from vggc_cp.vision.density import kernel_loglik, kernel_posterior


def test_the_density_falls_with_distance_and_keeps_every_look():
    two_looks = np.array([[0.7, 0.15], [0.5, 0.4]])           # one class, two shades
    ll = kernel_loglik(np.array([[0.7, 0.15], [0.5, 0.4], [0.6, 0.28]]), two_looks, 0.02)
    assert ll[0] == ll[1] > ll[2] + 10                          # both looks, not their mean


def test_posteriors_sum_to_one_and_favour_the_nearer_class():
    rng = np.random.default_rng(0)
    red = [0.7, 0.15] + 0.01 * rng.standard_normal((30, 2))
    yellow = [0.5, 0.4] + 0.01 * rng.standard_normal((30, 2))
    q = np.array([[0.69, 0.16], [0.52, 0.39], [0.6, 0.275]])
    post = kernel_posterior(q, [red, yellow], 0.02)
    np.testing.assert_allclose(post.sum(axis=1), 1.0)
    assert post[0, 0] > 0.99 and post[1, 1] > 0.99
    assert 0.01 < post[2, 0] < 0.99                             # between them: undecided
