"""Cached robustness rows are trusted only when made under the key, from the trace on disk (its
SHA-256), with fields of the right type, range and finiteness (issue 26)."""

from __future__ import annotations

import json

import pytest

from vggc_cp.experiments import robustness as rob
from vggc_cp.experiments.cells import file_sha256, read_cell, row_problem, validate_cell


@pytest.fixture
def cell(tmp_path):
    """A job of a study never run, its trace file (any bytes) and a well-formed record."""
    cfg = rob.RobustnessConfig(tmp_path, ("fruit-2x3",), (0,), ("clean",), transitions=10,
                               n_queries=10)
    job = rob.cell_jobs(cfg)[0]
    job.trace_path.parent.mkdir(parents=True)
    job.trace_path.write_bytes(b"the trace")
    row = {"benchmark": "fruit-2x3", "look": "clean", "seed": 0, "split": "tuning",
           "transitions": 10, "observations": 11, "true_states": 6, "nodes": 6,
           "nodes_ratio": 1.0, "exec": 0.5, "opt_path": 0.5, "any_path": 1.0,
           "trans_prec": 1.0, "trans_cov": 0.5, "evidence": "footprints", "threshold": 0.1,
           "suspect": True, "reasons": "x", "margin": None, "plateau": 1,
           "heldout_predicted": 0.5, "heldout_contradicted": 0.0, "obs_per_node": 1.8,
           "obs_per_state": 1.8, "seconds_learn": 0.1, "seconds_evaluate": 0.1,
           "dynamics": "simulator"}
    record = {"key": job.key, "trace_sha256": file_sha256(job.trace_path), "row": row}
    return job, record


def _write(job, record, text=None):
    job.cell_path.parent.mkdir(parents=True, exist_ok=True)
    job.cell_path.write_text(text if text is not None else json.dumps(record))


def test_a_sound_row_tied_to_its_trace_is_reused(cell):
    job, record = cell
    _write(job, record)
    assert read_cell(job.cell_path, job.key, job.trace_path) == record["row"]
    assert rob.cached_row(job) == record["row"]


@pytest.mark.parametrize("change, phrase", [
    (lambda r: r.pop("trace_sha256"), "trace_sha256"),           # written by hand
    (lambda r: r.update(trace_sha256="0" * 64), "trace_sha256"),  # another trace's row
    (lambda r: r["row"].update(exec="abc"), "row.exec"),
    (lambda r: r["row"].update(exec=1.5), "row.exec"),
    (lambda r: r["row"].update(exec=True), "row.exec"),
    (lambda r: r.update(row={}), "row.benchmark"),
    (lambda r: r.update(row=[]), "'row'"),
    (lambda r: r["row"].update(benchmark="fruit-4x6"), "row.benchmark"),
    (lambda r: r["row"].update(seed=7), "row.seed"),
    (lambda r: r["row"].update(nodes=-1), "row.nodes"),
    (lambda r: r["row"].update(nodes=2.5), "row.nodes"),
    (lambda r: r["row"].update(suspect="no"), "row.suspect"),
    (lambda r: r["row"].update(nodes_ratio=3.0), "row.nodes_ratio"),
    (lambda r: r["row"].update(seconds_learn=-1.0), "row.seconds_learn"),
    (lambda r: r["row"].update(evidence=5), "row.evidence"),
])
def test_a_forged_or_damaged_row_is_recomputed_with_a_warning(cell, capsys, change, phrase):
    job, record = cell
    change(record)
    _write(job, record)
    assert read_cell(job.cell_path, job.key, job.trace_path) is None
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and phrase in err and "recomputing" in err


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_fields_are_refused(cell, capsys, literal):
    job, record = cell
    text = json.dumps(record).replace('"exec": 0.5', f'"exec": {literal}')
    _write(job, record, text)
    assert read_cell(job.cell_path, job.key, job.trace_path) is None
    assert "row.exec" in capsys.readouterr().err


def test_another_key_or_no_trace_is_recomputed_silently(cell, capsys):
    job, record = cell
    _write(job, record)
    assert read_cell(job.cell_path, {**job.key, "queries": 11}, job.trace_path) is None
    job.trace_path.unlink()
    assert read_cell(job.cell_path, job.key, job.trace_path) is None
    assert capsys.readouterr().err == ""


def test_a_changed_trace_unties_its_row(cell, capsys):
    job, record = cell
    _write(job, record)
    job.trace_path.write_bytes(b"another trace")
    assert rob.cached_row(job) is None
    assert "trace_sha256" in capsys.readouterr().err


def test_row_problem_accepts_unmeasured_fields(cell):
    job, record = cell
    row = {**record["row"], "exec": None, "threshold": None, "heldout_predicted": None}
    assert row_problem(row, job.key) is None
    assert validate_cell("not a dict", job.key, "x") is None


@pytest.mark.slow
def test_a_benchmark_cell_is_reused_only_when_tied_to_its_trace(tmp_path, capsys):
    from vggc_cp.experiments.table1 import BenchmarkConfig, run_benchmark

    cfg = BenchmarkConfig(tmp_path, ("fruit-2x3",), ("merge",), (0,), transitions=16, queries=20)
    first = run_benchmark(cfg, progress=False)
    again = run_benchmark(cfg, progress=False)
    assert (first.computed, again.computed) == (1, 0) and again.rows == first.rows
    cell = next((tmp_path / "cells").glob("*.json"))
    record = json.loads(cell.read_text())
    assert record["trace_sha256"] == file_sha256(next((tmp_path / "traces").glob("*.npz")))
    record["row"]["exec"] = 1.0
    record.pop("trace_sha256")  # a row written by hand
    cell.write_text(json.dumps(record))
    capsys.readouterr()
    assert run_benchmark(cfg, progress=False).computed == 1
    assert "trace_sha256" in capsys.readouterr().err
