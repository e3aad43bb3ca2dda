"""Camera shake undone (vggc_cp.vision.registration)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vggc_cp.trace import load_trace
from vggc_cp.vision.registration import shake_shifts, steady, undo_shake, unseen_margin
from vggc_cp.vision.working import normalise_frames

DATA = Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz"


def shaken(x: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """Frames showing the scene moved by ``shifts`` (edge pixels repeated)."""
    return undo_shake(x, -shifts)


def test_the_shake_of_every_frame_is_found_and_undone():
    x = normalise_frames(load_trace(DATA).observations)
    rng = np.random.default_rng(0)
    shifts = rng.integers(-2, 3, size=(len(x), 2))
    found = shake_shifts(shaken(x, shifts))
    assert np.array_equal(found, shifts)
    back, margin = steady(shaken(x, shifts))
    assert margin == unseen_margin(shifts) == (2, 2)
    m = 2  # away from the repeated edges the frames are the originals again
    assert np.array_equal(back[:, m:-m, m:-m], x[:, m:-m, m:-m])
    assert not np.array_equal(back, x)  # there they are not


def test_a_camera_that_does_not_shake_leaves_the_frames_as_they_are():
    x = normalise_frames(load_trace(DATA).observations)
    assert not shake_shifts(x).any()
    back, margin = steady(x)
    assert back is x and margin == (0, 0)


def test_every_frame_of_a_robot_recording_is_moved_back_by_the_shake_it_was_given(
        monkeypatch):
    """The renderer's own record of every frame's shake (multifruit-2x3, robot look, seed 2:
    an arm in view, lighting drift, a mug that moves; the first round alone, against the
    median of the shaken frames, gets 44 % of them right)."""
    from vggc_cp.sim import looks
    from vggc_cp.sim.explore import generate

    given = []
    shift = looks.shift_image

    def recorded(img, dx, dy):
        given.append((dy, dx))
        return shift(img, dx, dy)

    monkeypatch.setattr(looks, "shift_image", recorded)
    obs = generate("multifruit-2x3", 95, 2, look="robot").trace.observations
    given = np.array(given[:len(obs)])
    found = shake_shifts(normalise_frames(obs))
    assert np.array_equal(found, given)
    assert not np.array_equal(shake_shifts(normalise_frames(obs), passes=1), given)


def test_a_scene_with_nothing_to_match_is_not_moved():
    """Sensor noise on a bare table: some shift always fits a frame best, by chance only."""
    rng = np.random.default_rng(0)
    x = (0.5 + rng.normal(0.0, 0.02, (60, 32, 32, 3))).astype(np.float32)
    assert not shake_shifts(x).any()
    assert shake_shifts(x, odds=1.0).any()          # with no bar, chance shifts are kept


def test_no_footprint_in_the_margin_a_shake_hides():
    """An action taken once whose transition also changed the image's edge (a shaken frame
    moved back repeats its edge there) keeps its footprint where it acted."""
    from vggc_cp.trace import PICK, PLACE
    from vggc_cp.vision.footprints import FootprintConfig, footprint_maps

    rng = np.random.default_rng(0)
    x = np.repeat(rng.uniform(0.4, 0.6, (1, 20, 20, 3)).astype(np.float32), 7, axis=0)
    x += rng.normal(0, 0.005, x.shape).astype(np.float32)
    src, act, dst = np.arange(6), np.array([0, 1, 0, 1, 2, 3]), np.arange(1, 7)
    for t, (r, c) in enumerate([(5, 5), (5, 5), (5, 5), (5, 5), (12, 12), (12, 12)]):
        if t % 2 == 0:   # a pick empties its region, the place after it fills it again
            x[t + 1:, r:r + 3, c:c + 3] = 0.0 if t < 4 else 0.9
    x[5:, :, :2] = 2.0    # from frame 5 on, moved back by two columns: the edge repeated
    roles = np.array([PICK, PLACE] * 3 + [PICK])
    kw = dict(roles=roles, src=src, act=act, dst=dst, n_actions=4, params=FootprintConfig())
    edge = footprint_maps(x, **kw)
    kept = footprint_maps(x, **kw, margin=(0, 2))
    assert edge[2][:, :2].sum() > 0.5          # the edge is the action's heaviest change
    assert kept[2][:, :2].sum() == 0 and kept[2][12:15, 12:15].sum() > 0.99
    assert np.array_equal(kept[0], edge[0])   # an action the edge never touched: the same
