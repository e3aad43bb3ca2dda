"""Camera shake undone: every frame moved back onto the scene's resting view.

A robot's camera shakes a pixel or two between frames (a mount that vibrates, an arm that
jolts the table). Every edge of the scene -- region markers, the table's border -- then changes
in every transition, and evidence built on what changes between frames sees change
everywhere. The static scene is what most frames share: the per-pixel median of the frames is
its resting view, and a frame's shake is the whole-pixel translation that brings it closest to
that view (least mean absolute difference of the brightness, over the pixels that stay inside
the image). Moving parts (an arm, the objects) cover a minority of the pixels and do not move
with the shake, so they leave the minimum where the background lies.

A translation is kept only when it explains the frame clearly better than none: its
difference must be below ``1 - GAIN`` times the unshifted one. A camera that does not shake
gives every frame the shift ``(0, 0)`` and the frames unchanged.
"""

from __future__ import annotations

import numpy as np

#: Largest shake looked for, in pixels (per axis).
MAX_SHIFT = 3
#: A shift must lower the difference to the resting view by this share to be kept.
GAIN = 0.1
#: Frames whose median makes the resting view (evenly spaced over the trace).
REFERENCE_FRAMES = 256


def _brightness(x: np.ndarray) -> np.ndarray:
    return x.mean(axis=-1, dtype=np.float32)


def shake_shifts(x: np.ndarray, max_shift: int = MAX_SHIFT, gain: float = GAIN,
                 chunk: int = 256) -> np.ndarray:
    """The whole-pixel shake of every frame (module docstring).

    Parameters
    ----------
    x : ndarray of float32, shape (N, H, W, 3)
        Frames (any scale; :func:`vggc_cp.vision.working.normalise_frames`).
    max_shift : int
    gain : float

    Returns
    -------
    ndarray of int64, shape (N, 2)
        ``(dy, dx)`` per frame: the frame shows the scene moved by ``(dy, dx)`` pixels.
    """
    n, h, w = x.shape[:3]
    m = int(max_shift)
    if n < 3 or h <= 4 * m or w <= 4 * m:
        return np.zeros((n, 2), dtype=np.int64)
    pick = np.unique(np.linspace(0, n - 1, min(n, REFERENCE_FRAMES)).round().astype(int))
    ref = np.median(_brightness(x[pick]), axis=0)
    core = ref[m:h - m, m:w - m]
    offsets = [(dy, dx) for dy in range(-m, m + 1) for dx in range(-m, m + 1)]
    out = np.zeros((n, 2), dtype=np.int64)
    for s in range(0, n, chunk):
        b = _brightness(x[s:s + chunk])
        cost = np.stack([np.abs(b[:, m + dy:h - m + dy, m + dx:w - m + dx] - core).mean(axis=(1, 2))
                         for dy, dx in offsets], axis=1)                 # (n, shifts)
        zero = cost[:, offsets.index((0, 0))]
        best = np.argmin(cost, axis=1)
        keep = cost[np.arange(len(b)), best] < (1.0 - gain) * zero
        out[s:s + chunk][keep] = np.array(offsets)[best[keep]]
    return out


def undo_shake(x: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """Frames moved back by their shake (edge pixels repeated), same shape and dtype; frames
    with shift ``(0, 0)`` are left as they are."""
    out = x.copy() if shifts.any() else x
    h, w = x.shape[1:3]
    for i in np.flatnonzero(shifts.any(axis=1)):
        dy, dx = (int(v) for v in shifts[i])
        rows = np.clip(np.arange(h) + dy, 0, h - 1)
        cols = np.clip(np.arange(w) + dx, 0, w - 1)
        out[i] = x[i][rows][:, cols]
    return out


def steady(x: np.ndarray) -> np.ndarray:
    """``x`` with its camera shake undone (:func:`shake_shifts`, :func:`undo_shake`)."""
    return undo_shake(x, shake_shifts(x))
