"""Atomic file writes: write to a temporary file beside the target, then rename."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

from vggc_cp.safeio import TEMP_MARK, cleanup_temps, temp_file

__all__ = ["atomic_path", "cleanup_temps", "write_bytes", "write_text"]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """Yield a temporary path in the target's folder; rename it onto ``path`` on success.

    On an exception the temporary file is removed and ``path`` is left untouched,
    so a reader never sees a half-written file. The temporary file is registered for
    :func:`cleanup_temps` before it exists (:func:`vggc_cp.safeio.temp_file`), so a signal
    at any moment removes it.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    with temp_file(target.parent, f".{target.name}{TEMP_MARK}", suffix or target.suffix) as tmp:
        yield tmp
        os.replace(tmp, target)


def write_text(path: str | os.PathLike, text: str) -> None:
    """Atomically write ``text`` (UTF-8) to ``path``."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Atomically write ``data`` to ``path``."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
