"""The notebook runner injects parameters after the tagged cell and reports failures."""

from __future__ import annotations

import nbformat
import pytest

from vggc_cp.cli import main
from vggc_cp.errors import VggcError
from vggc_cp.notebooks import run_notebook


def tiny_notebook(path):
    nb = nbformat.v4.new_notebook()
    params = nbformat.v4.new_code_cell("size = 1\nname = 'small'")
    params.metadata["tags"] = ["parameters"]
    nb.cells = [params, nbformat.v4.new_code_cell("assert size == 5, size\nprint(name * 2)")]
    nbformat.write(nb, path)
    return path


@pytest.mark.slow
def test_parameters_are_injected_and_outputs_written(tmp_path):
    src = tiny_notebook(tmp_path / "nb.ipynb")
    out = tmp_path / "out.ipynb"
    run = run_notebook(src, {"size": 5, "name": "ab"}, out, timeout=120)
    assert run.cells == 3
    nb = nbformat.read(out, as_version=4)
    assert nb.cells[1].metadata["tags"] == ["injected-parameters"]
    assert nb.cells[2].outputs[0]["text"] == "abab\n"
    # running the executed copy again replaces, not stacks, the injected cell
    assert run_notebook(out, {"size": 5}, out, timeout=120).cells == 3


def test_failing_cell_is_a_clear_error(tmp_path, capsys):
    src = tiny_notebook(tmp_path / "nb.ipynb")
    with pytest.raises(VggcError, match="a cell failed"):
        run_notebook(src, {}, None, timeout=120)
    assert main(["notebook", str(src), "-p", "size=2", "-o", str(tmp_path / "o.ipynb")]) == 2
    assert "a cell failed" in capsys.readouterr().err
    assert not (tmp_path / "o.ipynb").exists()


def test_cli_without_output_keeps_the_input(tmp_path, capsys):
    src = tiny_notebook(tmp_path / "nb.ipynb")
    before = src.read_bytes()
    assert main(["notebook", str(src), "-p", "size=5"]) == 0
    assert src.read_bytes() == before  # the (tracked) input is never overwritten
    executed = tmp_path / "nb.executed.ipynb"
    assert str(executed) in capsys.readouterr().out
    assert nbformat.read(executed, as_version=4).cells[1].metadata["tags"] == [
        "injected-parameters"]


def test_default_output_names():
    from vggc_cp.cli.notebook_cmds import default_output

    assert default_output("notebooks/a.ipynb").as_posix() == "notebooks/a.executed.ipynb"
    assert default_output("a.executed.ipynb").as_posix() == "a.executed.ipynb"


def test_a_folder_or_a_missing_notebook_is_named_as_such(tmp_path, capsys):
    assert main(["notebook", str(tmp_path)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"vggc-cp: error: {tmp_path}: the notebook is a directory, not a file")
    assert main(["notebook", str(tmp_path / "nope.ipynb")]) == 2
    assert "nope.ipynb: no such file" in capsys.readouterr().err
