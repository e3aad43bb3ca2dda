"""``vggc-cp import robomimic FILE --camera NAME --labels KEY``: an HDF5 file in robomimic's
layout.

Every group ``data/demo_K`` is one episode, taken in the order of K (``demo_2`` before
``demo_10``; other groups under ``data`` are ignored). Its frames are the dataset
``data/demo_K/obs/NAME``, uint8 ``[T, H, W, 3]``. The action labels are the dataset
``data/demo_K/KEY`` (``KEY`` may be a path inside the demo, e.g. ``obs/labels``), of length T
(entry t: the action taken after frame t; the last entry leads out of the recording and is
ignored) or T - 1, holding either

* strings (the labels themselves), or
* integers, indices into the dataset's attribute ``names`` (a list of strings); ``-1`` on
  the last frame is allowed.

The optional ``--states KEY2`` names a dataset of T strings per demo kept as ground truth.
"""

from __future__ import annotations

import os
import re

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.importers.base import (
    Argument,
    ImportConfig,
    Importer,
    RecordingBuilder,
    register_importer,
    require,
)
from vggc_cp.safeio import CAPS, cap, check_image_size, check_input
from vggc_cp.trace import Trace

DEMO = re.compile(r"demo_(\d+)")
#: frames read from HDF5 at once
BLOCK = 64


def _dataset(h5py, f, path: str, src: str):
    parent, _, _name = path.rpartition("/")
    node = f.get(path)
    if node is None or not isinstance(node, h5py.Dataset):
        group = f.get(parent)
        holds = (", ".join(sorted(group.keys())) if isinstance(group, h5py.Group) else None)
        what = "not a dataset" if node is not None else "no such dataset"
        raise VggcError(f"{src}: {path}: {what}"
                        + (f" ({parent} holds: {holds or 'nothing'})" if holds is not None
                           else ""))
    return node


def _strings(values, path: str, src: str) -> list[str]:
    out = []
    for i, v in enumerate(values):
        if isinstance(v, bytes):
            try:
                v = v.decode("utf-8")
            except UnicodeDecodeError:
                raise VggcError(f"{src}: {path}[{i}]: not UTF-8 text") from None
        out.append(str(v).strip())
    return out


def _labels(h5py, f, path: str, n_frames: int, src: str) -> list[str | None]:
    ds = _dataset(h5py, f, path, src)
    if ds.ndim != 1 or ds.shape[0] not in (n_frames, n_frames - 1):
        raise VggcError(f"{src}: {path}: shape {ds.shape}, expected ({n_frames},) or "
                        f"({n_frames - 1},): one label per frame or per transition")
    kind = ds.dtype.kind
    if kind in "SOU":
        labels: list[str | None] = list(_strings(ds.asstr()[()] if kind == "O" else ds[()],
                                                 path, src))
    elif kind in "iu":
        names = ds.attrs.get("names")
        if names is None:
            raise VggcError(f"{src}: {path}: integer labels need the attribute 'names' (a list "
                            f"of strings: the name of each index)")
        names = _strings(np.atleast_1d(names), f"{path}.attrs['names']", src)
        labels = []
        for i, v in enumerate(ds[()].tolist()):
            if v == -1:
                labels.append(None)
            elif 0 <= v < len(names):
                labels.append(names[v])
            else:
                raise VggcError(f"{src}: {path}[{i}] = {v} is out of range for its "
                                f"{len(names)} names")
    else:
        raise VggcError(f"{src}: {path}: dtype {ds.dtype}, expected strings or integers")
    labels = [x if x else None for x in labels]
    return labels + [None] * (n_frames - len(labels))


