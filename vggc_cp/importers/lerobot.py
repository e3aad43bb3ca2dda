"""``vggc-cp import lerobot DIR --camera KEY --labels COLUMN``: a LeRobot dataset folder.

Read with pyarrow and PyAV (the ``lerobot`` package is not needed). The folder holds

* ``meta/info.json`` -- ``fps``, ``features`` (the camera ``KEY`` is a feature of dtype
  ``video``, or ``image`` for frames stored in the parquet files), ``video_path`` (a template);
* ``data/**/*.parquet`` -- one row per frame with ``episode_index``, ``frame_index``,
  ``timestamp`` and the label ``COLUMN`` (layout v2: ``data/chunk-000/episode_000000.parquet``;
  v3: ``data/chunk-000/file-000.parquet`` holding many episodes);
* for a video camera, the videos: v2, one file per episode,
  ``videos/chunk-{episode_chunk:03d}/{video_key}/episode_{episode_index:06d}.mp4``; v3, many
  episodes per file, ``videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4``,
  located by ``meta/episodes/**/*.parquet`` (columns ``episode_index``,
  ``videos/{video_key}/chunk_index``, ``.../file_index``, ``.../from_timestamp``).

Episodes are taken in the order of ``episode_index``, frames in the order of ``frame_index``
(which must run 0, 1, 2, ...); frame t of an episode is the video frame at
``from_timestamp + timestamp``. The label column holds strings, or integers that index the
feature's ``names`` in ``info.json`` (without names the integer itself is the label, for
``--map``); the label of an episode's last frame is ignored. Error messages count parquet rows
from 0, as pyarrow and pandas do.
"""

from __future__ import annotations

import os
import string
from collections import defaultdict
from pathlib import Path

from vggc_cp.errors import VggcError
from vggc_cp.importers.base import (
    Argument,
    ImportConfig,
    Importer,
    RecordingBuilder,
    register_importer,
    require,
)
from vggc_cp.importers.decode import frames_by_time, image_from_bytes
from vggc_cp.safeio import read_json
from vggc_cp.trace import Trace

TEMPLATE_FIELDS = {"episode_chunk", "episode_index", "video_key", "chunk_index", "file_index"}


def _columns(pq, path: Path, wanted: list[str]) -> dict[str, list]:
    """The columns ``wanted`` of one parquet file as Python lists."""
    try:
        pf = pq.ParquetFile(str(path))
        names = pf.schema_arrow.names
    except Exception as exc:  # noqa: BLE001 - pyarrow raises many kinds on damage
        raise VggcError(f"{path}: not a readable parquet file ({type(exc).__name__})") from None
    for col in wanted:
        if col not in names:
            raise VggcError(f"{path}: no column {col!r} (columns: {', '.join(names)})")
    try:
        table = pf.read(columns=wanted)
    except Exception as exc:  # noqa: BLE001
        raise VggcError(f"{path}: unreadable ({type(exc).__name__})") from None
    return {col: table.column(col).to_pylist() for col in wanted}


def _scalar(value):
    if isinstance(value, list) and len(value) == 1:
        return value[0]
    return value


def _path_from(template: str, root: Path, where: str, **fields) -> Path:
    """Fill a path template of ``info.json`` (only LeRobot's fields; no attribute access), and
    keep the result inside the dataset folder."""
    try:
        used = {f for _, f, _, _ in string.Formatter().parse(template) if f is not None}
    except ValueError:
        used = {"?"}
    if not used <= TEMPLATE_FIELDS:
        raise VggcError(f"{where}: the template {template!r} uses fields other than "
                        f"{', '.join(sorted(TEMPLATE_FIELDS))}")
    try:
        rel = template.format(**fields)
    except (KeyError, ValueError, IndexError, TypeError) as exc:
        raise VggcError(f"{where}: cannot fill the template {template!r} ({exc})") from None
    path = (root / rel).resolve()
    if root.resolve() not in path.parents:
        raise VggcError(f"{where}: the template {template!r} leads out of the dataset folder")
    return path


