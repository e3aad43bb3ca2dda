"""Decoding frames: image files (Pillow) and chosen frames of a video (PyAV).

Both check the frame size from the header against the pixel caps of :mod:`vggc_cp.safeio`
before decoding anything, and name the file (and the place in the log) when they fail.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.importers.base import require
from vggc_cp.safeio import check_image_size, check_input

#: a wanted time further ahead than this (seconds) is reached by seeking, not decoding
SEEK_AHEAD_S = 2.0


def read_image(path, place: str) -> np.ndarray:
    """Read an image file (PNG, JPEG, ... as Pillow reads them) as uint8 [H, W, 3] RGB.

    ``place`` (e.g. ``"log.csv: row 4"``) begins every error message.
    """
    p = Path(path)
    try:
        check_input(p, "frame")
    except VggcError as exc:
        raise VggcError(f"{place}: frame {str(p)!r}: {str(exc).rsplit(': ', 1)[-1]}") from None
    return _decode_image(p, f"{place}: frame {str(p)!r}")


def image_from_bytes(data: bytes, place: str) -> np.ndarray:
    """Decode an encoded image (PNG, JPEG, ...) held in memory as uint8 [H, W, 3] RGB."""
    import io

    return _decode_image(io.BytesIO(data), place)


def _decode_image(fp, what: str) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    bomb_limit = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None  # our cap (VGGC_CP_MAX_PIXELS) is checked instead
    try:
        with Image.open(fp) as im:
            w, h = im.size  # from the header, before decoding
            check_image_size(h, w, what)
            im.load()
            rgb = im.convert("RGB")
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError, EOFError) as exc:
        raise VggcError(f"{what} is not a readable image ({type(exc).__name__})") from None
    finally:
        Image.MAX_IMAGE_PIXELS = bomb_limit
    return np.asarray(rgb, dtype=np.uint8).copy()


def _open_video(path):
    av = require("av")
    src = str(path)
    check_input(src, "video")
    try:
        container = av.open(src)
    except (av.FFmpegError, OSError, ValueError) as exc:
        raise VggcError(f"{src}: not a readable video ({type(exc).__name__})") from None
    if not container.streams.video:
        container.close()
        raise VggcError(f"{src}: holds no video stream")
    stream = container.streams.video[0]
    ctx = stream.codec_context
    try:
        check_image_size(int(ctx.height), int(ctx.width), f"{src}: video stream")
    except VggcError:
        container.close()
        raise
    return av, container, stream


def _frames(av, container, stream, src: str) -> Iterator:
    try:
        yield from container.decode(stream)
    except (av.FFmpegError, OSError, ValueError) as exc:
        raise VggcError(f"{src}: the video is damaged ({type(exc).__name__})") from None


def _rgb(frame) -> np.ndarray:
    image = frame.to_ndarray(format="rgb24")
    return np.ascontiguousarray(image, dtype=np.uint8)


def _check_increasing(values: Sequence, places: Sequence[str], what: str) -> None:
    for j in range(1, len(values)):
        if not values[j] > values[j - 1]:
            raise VggcError(f"{places[j]}: {what} {values[j]} is not after {what} "
                            f"{values[j - 1]} ({places[j - 1]}); the log must be in time order, "
                            f"one frame per row")


def frames_by_index(path, indices: Sequence[int], places: Sequence[str]
                    ) -> Iterator[np.ndarray]:
    """Yield the frames ``indices`` (0 the first frame in display order) of the video at
    ``path``, in order, as uint8 [H, W, 3].

    ``indices`` must increase strictly; ``places[j]`` names index ``j`` in error messages.
    The packets are read first (no decoding) to learn every frame's time stamp, so a wanted
    frame more than :data:`SEEK_AHEAD_S` ahead is reached by seeking; a video whose packets
    carry no time stamps, or whose decoded frames do not match them, is decoded from the start
    (frames between the wanted ones decoded but not converted to RGB).
    """
    _check_increasing(list(indices), places, "frame")
    if len(indices) and indices[0] < 0:
        raise VggcError(f"{places[0]}: frame {indices[0]} is negative")
    stamps = _display_pts(path)
    if stamps is None:
        yield from _frames_in_order(path, indices, places)
        return
    for j, k in enumerate(indices):
        if k >= len(stamps):
            raise VggcError(f"{places[j]}: frame {k} is past the end of {path} "
                            f"({len(stamps)} frames)")
    done = 0
    for image in _frames_at_pts(path, [stamps[k] for k in indices]):
        if image is None:  # the decoded frames do not match the packets' time stamps
            yield from _frames_in_order(path, indices[done:], places[done:])
            return
        yield image
        done += 1


def _display_pts(path) -> list[int] | None:
    """Time stamps (pts) of every frame in display order, read from the packets without
    decoding; None when a packet has none or two share one."""
    av, container, stream = _open_video(path)
    pts = []
    with container:
        try:
            for packet in container.demux(stream):
                if packet.size == 0:
                    continue  # the demuxer's final empty packet
                if packet.pts is None:
                    return None
                pts.append(int(packet.pts))
        except (av.FFmpegError, OSError, ValueError) as exc:
            raise VggcError(f"{path}: the video is damaged ({type(exc).__name__})") from None
    pts.sort()
    return pts if len(set(pts)) == len(pts) else None


def _frames_at_pts(path, targets: Sequence[int]) -> Iterator[np.ndarray | None]:
    """The frames whose pts are ``targets`` (increasing), seeking over long gaps; yields None
    (and stops) when decoding does not give a frame of exactly that pts."""
    av, container, stream = _open_video(path)
    src = str(path)
    stream.thread_type = "AUTO"
    base = float(stream.time_base) if stream.time_base else 0.0
    with container:
        it = _frames(av, container, stream, src)
        last = None  # pts of the last frame decoded
        for target in targets:
            ahead = (target - (last if last is not None else 0)) * base
            if base and ahead > SEEK_AHEAD_S:
                container.seek(int(target), stream=stream, backward=True, any_frame=False)
                it = _frames(av, container, stream, src)
            for frame in it:
                if frame.pts is None or frame.pts > target:
                    yield None
                    return
                last = frame.pts
                if frame.pts == target:
                    yield _rgb(frame)
                    break
            else:
                yield None
                return


def _frames_in_order(path, indices: Sequence[int], places: Sequence[str]
                     ) -> Iterator[np.ndarray]:
    """The frames ``indices`` decoding from the first frame, counting frames."""
    av, container, stream = _open_video(path)
    src = str(path)
    stream.thread_type = "AUTO"
    j = 0
    n = 0
    with container:
        for n, frame in enumerate(_frames(av, container, stream, src), start=1):
            if j < len(indices) and n - 1 == indices[j]:
                yield _rgb(frame)
                j += 1
            if j == len(indices):
                return
    if j < len(indices):
        raise VggcError(f"{places[j]}: frame {indices[j]} is past the end of {src} "
                        f"({n} frames)")


def frames_by_time(path, times: Sequence[float], places: Sequence[str]
                   ) -> Iterator[np.ndarray]:
    """Yield the frame shown at each of ``times`` (seconds on the video's clock, as ffprobe's
    ``pts_time``) of the video at ``path``, in order, as uint8 [H, W, 3].

    The frame whose time is nearest is taken; it must lie within half a frame period (by the
    stream's average rate), else the time falls in a gap or beyond the end and is refused.
    ``times`` must increase strictly and give distinct frames. A wanted time more than
    :data:`SEEK_AHEAD_S` ahead is reached by seeking to the key frame before it.
    """
    _check_increasing(list(times), places, "time")
    av, container, stream = _open_video(path)
    src = str(path)
    stream.thread_type = "AUTO"
    base = stream.time_base
    rate = stream.average_rate or stream.guessed_rate
    half = 0.5 / float(rate) if rate else 1e-3

    seconds = float(base) if base else 0.0

    def when(frame) -> float:
        return frame.pts * seconds if frame.pts is not None else float(frame.time or 0.0)

    with container:
        it = _frames(av, container, stream, src)
        prev = None  # (time, frame): the last frame decoded before the wanted time
        ahead = None  # (time, frame): the first frame decoded at or after it
        last_pts = None
        for j, t in enumerate(times):
            known = ahead or prev
            if t - (known[0] if known else 0.0) > SEEK_AHEAD_S and base:
                container.seek(int(max(t - 4 * half, 0.0) / base), stream=stream,
                               backward=True, any_frame=False)
                it = _frames(av, container, stream, src)
                prev = ahead = None
            while ahead is None or ahead[0] < t:
                if ahead is not None:
                    prev = ahead
                frame = next(it, None)
                if frame is None:
                    ahead = None
                    break
                ahead = (when(frame), frame)
            best = min((c for c in (prev, ahead) if c is not None),
                       key=lambda c: abs(c[0] - t), default=None)
            if best is None or abs(best[0] - t) > half + 1e-9:
                near = f"; the nearest frame is at {best[0]:.6g} s" if best else ""
                raise VggcError(f"{places[j]}: no frame of {src} at time {t:.6g} s{near}")
            if last_pts is not None and best[1].pts == last_pts:
                raise VggcError(f"{places[j]}: time {t:.6g} s shows the same frame as "
                                f"{places[j - 1]} (frames are {2 * half:.4g} s apart)")
            last_pts = best[1].pts
            yield _rgb(best[1])


