"""Stacks: which slot stands on which, from the labels, the footprints, the sequence and
trusted readings (:mod:`vggc_cp.vision.stacks`)."""

from __future__ import annotations

import numpy as np

from vggc_cp.vision import slots, stacks


def test_the_sequence_alone_can_show_a_stack():
    """Site 1 is filled in four separate runs, each while site 0 is full, and site 0 is full
    in a quarter of its stated frames: (1/q)^k = 4^4 = 256 to 1 for a stack. Their footprints
    do not overlap (an arm hides the block below), yet site 1 is above site 0; filled twice,
    it is not (16 < 20)."""
    la = np.array([0, 0] * 4 + [slots.EMPTY] * 24)
    lb = np.array([0, slots.EMPTY] * 4 + [slots.EMPTY] * 24)
    run = np.arange(len(la))
    assert stacks.sequence_stacked(la, lb, run)
    ov = np.eye(2)
    runs = {0: (la, run, np.zeros(0, dtype=np.int64), np.array([0])),
            1: (lb, run, np.zeros(0, dtype=np.int64), np.array([1]))}
    assert stacks.slots_above(runs, ov, 0.5) == {0: [1]}
    lb2 = np.array([0, slots.EMPTY] * 2 + [slots.EMPTY] * 28)
    la2 = np.array([0, 0] * 2 + [slots.EMPTY] * 4 + [0] * 4 + [slots.EMPTY] * 20)
    assert not stacks.sequence_stacked(la2, lb2, run)


def test_a_trusted_reading_of_the_slot_below_shows_a_stack_the_actions_never_state():
    """Site 1 (an upper slot) is filled in one run of an episode that never acts at site 0,
    the slot below: no frame states both, so the actions alone show no stack. Site 0's
    reading, trusted (kappa 0.9), is full wherever site 1 is stated full and full with site 1
    empty too: site 1 is above site 0. Site 1's own reading, full in nearly every frame, would
    make site 0 stacked on it, at lower odds ((1/q)^k: q = 6/8 against site 0's 5/8): the
    stack goes one way. Footprints apart show no stack, nor does an untrusted reading (kappa
    0.3)."""
    u, e = slots.UNLABELLED, slots.EMPTY
    # episode 0 (frames 0-3) acts at site 0 only; episode 1 (frames 4-7) at site 1 only
    la = np.array([0, e, e, e, u, u, u, u])
    lb = np.array([u, u, u, u, e, 0, 0, e])
    run = np.array([0, 1, 1, 1, 2, 3, 3, 4])
    runs = {0: (la, run, np.arange(4, 8), np.array([0])),
            1: (lb, run, np.arange(4), np.array([1]))}
    ov = np.array([[1.0, 0.5], [0.5, 1.0]])
    assert stacks.slots_above(runs, ov, 0.2) == {}
    presence = np.ones((8, 2))
    presence[1:4, 0] = 0.0
    trust = np.full((8, 2), 0.9)
    assert stacks.slots_above(runs, ov, 0.2, presence, trust) == {0: [1]}
    assert stacks.slots_above(runs, np.eye(2), 0.2, presence, trust) == {}   # apart
    assert stacks.slots_above(runs, ov, 0.2, presence, np.full((8, 2), 0.3)) == {}
