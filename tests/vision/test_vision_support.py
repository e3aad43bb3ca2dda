"""Objects rest on something (vggc_cp.vision.support): nothing is read in the air."""

from __future__ import annotations

import numpy as np

from vggc_cp.vision.support import fillings, supported

#: two sites per slot (a pick and a place), three slots stacked: 0 at the bottom
SLOT = np.array([0, 0, 1, 1, 2, 2])
#: the pick at slot 1 and the place at slot 2 stand on the place below them (as
#: vggc_cp.vision.stacks.slots_above reports stacks: site -> sites on it)
ABOVE = {1: [2, 3], 3: [4, 5]}


def _slots(values):
    """(N, 3) slot presences -> (N, 6) site presences."""
    return np.repeat(np.asarray(values, dtype=float), 2, axis=1)


def test_a_tower_is_filled_from_the_bottom_and_two_tops_need_their_base():
    assert fillings({1: {0}, 2: {1}}, [0, 1, 2]).astype(int).tolist() == \
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [1, 1, 1]]
    both = fillings({1: {0}, 2: {0}}, [0, 1, 2]).astype(int).tolist()
    assert sorted(both) == [[0, 0, 0], [1, 0, 0], [1, 0, 1], [1, 1, 0], [1, 1, 1]]


def test_readings_with_nothing_in_the_air_stay_as_read():
    presence = _slots([[1, 1, 0], [1, 0, 0], [0, 0, 0], [1, 1, 1]]) * 0.9
    trust = np.full(presence.shape, 0.5)
    out, changed = supported(presence, trust, np.zeros(presence.shape, bool), SLOT, ABOVE)
    assert changed == 0 and np.array_equal(out, presence)


def test_the_less_trusted_reading_gives_way():
    """Slot 1 read full above an empty slot 0: with slot 0 trusted more, slot 1 is emptied;
    with slot 1 trusted more, slot 0 is filled. Both sites of a slot change together."""
    presence = _slots([[0, 1, 0], [0, 1, 0]])
    trust = np.repeat(np.array([[0.9, 0.3, 0.9], [0.3, 0.9, 0.9]]), 2, axis=1)
    out, changed = supported(presence, trust, np.zeros(presence.shape, bool), SLOT, ABOVE)
    assert changed == 2
    assert out[0].tolist() == [0, 0, 0, 0, 0, 0]
    assert out[1].tolist() == [1, 1, 1, 1, 0, 0]


def test_a_stated_reading_is_a_fact():
    """Slot 0 stated empty (its trust no matter): slot 1 and 2, read full at kappa 0.99, are
    emptied; slot 2 stated full: the slots under it are filled."""
    presence = _slots([[0, 1, 1], [0, 0, 1]])
    trust = np.full(presence.shape, 0.99)
    trust[:, 0:2] = 0.0
    stated = np.zeros(presence.shape, bool)
    stated[0, 0:2] = True
    stated[1, 4:6] = True
    out, changed = supported(presence, trust, stated, SLOT, ABOVE)
    assert out[0].tolist() == [0] * 6 and out[1].tolist() == [1] * 6 and changed == 4


def test_no_stack_no_change():
    presence = _slots([[0, 1, 1]])
    out, changed = supported(presence, np.ones(presence.shape), np.zeros(presence.shape, bool),
                             SLOT, {})
    assert changed == 0 and np.array_equal(out, presence)


def test_a_slots_pick_and_place_read_apart_take_the_stacks_filling():
    """Slot 2's place read full at kappa 0.14 and its pick empty above an empty slot 1 (their
    mean says empty, the place alone says full): both sites empty, as the stack has it."""
    presence = np.array([[1.0, 1.0, 0.2, 0.0, 0.0, 0.52]])
    trust = np.array([[0.9, 0.9, 0.66, 0.68, 0.0, 0.14]])
    out, changed = supported(presence, trust, np.zeros(presence.shape, bool), SLOT, ABOVE)
    assert out[0, 4:].tolist() == [0.0, 0.0] and changed == 1
    assert out[0, :4].tolist() == [1.0, 1.0, 0.2, 0.0]     # as read: nothing in the air there


def test_an_untouched_slot_holds_one_thing_all_episode():
    """Slot 1 is untouched for the whole episode (read full throughout, kappa 0.8) while the
    actions empty slot 0 below it in frame 0 and fill it in frame 1. Frame by frame only
    frame 0 is wrong; over the episode, slot 1 cannot hold anything in any frame."""
    presence = _slots([[0, 1, 0], [1, 1, 0], [1, 1, 0]])
    trust = np.full(presence.shape, 0.8)
    stated = np.zeros(presence.shape, bool)
    stated[:, 0:2] = True
    per_frame, changed = supported(presence, trust, stated, SLOT, ABOVE)
    assert changed == 1 and per_frame[:, 2].tolist() == [0, 1, 1]
    whole, changed = supported(presence, trust, stated, SLOT, ABOVE, [(0, 2)])
    assert changed == 3 and whole[:, 2:4].tolist() == [[0, 0]] * 3
    # two episodes: the second, whose base is full throughout, keeps its reading
    presence = np.concatenate([presence, _slots([[1, 1, 0], [1, 1, 0]])])
    trust = np.full(presence.shape, 0.8)
    stated = np.zeros(presence.shape, bool)
    stated[:, 0:2] = True
    out, changed = supported(presence, trust, stated, SLOT, ABOVE, [(0, 2), (3, 4)])
    assert changed == 3 and out[:, 2].tolist() == [0, 0, 0, 1, 1]


def test_a_base_the_actions_fill_above_holds_all_episode():
    """The actions put something on slot 2 in frame 1; slots 0 and 1, untouched and read
    empty (kappa 0.6), hold something all episode."""
    presence = _slots([[0, 0, 0], [0, 0, 1], [0, 0, 0]])
    trust = np.full(presence.shape, 0.6)
    stated = np.zeros(presence.shape, bool)
    stated[:, 4:6] = True
    out, changed = supported(presence, trust, stated, SLOT, ABOVE, [(0, 2)])
    assert out[:, :4].tolist() == [[1.0] * 4] * 3 and changed == 6


def test_a_frame_whose_facts_contradict_each_other_leaves_the_others_decided():
    """Frame 1 states slot 1 full above a slot 0 stated empty (a misread fact): no filling
    fits it and it stays as it is; the episode's other frames still lose slot 2, read full
    (kappa 0.3) above an empty slot 1."""
    presence = _slots([[1, 0, 1], [0, 1, 0], [1, 0, 1]])
    trust = np.full(presence.shape, 0.3)
    stated = np.zeros(presence.shape, bool)
    stated[:, 0:4] = True
    out, changed = supported(presence, trust, stated, SLOT, ABOVE, [(0, 2)])
    assert out[1].tolist() == presence[1].tolist()
    assert out[[0, 2], 4:6].tolist() == [[0, 0], [0, 0]] and changed == 2
