"""How far a site's reading can be trusted (:mod:`vggc_cp.vision.trust`)."""

from __future__ import annotations

import numpy as np

from vggc_cp.vision import trust

UNLABELLED, EMPTY = -2, -1


def test_a_run_read_by_a_pose_few_stated_frames_show_is_trusted_little():
    """Two poses read every held-out frame right: pose 0 on 60 frames, pose 1 on 3. A run
    read by pose 0 is trusted for sure nearly as far as its kappa (1); one read by pose 1
    hardly at all; a run read by both rests on the frames of both, the few weighing as
    much as their share of the run's strength allows."""
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
    both = 2.0 ** 2 / (1 / 60 + 1 / 3)                  # frames the pooled share rests on
    assert np.isclose(bounds[3], trust.kappa_lower(1.0, 32 / 63, both))
    assert bounds[2] < bounds[3] < bounds[1]
    # nothing stated: nothing to bound against
    assert trust.pose_bounds(right, weight, np.full(6, UNLABELLED), pose[:6], strength[:6],
                             run[:6], np.arange(6)) == {}


def test_a_run_several_poses_read_rests_on_all_their_frames():
    """Four poses, each right on its 4 held-out frames: one alone is trusted little (its 4
    frames bound kappa 1 near 0.2), a run all four read equally rests on 16 frames. A pose
    that read no held-out frame counts as chance (kappa 0) and lowers the run it reads."""
    labels = np.array([0, EMPTY] * 8 + [UNLABELLED] * 5)
    pose = np.array([b for b in range(4) for _ in range(4)] + [0, 1, 2, 3, 4])
    weight = np.where(labels == UNLABELLED, 0.0, 1.0)
    right = labels != UNLABELLED
    loose = np.flatnonzero(labels == UNLABELLED)
    strength = np.ones(len(labels))
    alone = trust.pose_bounds(right, weight, labels, pose, strength, np.arange(len(labels)),
                              loose)
    run = np.array([0] * 16 + [1] * 4 + [2])
    together = trust.pose_bounds(right, weight, labels, pose, strength, run, loose)
    assert np.isclose(alone[16], trust.kappa_lower(1.0, 0.5, 4)) and alone[16] < 0.3
    assert alone[20] == 0.0                               # pose 4: no held-out frame
    assert np.isclose(together[1], trust.kappa_lower(1.0, 0.5, 16)) and together[1] > 0.6
    run[20] = 1                                           # pose 4 reads the run too
    mixed = trust.pose_bounds(right, weight, labels, pose, strength, run, loose)
    assert mixed[1] < together[1]
