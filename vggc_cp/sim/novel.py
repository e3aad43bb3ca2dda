"""Novel images for localization (``FORMATS.md``, "Novel images"): fresh renders of states a
trace visited, written beside the trace as ``<trace stem>.novel.npz``.

Keys: ``observations`` uint8 ``[M, H, W, 3]`` and ``states`` unicode ``[M]``. The file is
written with fixed zip timestamps, so the same arrays give the same bytes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vggc_cp.atomic import write_bytes
from vggc_cp.errors import VggcError
from vggc_cp.trace import npz_bytes


def novel_path(trace_path: str | Path) -> Path:
    """``dir/name.npz`` -> ``dir/name.novel.npz`` (the suffix ``.npz`` is dropped if present)."""
    p = Path(trace_path)
    stem = p.name[:-4] if p.name.endswith(".npz") else p.name
    return p.with_name(f"{stem}.novel.npz")


def novel_bytes(observations: np.ndarray, states: np.ndarray) -> bytes:
    """Serialize novel images to npz bytes (deterministic)."""
    return npz_bytes({"observations": np.ascontiguousarray(observations, dtype=np.uint8),
                      "states": np.asarray(states, dtype=str).reshape(-1)})


def save_novel(path: str | Path, observations: np.ndarray, states: np.ndarray) -> None:
    """Atomically write a novel-images file."""
    if observations.ndim != 4 or observations.shape[3] != 3 or observations.dtype != np.uint8:
        raise VggcError(f"{path}: novel observations must be uint8 [M, H, W, 3]")
    if len(states) != observations.shape[0]:
        raise VggcError(f"{path}: {len(states)} states for {observations.shape[0]} images")
    write_bytes(path, novel_bytes(observations, states))


def load_novel(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a novel-images file: ``(observations [M, H, W, 3] uint8, states [M] str)``."""
    from vggc_cp.safeio import check_image_size, check_input, npz_headers

    p = Path(path)
    check_input(p, "novel-images file")
    headers = npz_headers(p, str(p))
    for key in ("observations", "states"):
        if key not in headers:
            raise VggcError(f"{p}: not a novel-images file (missing field {key!r})")
    shape = headers["observations"][0]
    if len(shape) == 4:
        check_image_size(shape[1], shape[2], f"{p}: field 'observations'")
    try:
        with np.load(p, allow_pickle=False) as data:
            obs, states = data["observations"], data["states"]
    except Exception as exc:  # noqa: BLE001 - zlib, zip, npy damage: all refusals
        raise VggcError(f"{p}: not a novel-images file ({type(exc).__name__})") from None
    if obs.dtype != np.uint8 or obs.ndim != 4 or obs.shape[3] != 3:
        raise VggcError(f"{p}: field 'observations' must be uint8 [M, H, W, 3]")
    if states.dtype.kind != "U" or states.shape != (obs.shape[0],):
        raise VggcError(f"{p}: field 'states' must be unicode [M]")
    if obs.shape[0] == 0:
        raise VggcError(f"{p}: field 'observations' holds no image")
    return obs, states
