"""Slots: which actions act at one place, from the sequence and the footprints."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.trace import PICK, PLACE
from vggc_cp.vision import occupancy as occ
from vggc_cp.vision import slots


def test_the_sequence_pairs_a_pick_with_the_place_that_refills_its_slot():
    """Footprints that pair a pick with the wrong place (an arm's, not the object's) are
    overruled by the sequence: the twin alternates with the action in every episode; a
    candidate seen alternating too rarely, or when no candidate ever breaks the rule, leaves
    the choice to the pixels."""
    kinds = np.array([PICK, PICK, PLACE, PLACE], dtype=np.int8)
    wrong = np.array([[1, 0, .1, .6], [0, 1, .6, .1], [.1, .6, 1, 0], [.6, .1, 0, 1]])
    colour = np.zeros(4, dtype=np.int64)
    assert slots.twins(wrong, colour, kinds).tolist() == [3, 2, 1, 0]
    rng = np.random.default_rng(0)
    # two slots: 0/2 at one, 1/3 at the other, one object, random episodes
    actions, episodes, start = [], [], 0
    for _ in range(12):
        held_at, ep = int(rng.integers(2)), []
        for _ in range(int(rng.integers(3, 7))):
            ep += [held_at, 2 + (held_at := int(rng.integers(2)))]
        actions += ep + [-1]
        episodes.append((start, start + len(ep)))
        start += len(ep) + 1
    actions = np.array(actions[:-1])
    assert slots.sequence_twins(actions, episodes, wrong, colour, kinds).tolist() == [2, 3, 0, 1]
    # one short episode is too little evidence against the pixels
    few = np.array([0, 2, 1, 3])
    assert slots.sequence_twins(few, [(0, 4)], wrong, colour, kinds).tolist() == [3, 2, 1, 0]
    # other colours are never candidates: with the true twins in another colour, the only
    # candidate breaks the rule, and it is not taken whatever the pixels say
    two = np.array([0, 1, 1, 0])
    assert slots.sequence_twins(actions, episodes, wrong, two, kinds).tolist() == [-1] * 4


def test_a_pick_nothing_ever_alternates_with_keeps_the_pixels_twin():
    """Pick 0 once per episode, place 2 twice in a row in another, place 3 never: no
    neighbours alternate, so no candidate qualifies (no division by a zero rate) and the
    footprints decide among the candidates the sequence does not rule out. Place 2 twice in
    a row with no pick between rules out every pick as its twin, and pick 1's pixel twin."""
    kinds = np.array([PICK, PICK, PLACE, PLACE], dtype=np.int8)
    ov = np.array([[1, 0, .1, .5], [0, 1, .5, .1], [.1, .5, 1, 0], [.5, .1, 0, 1]])
    actions = np.array([0, -1, 2, 2])
    colour = np.zeros(4, dtype=np.int64)
    assert slots.twins(ov, colour, kinds).tolist() == [3, 2, 1, 0]
    out = slots.sequence_twins(actions, [(0, 1), (2, 4)], ov, colour, kinds)
    assert out.tolist() == [3, 3, -1, 0]


def test_the_pixels_twin_the_sequence_rules_out_is_not_taken():
    """Too few alternations for 20 to 1, but one candidate breaks the rule: the footprints
    decide among the candidates that never break it (an arm's footprint overlapping the
    wrong place's most is not the twin); where none of those overlaps, the one candidate
    the sequence leaves is the twin, and none where it leaves two."""
    kinds = np.array([PICK, PLACE, PLACE], dtype=np.int8)
    colour = np.zeros(3, dtype=np.int64)
    ov = np.array([[1, .07, .37], [.07, 1, 0], [.37, 0, 1]])
    # 0 and 1 alternate three times; 0 twice with no 2 between, and 2 twice in a row
    actions = np.array([0, 1, 0, 1, -1, 0, 2, 2])
    episodes = [(0, 4), (5, 8)]
    counts = slots.alternations(actions, slots.action_episodes(8, episodes), kinds, 0,
                                np.array([1, 2]))
    assert counts.tolist() == [[0, 3], [2, 1]] and not slots.qualifies(counts).any()
    assert slots.twins(ov, colour, kinds)[0] == 2                 # the pixels alone
    assert slots.sequence_twins(actions, episodes, ov, colour, kinds)[0] == 1
    far = ov.copy()
    far[0, 1] = far[1, 0] = 0.0
    assert slots.sequence_twins(actions, episodes, far, colour, kinds)[0] == 1
    # a third place that alternates with 0 as well: two candidates left, none overlapping
    kinds3 = np.array([PICK, PLACE, PLACE, PLACE], dtype=np.int8)
    ov3 = np.zeros((4, 4))
    ov3[0, 2] = ov3[2, 0] = 0.37
    two = np.array([0, 1, 3, 0, -1, 0, 2, 2])
    assert slots.alternations(two, slots.action_episodes(8, episodes), kinds3, 0,
                              np.array([1, 2, 3])).tolist() == [[0, 2], [2, 1], [0, 2]]
    assert slots.sequence_twins(two, episodes, ov3, np.zeros(4, dtype=np.int64),
                                kinds3)[0] == -1