def _read_demos(h5py, f, src: str, builder: RecordingBuilder, camera: str, labels: str,
                states: str | None) -> None:
    """Every demo of the open file ``f`` into ``builder``, in natural demo order."""
    data = f.get("data")
    if not isinstance(data, h5py.Group):
        raise VggcError(f"{src}: no group 'data' (robomimic keeps its demos in "
                        f"data/demo_K)")
    demos = sorted((int(m.group(1)), k) for k in data.keys()
                   if (m := DEMO.fullmatch(k)))
    if not demos:
        raise VggcError(f"{src}: data holds no demo_K group (it holds: "
                        f"{', '.join(sorted(data.keys())) or 'nothing'})")
    for _k, demo in demos:
        obs_path = f"data/{demo}/obs/{camera}"
        obs = _dataset(h5py, f, obs_path, src)
        if obs.dtype != np.uint8 or obs.ndim != 4 or obs.shape[3] != 3:
            raise VggcError(f"{src}: {obs_path}: dtype {obs.dtype}, shape {obs.shape}; "
                            f"expected uint8 [T, H, W, 3]")
        t_len, h, w = (int(x) for x in obs.shape[:3])
        check_image_size(h, w, f"{src}: {obs_path}")
        name = "max_frame_bytes" if builder.frames.spills else "max_bytes"  # read in blocks
        if obs.size > cap(name):
            raise VggcError(f"{src}: {obs_path}: {obs.size:,} bytes, over the cap of "
                            f"{cap(name):,} ({CAPS[name][1]})")
        names = _labels(h5py, f, f"data/{demo}/{labels}", t_len, src)
        truth = None
        if states:
            st_path = f"data/{demo}/{states}"
            ds = _dataset(h5py, f, st_path, src)
            if ds.ndim != 1 or ds.shape[0] != t_len or ds.dtype.kind not in "SOU":
                raise VggcError(f"{src}: {st_path}: expected {t_len} strings, found "
                                f"shape {ds.shape} of {ds.dtype}")
            truth = _strings(ds.asstr()[()] if ds.dtype.kind == "O" else ds[()],
                             st_path, src)
        builder.start_episode(demo)
        for lo in range(0, t_len, BLOCK):
            try:
                block = obs[lo:lo + BLOCK]
            except (OSError, ValueError) as exc:
                raise VggcError(f"{src}: {obs_path}[{lo}]: unreadable "
                                f"({type(exc).__name__})") from None
            for i, image in enumerate(block, start=lo):
                label = names[i] if i < t_len - 1 else None
                builder.add(image, label, f"{src}: {obs_path}[{i}]",
                            truth[i] if truth else None)


def read_robomimic(config: ImportConfig, file, camera: str, labels: str,
                   states: str | None = None) -> Trace:
    """The trace of the demos of the robomimic HDF5 ``file`` (module docstring)."""
    h5py = require("h5py")
    src = str(file)
    check_input(src, "HDF5 file")
    try:
        f = h5py.File(src, "r")
    except (OSError, ValueError) as exc:
        raise VggcError(f"{src}: not a readable HDF5 file ({type(exc).__name__})") from None
    builder = RecordingBuilder(config, last_label="ignore")
    with f:
        try:
            _read_demos(h5py, f, src, builder, camera, labels, states)
        except (OSError, RuntimeError, KeyError, TypeError) as exc:
            raise VggcError(f"{src}: damaged HDF5 file ({type(exc).__name__}: "
                            f"{str(exc)[:120]})") from None
    source = {"format": "robomimic", "file": os.path.basename(src), "camera": camera,
              "labels": labels}
    if states:
        source["states"] = states
    return builder.trace(source)


ROBOMIMIC = register_importer(Importer(
    name="robomimic",
    help="an HDF5 file in robomimic's layout (data/demo_K/obs/CAMERA)",
    description=__doc__.split("\n", 3)[3].strip(),
    arguments=(Argument("file", "the HDF5 file", metavar="FILE"),
               Argument("--camera", "the image dataset under data/demo_K/obs", metavar="NAME"),
               Argument("--labels", "the dataset of action labels under data/demo_K (strings, "
                                    "or integers with a 'names' attribute)", metavar="KEY"),
               Argument("--states", "a dataset of ground-truth state strings under "
                                    "data/demo_K, kept for evaluate", required=False,
                        metavar="KEY")),
    read=read_robomimic,
))
