"""``vggc-cp import video VIDEO LOG``: one video file and a log of the frames to take from it.

The log is CSV (or JSON lines, by the suffix ``.jsonl``) with the columns ``action`` and
``episode`` as for :mod:`~vggc_cp.importers.images`, and one of

* ``frame`` -- the frame's index in the video, 0 the first frame (display order), or
* ``time`` -- the frame's time in seconds on the video's clock (ffprobe's ``pts_time``); the
  frame nearest that time is taken, and it must lie within half a frame period,

one row per frame in time order (strictly increasing); ``state`` is optional as for images.
Only the frames the log names are converted; far jumps are made by seeking.
"""

from __future__ import annotations

import os

from vggc_cp.errors import VggcError
from vggc_cp.importers.base import (
    Argument,
    ImportConfig,
    Importer,
    RecordingBuilder,
    episodes_of_log,
    read_log,
    register_importer,
)
from vggc_cp.importers.decode import frames_by_index, frames_by_time
from vggc_cp.trace import Trace


def _log_rows(src: str):
    """The log's rows and which column (``frame`` or ``time``) names the frames."""
    rows = read_log(src, ("action", "episode"), ("frame", "time", "state"))
    first = rows[0][1]
    kind = "frame" if "frame" in first else "time" if "time" in first else None
    if kind is None:
        raise VggcError(f"{src}: no column 'frame' (a frame index) nor 'time' (seconds); the "
                        f"log needs one of them, with 'action' and 'episode'")
    for n, row in rows:
        if kind not in row:
            raise VggcError(f"{src}: row {n}: no key {kind!r} (the first row has it)")
    return rows, kind


def _number(text: str, kind: str, place: str):
    try:
        if kind == "frame":
            return int(text)
        value = float(text)
        if value != value or value in (float("inf"), float("-inf")):
            raise ValueError
        return value
    except ValueError:
        want = "a frame index (an integer)" if kind == "frame" else "a time in seconds"
        raise VggcError(f"{place}: {kind} {text!r} is not {want}") from None


def read_video(config: ImportConfig, video, log) -> Trace:
    """The trace of the frames of ``video`` that ``log`` names (module docstring)."""
    src = str(log)
    rows, kind = _log_rows(src)
    episodes = episodes_of_log(src, rows)
    places = [f"{src}: row {n}" for ep in episodes for n, _ in ep]
    keys = [_number(row[kind], kind, f"{src}: row {n}") for ep in episodes for n, row in ep]
    decode = frames_by_index if kind == "frame" else frames_by_time
    frames = decode(video, keys, places)
    builder = RecordingBuilder(config, last_label="empty")
    k = 0
    for episode in episodes:
        builder.start_episode(episode[0][1]["episode"])
        for _n, row in episode:
            builder.add(next(frames), row["action"], places[k], row.get("state"))
            k += 1
    frames.close()
    return builder.trace({"format": "video", "file": os.path.basename(str(video)),
                          "log": os.path.basename(src), "by": kind})


VIDEO = register_importer(Importer(
    name="video",
    help="one video file and a CSV/JSONL log of frame indices or times",
    description=__doc__.split("\n", 2)[2].strip(),
    arguments=(Argument("video", "the video file (mp4, mkv, mov, ... as FFmpeg reads them)",
                        metavar="VIDEO"),
               Argument("log", "CSV log with the columns frame (or time),action,episode (or "
                               ".jsonl)", metavar="LOG")),
    read=read_video,
))
