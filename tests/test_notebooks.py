"""The research notebooks execute end to end at their small size (CI).

Deselect locally with ``-m "not notebook"``.
"""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest

from vggc_cp.notebooks import run_notebook

NOTEBOOKS = Path(__file__).resolve().parent.parent / "notebooks"
pytestmark = pytest.mark.notebook


def small(tmp_path, **extra) -> dict:
    return {"SEEDS": [0], "TIME_LIMIT": 1.0, "WORKERS": 1, "IMAGE_SIZE": 32,
            "CACHE_DIR": str(tmp_path / "cache"), "FIG_DIR": str(tmp_path / "figures"), **extra}


CASES = {
    "feasibility_thresholds": {"SIZES": [30], "K_MAX": 5},
    "heuristic_vs_exact": {"BENCHMARKS": ["fruit-2x3"], "TRANSITIONS": 20, "QUERIES": 30},
    "scalability": {"SIZES": [20, 30], "QUERIES": 30, "SCALE_SIZES": [40, 80]},
    "robustness": {"BENCHMARKS": ["fruit-2x3"], "LOOKS": ["clean"], "TRANSITIONS": 50,
                   "QUERIES": 30, "JOBS": 1},
}
#: Parameters naming a folder of the run (under the test's tmp_path).
FOLDERS = {"robustness": "OUT"}


@pytest.mark.parametrize("name", sorted(CASES))
def test_notebook_runs_small(name, tmp_path):
    out = tmp_path / f"{name}.ipynb"
    extra = dict(CASES[name])
    if name in FOLDERS:
        extra[FOLDERS[name]] = str(tmp_path / name)
    run_notebook(NOTEBOOKS / f"{name}.ipynb", small(tmp_path, **extra), out, timeout=300)
    nb = nbformat.read(out, as_version=4)
    pngs = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
            if "image/png" in o.get("data", {})]
    assert pngs, "no figure in the executed notebook"
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", [])
              if o.get("output_type") == "error"]
    assert not errors
    assert list((tmp_path / "figures").glob("*.png"))