def test_the_sequence_says_which_action_of_another_colour_shares_a_slot():
    """A red pair (0, 1) and a yellow pair (2, 3) at one slot, a yellow pair (4, 5) at another
    whose footprints overlap the first slot's (a footprint on an arm): the yellow pair
    elsewhere is placed while the slot holds red, which a slot of one thing cannot; the
    sequence rules it out and takes the pair that always agrees."""
    kinds = np.array([PICK, PLACE] * 3, dtype=np.int8)
    colour, twin = np.array([0, 0, 1, 1, 1, 1]), np.array([1, 0, 3, 2, 5, 4])
    on = np.isin(np.arange(6), [0, 1, 4, 5])
    ov = np.eye(6) + 0.5 * (on[:, None] & on[None, :])
    actions = np.array([0, 3, 2, 1, 5, 4, 0, 3, 2, 1] * 4)
    mates = slots.sequence_mates(actions, [(0, 40)], ov, colour, kinds, twin, 0.2)
    assert np.flatnonzero(mates[0]).tolist() == [2, 3]
    assert slots.acting_at(0, ov, colour, twin, 0.2, mates).tolist() == [0, 1, 2, 3]
    # the pixels alone would have taken the wrong pair
    assert slots.acting_at(0, ov, colour, twin, 0.2).tolist() == [0, 1, 4, 5]


def test_a_slot_has_one_mate_of_each_colour_and_kind():
    """A red pair (0, 1) and a yellow pair (2, 3) at the bottom slot of a stack, a yellow pair
    (4, 5) on top of it: the top's footprints overlap the bottom's (0.5, above the site
    bar), the bottom yellow pair's overlap more (0.8). Short episodes never meet, so the
    pixels decide: the bottom slot's yellow mates are 2 and 3 alone, and the top pair, whose
    red candidates already have their yellow mates, gets none."""
    kinds = np.array([PICK, PLACE] * 3, dtype=np.int8)
    colour, twin = np.array([0, 0, 1, 1, 1, 1]), np.array([1, 0, 3, 2, 5, 4])
    ov = np.full((6, 6), 0.5)
    ov[np.ix_([0, 1, 2, 3], [0, 1, 2, 3])] = 0.8
    ov[[4, 5], [5, 4]] = 0.8
    np.fill_diagonal(ov, 1.0)
    actions = np.array([0, 1, -1, 2, 3, -1, 4, 5])
    mates = slots.sequence_mates(actions, [(0, 2), (3, 5), (6, 8)], ov, colour, kinds, twin, 0.2)
    assert np.flatnonzero(mates[0]).tolist() == [2, 3]
    assert np.flatnonzero(mates[1]).tolist() == [2, 3]
    assert not mates[4].any() and not mates[5].any()
    assert slots.acting_at(0, ov, colour, twin, 0.2, mates).tolist() == [0, 1, 2, 3]
    # the pixels alone would have put the top pair at the bottom slot
    assert slots.acting_at(0, ov, colour, twin, 0.2).tolist() == [0, 1, 2, 3, 4, 5]


