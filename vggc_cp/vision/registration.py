"""Camera shake undone: every frame moved back onto the scene's resting view.

A robot's camera shakes a pixel or two between frames (a mount that vibrates, an arm that
jolts the table). Every edge of the scene -- region markers, the table's border -- then changes
in every transition, and evidence built on what changes between frames sees change
everywhere. The static scene is what most frames share: the per-pixel median of the frames is
its resting view, and a frame's shake is the whole-pixel translation that brings it closest to
that view (least mean absolute difference of the brightness, over the pixels that stay inside
the image). Moving parts (an arm, the objects) cover a minority of the pixels and do not move
with the shake, so they leave the minimum where the background lies.

**Rounds until nothing changes.** The median of frames that each shake by up to two pixels
is a blurred view: its edges are as wide as the shake, and a frame one pixel off matches it
nearly as well as one in place (on the robot look's renders one round finds 44-80 % of the
shifts the renderer recorded). So the resting view is drawn again from the frames moved back
by the round before, and every frame matched against that sharper view, until no shift
changes (at most :data:`PASSES` rounds; multifruit-2x3 robot s2 is right from the fifth). The
shifts are re-centred every round so that their median is none: the resting view is where
the camera rests most, and a view drifting a pixel a round would push frames past
:data:`MAX_SHIFT`. Every frame of the tuning split's 51 robot traces is then moved back by
the shift the renderer gave it.

**What the shake hides.** A frame moved back by ``(dy, dx)`` has no pixels of its own in the
``|dy|`` rows and ``|dx|`` columns at the edge it came from; they repeat the edge. So the
margin the largest shift reaches (:func:`unseen_margin`) is not seen in every frame, and what
changes there changes with the shake: the footprints take nothing from it
(:func:`vggc_cp.vision.footprints.footprint_maps`).

**A shift is kept only where the frame shows it**: the per-pixel differences from the resting
view, unshifted less shifted, must have a mean of at least ``z`` standard errors with
``z^2 / 2 >= ln SHIFT_ODDS`` (a paired test, the odds the footprints' readings are held to).
A scene with no structure (a bare table under sensor noise) has a best shift by chance only
(``z`` under 2 there), and a camera that does not shake gives every frame the shift ``(0, 0)``
and the frames unchanged; a frame the renderer shook shows ``z`` of 8 or more.
"""

from __future__ import annotations

import math

import numpy as np

#: Largest shake looked for, in pixels (per axis).
MAX_SHIFT = 3
#: Odds at which a frame's shift must be shown: ``z^2 / 2 >= ln SHIFT_ODDS`` for the mean
#: improvement over no shift in standard errors.
SHIFT_ODDS = 20.0
#: Rounds of matching: the first against the median of the frames as they are, each next one
#: against the median of the frames moved back by the round before.
PASSES = 8
#: Frames whose median makes the resting view (evenly spaced over the trace).
REFERENCE_FRAMES = 256


def _brightness(x: np.ndarray) -> np.ndarray:
    return x.mean(axis=-1, dtype=np.float32)


def _difference(b: np.ndarray, core: np.ndarray, m: int, dy: int, dx: int) -> np.ndarray:
    """``|frame moved back by (dy, dx) - resting view|`` on the view's core, for brightness
    frames ``b`` of shape (..., H, W)."""
    h, w = b.shape[-2:]
    return np.abs(b[..., m + dy:h - m + dy, m + dx:w - m + dx] - core)


