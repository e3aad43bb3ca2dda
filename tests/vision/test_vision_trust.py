"""How far a site's reading can be trusted (:mod:`vggc_cp.vision.trust`)."""

from __future__ import annotations

import numpy as np

from vggc_cp.vision import trust

UNLABELLED, EMPTY = -2, -1


def test_a_run_read_by_a_pose_few_stated_frames_show_is_trusted_little():
    """Two poses read every held-out frame right: pose 0 on 60 frames, pose 1 on 3. A run
    read by pose 0 is trusted for sure nearly as far as its kappa (1); one read by pose 1
    hardly at all; a run read by both takes the strength-weighted mean."""
    labels = np.array([0, EMPTY] * 30 + [0, EMPTY, 0] + [UNLABELLED] * 6)
    pose = np.array([0] * 60 + [1] * 3 + [0, 0, 1, 1, 0, 1])
    weight = np.where(labels == UNLABELLED, 0.0, 1.0)
    right = labels != UNLABELLED
    run = np.array([0] * 63 + [1, 1, 2, 2, 3, 3])
    loose = np.flatnonzero(labels == UNLABELLED)
    strength = np.ones(len(labels))
    bounds = trust.pose_bounds(right, weight, labels, pose, strength, run, loose)
    assert trust.majority_share(labels) == 32 / 63      # 32 of the 63 stated frames full
    assert 0.8 < bounds[1] < 1.0 and bounds[2] < 0.3
    assert np.isclose(bounds[3], (bounds[1] + bounds[2]) / 2)
    # nothing stated: nothing to bound against
    assert trust.pose_bounds(right, weight, np.full(6, UNLABELLED), pose[:6], strength[:6],
                             run[:6], np.arange(6)) == {}