def read_lerobot(config: ImportConfig, folder, camera: str, labels: str,
                 states: str | None = None) -> Trace:
    """The trace of a LeRobot dataset folder (module docstring)."""
    pq = require("pyarrow.parquet")
    root = Path(str(folder))
    if not root.is_dir():
        raise VggcError(f"{root}: not a folder (a LeRobot dataset is a folder with meta/, "
                        f"data/ and videos/)")
    info_path = root / "meta" / "info.json"
    if not info_path.is_file():
        raise VggcError(f"{root}: no meta/info.json (not a LeRobot dataset folder)")
    info = read_json(info_path)
    features = info.get("features") if isinstance(info, dict) else None
    if not isinstance(features, dict):
        raise VggcError(f"{info_path}: no 'features' object")
    cams = sorted(k for k, v in features.items()
                  if isinstance(v, dict) and v.get("dtype") in ("video", "image"))
    if camera not in features:
        raise VggcError(f"{info_path}: no feature {camera!r} (cameras: "
                        f"{', '.join(cams) or 'none'})")
    kind = features[camera].get("dtype") if isinstance(features[camera], dict) else None
    if kind not in ("video", "image"):
        raise VggcError(f"{info_path}: feature {camera!r} has dtype {kind!r}, not a camera "
                        f"(cameras: {', '.join(cams) or 'none'})")
    names = features.get(labels, {}).get("names") if isinstance(features.get(labels),
                                                                 dict) else None
    names = names if isinstance(names, list) and all(isinstance(n, str) for n in names) \
        else None

    data_files = sorted((root / "data").glob("**/*.parquet"))
    if not data_files:
        raise VggcError(f"{root}: no parquet file under data/")
    wanted = ["episode_index", "frame_index", labels]
    wanted += ["timestamp"] if kind == "video" else [camera]
    wanted += [states] if states else []
    # episode -> [(frame_index, file, row, label, state, image bytes or timestamp)]
    episodes: dict[int, list] = defaultdict(list)
    for path in data_files:
        cols = _columns(pq, path, list(dict.fromkeys(wanted)))
        rel = path
        for r in range(len(cols["episode_index"])):
            ep, fi = _scalar(cols["episode_index"][r]), _scalar(cols["frame_index"][r])
            if not isinstance(ep, int) or not isinstance(fi, int):
                raise VggcError(f"{rel}: row {r}: episode_index {ep!r} / frame_index {fi!r} "
                                f"are not integers")
            label = _label(_scalar(cols[labels][r]), names, f"{rel}: row {r}", labels)
            state = _scalar(cols[states][r]) if states else None
            payload = cols["timestamp" if kind == "video" else camera][r]
            episodes[ep].append((fi, rel, r, label, state, _scalar(payload)))
    video_of = _video_locator(pq, root, info, camera, sorted(episodes)) \
        if kind == "video" else None

    builder = RecordingBuilder(config, last_label="ignore")
    for ep in sorted(episodes):
        rows = sorted(episodes[ep], key=lambda x: x[0])
        for k, (fi, rel, r, *_rest) in enumerate(rows):
            if fi != k:
                raise VggcError(f"{rel}: row {r}: episode {ep} frame_index {fi}, expected {k} "
                                f"(frame_index must run 0, 1, 2, ... within an episode)")
        places = [f"{rel}: row {r} (episode {ep}, frame {fi})" for fi, rel, r, *_ in rows]
        if kind == "video":
            video, offset = video_of(ep)
            times = []
            for (_, _, _, _, _, ts), place in zip(rows, places):
                if not isinstance(ts, (int, float)):
                    raise VggcError(f"{place}: timestamp {ts!r} is not a number")
                times.append(offset + float(ts))
            images = frames_by_time(video, times, places)
        else:
            images = (_image_cell(row[5], place, camera) for row, place in zip(rows, places))
        builder.start_episode(f"episode {ep}")
        for row, place, image in zip(rows, places, images):
            builder.add(image, row[3], place, None if row[4] is None else str(row[4]))
    source = {"format": "lerobot", "file": os.path.basename(os.path.abspath(root)),
              "camera": camera, "labels": labels,
              "codebase_version": str(info.get("codebase_version", ""))}
    if states:
        source["states"] = states
    return builder.trace(source)