def test_a_chain_of_mates_does_not_join_two_levels_the_sequence_keeps_apart():
    """random-14 clean: a red pair (0, 1) and a yellow pair (2, 3) at level 0 of a region, a
    green pair (4, 5) at level 1 above them. Red and green never meet in an episode, so the
    pixels (0.6, above the site bar) make them mates; but yellow is placed and then green
    on top of it, which one slot of one thing cannot hold: the green pair is ruled out of
    the yellow pair's slot, so it is no mate of the red pair either, and the level-0 slot
    keeps red and yellow alone."""
    kinds = np.array([PICK, PLACE] * 3, dtype=np.int8)
    colour, twin = np.array([0, 0, 1, 1, 2, 2]), np.array([1, 0, 3, 2, 5, 4])
    ov = np.full((6, 6), 0.6)
    ov[np.ix_([0, 1, 2, 3], [0, 1, 2, 3])] = 0.8
    np.fill_diagonal(ov, 1.0)
    swap = [0, 3, 2, 1]                                 # red out, yellow in and out, red in
    stack = [3, 5, 4, 2]                                # yellow in, green on it, both out
    actions = np.array((swap + [-1] + stack + [-1]) * 3)[:-1]
    episodes = [(i * 10, i * 10 + 4) for i in range(3)] + [(i * 10 + 5, i * 10 + 9)
                                                          for i in range(3)]
    mates = slots.sequence_mates(actions, sorted(episodes), ov, colour, kinds, twin, 0.2)
    assert np.flatnonzero(mates[0]).tolist() == [2, 3]
    assert not mates[4].any() and not mates[5].any()
    assert slots.acting_at(0, ov, colour, twin, 0.2, mates).tolist() == [0, 1, 2, 3]
    assert occ.slot_groups(ov, colour, np.ones(6, int), twin, mates, 0.2).tolist() == \
        [0, 0, 0, 0, 1, 1]


def test_one_mate_per_colour_prefers_what_the_pixels_confirm():
    """Of two candidates of one colour and kind, one that the footprints put at the slot too
    beats one only the sequence names; among equals, the larger overlap."""
    kinds, colour = np.array([PICK, PICK, PICK]), np.array([0, 1, 1])
    ov = np.array([[1, .1, .6], [.1, 1, 0], [.6, 0, 1]])
    mates = np.array([[0, 1, 1], [1, 0, 0], [1, 0, 0]], dtype=bool)
    seen = mates & (ov >= 0.2)
    assert slots.one_per_colour(mates, seen, ov, colour, kinds)[0].tolist() == [False, False, True]
    nothing = np.zeros_like(mates)
    assert slots.one_per_colour(mates, nothing, ov, colour, kinds)[0].tolist() == [False, False,
                                                                                 True]
    # another kind or colour is another mate
    kinds2 = np.array([PICK, PICK, PLACE])
    assert slots.one_per_colour(mates, nothing, ov, colour, kinds2)[0].tolist() == [False, True,
                                                                                  True]


def test_a_place_whose_own_pick_was_never_taken_has_no_twin():
    """A red place (0) and pick (1) at the bottom of a stack and a red place on top (2) whose
    pick the trace never took: the footprints' nearest pick for 2 is 1, which pairs with 0
    both ways, so 2 has no twin, and its site's labels are its own place alone."""
    kinds = np.array([PLACE, PICK, PLACE], dtype=np.int8)
    colour = np.zeros(3, dtype=np.int64)
    ov = np.array([[1, .9, .5], [.9, 1, .5], [.5, .5, 1]])
    twin = slots.twins(ov, colour, kinds)
    assert twin.tolist() == [1, 0, 1]
    assert slots.exclusive_twins(twin).tolist() == [1, 0, -1]
    actions = np.array([0, -1, 2, -1, 1, 0])
    trace_twin = slots.sequence_twins(actions, [(0, 1), (2, 3), (4, 6)], ov, colour, kinds)
    assert slots.exclusive_twins(trace_twin)[2] == -1
    labels = occ.site_labels(actions, [(0, 1), (2, 3), (4, 6)],
                             slots.acting_at(2, ov, colour, slots.exclusive_twins(twin), 0.2),
                             kinds, colour)
    assert labels.tolist() == [-2, -2, -1, 0, -2, -2, -2]


