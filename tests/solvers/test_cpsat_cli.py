"""``vggc-cp compare``: bad CP-SAT options exit 2; a small end-to-end run writes CSV and PNG."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from vggc_cp.cli import main
from vggc_cp.trace import save_trace


def test_compare_rejects_bad_cpsat_params(tmp_path, toy_trace, capsys):
    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    assert main(["compare", str(path), "--cpsat-params", "no_such_field:1"]) == 2
    err = capsys.readouterr().err
    assert "cpsat-params" in err and err.count("\n") == 1
    assert main(["compare", str(path), "--cpsat-params", "num_workers:many"]) == 2
    assert main(["compare", str(path), "--max-actions", "0"]) == 2


@pytest.mark.slow
def test_compare_end_to_end(tmp_path, toy_trace, capsys):
    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    out_csv, out_png = tmp_path / "cmp.csv", tmp_path / "cmp.png"
    rc = main(["compare", str(path), "--k-pick", "1:3", "--k-place", "1:2", "--quiet",
               "--cpsat-params", "max_time_in_seconds:10,num_workers:1",
               "--grid", "4", "--cache-dir", str(tmp_path / "cache"), "--csv", str(out_csv),
               "--plot", str(out_png), "--optimize", "all"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "cpsat" in text and "proved minimal: yes" in text
    rows = list(csv.DictReader(out_csv.open()))
    assert len(rows) == 6
    assert {"greedy_feasible", "greedy_J", "cpsat_status", "cpsat_J", "bound", "gap",
            "cpsat_seconds", "variables", "constraints"} <= set(rows[0])
    for r in rows:
        assert r["cpsat_status"] in ("optimal", "infeasible")
        if r["greedy_feasible"] == "True":
            assert float(r["cpsat_J"]) <= float(r["greedy_J"]) + 1e-9
    assert out_png.stat().st_size > 1000


@pytest.mark.slow
def test_compare_on_a_restricted_range_proves_nothing(tmp_path, toy_trace, capsys):
    """No cell with fewer nodes was tried: the report must not claim minimality."""
    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    rc = main(["compare", str(path), "--k-pick", "3:3", "--k-place", "2:2",
               "--cpsat-params", "max_time_in_seconds:10,num_workers:1",
               "--grid", "4", "--cache-dir", str(tmp_path / "cache")])
    assert rc == 0
    text = capsys.readouterr().out
    assert max(len(line) for line in text.splitlines() if line.startswith("|")) <= 120
    assert "proved minimal: yes" not in text
    assert text.count("proved minimal: not proved (smaller cells not tried)") == 2


def test_node_frontier_needs_every_smaller_cell_decided():
    from vggc_cp.solvers import SolveResult
    from vggc_cp.solvers.cpsat import node_frontier
    from vggc_cp.solvers.sweep import Sweep

    def cell(a, b, status, nodes=None):
        labels = None if nodes is None else np.arange(nodes)
        return SolveResult(labels, a, b, 0.0 if nodes else float("nan"), status, "cpsat")

    found = cell(2, 2, "optimal", nodes=4)
    only = Sweep((found,), 0, "fewest", "cpsat", 0.0, 1)
    front = node_frontier(only)
    assert not front.proved and front.untried == 3  # (1,1), (1,2), (2,1) never tried
    assert front.verdict == "not proved (smaller cells not tried)"
    # with two actions per role, (1,1) has too few colour pairs: counting rules it out
    assert node_frontier(only, need=2).untried == 2
    below = (cell(1, 2, "infeasible"), cell(2, 1, "infeasible"))
    full = Sweep(below + (found,), 2, "fewest", "cpsat", 0.0, 1)
    assert node_frontier(full, need=2).verdict == "yes"
    assert node_frontier(full).verdict == "not proved (smaller cells not tried)"
    undecided = Sweep((cell(1, 1, "infeasible"), cell(1, 2, "unknown"), cell(2, 1, "infeasible"),
                       found), 3, "fewest", "cpsat", 0.0, 1)
    assert node_frontier(undecided).verdict == "no"


@pytest.mark.slow
def test_solve_without_a_colouring_says_proved_or_undecided(tmp_path, toy_trace, capsys):
    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    base = ["solve", str(path), "-o", str(tmp_path / "s.json"), "--k-pick", "1:1",
            "--k-place", "1:1", "--quiet", "--grid", "4", "--cache-dir", str(tmp_path / "c")]
    # CP-SAT proves the single cell infeasible: the message says so
    assert main(base + ["--solver", "cpsat"]) == 2
    err = capsys.readouterr().err
    assert "1 cells: all proved infeasible" in err and err.count("\n") == 1
    # the greedy heuristic proves nothing: the cell is undecided, not infeasible
    assert main(base + ["--solver", "greedy", "--select", "fewest"]) == 2
    err = capsys.readouterr().err
    assert "0 proved infeasible, 1 undecided" in err
    assert not (tmp_path / "s.json").exists()


@pytest.mark.slow
def test_solve_with_a_hint_from_a_larger_cell(tmp_path, toy_trace, capsys):
    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    common = ["--quiet", "--grid", "4", "--cache-dir", str(tmp_path / "c"), "--solver", "cpsat",
              "--cpsat-params", "max_time_in_seconds:10,num_workers:1"]
    big = tmp_path / "big.json"
    assert main(["solve", str(path), "-o", str(big), "--k-pick", "3:3", "--k-place", "2:2"]
                + common) == 0
    out = tmp_path / "small.json"
    assert main(["solve", str(path), "-o", str(out), "--k-pick", "2:2", "--k-place", "1:1",
                 "--hint", str(big)] + common) == 0
    from vggc_cp.solution import read_solution, verify_solution

    verify_solution(read_solution(out), toy_trace)
    capsys.readouterr()
    # a hint that labels another trace: one clear line, exit 2, nothing written
    other = tmp_path / "other.json"
    other.write_text(big.read_text().replace('"labels": [', '"labels": [0, '))
    bad = tmp_path / "bad.json"
    rc = main(["solve", str(path), "-o", str(bad), "--k-pick", "2:2", "--k-place", "1:1",
               "--hint", str(other)] + common)
    err = capsys.readouterr().err
    assert rc == 2 and "other.json" in err and "'labels'" in err and err.count("\n") == 1
    assert not bad.exists()


def test_compare_with_csv_prints_a_summary_and_table_prints_the_cells(tmp_path, toy_trace,
                                                                       capsys):
    """--csv gets the per-cell table; the terminal the summary (status counts, the fewest
    nodes and selected cells), unless --table asks for the cells too."""
    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    base = ["compare", str(path), "--k-pick", "2:3", "--k-place", "2:2",
            "--cpsat-params", "max_time_in_seconds:10,num_workers:1", "--grid", "4",
            "--sinkhorn-device", "numpy", "--cache-dir", str(tmp_path / "cache")]
    assert main([*base, "--csv", str(tmp_path / "c.csv")]) == 0
    text = capsys.readouterr().out
    assert not any(line.startswith("|") for line in text.splitlines())
    assert "CP-SAT cells" in text and "fewest nodes" in text
    assert f"csv            {tmp_path / 'c.csv'}: the per-cell table, 2 rows" in text
    assert "--table prints it here too" in text
    assert len(list(csv.DictReader((tmp_path / "c.csv").open()))) == 2
    assert main([*base, "--csv", str(tmp_path / "d.csv"), "--table"]) == 0
    cells = [line for line in capsys.readouterr().out.splitlines() if line.startswith("|")]
    assert len(cells) == 2 + 2  # header, rule, one row per cell
    assert main(base) == 0  # no --csv: the cells are printed, as before
    assert sum(line.startswith("|") for line in capsys.readouterr().out.splitlines()) == 4
