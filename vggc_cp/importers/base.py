"""What every importer shares: its settings, its registry entry, and the assembly of the frames
it reads into a :class:`~vggc_cp.trace.Trace`.

An importer reads a recording (a folder of images with a log, a video with a log, a robomimic
HDF5 file, a LeRobot dataset folder) frame by frame into a :class:`RecordingBuilder`: each frame
with the label of the action taken after it and the *place* that names it in error messages
(``log.csv: row 7``, ``demos.hdf5: data/demo_3/obs/agentview_image[5]``). The builder checks
what a trace needs (one frame size, an action between the frames of an episode, labels that map
to ``pick``/``place`` names, picks and places alternating) and names the first place that breaks
it; :meth:`RecordingBuilder.trace` then gives the trace, validated.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vggc_cp.errors import VggcError, lookup
from vggc_cp.frames import FrameSpool
from vggc_cp.safeio import CAPS, cap, check_image_size, check_input, read_json
from vggc_cp.trace import Trace, action_kind, validate

#: how the readers that are not part of the base install are installed
EXTRA_HINT = "pip install -e '.[import]'"


def require(module: str):
    """Import the optional reader ``module`` (h5py, pyarrow.parquet, av), or fail with the
    command that installs it."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        top = module.split(".")[0]
        raise VggcError(f"importing this recording needs the Python package {top!r}, which is "
                        f"not installed: {EXTRA_HINT}") from None


# ------------------------------------------------------------------ settings


def parse_size(text: str) -> tuple[int, int]:
    """``--size``: ``"PX"`` (a square PX x PX) or ``"WxH"``; returns ``(width, height)``."""
    raw = str(text).strip().lower()
    parts = raw.split("x")
    try:
        if len(parts) == 1:
            w = h = int(parts[0])
        elif len(parts) == 2:
            w, h = int(parts[0]), int(parts[1])
        else:
            raise ValueError
    except ValueError:
        raise VggcError(f"--size {text!r}: expected PX (a square side) or WxH, e.g. 64 or "
                        f"96x64") from None
    return w, h


def read_label_map(path) -> dict[str, str]:
    """Read ``--map``: the recording's labels to ``pick``/``place`` action names.

    A ``.json`` file holds one object ``{"label": "action", ...}``; any other file is CSV with
    the header ``label,action``. Every action must begin with ``pick`` or ``place``.
    """
    src = str(path)
    out: dict[str, str] = {}
    if Path(src).suffix.lower() == ".json":
        data = read_json(src)
        if not isinstance(data, dict):
            raise VggcError(f"{src}: expected a JSON object {{\"label\": \"action\", ...}}")
        items = [(f"key {k!r}", k, v) for k, v in data.items()]
    else:
        rows = read_csv(src, ("label", "action"))
        items = [(f"row {n}", r["label"], r["action"]) for n, r in rows]
    for where, label, action in items:
        if not isinstance(action, str) or action_kind(action.strip()) is None:
            raise VggcError(f"{src}: {where}: maps {label!r} to {action!r}, which begins with "
                            f"neither 'pick' nor 'place'")
        out[str(label).strip()] = action.strip()
    return out


@dataclass(frozen=True)
class ImportConfig:
    """Settings every importer takes.

    Attributes
    ----------
    size : (int, int) or None
        ``(width, height)`` every frame is resized to by area averaging (Pillow's box filter:
        each output pixel the mean of the input pixels it covers); ``None`` keeps the
        recording's size. Only downsampling: a size above the recording's is refused.
    label_map : mapping of str to str
        The recording's labels to action names; a label that is not mapped must itself begin
        with ``pick`` or ``place``.
    label_map_file : str or None
        Where ``label_map`` came from (recorded in the trace's ``meta``).
    spool : path or None
        A file that frames beyond ``max_bytes`` spill into while the recording is read (the
        trace's frames are then mapped from it, :class:`vggc_cp.frames.FrameSpool`);
        ``vggc-cp import`` gives a temporary file beside its output. ``None``: a recording
        whose frames exceed ``max_bytes`` is refused.
    """

    size: tuple[int, int] | None = None
    label_map: Mapping[str, str] = field(default_factory=dict)
    label_map_file: str | None = None
    spool: str | os.PathLike | None = None

    def __post_init__(self):
        if self.size is not None:
            if (len(self.size) != 2 or not all(isinstance(s, (int, np.integer))
                                               for s in self.size)):
                raise VggcError(f"--size {self.size!r}: expected (width, height)")
            w, h = (int(s) for s in self.size)
            lo = cap("min_side")
            if min(w, h) < lo:
                raise VggcError(f"--size {w}x{h}: each side must be at least {lo}")
            check_image_size(h, w, f"--size {w}x{h}")
        for label, action in self.label_map.items():
            if action_kind(action) is None:
                raise VggcError(f"label map: {label!r} -> {action!r} begins with neither "
                                f"'pick' nor 'place'")