def test_too_little_sequence_leaves_the_slot_to_the_pixels():
    """Two agreements are not 20:1: the candidates that never break the rule keep what the
    footprints say; one that breaks it is still ruled out."""
    kinds = np.array([PICK, PLACE] * 3, dtype=np.int8)
    colour, twin = np.array([0, 0, 1, 1, 1, 1]), np.array([1, 0, 3, 2, 5, 4])
    on = np.isin(np.arange(6), [0, 1, 4, 5])
    ov = np.eye(6) + 0.5 * (on[:, None] & on[None, :])
    actions = np.array([0, 3, 2, 1, 5, 4])
    mates = slots.sequence_mates(actions, [(0, 6)], ov, colour, kinds, twin, 0.2)
    assert not mates[0, [4, 5]].any()                # 1 leaves red, 5 finds the slot empty
    assert not mates[0, [2, 3]].any()                # too few to overrule the pixels (no overlap)
    # no candidate of another colour ever met: the footprints decide
    alone = slots.sequence_mates(np.array([0, 1, -1, 2, 3]), [(0, 2), (3, 5)], ov, colour,
                               kinds, twin, 0.2)
    np.testing.assert_array_equal(alone, (colour[:, None] != colour) & (ov >= 0.2))


def test_a_slot_s_mates_are_every_action_its_links_reach():
    """multifruit-2x3 randomized s262 (twenty-first draw, silent): at one region a red pair
    (0, 1) and a yellow pair (2, 3) never act next to each other in an episode, and of their
    footprints only the two picks overlap by the site bar (the objects' shapes differ, and
    the randomized look moves where each is put). The picks are mates and each pair is
    twins, so the four share one slot: the red place's mates are the yellow pick and place,
    not none (before, the place's site was read without the yellow pick that empties it)."""
    kinds = np.array([PICK, PLACE] * 2, dtype=np.int8)
    colour, twin = np.array([0, 0, 1, 1]), np.array([1, 0, 3, 2])
    ov = np.array([[1, .74, .25, .09], [.74, 1, .16, .03],
                   [.25, .16, 1, .65], [.09, .03, .65, 1]])
    actions = np.array([0, 1, -1, 2, 3])
    mates = slots.sequence_mates(actions, [(0, 2), (3, 5)], ov, colour, kinds, twin, 0.2)
    assert [np.flatnonzero(m).tolist() for m in mates] == [[2, 3], [2, 3], [0, 1], [0, 1]]
    assert slots.acting_at(1, ov, colour, twin, 0.2, mates).tolist() == [0, 1, 2, 3]


@pytest.mark.slow
def test_multifruit_2x3_randomized_s262_learns_the_true_graph():
    """The twenty-first draw's silent miss (session 39): the red place at region 2 had no
    mates, so its site's run was not cut where the yellow pick emptied the region, and a bare
    region was read full at trust 1.00 (13 nodes for 12, Exec 74 %, quiet)."""
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.sim.explore import generate

    trace = generate("multifruit-2x3", 95, 262, look="randomized").trace
    labels = learn_graph(trace.without_states()).labels
    np.testing.assert_array_equal(labels[:, None] == labels[None],
                                  trace.states[:, None] == trace.states[None])


def test_twins_are_mutual():
    """A place that names a pick its twin (the sequence settles it) makes that pick's twin
    the place, where the pick named none; a pick two places name stays without one."""
    assert slots.mutual_twins(np.array([-1, 0])).tolist() == [1, 0]
    assert slots.mutual_twins(np.array([-1, 0, 0])).tolist() == [-1, 0, 0]
    assert slots.mutual_twins(np.array([1, 0, -1])).tolist() == [1, 0, -1]


