"""Camera shake undone (vggc_cp.vision.registration)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vggc_cp.trace import load_trace
from vggc_cp.vision.footprints import normalise_frames
from vggc_cp.vision.registration import shake_shifts, steady, undo_shake

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


def with_a_moving_arm(x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``x`` with a bright block (a ninth of the frame) at a random place in every frame:
    a large part that moves on its own and does not shake with the camera."""
    out = x.copy()
    n, h, w = x.shape[:3]
    for i in range(n):
        top, left = rng.integers(0, h - h // 3), rng.integers(0, w - w // 3)
        out[i, top:top + h // 3, left:left + w // 3] = 2.0
    return out


@pytest.mark.slow
def test_a_shake_under_a_moving_arm_is_found_against_a_rebuilt_resting_view():
    # the median of shaken frames is blurred: matched against it alone, many shaken frames
    # keep (0, 0); the view rebuilt from the frames moved back finds them
    x = normalise_frames(load_trace(DATA).observations)
    rng = np.random.default_rng(1)
    shifts = rng.integers(-2, 3, size=(len(x), 2))
    scene = shaken(with_a_moving_arm(x, rng), shifts)
    first = shake_shifts(scene, refine=0)
    found = shake_shifts(scene)
    assert (found == shifts).all(axis=1).mean() >= 0.9
    assert (found == shifts).all(axis=1).mean() > (first == shifts).all(axis=1).mean()
    assert np.array_equal(shake_shifts(scene), found)            # same frames, same shifts
