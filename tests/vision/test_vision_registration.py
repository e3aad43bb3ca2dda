"""Camera shake undone (vggc_cp.vision.registration)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vggc_cp.trace import load_trace
from vggc_cp.vision.registration import shake_shifts, steady, undo_shake
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
    back = steady(shaken(x, shifts))
    m = 3  # away from the repeated edges the frames are the originals again
    assert np.array_equal(back[:, m:-m, m:-m], x[:, m:-m, m:-m])


def test_a_camera_that_does_not_shake_leaves_the_frames_as_they_are():
    x = normalise_frames(load_trace(DATA).observations)
    assert not shake_shifts(x).any()
    assert steady(x) is x


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
