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


def _column(centres):
    """Footprints of one pixel at each of ``centres`` (row, column), all overlapping."""
    maps = np.zeros((len(centres), 24, 24))
    for a, (r, c) in enumerate(centres):
        maps[a, r, c] = 1.0
    return maps, np.ones((len(centres), len(centres)))


def _runs(labels):
    return {a: (np.asarray(la), np.arange(len(la)), np.zeros(0, dtype=np.int64),
                np.array([a])) for a, la in enumerate(labels)}


def test_a_column_is_continued_by_one_more_step_where_no_frame_states_its_top():
    """Sites 0, 1, 2 stand one above the other, 5 px a level, the upper step a little
    shorter and turned (perspective, an arm in the footprint: cosine 0.97, ratio 0.82). Site 0
    is known below site 1 (the labels state both); site 2 is stated only in an episode that
    never acts at site 1 (blocks-3 robot s429): it stands on site 1. Site 3, a step off to
    the side, and site 4, three steps up, do not; nor does site 2 where a frame states both
    (the labels have had their say), where it is known to stand on another column's slot, or
    where the trusted reading of site 1 is empty where site 2 is stated full."""
    u, e = slots.UNLABELLED, slots.EMPTY
    maps, ov = _column([(20, 10), (15, 10), (11, 11), (15, 15), (0, 10)])
    labels = [[0, 0, 0, u, u, u], [e, 0, e, u, u, u], [u, u, u, e, 0, e],
              [u, u, u, e, 0, e], [u, u, u, e, 0, e]]
    runs = _runs(labels)
    assert stacks.column_steps({0: [1]}, runs, ov, 0.2, maps) == {0: [1], 1: [2]}
    assert stacks.column_steps({0: [1]}, runs, np.eye(5), 0.2, maps) == {0: [1]}   # apart
    both = _runs(labels[:2] + [[u, 0, u, e, 0, e]] + labels[3:])
    assert stacks.column_steps({0: [1]}, both, ov, 0.2, maps) == {0: [1]}
    assert stacks.column_steps({0: [1], 3: [2]}, runs, ov, 0.2, maps) == {0: [1], 3: [2]}
    presence, trust = np.ones((6, 5)), np.full((6, 5), 0.9)
    assert stacks.column_steps({0: [1]}, runs, ov, 0.2, maps, presence, trust) == \
        {0: [1], 1: [2]}
    presence[3:, 1] = 0.0                     # read empty, trusted, under a full site 2
    assert stacks.column_steps({0: [1]}, runs, ov, 0.2, maps, presence, trust) == {0: [1]}
    trust[3:, 1] = 0.3                        # the same reading, untrusted: no say
    assert stacks.column_steps({0: [1]}, runs, ov, 0.2, maps, presence, trust) == \
        {0: [1], 1: [2]}


def test_a_continued_column_is_continued_again():
    """A fourth level (site 3) one more step above the continued third (site 2), stated in
    other frames, stands on it: the steps go on while each is one of the column's. Two steps
    at once are no step (a skipped level: ratio 2 > 1.5): site 3 is not put on site 1."""
    u, e = slots.UNLABELLED, slots.EMPTY
    maps, ov = _column([(20, 10), (15, 10), (10, 10), (5, 10)])
    runs = _runs([[0, 0, 0, u, u, u, u, u], [e, 0, e, u, u, u, u, u],
                  [u, u, u, e, 0, u, u, u], [u, u, u, u, u, e, 0, e]])
    assert stacks.column_steps({0: [1]}, runs, ov, 0.2, maps) == {0: [1], 1: [2], 2: [3]}
