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