def _match(x: np.ndarray, ref: np.ndarray, m: int, odds: float, chunk: int) -> np.ndarray:
    """Every frame's shift against the resting view ``ref`` (one round of
    :func:`shake_shifts`)."""
    n, h, w = x.shape[:3]
    core = ref[m:h - m, m:w - m]
    offsets = np.array([(dy, dx) for dy in range(-m, m + 1) for dx in range(-m, m + 1)])
    zero = int(np.flatnonzero((offsets == 0).all(axis=1))[0])
    bar = math.sqrt(2.0 * math.log(odds))
    out = np.zeros((n, 2), dtype=np.int64)
    for s in range(0, n, chunk):
        b = _brightness(x[s:s + chunk])
        cost = np.stack([_difference(b, core, m, dy, dx).mean(axis=(1, 2))
                         for dy, dx in offsets], axis=1)                 # (n, shifts)
        best = np.argmin(cost, axis=1)
        for k in np.flatnonzero(best != zero):
            gain = (_difference(b[k], core, m, 0, 0)
                    - _difference(b[k], core, m, *offsets[best[k]])).ravel()
            error = gain.std() / math.sqrt(gain.size)
            if error > 0 and gain.mean() >= bar * error:
                out[s + k] = offsets[best[k]]
    return out


def shake_shifts(x: np.ndarray, max_shift: int = MAX_SHIFT, odds: float = SHIFT_ODDS,
                 passes: int = PASSES, chunk: int = 256) -> np.ndarray:
    """The whole-pixel shake of every frame (module docstring).

    Parameters
    ----------
    x : ndarray of float32, shape (N, H, W, 3)
        Frames (any scale; :func:`vggc_cp.vision.working.normalise_frames`).
    max_shift : int
        Largest shift looked for, per axis.
    odds : float
        :data:`SHIFT_ODDS`.
    passes : int
        Rounds of matching (:data:`PASSES`).

    Returns
    -------
    ndarray of int64, shape (N, 2)
        ``(dy, dx)`` per frame: the frame shows the scene moved by ``(dy, dx)`` pixels.

    Examples
    --------
    A frame that shows the scene one pixel down and two right:

    >>> rng = np.random.default_rng(0)
    >>> scene = rng.uniform(0, 1, (1, 24, 24, 3)).astype(np.float32).repeat(5, axis=0)
    >>> scene[2] = undo_shake(scene[2:3], np.array([[-1, -2]]))[0]
    >>> shake_shifts(scene)[2].tolist(), int(np.abs(shake_shifts(scene)).sum())
    ([1, 2], 3)
    """
    n, h, w = x.shape[:3]
    m = int(max_shift)
    shifts = np.zeros((n, 2), dtype=np.int64)
    if n < 3 or h <= 4 * m or w <= 4 * m:
        return shifts
    pick = np.unique(np.linspace(0, n - 1, min(n, REFERENCE_FRAMES)).round().astype(int))
    for _ in range(max(1, int(passes))):
        ref = np.median(_brightness(undo_shake(x[pick], shifts[pick])), axis=0)
        found = _match(x, ref, m, odds, chunk)
        # the resting view is where the camera rests most: the median shake is none
        found -= np.round(np.median(found, axis=0)).astype(np.int64)
        if np.array_equal(found, shifts):
            break
        shifts = found
    return shifts


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


def unseen_margin(shifts: np.ndarray) -> tuple[int, int]:
    """Rows and columns at each edge of the image that some frame's shake moved out of view:
    the largest ``|dy|`` and ``|dx|`` of ``shifts`` (shape (N, 2)). Moved back, such a frame
    repeats its edge there (:func:`undo_shake`), so those pixels change wherever the shake
    does, whatever the scene does; ``(0, 0)`` for a camera that does not shake.

    >>> unseen_margin(np.array([[0, 0], [1, -2], [-1, 1]]))
    (1, 2)
    >>> unseen_margin(np.zeros((0, 2), dtype=int))
    (0, 0)
    """
    shifts = np.asarray(shifts, dtype=np.int64).reshape(-1, 2)
    if not len(shifts):
        return 0, 0
    dy, dx = np.abs(shifts).max(axis=0)
    return int(dy), int(dx)


def steady(x: np.ndarray) -> tuple[np.ndarray, tuple[int, int]]:
    """``x`` with its camera shake undone (:func:`shake_shifts`, :func:`undo_shake`), and the
    margin the shake moved out of view in some frame (:func:`unseen_margin`)."""
    shifts = shake_shifts(x)
    return undo_shake(x, shifts), unseen_margin(shifts)