@pytest.mark.slow
def test_random_14_clean_keeps_each_level_of_a_region_its_own_slot(monkeypatch):
    """random-14 clean (three regions in a row, towers of two, four colours; tuning split,
    trace seed 0, 600 transitions): before the slots were kept consistent, level 0 and level 1
    of every region were one slot (mates chained through a pick that met neither in an
    episode), and the counts moved blocks onto regions read empty. Every slot the evidence
    groups now holds the actions of one region and one level (the names are read by the test
    only)."""
    import re

    from vggc_cp.sim.explore import generate
    from vggc_cp.vision import conservation
    from vggc_cp.vision.footprints import action_footprints

    trace = generate("random-14", 600, 0, size=64, look="clean").trace
    seen = {}

    def spy(*args, **kwargs):
        seen["slot"] = conservation.slot_groups(*args, **kwargs)
        return seen["slot"]

    monkeypatch.setattr(occ, "slot_groups", spy)
    action_footprints(trace.without_states())
    places = {}
    for a, s in enumerate(seen["slot"]):
        if s >= 0:
            region, level = re.search(r"_(\d+)_(\d+)$", trace.action_names[a]).groups()
            places.setdefault(int(s), set()).add((region, level))
    assert len(places) >= 5
    assert all(len(p) == 1 for p in places.values()), places


def test_one_pick_then_place_is_no_mate():
    """Red (0, 1) and yellow (2, 3) act at two slots: ten episodes put them side by side
    only in orders that break one slot (30 pairs, none agreeing). One episode has red's pick
    followed by blue's place (4, 5, a third slot, footprints apart): that pair agrees, at a
    rate of 1 in 31, which alone would make blue red's mate at 20 to 1; one pick then place
    is one coincidence of order, and two are asked."""
    kinds = np.array([PICK, PLACE] * 3)
    colour, twin = np.array([0, 0, 1, 1, 2, 2]), np.array([1, 0, 3, 2, 5, 4])
    actions, episodes, start = [], [], 0
    for seq in [[1, 3, 0, 2]] * 10 + [[1, 0, 5]]:
        episodes.append((start, start + len(seq)))
        actions += seq + [-1]
        start += len(seq) + 1
    actions = np.array(actions[:-1])
    out = slots.sequence_mates(actions, episodes, np.eye(6), colour, kinds, twin, 0.2)
    assert not out.any()
    assert slots.MIN_MATE_AGREEMENTS == 2


def test_a_pixels_twin_never_met_yields_to_one_seen_alternating():
    """Pick 0 and place 2 alternate once in each of two episodes, never broken; place 3,
    which the footprints pair with 0 (an arm's move under a pick taken twice), never shares
    an episode with it, and place 1 breaks the rule: the sequence's two alternations
    outweigh the pixels' choice, which it has nothing for. One alternation is not enough
    (any pick and place of one episode give it), and a pixels' choice met in an episode
    stands."""
    kinds = np.array([PICK, PLACE, PLACE, PLACE], dtype=np.int8)
    colour = np.zeros(4, dtype=np.int64)
    ov = np.array([[1, 0, .01, .4], [0, 1, 0, 0], [.01, 0, 1, 0], [.4, 0, 0, 1]])
    episodes = [(0, 2), (3, 5), (6, 8), (9, 10)]
    actions = np.array([2, 0, -1, 0, 2, -1, 1, 1, -1, 3])
    counts = slots.alternations(actions, slots.action_episodes(10, episodes), kinds, 0,
                                np.array([1, 2, 3]))
    assert counts.tolist() == [[1, 0], [0, 2], [0, 0]]
    assert not slots.qualifies(counts).any()                  # two are not 20 to 1
    assert slots.twins(ov, colour, kinds)[0] == 3
    assert slots.sequence_twins(actions, episodes, ov, colour, kinds)[0] == 2
    once = np.array([2, 0, -1, 0, 1, -1, 1, 1, -1, 3])        # one alternation only
    assert slots.sequence_twins(once, episodes, ov, colour, kinds)[0] == 3
    met = np.array([2, 0, -1, 0, 2, -1, 0, 3, -1, 3])         # 0 then 3 in one episode
    assert slots.sequence_twins(met, episodes, ov, colour, kinds)[0] == 3
    # the pixels' first choice broken (1), their nearest kept one (3) never met: the same
    broken = ov.copy()
    broken[0, 1] = broken[1, 0] = 0.5
    assert slots.twins(broken, colour, kinds)[0] == 1
    assert slots.sequence_twins(actions, episodes, broken, colour, kinds)[0] == 2