# ------------------------------------------------------------------ logs


def read_csv(path, required: tuple[str, ...], optional: tuple[str, ...] = ()
             ) -> list[tuple[int, dict[str, str]]]:
    """Rows of a CSV file with a header: ``[(row number, {column: text}), ...]``.

    Rows are numbered from 1 (the header is row 0, so row N is line N + 1 of a file without
    quoted line breaks). Fails naming the file on a missing column and naming the row on a row
    with too few or too many fields. Empty cells read as ``""``.
    """
    src = str(path)
    text = _read_text(src)
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = next(reader)
    except StopIteration:
        raise VggcError(f"{src}: empty file (expected the header "
                        f"{','.join(required)})") from None
    except csv.Error as exc:
        raise VggcError(f"{src}: row 0: not CSV ({exc})") from None
    header = [h.strip() for h in header]
    for col in required:
        if col not in header:
            raise VggcError(f"{src}: no column {col!r} (the header has: "
                            f"{', '.join(header) or 'nothing'})")
    keep = [c for c in (*required, *optional) if c in header]
    at = {c: header.index(c) for c in keep}
    rows = []
    try:
        for n, fields in enumerate(reader, start=1):
            if not fields or (len(fields) == 1 and not fields[0].strip()):
                continue  # a blank line
            if len(fields) != len(header):
                raise VggcError(f"{src}: row {n}: {len(fields)} fields, the header has "
                                f"{len(header)}")
            rows.append((n, {c: fields[i].strip() for c, i in at.items()}))
    except csv.Error as exc:
        raise VggcError(f"{src}: row {reader.line_num}: not CSV ({exc})") from None
    return rows


def read_jsonl(path, required: tuple[str, ...], optional: tuple[str, ...] = ()
               ) -> list[tuple[int, dict[str, str]]]:
    """Rows of a JSON-lines file, one object a line: ``[(row number, {key: text}), ...]``.

    Row N is line N of the file (blank lines are skipped but counted). Values are turned into
    text (``null`` into ``""``); nested values are refused.
    """
    from vggc_cp.safeio import loads_json

    src = str(path)
    rows = []
    for n, line in enumerate(_read_text(src).splitlines(), start=1):
        if not line.strip():
            continue
        obj = loads_json(line, f"{src}: row {n}")
        if not isinstance(obj, dict):
            raise VggcError(f"{src}: row {n}: expected a JSON object")
        for key in required:
            if key not in obj:
                raise VggcError(f"{src}: row {n}: no key {key!r} (the row has: "
                                f"{', '.join(map(str, obj)) or 'nothing'})")
        row = {}
        for key in (*required, *optional):
            if key not in obj:
                continue
            value = obj[key]
            if isinstance(value, (dict, list)):
                raise VggcError(f"{src}: row {n}: key {key!r} holds a {type(value).__name__}, "
                                f"expected text or a number")
            row[key] = "" if value is None else str(value).strip()
        rows.append((n, row))
    if not rows:
        raise VggcError(f"{src}: no rows")
    return rows


def read_log(path, required: tuple[str, ...], optional: tuple[str, ...] = ()
             ) -> list[tuple[int, dict[str, str]]]:
    """A log by its suffix: ``.jsonl`` (or ``.ndjson``) JSON lines, anything else CSV."""
    if Path(str(path)).suffix.lower() in (".jsonl", ".ndjson"):
        return read_jsonl(path, required, optional)
    rows = read_csv(path, required, optional)
    if not rows:
        raise VggcError(f"{path}: no rows after the header")
    return rows


