"""``vggc-cp import images LOG``: a folder of image files and a log naming them.

The log is CSV with the header ``frame,action,episode`` (or JSON lines, by the suffix
``.jsonl``, one object with those keys a line), one row per image in time order:

* ``frame`` -- the image file, relative to the log's folder (PNG, JPEG, anything Pillow reads);
* ``action`` -- the action taken after this frame; empty on an episode's last frame;
* ``episode`` -- any id; the rows of an episode are consecutive;
* ``state`` (optional) -- a ground-truth state key, kept as the trace's ``states`` when every
  row has one (only ``evaluate`` reads it).
"""

from __future__ import annotations

import os
from pathlib import Path

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
from vggc_cp.importers.decode import read_image
from vggc_cp.trace import Trace

COLUMNS = ("frame", "action", "episode")


def read_images(config: ImportConfig, log) -> Trace:
    """The trace of the image files that ``log`` lists (module docstring)."""
    src = str(log)
    rows = read_log(src, COLUMNS, ("state",))
    folder = Path(src).parent
    builder = RecordingBuilder(config, last_label="empty")
    for episode in episodes_of_log(src, rows):
        builder.start_episode(episode[0][1]["episode"])
        for n, row in episode:
            place = f"{src}: row {n}"
            if not row["frame"]:
                raise VggcError(f"{place}: empty 'frame' (the image file of this row)")
            image = read_image(folder / row["frame"], place)
            builder.add(image, row["action"], place, row.get("state"))
    return builder.trace({"format": "images", "file": os.path.basename(src)})


IMAGES = register_importer(Importer(
    name="images",
    help="image files listed by a CSV/JSONL log (frame,action,episode)",
    description=__doc__.split("\n", 2)[2].strip(),
    arguments=(Argument("log", "CSV log with the header frame,action,episode (or .jsonl); "
                               "frame paths are relative to its folder", metavar="LOG"),),
    read=read_images,
))
