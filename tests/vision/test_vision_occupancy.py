"""Presence of many looks: labels stated by the trace's actions, nearest looks, stacked sites."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vggc_cp.recorded import RecordedFacts
from vggc_cp.trace import PICK, PLACE, load_trace
from vggc_cp.vision import occupancy as occ
from vggc_cp.vision import slots
from vggc_cp.vision.footprints import action_footprints, overlaps
from vggc_cp.vision.working import normalise_frames

DATA = Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz"


def test_the_actions_state_what_a_site_holds_between_them():
    # actions: 0 pick red at s, 1 place red at s, 2 pick yellow at s, 3 acts elsewhere
    kinds = np.array([PICK, PLACE, PICK, PLACE], dtype=np.int8)
    colour = np.array([0, 0, 1, 0])
    acting = np.array([0, 1, 2])
    # episode 1: o0 -3-> o1 -0-> o2 -3-> o3 -1-> o4 ; episode 2: o5 -3-> o6 (nothing at s);
    # episode 3: o7 -2-> o8 -2-> o9 (two picks in a row: a contradiction)
    actions = np.array([3, 0, 3, 1, -1, 3, -1, 2, 2])
    episodes = [(0, 4), (5, 6), (7, 9)]
    lab = occ.site_labels(actions, episodes, acting, kinds, colour)
    assert lab.tolist() == [0, 0, slots.EMPTY, slots.EMPTY, 0,
                            occ.UNLABELLED, occ.UNLABELLED,
                            occ.UNLABELLED, occ.UNLABELLED, occ.UNLABELLED]


def _reset_trace():
    # actions: 0 pick red at s, 1 place red at s, 2 acts elsewhere (a pick), 3 acts elsewhere
    # (a place); episode 1: o0 -2-> o1 -3-> o2 (nothing at s); episode 2: o3 -0-> o4 (picks
    # red at s: s held red at o3); episode 3: o5 -2-> o6 (nothing at s)
    kinds = np.array([PICK, PLACE, PICK, PLACE], dtype=np.int8)
    colour = np.array([0, 0, 1, 1])
    actions = np.array([2, 3, -1, 0, -1, 2])
    return kinds, colour, actions, [(0, 2), (3, 4), (5, 6)], np.array([0, 1])


def test_a_reset_carries_what_the_actions_state_to_an_episode_that_never_acts_there():
    kinds, colour, actions, episodes, acting = _reset_trace()
    alone = occ.site_labels(actions, episodes, acting, kinds, colour)
    assert alone[:3].tolist() == [occ.UNLABELLED] * 3
    # episode 2 was recorded from the state of o0: s held red there, in all of episode 1
    facts = RecordedFacts(resets=((0, 3),))
    lab = occ.site_labels(actions, episodes, acting, kinds, colour, facts)
    assert lab.tolist() == [0, 0, 0, 0, slots.EMPTY, occ.UNLABELLED, occ.UNLABELLED]
    # and on through a chain of resets between episodes that never act there
    chain = RecordedFacts(resets=((0, 3), (1, 5)))
    lab = occ.site_labels(actions, episodes, acting, kinds, colour, chain)
    assert lab[5:].tolist() == [0, 0]
    # a reset never overrides what an episode's own actions state
    back = RecordedFacts(resets=((4, 0),))
    lab = occ.site_labels(actions, episodes, acting, kinds, colour, back)
    assert lab[:5].tolist() == [slots.EMPTY] * 3 + [0, slots.EMPTY]


def test_a_refused_action_states_what_the_site_holds_only_where_one_value_is_left():
    kinds, colour, actions, episodes, acting = _reset_trace()
    # a place at s refused at o0 (a pick role: the hand's reason, nothing ruled out)
    wrong_role = RecordedFacts(refusals=((0, 1),))
    lab = occ.site_labels(actions, episodes, acting, kinds, colour, wrong_role, refusals=True)
    assert lab[:3].tolist() == [occ.UNLABELLED] * 3
    # a red place at s refused at o1 (a place role) with a yellow in hand (o0 -2-> o1
    # lifted it): the hand's colour explains it, nothing ruled out
    taken = RecordedFacts(refusals=((1, 1),))
    lab = occ.site_labels(actions, episodes, acting, kinds, colour, taken, refusals=True)
    assert lab[:3].tolist() == [occ.UNLABELLED] * 3
    # with a red in hand: s is taken, and only red acts there
    red = np.array([0, 0, 0, 0])
    lab = occ.site_labels(actions, episodes, acting, kinds, red, taken, refusals=True)
    assert lab[:3].tolist() == [0, 0, 0]
    # the caller decides whether refusals count (a site in a stack: they do not)
    lab = occ.site_labels(actions, episodes, acting, kinds, red, taken)
    assert lab[:3].tolist() == [occ.UNLABELLED] * 3
    # a refused red pick at o5 leaves empty (episode 3 only), not at a site it does not act at
    lab = occ.site_labels(actions, episodes, acting, kinds, colour,
                          RecordedFacts(refusals=((5, 0), (0, 2))), refusals=True)
    assert lab.tolist()[5:] == [slots.EMPTY, slots.EMPTY]
    assert lab[:3].tolist() == [occ.UNLABELLED] * 3


def test_recorded_facts_are_written_after_the_reading_and_refusals_skip_stacks():
    kinds, colour, actions, episodes, acting = _reset_trace()
    labels = occ.site_labels(actions, episodes, acting, kinds, colour)
    n, n_act = len(actions) + 1, len(kinds)
    presence = np.full((n, n_act), 0.3)
    posterior = np.full((n, n_act, 2), 0.5)
    stated = labels[:, None] != occ.UNLABELLED
    stated = np.repeat(stated, n_act, axis=1)
    trust = stated.astype(float)
    runs = {0: (labels.copy(), np.zeros(n, int), np.flatnonzero(~stated[:, 0]), acting)}
    facts = RecordedFacts(resets=((0, 3),), refusals=((5, 0),))
    occ.recorded_labels(runs, {}, facts, actions, episodes, kinds, colour, presence,
                        posterior, stated, trust)
    # episode 1 takes what o3 holds (red), episode 3 is empty (its red pick was refused)
    assert stated[:, 0].tolist() == [True] * n
    assert presence[:, 0].tolist() == [1.0, 1.0, 1.0, 0.3, 0.3, 0.0, 0.0]
    assert posterior[0, 0].tolist() == [1.0, 0.0] and trust[5, 0] == 1.0
    # site 0 with a slot stacked on it: the reset still holds, the refusal says nothing
    presence[:], stated[:] = 0.3, np.repeat(labels[:, None] != occ.UNLABELLED, n_act, axis=1)
    runs = {0: (labels.copy(), np.zeros(n, int), np.flatnonzero(~stated[:, 0]), acting)}
    occ.recorded_labels(runs, {0: [2]}, facts, actions, episodes, kinds, colour, presence,
                        posterior, stated, trust)
    assert stated[:, 0].tolist() == [True] * 5 + [False] * 2


def test_a_refusal_that_leaves_two_values_keeps_the_reading_off_the_one_it_ruled_out():
    """Red and yellow are played at s (action 4 places a yellow there): a refused red pick at
    o5 leaves empty or yellow -- no label, but episode 3 may no longer read red there
    (multifruit-2x3 robot s349, draw 36: an episode read a red one place off, and the four
    probes of its doubt, all refused, stated nothing the reading had to respect)."""
    kinds, colour, actions, episodes, _ = _reset_trace()
    kinds, colour = np.append(kinds, PLACE).astype(np.int8), np.append(colour, 1)
    acting = np.array([0, 1, 4])
    facts = RecordedFacts(refusals=((5, 0),))
    gone: dict = {}
    lab = occ.site_labels(actions, episodes, acting, kinds, colour, facts, refusals=True,
                          ruled_out=gone)
    assert lab[5:].tolist() == [occ.UNLABELLED] * 2 and gone == {2: {0}}
    # read red in episodes 1 and 3: episode 3 turns to yellow, episode 1 is left alone
    labels = occ.site_labels(actions, episodes, acting, kinds, colour)
    n, n_act = len(actions) + 1, len(kinds)
    presence = np.full((n, n_act), 0.9)
    posterior = np.tile(np.array([0.8, 0.2]), (n, n_act, 1))
    stated = np.repeat((labels != occ.UNLABELLED)[:, None], n_act, axis=1)
    runs = {0: (labels.copy(), np.zeros(n, int), np.flatnonzero(~stated[:, 0]), acting)}
    occ.recorded_labels(runs, {}, facts, actions, episodes, kinds, colour, presence,
                        posterior, stated, stated.astype(float))
    assert posterior[5:, 0].tolist() == [[0.0, 1.0]] * 2 and presence[5, 0] == 0.9
    assert posterior[:3, 0].tolist() == [[0.8, 0.2]] * 3 and not stated[5:, 0].any()
    # the same refusal where only red is played at s states the site empty, as before
    only_red = occ.site_labels(actions, episodes, np.array([0, 1]), kinds, colour, facts,
                               refusals=True, ruled_out=(none := {}))
    assert only_red[5:].tolist() == [slots.EMPTY] * 2 and none == {}


def test_a_refused_pick_rules_nothing_out_where_another_pick_there_shares_its_colour():
    kinds, colour, actions, episodes, acting = _reset_trace()
    # action 4: a pick of another shape of red at s (same colour 0): the site may hold that
    kinds, colour = np.append(kinds, PICK).astype(np.int8), np.append(colour, 0)
    facts = RecordedFacts(refusals=((5, 0),))
    lab = occ.site_labels(actions, episodes, np.array([0, 1, 4]), kinds, colour, facts,
                          refusals=True)
    assert lab[5:].tolist() == [occ.UNLABELLED] * 2


def test_twins_actions_at_a_site_and_stacked_sites():
    # 0 pick red at p, 1 place red at p, 2 place red at q (above p), 3 place yellow at p,
    # 4 pick red at q
    ov = np.array([[1.0, 0.9, 0.3, 0.6, 0.3],
                   [0.9, 1.0, 0.3, 0.6, 0.3],
                   [0.3, 0.3, 1.0, 0.0, 0.9],
                   [0.6, 0.6, 0.0, 1.0, 0.0],
                   [0.3, 0.3, 0.9, 0.0, 1.0]])
    colour = np.array([0, 0, 0, 1, 0])
    kinds = np.array([PICK, PLACE, PLACE, PLACE, PICK], dtype=np.int8)
    twin = slots.twins(ov, colour, kinds)
    assert twin.tolist() == [1, 0, 4, -1, 2]
    assert slots.acting_at(0, ov, colour, twin, 0.2).tolist() == [0, 1, 3]
    assert slots.acting_at(3, ov, colour, twin, 0.2).tolist() == [0, 1, 3]
    assert occ.stacked(ov, colour, twin, 0.2).tolist() == [True, True, True, False, True]
    # apart (overlap below site_overlap) nothing is stacked
    assert not occ.stacked(ov, colour, twin, 0.5).any()


def _two_look_site(rng, n_episodes=30, per=6):
    """A site whose empty look is one of two (nothing there, or a dark block below) and
    whose occupied look is bright; labels for the even episodes only."""
    n = n_episodes * per
    episode = np.repeat(np.arange(n_episodes), per)
    truth = rng.integers(0, 2, n).astype(bool)
    below = rng.integers(0, 2, n).astype(bool)
    px = np.zeros((n, 8, 3), dtype=np.float32)
    px[below & ~truth, :4] = 0.6                    # the block below shows in half the site
    px[truth] = 1.0
    px += 0.05 * rng.standard_normal(px.shape).astype(np.float32)
    labels = np.where(truth, 0, slots.EMPTY)
    labels[episode % 2 == 1] = occ.UNLABELLED
    return px, np.full(8, 1 / 8), labels, episode, truth


def test_nearest_looks_know_every_empty_look():
    rng = np.random.default_rng(0)
    px, w, labels, episode, truth = _two_look_site(rng)
    f = occ.site_features(px, w)
    p = occ.look_presence(f, labels, episode)
    assert p.min() >= 0 and p.max() <= 1
    assert np.all((p >= 0.5) == truth)              # unlabelled episodes included
    # the mean of the empties (what one template compares with) sits between the two looks
    mean_empty = px[labels == slots.EMPTY].mean(axis=0)
    dev = np.abs(px - mean_empty).sum(-1) @ w
    assert dev[~truth & ~(px[:, 0, 0] > 0.3)].mean() > 0.2
    # a label of one kind only, or too few, teaches nothing
    assert occ.look_presence(f, np.where(truth, 0, occ.UNLABELLED), episode) is None
    # the references of a labelled observation come from other episodes
    d = occ.nearest_looks(f, np.arange(6), episode)
    assert np.all(np.isinf(d[:6])) and np.all(np.isfinite(d[6:]))


def test_looks_that_do_not_separate_give_nothing():
    rng = np.random.default_rng(1)
    px, w, labels, episode, _ = _two_look_site(rng)
    shuffled = labels.copy()
    known = shuffled != occ.UNLABELLED
    shuffled[known] = rng.permutation(shuffled[known])
    out = occ.look_presence(occ.site_features(px, w), shuffled, episode)
    assert out is None or np.mean((out[known] >= 0.5) == (labels[known] >= 0)) < 0.75


def test_side_by_side_sites_keep_the_hand_made_presence():
    """Nothing on the shipped fruit trace is stacked: the presence is the hand-made one."""
    trace = load_trace(DATA).without_states()
    fp = action_footprints(trace)
    ov = overlaps(fp.maps)
    kinds = trace.action_kinds()
    twin = slots.twins(ov, fp.colour, kinds)
    assert not occ.stacked(ov, fp.colour, twin, 0.2).any()
    p, refined = occ.refine_presence(trace, normalise_frames(trace.observations), fp.sites, ov,
                                     fp.colour, fp.counts, fp.presence, 0.2)
    assert not refined.any() and np.array_equal(p, fp.presence)


def test_settled_sites_are_what_the_actions_state_even_where_a_frame_hides_them():
    """Paste an opaque grey square (an arm, a distractor) over a random spot of the table in
    every third frame: where an episode's actions state what a site holds, the settled
    presence is that, whatever the frame shows; the learned graph stays the true one."""
    from pathlib import Path

    from vggc_cp.learned import LearnConfig
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.trace import Trace, load_trace
    from vggc_cp.vision.footprints import action_footprints

    tr = load_trace(Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz")
    obs = tr.observations.copy()
    rng = np.random.default_rng(0)
    for t in range(0, len(obs), 3):
        y, x = rng.integers(24, 40), rng.integers(4, 50)
        obs[t, y:y + 10, x:x + 10] = 200
    hidden = Trace(obs, tr.actions, tr.action_names, tr.states, tr.meta)
    fp = action_footprints(hidden)
    # every site of a pick: occupied right before the pick, empty right after it
    src, act, dst = hidden.transitions()
    kinds = hidden.action_kinds()
    for s, a, d in zip(src, act, dst):
        if kinds[a] == 0:
            assert fp.presence[s, a] == 1.0 and fp.presence[d, a] == 0.0
    learned = learn_graph(hidden.without_states(), LearnConfig(evidence="footprints"))
    same = learned.labels[:, None] == learned.labels[None, :]
    np.testing.assert_array_equal(same, tr.states[:, None] == tr.states[None, :])


def test_a_footprint_presence_no_better_than_the_majority_is_not_a_reading():
    """A site whose footprint presence agrees with its labelled frames no more often than
    saying what most of them hold (stacked sites of several colours, a site under an arm)
    gives its unread runs that majority; a better presence keeps its own reading; a site no
    frame of which is labelled keeps it too."""
    mostly_full = np.array([0, 0, 0, 1, slots.EMPTY, occ.UNLABELLED])
    assert occ.majority_guess(0.8, mostly_full) == 1.0          # 4 of 5 occupied: 0.8
    assert occ.majority_guess(0.81, mostly_full) is None
    assert occ.majority_guess(0.6, np.array([slots.EMPTY] * 3 + [0])) == 0.0
    assert occ.majority_guess(0.0, np.full(4, occ.UNLABELLED)) is None


def _same_partition(labels: np.ndarray, states: np.ndarray) -> bool:
    return bool(np.array_equal(labels[:, None] == labels[None], states[:, None] == states[None]))


def test_a_reading_judged_on_the_one_episode_that_taught_it_is_not_trusted():
    """blocks-2 randomized, trace seed 99: only one episode acts at the slot above region 1,
    always with a block below it, and the footprint presence agrees with every frame that
    episode states (kappa 1 on them) while it reads a block in the air wherever region 1 is
    bare. Judged on the one episode that taught it, its kappa says nothing of the others: it
    is 0, the object counts decide those frames, and the graph is the true one (12 nodes for
    9 states when it was trusted). Sites stated in several episodes keep their kappa."""
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.sim.explore import generate

    trace = generate("blocks-2", 95, 99, size=64, look="randomized").trace
    blind = trace.without_states()
    fp = action_footprints(blind)
    names = list(trace.action_names)
    above = [names.index("pick_1_1"), names.index("place_1_1")]
    episode = trace.episode_index()
    acting = np.isin(trace.actions, above)
    assert len(np.unique(episode[:-1][acting])) == 1         # one episode acts there
    assert np.all(fp.kappa[above] == 0.0)
    assert fp.kappa[names.index("pick_2_0")] > 0.9
    # the slot above region 1 and the one under it are stacked, and the sites say so
    assert fp.stacked[above].all() and fp.stacked[names.index("pick_1_0")]
    assert _same_partition(learn_graph(blind).labels, trace.states)


def test_a_robot_trace_whose_footprints_pair_the_wrong_places_is_learned_right():
    """fruit-2x3 robot, 50 transitions, trace seed 101: the arm makes pick_red_1's
    footprint overlap place_red_2's most, but the two break the slot's alternation once
    (:func:`vggc_cp.vision.slots.sequence_twins`): the twin is the unbroken place_red_1,
    and the graph is the true one (8 nodes for 6 states with the pixels' twin)."""
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.sim.explore import generate

    trace = generate("fruit-2x3", 50, 101, size=64, look="robot").trace
    blind = trace.without_states()
    names = list(trace.action_names)
    ov = overlaps(action_footprints(blind).maps)
    pick1 = names.index("pick_red_1")
    assert ov[pick1, names.index("place_red_2")] > ov[pick1, names.index("place_red_1")]
    colour = np.zeros(trace.n_actions, dtype=np.int64)
    twin = slots.action_twins(blind, ov, colour)
    assert twin[pick1] == names.index("place_red_1")
    assert _same_partition(learn_graph(blind).labels, trace.states)


@pytest.mark.slow
def test_a_run_no_pose_reads_is_trusted_as_the_guess_it_took_and_its_episode_doubted():
    """fruit-2x3 robot, 50 transitions, trace seed 102: in the episode of observations
    41-50 the hand only acts at region 0, and the arm above it hides regions 1 and 2; no pose
    reads region 2 there, so its run takes the majority guess (trust 0). Until session 28 the
    site's pose reading elsewhere agreed with the stated frames perfectly (kappa 1) and the
    episode was dismissed as settled (six nodes for six states, Exec 63 %, quiet); since
    poses count their looks once per episode that reading is none (kappa 0). Either way the
    run's trust is the guess's, an episode is a doubt, and the graph is flagged."""
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.sim.explore import generate

    trace = generate("fruit-2x3", 50, 102, size=64, look="robot").trace
    blind = trace.without_states()
    fp = action_footprints(blind)
    site = list(trace.action_names).index("pick_red_2")
    assert np.all(fp.trust[41:51, site] == 0.0) and np.all(~fp.stated[41:51, site])
    learned = learn_graph(blind)
    assert not _same_partition(learned.labels, trace.states)
    assert learned.confidence.suspect
    assert any(r.startswith("the episode of observations") for r in learned.confidence.reasons)


def test_a_level_one_slot_filled_in_one_episode_is_not_read_full_over_a_bare_region():
    """random-3 clean (a red brick and a blue cube, eight regions, towers of three; 176
    transitions): level 1 of region 0 is stated in two episodes only, which never act at
    level 0, and its reading (kappa 1 on those) was full in 179 of the 205 frames it is
    unstated, 143 of them over a bare region: 55 nodes for 49 states. The trusted reading of
    level 0 shows the stack, nothing stands in the air, and the graph is the true one."""
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.sim.explore import generate

    trace = generate("random-3", 176, 0, size=64, look="clean").trace
    assert _same_partition(learn_graph(trace.without_states()).labels, trace.states)


@pytest.mark.slow
@pytest.mark.parametrize("seed, top", [(429, "pick_0_2"), (425, "pick_2_2")])
def test_a_column_top_no_episode_states_with_the_level_below_stands_on_it(seed, top):
    """blocks-3 robot, 200 transitions, trace seeds 425 and 429 (draws 48 and 49, the two
    silent misses of session 53): the episodes that act at one region's third level start
    there with two blocks in the column and loop a place and a pick on top, so no frame
    states the top slot with the level below, and nothing said that one stands on the
    other. The arm's held block over region 0 read as a block there (s425), the level below
    read empty (s429, kappa 0): whole episodes went one block off, quietly (17 nodes for 16
    states, and 16 with two nodes holding two states each). The footprints continue the
    column's known stack by one step (:func:`vggc_cp.vision.stacks.column_steps`), the
    slot below is full wherever the top is, and the graph is the true one."""
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.sim.explore import generate

    trace = generate("blocks-3", 200, seed, size=64, look="robot").trace
    blind = trace.without_states()
    assert action_footprints(blind).stacked[list(trace.action_names).index(top)]
    assert _same_partition(learn_graph(blind).labels, trace.states)