def _label(value, names, place: str, column: str) -> str | None:
    if value is None:
        return None
    if isinstance(value, bool):
        value = int(value)
    if isinstance(value, int):
        if names is None:
            return str(value)
        if not 0 <= value < len(names):
            raise VggcError(f"{place}: {column} = {value} is out of range for the "
                            f"{len(names)} names of info.json")
        return names[value]
    if isinstance(value, (bytes, bytearray)):
        value = value.decode("utf-8", "replace")
    if not isinstance(value, str):
        raise VggcError(f"{place}: {column} holds {type(value).__name__}, expected a string or "
                        f"an integer")
    return value


def _image_cell(cell, place: str, camera: str):
    data = cell.get("bytes") if isinstance(cell, dict) else cell
    if not isinstance(data, (bytes, bytearray)):
        raise VggcError(f"{place}: column {camera!r} holds no encoded image")
    return image_from_bytes(bytes(data), f"{place}: {camera}")


def _video_locator(pq, root: Path, info: dict, camera: str, episodes: list[int]):
    """``episode -> (video file, time offset of its first frame)``."""
    where = f"{root / 'meta' / 'info.json'}"
    template = info.get("video_path") or (info.get("videos") or {}).get("videos_path")
    if not isinstance(template, str):
        raise VggcError(f"{where}: no 'video_path' template")
    if "{episode_index" in template:  # v2: one file per episode
        chunks = info.get("chunks_size", 1000)
        if not isinstance(chunks, int) or chunks < 1:
            raise VggcError(f"{where}: chunks_size {chunks!r} is not a positive integer")
        return lambda ep: (_path_from(template, root, where, episode_chunk=ep // chunks,
                                      episode_index=ep, video_key=camera), 0.0)
    meta_files = sorted((root / "meta" / "episodes").glob("**/*.parquet"))
    if not meta_files:
        raise VggcError(f"{root}: no parquet file under meta/episodes/ (layout v3 locates "
                        f"each episode's video there)")
    keys = [f"videos/{camera}/chunk_index", f"videos/{camera}/file_index",
            f"videos/{camera}/from_timestamp"]
    table: dict[int, tuple] = {}
    for path in meta_files:
        cols = _columns(pq, path, ["episode_index", *keys])
        for r, ep in enumerate(cols["episode_index"]):
            table[ep] = (cols[keys[0]][r], cols[keys[1]][r], cols[keys[2]][r], path, r)
    for ep in episodes:
        if ep not in table:
            raise VggcError(f"{root}: meta/episodes/ has no row for episode {ep}")

    def locate(ep: int):
        chunk, file, start, path, r = table[ep]
        if not isinstance(start, (int, float)):
            raise VggcError(f"{path}: row {r}: from_timestamp {start!r} is not a number")
        return (_path_from(template, root, f"{path}: row {r}", chunk_index=chunk,
                           file_index=file, video_key=camera), float(start))
    return locate


LEROBOT = register_importer(Importer(
    name="lerobot",
    help="a LeRobot dataset folder (meta/info.json, parquet, mp4; v2 or v3)",
    description=__doc__.split("\n", 2)[2].strip(),
    arguments=(Argument("folder", "the dataset folder (holding meta/info.json)", metavar="DIR"),
               Argument("--camera", "the camera feature, e.g. observation.images.top",
                        metavar="KEY"),
               Argument("--labels", "the parquet column of action labels", metavar="COLUMN"),
               Argument("--states", "a parquet column of ground-truth state strings, kept for "
                                    "evaluate", required=False, metavar="COLUMN")),
    read=read_lerobot,
))
