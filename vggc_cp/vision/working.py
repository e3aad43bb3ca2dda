"""The footprints' working copy of the frames: averaged down, lighting cancelled, read in chunks.

The footprint evidence (:mod:`vggc_cp.vision.footprints`) holds one float copy of every frame
at a *working resolution*, each frame averaged down by an integer ``factor`` and divided by its
per-channel gain against the recording (:func:`frame_gains`: a per-frame lighting gain and
tint cancel). How coarse it may be is a property of the scene, not of the camera: an object
must still span a few pixels. Three things set it:

* the **image-size bound** :func:`working_factor`: frames are never averaged below about
  ``WORK_SIDE x WORK_SIDE`` pixels (:data:`WORK_SIDE`; as many as the renders the defaults
  were tuned on hold), so a scene like the tuning renders is worked at about their size;
* the **footprints' scale**: :func:`vggc_cp.vision.footprints.action_footprints` measures the
  typical width of the actions' footprints at the working resolution
  (:func:`vggc_cp.vision.footprints.footprint_side`) and, where it is under
  :data:`FOOTPRINT_SIDE`, works again at the finer factor that brings it there (small objects
  seen by a wide camera);
* and the **memory cap** (``VGGC_CP_MAX_BYTES``): the finest factor whose float copy fits it
  (:func:`finest_factor`).

:class:`WorkingResolution` records which of them chose the factor.

Frames are read in chunks of :data:`CHUNK_BYTES` (a :class:`vggc_cp.frames.StreamedFrames`
in one forward pass over the file), so only the working copy is ever held whole.

Examples
--------
>>> working_factor(64, 64), working_factor(480, 640)
(1, 8)
>>> frames = np.full((2, 8, 8, 3), 100, dtype=np.uint8)
>>> normalise_frames(frames, 4).shape
(2, 2, 2, 3)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import TraceError

#: Image side the footprint defaults were tuned at; larger frames are averaged down to about
#: it and no further (:func:`working_factor`).
WORK_SIDE = 64
#: Typical footprint width (pixels) the working resolution keeps at least: the narrowest
#: typical footprint among the renders the defaults were tuned on (the median over a trace's
#: actions of :func:`vggc_cp.vision.footprints.footprint_side`; 3.9-6.4 px on the tuning
#: split's clean and randomized 64 px traces, seed 0, the seven tasks and random-0..9).
FOOTPRINT_SIDE = 3.9
#: Bytes of float frames converted at once (:func:`normalise_frames`).
CHUNK_BYTES = 64 << 20
#: Frames of one block of :func:`working_frames` on an executor (fewer where they would
#: exceed :data:`BLOCK_BYTES` of pixels).
BLOCK_FRAMES = 256
#: Bytes of uint8 pixels in one block shipped to an executor's worker, at most.
BLOCK_BYTES = 32 << 20
#: Bytes of uint8 pixels read from a trace file (:class:`vggc_cp.frames.StreamedFrames`) and
#: shipped to an executor at once: the frames are inflated here in one pass, wave by wave.
WAVE_BYTES = 128 << 20
#: Bytes of uint8 pixels summed at once (:func:`_block_sums`): a few frames that stay in a
#: core's cache while their rows and then columns are added (a third less CPU than a whole
#: chunk at 640x480).
SUM_BYTES = 2 << 20


@dataclass(frozen=True)
class WorkingResolution:
    """The working resolution the footprints used, and why.

    Attributes
    ----------
    factor : int
        Frames were averaged down by ``factor x factor`` pixel blocks.
    bound : int
        The image-size bound (:func:`working_factor`): the coarsest factor considered.
    side : float
        Typical footprint width at ``factor`` in working pixels (``nan`` when not measured:
        frames at the tuned size or smaller are never averaged down).
    reason : str
        ``"image size"`` (the bound), ``"footprints' scale"`` (finer than the bound: the
        footprints were narrower than :data:`FOOTPRINT_SIDE` at it) or ``"memory cap"`` (the
        scale asked for a finer factor than the cap allows; ``side`` stays under
        :data:`FOOTPRINT_SIDE`).
    shape : tuple of int
        ``(height, width)`` of the working frames.
    """

    factor: int
    bound: int
    side: float
    reason: str
    shape: tuple[int, int]

    def describe(self) -> str:
        """One line for a person: the size, the factor and what chose it."""
        h, w = self.shape
        text = f"{w}x{h} (frames averaged down {self.factor}x, chosen by the {self.reason}"
        if np.isfinite(self.side):
            text += f"; footprints {self.side:.1f} px wide"
        if self.reason == "memory cap":
            text += (f", under the {FOOTPRINT_SIDE} px the scene asks for: raise "
                     f"VGGC_CP_MAX_BYTES to work finer")
        return text + ")"


def working_factor(height: int, width: int, side: int = WORK_SIDE) -> int:
    """Image-size bound on the factor by which frames of ``height x width`` are averaged down
    for the footprints: the largest that keeps at least ``side x side`` pixels, as many as
    the renders the defaults were tuned on hold (1 for those 64 px renders; 4 for 256x256; 8
    for a 640x480 camera, 80x60)."""
    return max(1, math.isqrt(int(height) * int(width) // (int(side) ** 2)))


def working_bytes(shape, factor: int) -> int:
    """Bytes of the float32 working copy of frames of ``shape`` (N, H, W, 3) at ``factor``."""
    n, h, w = (int(v) for v in shape[:3])
    return n * (h // factor) * (w // factor) * 3 * 4


def finest_factor(shape) -> int:
    """The smallest factor whose working copy of frames of ``shape`` fits ``max_bytes``."""
    from vggc_cp.safeio import cap

    limit = cap("max_bytes")
    f = 1
    while f < max(shape[1:3]) and working_bytes(shape, f) > limit:
        f += 1
    return f


def normalise_frames(observations: np.ndarray, factor: int = 1,
                     chunk_bytes: int = CHUNK_BYTES) -> np.ndarray:
    """Frames averaged down by ``factor`` (blocks of ``factor x factor`` pixels; edges that do
    not fill a block are cropped; :func:`block_means`), each divided by its per-channel gain
    against the recording (:func:`cancel_gains`: a per-frame lighting gain and tint cancel).
    Frames are read in chunks of about ``chunk_bytes`` of float pixels, so only the
    working-resolution copy of all of them is ever held.

    Parameters
    ----------
    observations : ndarray of uint8, shape (N, H, W, 3)
        Any array-like that slices along its first axis (a memory map too).
    factor : int

    Returns
    -------
    ndarray of float32, shape (N, H // factor, W // factor, 3)
    """
    return cancel_gains(block_means(observations, factor, chunk_bytes))


def block_means(observations: np.ndarray, factor: int = 1,
                chunk_bytes: int = CHUNK_BYTES) -> np.ndarray:
    """Frames averaged down by ``factor`` in ``[0, 1]``, float32 of shape
    ``(N, H // factor, W // factor, 3)``, read in chunks of about ``chunk_bytes``."""
    n, h, w = observations.shape[:3]
    f = max(1, int(factor))
    hh, ww = h // f, w // f
    out = np.empty((n, hh, ww, 3), dtype=np.float32)
    chunk = max(1, int(chunk_bytes) // (h * w * 3 * 4))  # a float32 copy of a chunk
    for s in range(0, n, chunk):
        block = np.asarray(observations[s:s + chunk, :hh * f, :ww * f])
        if f > 1:  # block sums in integers (exact), one division: the block means
            block = _block_sums(block, f)
        out[s:s + chunk] = block.astype(np.float32) / np.float32(255.0 * f * f)
    return out


#: Frames (evenly spaced over the recording) whose per-pixel median is the reference the
#: gains are measured against (:func:`frame_gains`).
REFERENCE_FRAMES = 64
#: Pixel values (in ``[0, 1]``) outside which a ratio says nothing of the gain: too dark to
#: measure, or clipped at white (in the reference or in the frame).
GAIN_RANGE = (8 / 255, 250 / 255)
#: The gain quantile whose frame sets the common ceiling of :func:`cancel_gains`: the
#: brightest frames but one in a hundred.
CEILING_QUANTILE = 0.99


def frame_gains(x: np.ndarray) -> np.ndarray:
    """Every frame's per-channel brightness against the recording's, shape (N, 3), float32.

    The reference is the per-pixel median of :data:`REFERENCE_FRAMES` evenly spaced frames;
    a frame's gain in channel ``c`` is the median of ``x_c / ref_c`` over the pixels that
    are measurable (:data:`GAIN_RANGE`) in the reference and in the frame, times the median
    of ``ref_c``: the median-of-ratios estimate of a common scale (Anders and Huber 2010),
    which the few pixels an action, an arm or a distractor changes do not move, and which a
    background clipped at white in the brighter frames does not pull down. A frame's own
    median, its previous divisor, jumps between two modes where half the image is
    background and half table (random-678 clean: 144 or 214 in red from one frame to the
    next), and that jump was read as change everywhere.

    >>> x = np.full((3, 4, 4, 3), 0.5, np.float32); x[1] *= 0.8; x[2, :1] = 1.0
    >>> [round(float(g), 3) for g in frame_gains(x)[:, 0]]   # a quarter of frame 2 changed
    [0.5, 0.4, 0.5]
    """
    n, h = x.shape[:2]
    pick = np.unique(np.linspace(0, n - 1, min(n, REFERENCE_FRAMES)).round().astype(np.int64))
    # in pieces of a sixteenth of the frames (rows, then frames): the working copy is the
    # only large array held
    rows = max(1, h // 16)
    ref = np.concatenate([np.median(x[pick, i:i + rows], axis=0)
                          for i in range(0, h, rows)]).reshape(-1, 3)
    chunk_frames = max(1, n // 16)
    lo, hi = GAIN_RANGE
    gains = np.empty((n, 3), dtype=np.float32)
    for c in range(3):
        r = ref[:, c]
        ok = (r > lo) & (r < hi)
        if not ok.any():  # nothing measurable: every pixel that is not black
            ok = r > 0
        if not ok.any():
            gains[:, c] = 1.0
            continue
        level = np.float32(np.median(r))
        for s in range(0, n, chunk_frames):
            part = x[s:s + chunk_frames, ..., c].reshape(-1, r.size)[:, ok]
            gains[s:s + chunk_frames, c] = _median_of_ratios(part, r[ok]) * level
    return gains


def _median_of_ratios(part: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Per row of ``part`` (n, p), the median of ``part / ref`` over its pixels inside
    :data:`GAIN_RANGE` (all of them where none is), shape (n,)."""
    lo, hi = GAIN_RANGE
    ratio = part / ref
    out = ~((part > lo) & (part < hi))
    ratio[out] = np.inf                       # sorted past every measurable pixel
    k = ratio.shape[1] - out.sum(axis=1)
    ratio.sort(axis=1)
    none = k == 0
    if none.any():
        ratio[none] = np.sort(part[none] / ref, axis=1)
        k[none] = ratio.shape[1]
    rows = np.arange(len(ratio))
    return (ratio[rows, (k - 1) // 2] + ratio[rows, k // 2]) / 2


def cancel_gains(x: np.ndarray) -> np.ndarray:
    """``x`` (float in ``[0, 1]``, shape (N, H, W, 3)) divided in place by
    :func:`frame_gains` and cut at a common ceiling; returned.

    A pixel clipped at white reads ``1 / g`` once divided by its frame's gain ``g``: brighter
    frames would read a clipped background darker than dimmer ones, a change everywhere
    the camera saturates. Every channel is therefore cut at ``1 / g`` of its
    :data:`CEILING_QUANTILE` gain, the brightest level every frame (but one in a hundred)
    can still measure: a clipped background reads alike in all of them, and an object put
    on a white table still changes it.
    """
    gains = np.maximum(frame_gains(x), 1e-3)
    x /= gains[:, None, None, :]
    ceiling = 1.0 / np.quantile(gains, CEILING_QUANTILE, axis=0)
    np.minimum(x, ceiling.astype(np.float32), out=x)
    return x


def _block_sums(frames: np.ndarray, f: int) -> np.ndarray:
    """Sums of ``f x f`` pixel blocks of uint8 frames (N, f*h, f*w, 3), exact integers of
    shape (N, h, w, 3): rows then columns added slice by slice (several times faster than a
    reduction over strided axes), :data:`SUM_BYTES` of frames at a time."""
    n, hf, wf = frames.shape[:3]
    dtype = np.uint16 if f * f * 255 <= np.iinfo(np.uint16).max else np.uint32
    step = max(1, SUM_BYTES // max(1, hf * wf * 3))
    if n > step:
        out = np.empty((n, hf // f, wf // f, 3), dtype=dtype)
        for s in range(0, n, step):
            out[s:s + step] = _block_sums(frames[s:s + step], f)
        return out
    v = frames.reshape(n, hf // f, f, wf // f, f, 3)
    rows = v[:, :, 0].astype(dtype)
    for k in range(1, f):
        rows += v[:, :, k]
    out = rows[:, :, :, 0].copy()
    for k in range(1, f):
        out += rows[:, :, :, k]
    return out


def _block_means_of(item: tuple[np.ndarray, int]) -> np.ndarray:
    observations, factor = item
    return block_means(observations, factor)


def check_working_bytes(observations, factor: int, source: str | None = None) -> None:
    """Refuse frames whose working-resolution float copy (what the footprints hold) would
    exceed ``max_bytes``, naming the trace, the sizes and the cap (a 640x480 recording of
    1,628 frames holds 94 MB at factor 8, whatever its 1.5 GB of pixels in the file)."""
    from vggc_cp.safeio import CAPS, cap

    n, h, w = (int(v) for v in observations.shape[:3])
    held = working_bytes(observations.shape, factor)
    if held > cap("max_bytes"):
        source = source or getattr(observations, "source", None) or "the trace"
        raise TraceError(f"{source}: field 'observations': {n:,} frames of {w}x{h} hold "
                         f"{held:,} bytes at the footprints' working resolution "
                         f"({w // factor}x{h // factor}, float32), above the cap of "
                         f"{cap('max_bytes'):,} ({CAPS['max_bytes'][1]})")


def working_frames(observations: np.ndarray, executor=None, block: int | None = None,
                   source: str | None = None, factor: int | None = None) -> np.ndarray:
    """:func:`normalise_frames` at ``factor`` (default: the image-size bound
    :func:`working_factor`); with an ``executor`` (e.g. a dask cluster), blocks of ``block``
    (default :data:`BLOCK_FRAMES`, fewer where that would be more than :data:`BLOCK_BYTES`)
    frames are averaged down on its workers (:func:`block_means`, each frame on its own) and
    their gains cancelled here (:func:`cancel_gains`): the same numbers either way.
    Frames read from the trace file (:class:`vggc_cp.frames.StreamedFrames`) are inflated
    here, in one pass over the file (a deflated member is read from its start), and shipped
    in waves of about :data:`WAVE_BYTES`, so only a wave of full-size frames is held at once.

    Returns
    -------
    ndarray of float32, shape (N, H // f, W // f, 3)
    """
    if factor is None:
        factor = working_factor(*observations.shape[1:3])
    check_working_bytes(observations, factor, source)
    n, h, w = (int(v) for v in observations.shape[:3])
    frame_bytes = h * w * 3
    block = max(1, min(int(block or BLOCK_FRAMES), BLOCK_BYTES // frame_bytes))
    if executor is None or n <= block:
        return normalise_frames(observations, factor)
    out = np.empty((n, h // factor, w // factor, 3), dtype=np.float32)
    wave = block * max(1, WAVE_BYTES // (block * frame_bytes))
    for s in range(0, n, wave):
        frames = np.asarray(observations[s:s + wave])
        items = [(np.ascontiguousarray(frames[b:b + block]), factor)
                 for b in range(0, len(frames), block)]
        del frames
        for i, x in executor.completed(_block_means_of, items):
            out[s + i * block:s + i * block + len(x)] = x
    return cancel_gains(out)