def _read_text(src: str) -> str:
    st = check_input(src, "log")
    if st.st_size > cap("max_json_bytes"):
        raise VggcError(f"{src}: the log has {st.st_size:,} bytes, over the cap of "
                        f"{cap('max_json_bytes'):,} (VGGC_CP_MAX_JSON_BYTES)")
    try:
        with open(src, "rb") as f:
            raw = f.read()
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise VggcError(f"{src}: not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise VggcError(f"{src}: cannot read ({exc.strerror or type(exc).__name__})") from None


def episodes_of_log(src: str, rows: list[tuple[int, dict[str, str]]], key: str = "episode"
                    ) -> list[list[tuple[int, dict[str, str]]]]:
    """Split log rows into episodes where ``key`` changes; an id that comes back after another
    episode is refused (the rows must be in time order, one episode after another)."""
    episodes: list[list[tuple[int, dict[str, str]]]] = []
    ended: dict[str, int] = {}
    current = None
    for n, row in rows:
        ep = row[key]
        if episodes and ep == current:
            episodes[-1].append((n, row))
            continue
        if ep in ended:
            raise VggcError(f"{src}: row {n}: episode {ep!r} appears again (it ended at row "
                            f"{ended[ep]}); the rows must be in time order, one episode after "
                            f"another")
        if episodes:
            ended[current] = episodes[-1][-1][0]
        current = ep
        episodes.append([(n, row)])
    return episodes


# ------------------------------------------------------------------ frames


def resize(image: np.ndarray, size: tuple[int, int] | None, place: str) -> np.ndarray:
    """``image`` brought to ``size`` by area averaging.

    Parameters
    ----------
    image : ndarray, uint8, shape (H, W, 3)
    size : (int, int) or None
        ``(width, height)``; None returns ``image`` unchanged.
    place : str
        Names the frame in the error on upsampling (refused).

    Returns
    -------
    ndarray, uint8, shape (height, width, 3)
        Each pixel the mean of the input pixels it covers (Pillow's box filter, fixed-point:
        within 1 of the exact mean; deterministic).
    """
    if size is None:
        return image
    w, h = size
    ih, iw = image.shape[:2]
    if (iw, ih) == (w, h):
        return image
    if w > iw or h > ih:
        raise VggcError(f"{place}: --size {w}x{h} is larger than the frame ({iw}x{ih}); "
                        f"--size only downsamples")
    from PIL import Image

    out = Image.fromarray(np.ascontiguousarray(image)).resize((w, h), Image.Resampling.BOX)
    return np.asarray(out, dtype=np.uint8)


def as_rgb(image: np.ndarray, place: str) -> np.ndarray:
    """Check a decoded frame is uint8 [H, W, 3] within the pixel caps."""
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
        raise VggcError(f"{place}: a frame of shape {image.shape} and dtype {image.dtype}, "
                        f"expected uint8 [H, W, 3]")
    check_image_size(image.shape[0], image.shape[1], place)
    return image


# ------------------------------------------------------------------ the builder


@dataclass
class _Episode:
    name: str
    first: int  # index of its first frame


class RecordingBuilder:
    """Frames, labels and episodes as an importer reads them; :meth:`trace` assembles them.

    Parameters
    ----------
    config : ImportConfig
    last_label : {"empty", "ignore"}
        What the label of an episode's last frame must be: ``empty`` (a log says nothing
        after the last frame; an action there is refused) or ``ignore`` (robomimic and LeRobot
        give every frame an action; the last one leads out of the recording and is dropped).
    """

    def __init__(self, config: ImportConfig, last_label: str = "empty"):
        if last_label not in ("empty", "ignore"):
            raise ValueError(f"last_label {last_label!r}: expected 'empty' or 'ignore'")
        self.config = config
        self.last_label = last_label
        self.frames = FrameSpool(config.spool)
        self.labels: list[str | None] = []
        self.places: list[str] = []
        self.states: list[str | None] = []
        self.episodes: list[_Episode] = []
        self._bytes = 0
        self._shape: tuple[int, int] | None = None

    def start_episode(self, name: str) -> None:
        """Begin a new episode; the frames added next belong to it."""
        self.episodes.append(_Episode(str(name), len(self.frames)))

    def add(self, image: np.ndarray, label: str | None, place: str,
            state: str | None = None) -> None:
        """Add one frame (uint8 [H, W, 3], already decoded) with the label of the action taken
        after it (``None`` or ``""``: none) and its place for error messages."""
        if not self.episodes:
            raise ValueError("start_episode() before add()")
        image = resize(as_rgb(image, place), self.config.size, place)
        shape = image.shape[:2]
        if self._shape is None:
            self._shape = shape
        elif shape != self._shape:
            raise VggcError(f"{place}: the frame is {shape[1]}x{shape[0]} but the first frame "
                            f"({self.places[0]}) is {self._shape[1]}x{self._shape[0]}; give "
                            f"--size WxH to bring every frame to one size")
        self._bytes += image.nbytes
        name = "max_frame_bytes" if self.frames.spills else "max_bytes"
        if self._bytes > cap(name):
            raise VggcError(f"{place}: the frames up to here hold {self._bytes:,} bytes, over the "
                            f"cap of {cap(name):,} ({CAPS[name][1]}); give a smaller "
                            f"--size or raise the cap")
        self.frames.append(image, self._bytes)
        self.labels.append(label.strip() if isinstance(label, str) and label.strip() else None)
        self.places.append(place)
        self.states.append(state if state else None)

    # -------------------------------------------------------------- assembly

    def _action_name(self, label: str, place: str) -> str:
        mapped = self.config.label_map.get(label, label)
        if action_kind(mapped) is None:
            hint = (f"not in the label map {self.config.label_map_file}"
                    if self.config.label_map_file else "no --map FILE given")
            raise VggcError(f"{place}: action label {label!r} begins with neither 'pick' nor "
                            f"'place' ({hint})")
        if not mapped.isprintable():
            raise VggcError(f"{place}: action label {mapped!r} holds control characters")
        return mapped

    def actions(self) -> list[str | None]:
        """One action name per frame (``None`` on an episode's last frame), checked."""
        out: list[str | None] = []
        bounds = [e.first for e in self.episodes] + [len(self.frames)]
        for e, ep in enumerate(self.episodes):
            first, end = bounds[e], bounds[e + 1]
            if end - first < 2:
                where = self.places[first] if end > first else f"episode {ep.name!r}"
                raise VggcError(f"{where}: episode {ep.name!r} has {end - first} frame(s); an "
                                f"episode needs two frames or more (an action between them)")
            for t in range(first, end):
                label, place = self.labels[t], self.places[t]
                if t == end - 1:
                    if label is not None and self.last_label == "empty":
                        raise VggcError(f"{place}: action {label!r} on the last frame of "
                                        f"episode {ep.name!r} (the action after an episode's "
                                        f"last frame must be empty)")
                    out.append(None)
                    continue
                if label is None:
                    raise VggcError(f"{place}: no action, but episode {ep.name!r} goes on at "
                                    f"{self.places[t + 1]} (only an episode's last frame has "
                                    f"none)")
                name = self._action_name(label, place)
                if t > first and action_kind(name) == action_kind(out[-1]):
                    kind = "pick" if action_kind(name) == 0 else "place"
                    raise VggcError(f"{place}: action {name!r} follows {out[-1]!r} "
                                    f"({self.places[t - 1]}): two {kind}s in a row; picks and "
                                    f"places must alternate within an episode")
                out.append(name)
        return out

    def trace(self, source: dict) -> Trace:
        """The assembled trace (validated), with ``source`` recorded as ``meta["source"]``.

        ``action_names`` are the distinct action names in sorted order.
        """
        if not self.frames:
            raise VggcError(f"{source.get('file', 'the recording')}: no frames")
        names = self.actions()
        action_names = tuple(sorted({n for n in names if n is not None}))
        index = {n: i for i, n in enumerate(action_names)}
        actions = np.array([index[n] if n is not None else -1 for n in names[:-1]],
                           dtype=np.int64)
        states = None
        if all(s is not None for s in self.states):
            states = np.array(self.states, dtype=str)
        meta_source = dict(source)
        meta_source["frames"] = len(self.frames)
        meta_source["episodes"] = len(self.episodes)
        if self.config.size is not None:
            meta_source["size"] = list(self.config.size)
        if self.config.label_map_file:
            meta_source["map"] = os.path.basename(self.config.label_map_file)
        trace = Trace(self.frames.array(), actions, action_names, states,
                      {"source": meta_source})
        validate(trace, source.get("file", "<import>"))
        return trace


# ------------------------------------------------------------------ the registry


@dataclass(frozen=True)
class Argument:
    """One argument an importer takes besides the shared ones (``-o``, ``--size``, ``--map``).

    ``name`` without dashes is a positional argument (a file or folder), with ``--`` an option.
    """

    name: str
    help: str
    required: bool = True
    metavar: str | None = None

    @property
    def dest(self) -> str:
        return self.name.lstrip("-").replace("-", "_")


@dataclass(frozen=True)
class Importer:
    """A registered recording layout.

    Attributes
    ----------
    name : str
        The layout's name (``vggc-cp import NAME``).
    help : str
        One line for ``vggc-cp import --help``.
    description : str
        The layout, for ``vggc-cp import NAME --help``.
    arguments : tuple of Argument
    read : callable
        ``read(config, **arguments) -> Trace`` (keyword arguments by :attr:`Argument.dest`).
    """

    name: str
    help: str
    description: str
    arguments: tuple[Argument, ...]
    read: Callable[..., Trace]


#: name -> importer, in registration order
IMPORTERS: dict[str, Importer] = {}


def register_importer(importer: Importer) -> Importer:
    """Add ``importer`` to :data:`IMPORTERS` under its name."""
    IMPORTERS[importer.name] = importer
    return importer


def get_importer(name: str) -> Importer:
    """The importer called ``name`` (an unknown name lists the known ones)."""
    return lookup(IMPORTERS, name, "recording layout")
