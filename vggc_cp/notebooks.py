"""Run the research notebooks with parameters (papermill-style, on nbclient).

A notebook declares its defaults in one code cell tagged ``parameters``; :func:`run_notebook`
inserts a cell right after it that overrides them, executes the notebook top to bottom and
writes the executed copy atomically. The notebooks in ``notebooks/`` call the library, never
copies of its code; CI runs them at their small size.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from vggc_cp.atomic import write_text
from vggc_cp.errors import VggcError
from vggc_cp.safeio import check_input


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
    check_input(path, "notebook")
    nb = nbformat.read(path, as_version=4)
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
        raise VggcError(f"{path}: a cell failed: {first[-1] if first else exc}") from None
    seconds = time.perf_counter() - t0
    if output is not None:
        nb.metadata["vggc_cp"] = {"parameters": parameters or {}, "seconds": round(seconds, 1)}
        write_text(output, nbformat.writes(nb))
    return NotebookRun(path, Path(output) if output else None, seconds, len(nb.cells))
