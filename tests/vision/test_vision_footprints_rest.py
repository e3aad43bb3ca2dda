"""Footprints when something rests where the last action acted (a robot arm in view)."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.trace import PICK, Trace
from vggc_cp.vision.footprints import (
    FootprintConfig,
    action_footprints,
    footprint_codes,
    rest_masks,
)
from vggc_cp.vision.footprints import normalise_frames as _normalise

PLACES = 5
HEIGHT, WIDTH = 32, 64
OBJECT_ROWS = slice(22, 26)            # where an object stands on its place


def _object_cols(p: int) -> slice:
    return slice(4 + 12 * p, 8 + 12 * p)


def _render(occupied: tuple[bool, ...], holding: bool, arm_at: int | None,
            rng: np.random.Generator) -> np.ndarray:
    """A 32 x 64 frame: dark table, light place markers, red objects on their places and,
    unless ``arm_at`` is None, a big white arm resting just above place ``arm_at`` (holding
    a red object when ``holding``)."""
    img = np.full((HEIGHT, WIDTH, 3), (40, 60, 45), dtype=np.float64)
    for p in range(PLACES):
        c = _object_cols(p)
        img[27, c.start - 1:c.stop + 1] = 150                   # the place's marker
        if occupied[p]:
            img[OBJECT_ROWS, c] = (200, 30, 25)
    if arm_at is not None:
        c = _object_cols(arm_at)
        img[0:19, c.start - 2:c.stop + 2] = (235, 235, 230)     # arm and hand, above the place
        if holding:
            img[16:19, c] = (200, 30, 25)
    img += rng.normal(0, 2.0, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8)


def robot_trace(seed: int = 0, episodes: int = 24, length: int = 8, arm: bool = True) -> Trace:
    """Two objects of one class on five places, picked and placed at random; the arm rests
    above the place of the last action (at an episode's start: at a random place)."""
    rng = np.random.default_rng(seed)
    names = tuple([f"pick_red_{p}" for p in range(PLACES)]
                  + [f"place_red_{p}" for p in range(PLACES)])
    frames, actions, states = [], [], []
    for e in range(episodes):
        occupied = [True, True] + [False] * (PLACES - 2)
        rng.shuffle(occupied)
        holding, arm_at = False, int(rng.integers(PLACES))
        for step in range(length + 1):
            frames.append(_render(tuple(occupied), holding, arm_at if arm else None, rng))
            states.append("".join("r" if o else "-" for o in occupied)
                          + ("|r" if holding else "|-"))
            if step == length:
                break
            choices = [p for p in range(PLACES) if occupied[p] != holding]
            p = int(rng.choice(choices))
            occupied[p] = holding
            actions.append(names.index(("place_red_" if holding else "pick_red_") + str(p)))
            holding, arm_at = not holding, p
        if e < episodes - 1:
            actions.append(-1)
    return Trace(np.stack(frames), np.array(actions, dtype=np.int64), names,
                 np.array(states))


@pytest.fixture(scope="module")
def robot():
    return robot_trace()


def _mass_on_object(fp, trace) -> np.ndarray:
    """Share of every pick's footprint on the object pixels of its own place."""
    out = []
    for p in range(PLACES):
        a = trace.action_names.index(f"pick_red_{p}")
        out.append(float(fp.maps[a][OBJECT_ROWS, _object_cols(p)].sum()))
    return np.array(out)


def test_what_rests_where_it_acted_is_found_and_a_still_scene_has_none(robot):
    x = _normalise(robot.observations)
    rest = rest_masks(x, robot.actions, robot.action_kinds(), FootprintConfig())
    assert rest is not None
    for p in range(PLACES):
        a = robot.action_names.index(f"pick_red_{p}")
        assert rest[a][5:15, _object_cols(p)].all()            # the arm above the place
        assert not rest[a][OBJECT_ROWS, _object_cols(p)].any()  # not what the pick changed
    still = robot_trace(arm=False)
    assert rest_masks(_normalise(still.observations), still.actions, still.action_kinds(),
                      FootprintConfig()) is None


@pytest.mark.slow
def test_footprints_lie_on_the_place_not_on_the_arm_resting_above_it(robot):
    fp = action_footprints(robot.without_states())
    assert (_mass_on_object(fp, robot) > 0.5).all()
    # the change footprints (nothing taken to rest: ``rest`` out of reach) lie on the arm
    moved = action_footprints(robot.without_states(), FootprintConfig(rest=1e9))
    assert (_mass_on_object(moved, robot) < 0.5).all()


def _pick_distances(trace, params=None):
    """Pick-role distances through the descriptor codes, and whether two rows share a state."""
    fp = action_footprints(trace.without_states(), params)
    roles = trace.roles()
    (codes, _), (table, _) = footprint_codes(fp, roles)
    states = trace.states[roles == PICK]
    return table[codes[:, None], codes[None, :]], states[:, None] == states[None, :]


def test_one_state_seen_with_the_arm_at_different_places_is_at_distance_about_zero(robot):
    d, same = _pick_distances(robot)
    roles = robot.roles()
    prev = np.r_[-1, robot.actions][roles == PICK]
    arm = np.where(prev >= 0, prev % PLACES, -1)
    moved = same & (arm[:, None] != arm[None, :]) & (arm[:, None] >= 0) & (arm[None, :] >= 0)
    assert moved.sum() > 100                          # many pairs with the arm elsewhere
    assert d[moved].max() < 0.02                      # one state wherever the arm rests
    assert d[~same].min() > 0.3                       # two states stay far apart
    # the change footprints (``rest`` out of reach) see where the arm rests instead
    d0, same0 = _pick_distances(robot, FootprintConfig(rest=1e9))
    assert d0[same0].max() > d0[~same0].min()


@pytest.mark.slow
def test_same_seed_same_footprints_and_codes():
    one, two = robot_trace(seed=3), robot_trace(seed=3)
    assert np.array_equal(one.observations, two.observations)
    fa, fb = action_footprints(one.without_states()), action_footprints(two.without_states())
    assert np.array_equal(fa.maps, fb.maps)
    assert np.array_equal(fa.presence, fb.presence)
    assert np.array_equal(footprint_codes(fa, one.roles())[0][0],
                          footprint_codes(fb, two.roles())[0][0])


def test_a_bad_rest_setting_is_refused():
    from vggc_cp.errors import VggcError
    with pytest.raises(VggcError, match="rest"):
        FootprintConfig(rest=0.0)
