"""Run the research notebooks with parameters (papermill-style, on nbclient).

A notebook declares its defaults in one code cell tagged ``parameters``; :func:`run_notebook`
inserts a cell right after it that overrides them, executes the notebook top to bottom and
writes the executed copy atomically. The notebooks in ``notebooks/`` call the library, never
copies of its code; CI runs them at their small size.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path

from vggc_cp.atomic import write_text
from vggc_cp.errors import VggcError
from vggc_cp.safeio import read_json

#: notebook format major versions this runner reads
NBFORMATS = (4,)
_ANSI = re.compile(r"\x1b\[[0-9;?]*[ -/]*[@-~]|\x1b[@-_]")


def plain_text(text: str) -> str:
    """``text`` without ANSI escape sequences (a kernel's coloured traceback)."""
    return _ANSI.sub("", text)


def read_notebook(path: Path):
    """The notebook at ``path`` as an nbformat v4 node, checked before nbformat parses it:
    UTF-8 JSON within the size and depth caps, an object whose ``nbformat`` is in
    :data:`NBFORMATS`, valid against nbformat's schema. Errors name the file."""
    import nbformat

    data = read_json(path, str(path))
    if not isinstance(data, dict):
        raise VggcError(f"{path}: not a notebook (the JSON is not an object)")
    version = data.get("nbformat")
    if isinstance(version, bool) or not isinstance(version, int) or version not in NBFORMATS:
        raise VggcError(f"{path}: field 'nbformat' is {version!r}; this runner reads notebook "
                        f"format {', '.join(map(str, NBFORMATS))}")
    try:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the schema's verdict comes from validate()
            nb = nbformat.reads(path.read_text(encoding="utf-8"), as_version=4)
            nbformat.validate(nb)
    except Exception as exc:  # noqa: BLE001 - any schema failure of a third-party reader
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0][:200]
        raise VggcError(f"{path}: not a valid notebook ({first})") from None
    return nb


@dataclass(frozen=True)
class NotebookRun:
    """Outcome of one execution."""

    path: Path
    output: Path | None
    seconds: float
    cells: int


def _missing(name: str) -> VggcError:
    return VggcError(f"running notebooks needs {name}; install the dev extras: "
                     "pip install -e '.[dev]'")


def parameter_source(parameters: dict) -> str:
    """Python source assigning ``parameters`` (values written with ``repr``)."""
    lines = ["# injected parameters"]
    lines += [f"{key} = {value!r}" for key, value in parameters.items()]
    return "\n".join(lines) + "\n"


def run_notebook(path: str | Path, parameters: dict | None = None,
                 output: str | Path | None = None, timeout: int = 3600,
                 cwd: str | Path | None = None) -> NotebookRun:
    """Execute a notebook with overridden parameters.

    Parameters
    ----------
    path : path of the ``.ipynb``
    parameters : dict, optional
        Values that override the defaults of the cell tagged ``parameters``.
    output : path, optional
        Where the executed notebook (with outputs) is written; nothing is written when None.
    timeout : int
        Seconds allowed per cell.
    cwd : path, optional
        Working directory of the kernel (default: the notebook's folder).

    Raises
    ------
    VggcError
        The notebook is missing, has no ``parameters`` cell, or a cell raised.
    """
    try:
        import nbformat
        from nbclient import NotebookClient
        from nbclient.exceptions import CellExecutionError
    except ImportError as exc:
        raise _missing(exc.name or "nbclient") from None
    path = Path(path)
    nb = read_notebook(path)
    index = next((i for i, c in enumerate(nb.cells)
                  if "parameters" in c.get("metadata", {}).get("tags", [])), None)
    if index is None:
        raise VggcError(f"{path}: no cell tagged 'parameters'")
    nb.cells = [c for c in nb.cells
                if "injected-parameters" not in c.get("metadata", {}).get("tags", [])]
    if parameters:
        cell = nbformat.v4.new_code_cell(parameter_source(parameters))
        cell.metadata["tags"] = ["injected-parameters"]
        nb.cells.insert(index + 1, cell)
    client = NotebookClient(nb, timeout=timeout, kernel_name="python3",
                            resources={"metadata": {"path": str(cwd or path.parent)}})
    t0 = time.perf_counter()
    try:
        client.execute()
    except CellExecutionError as exc:
        first = str(exc).strip().splitlines()
        last = plain_text(first[-1] if first else str(exc))
        raise VggcError(f"{path}: a cell failed: {last}") from None
    seconds = time.perf_counter() - t0
    if output is not None:
        nb.metadata["vggc_cp"] = {"parameters": parameters or {}, "seconds": round(seconds, 1)}
        write_text(output, nbformat.writes(nb))
    return NotebookRun(path, Path(output) if output else None, seconds, len(nb.cells))
