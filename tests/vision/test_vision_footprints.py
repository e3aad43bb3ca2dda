"""Action footprints: where the trace's actions change the scene, and the distance they give."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import shuffled_within_roles

from vggc_cp.errors import VggcError
from vggc_cp.trace import PICK, PLACE, Trace, load_trace
from vggc_cp.vision.footprints import (
    FootprintConfig,
    action_footprints,
    footprint_distances,
    overlaps,
    site_maps,
)
from vggc_cp.vision.holdings import site_readings
from vggc_cp.vision.working import normalise_frames

DATA = Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz"


@pytest.fixture(scope="module")
def shipped():
    return load_trace(DATA)


def _per_role(trace, dists):
    roles = trace.roles()
    return [(trace.states[roles == r], d) for r, d in zip((PICK, PLACE), dists)]


def test_footprints_of_one_region_overlap_and_of_two_regions_do_not(shipped):
    fp = action_footprints(shipped.without_states())
    names = list(shipped.action_names)
    maps = fp.maps.reshape(len(names), -1)
    assert np.allclose(maps[fp.taken].sum(axis=1), 1.0)
    cos = (maps @ maps.T) / np.outer(np.linalg.norm(maps, axis=1), np.linalg.norm(maps, axis=1))
    same = cos[names.index("pick_red_0"), names.index("place_red_0")]
    other = cos[names.index("pick_red_0"), names.index("place_red_2")]
    assert same > 0.5 and other < 0.1
    assert fp.presence.min() >= 0 and fp.presence.max() <= 1


def test_footprint_distances_put_every_observation_next_to_its_own_state(shipped):
    dists = footprint_distances(shipped.without_states())
    for states, d in _per_role(shipped, dists):
        assert np.allclose(d, d.T) and np.all(np.diag(d) == 0) and d.max() <= 1
        same = states[:, None] == states[None, :]
        off = ~np.eye(len(d), dtype=bool)
        assert d[same & off].max() < d[~same].min()


def test_a_per_frame_lighting_gain_and_tint_cancel(shipped):
    rng = np.random.default_rng(0)
    # gains below 1 (nothing clips), a different one per frame and channel
    gain = rng.uniform(0.8, 1.0, size=(shipped.n_obs, 1, 1, 3))
    lit = np.clip(shipped.observations * gain, 0, 255).astype(np.uint8)
    x0, x1 = normalise_frames(shipped.observations), normalise_frames(lit)
    assert np.abs(x0 - x1).mean() < 0.02
    other = Trace(lit, shipped.actions, shipped.action_names, None, shipped.meta)
    d0, d1 = footprint_distances(shipped), footprint_distances(other)
    for a, b in zip(d0, d1):
        assert np.abs(a - b).max() < 0.1


def test_shuffled_images_spoil_only_what_the_actions_leave_open(shipped):
    """Where the actions state what a site holds, the images are not needed; what they leave
    open comes from the images. On the shipped 50 transitions the sequence names every
    slot's twin (by elimination where 20 to 1 is not reached) and the object counts decide
    the sites no action of an episode touches, so shuffling the observations within each
    role spoils nothing. In its first three episodes the sequence leaves a twin open and a
    shuffle spoils the readings that depend on the images; on the true images every
    reading is right."""
    from vggc_cp.trace import Trace

    site = np.array([int(n.rsplit("_", 1)[1]) for n in shipped.action_names])
    n = shipped.episodes()[2][1] + 1
    short = Trace(shipped.observations[:n], shipped.actions[:n - 1], shipped.action_names,
                  shipped.states[:n], shipped.meta)
    for trace, spoiled in ((shipped, ()), (short, (0,))):
        truth = np.array([[c != "-" for c in s.split("|")[0]] for s in trace.states])
        fp = action_footprints(trace.without_states())
        taken = fp.taken
        assert (np.abs(fp.presence[:, taken] - truth[:, site[taken]]) < 0.5).all()
        for seed in (0, 1, 2):
            shuffled = action_footprints(shuffled_within_roles(trace, seed).without_states())
            wrong = np.abs(shuffled.presence[:, taken] - truth[:, site[taken]]) >= 0.5
            assert wrong.mean() > 0.1 if seed in spoiled else not wrong.any()


def test_what_the_actions_state_is_right_and_a_slot_counts_once(shipped):
    """The stated readings (the description length codes them) agree with the true states
    wherever they are stated; the pick and place of one region state alike, so the three
    regions give three columns; pick-role observations right after an action are stated
    at its region."""
    fp = action_footprints(shipped.without_states())
    site = np.array([int(n.rsplit("_", 1)[1]) for n in shipped.action_names])
    truth = np.array([[c != "-" for c in s.split("|")[0]] for s in shipped.states])
    for a in fp.taken:
        on = fp.stated[:, a]
        assert on.mean() > 0.3
        symbol = np.where(fp.presence[on, a] >= 0.5, 2, 1)        # one colour: 2 = occupied
        np.testing.assert_array_equal(symbol, np.where(truth[on, site[a]], 2, 1))
    rows = site_readings(fp)
    assert rows.shape == (shipped.n_obs, 3) and set(np.unique(rows)) <= {0, 1, 2}
    acted = np.flatnonzero(shipped.actions >= 0) + 1
    assert (rows[acted] > 0).any(axis=1).all()
    assert fp.stacked is not None and not fp.stacked.any()     # one level per region


def test_on_a_robot_camera_every_stated_fact_is_offered_and_a_slot_counts_once():
    """fruit-2x3 robot, |D| = 50, seed 436 (draw 50): the arm rests above the place it last
    acted on, so a site's own reading is mostly the arm. Every frame an episode's actions
    state is offered, right, whatever that reading says (until session 55 the facts it
    contradicted were left out: 104 of 292 here, all right, and region 2's pick and place
    left out different frames, so the slot took two columns of the code)."""
    from vggc_cp.sim.explore import generate
    from vggc_cp.vision.occupancy import UNLABELLED, site_labels
    from vggc_cp.vision.slots import acting_at, action_mates, action_twins

    trace = generate("fruit-2x3", 50, seed=436, look="robot").trace
    fp = action_footprints(trace.without_states())
    site = np.array([int(n.rsplit("_", 1)[1]) for n in trace.action_names])
    truth = np.array([[c != "-" for c in s.split("|")[0]] for s in trace.states])
    ov = overlaps(fp.maps)
    twin = action_twins(trace, ov, fp.colour)
    mates = action_mates(trace, ov, fp.colour, twin, 0.2)
    for a in fp.taken:
        labels = site_labels(trace.actions, trace.episodes(),
                             acting_at(int(a), ov, fp.colour, twin, 0.2, mates),
                             trace.action_kinds(), fp.colour)
        np.testing.assert_array_equal(fp.stated[:, a], labels != UNLABELLED)
        on = fp.stated[:, a]
        np.testing.assert_array_equal(fp.presence[on, a] >= 0.5, truth[on, site[a]])
    assert site_readings(fp).shape == (trace.n_obs, 3)        # one column per region


def test_bad_parameters_and_an_empty_trace_are_refused(shipped):
    with pytest.raises(VggcError):
        FootprintConfig(gripper=1.5)
    with pytest.raises(VggcError):
        FootprintConfig(bandwidth=0)
    one = Trace(shipped.observations[:1], np.zeros(0, dtype=np.int64), shipped.action_names)
    with pytest.raises(VggcError):
        action_footprints(one)


def test_two_classes_of_one_region_share_a_site_and_one_class_keeps_its_own():
    maps = np.zeros((3, 8, 8), dtype=np.float32)
    maps[0, 2:4, 2:4] = 1.0                      # class 0 at one place
    maps[1, 2:5, 2:5] = 1.0                      # class 1, a larger shape, same place
    maps[2, 3:5, 3:5] = 1.0                      # class 0 again, overlapping (a stack)
    maps /= maps.sum(axis=(1, 2), keepdims=True)
    ov = overlaps(maps)
    sites = site_maps(maps, ov, np.array([0, 1, 0]))
    assert sites[0][4, 4] > 0                    # widened by the other class's shape
    assert np.allclose(site_maps(maps, ov, np.array([0, 0, 0])), maps)   # one colour: own


@pytest.mark.slow
def test_two_classes_through_a_robot_camera_keep_their_colours():
    """multifruit-4x6 through a robot's camera (tuning seed 1): the footprints of both
    classes lie on the arm (one colour before); the windows the labels teach separate red
    from yellow, and the sites read right go up from 83 % to 90 % (95 % before the majority
    fallback, which reads the runs of site 3 wrongly here)."""
    from vggc_cp.sim.explore import generate

    trace = generate("multifruit-4x6", seed=1, look="robot").trace
    fp = action_footprints(trace.without_states())
    names = trace.action_names
    shade = np.array([n.split("_")[1] for n in names])
    taken = fp.taken
    same_colour = fp.colour[taken][:, None] == fp.colour[taken][None, :]
    np.testing.assert_array_equal(same_colour, shade[taken][:, None] == shade[taken][None, :])
    site = np.array([int(n.rsplit("_", 1)[1]) for n in names])
    truth = np.array([[c != "-" for c in s.split("|")[0]] for s in trace.states])
    right = np.abs(fp.presence[:, taken] - truth[:, site[taken]]) < 0.5
    assert right.mean() > 0.88                             # 90.5 %; before, 83.0 %


@pytest.mark.slow
@pytest.mark.parametrize("seed", [184, 201])
def test_windows_on_the_gripper_do_not_pool_two_colours(seed):
    """multifruit-2x3 through a robot's camera, 95 transitions (seed 184: the eighth draw's
    silent miss; 201: the eleventh draw's): the footprints read red and yellow as the arm's
    grey, and so did the windows that lay on the gripper above another region. One site's
    window shows them apart -- on s184 only within the site's own footprint, on s201 only
    anywhere -- and the two classes keep two colours (one colour for all twelve actions
    before)."""
    from vggc_cp.sim.explore import generate

    trace = generate("multifruit-2x3", 95, seed, look="robot").trace
    fp = action_footprints(trace.without_states())
    shade = np.array([n.split("_")[1] for n in trace.action_names])
    taken = fp.taken
    same_colour = fp.colour[taken][:, None] == fp.colour[taken][None, :]
    np.testing.assert_array_equal(same_colour, shade[taken][:, None] == shade[taken][None, :])
