"""``vggc-cp benchmark``: cells, caching and resumption, tables, backends."""

from __future__ import annotations

import importlib.util
import json

import numpy as np
import pytest

from vggc_cp.cli import main
from vggc_cp.errors import VggcError
from vggc_cp.experiments.table1 import (
    BenchmarkConfig,
    cell_jobs,
    check_backend,
    collect_rows,
    run_benchmark,
)
from vggc_cp.experiments.table1_methods import METHODS
from vggc_cp.experiments.table1_tables import table_markdown, write_tables
from vggc_cp.solution import read_solution, verify_solution
from vggc_cp.trace import load_trace

HAS_VISION = importlib.util.find_spec("vggc_cp.vision") is not None


def test_run_resume_and_tables(tmp_path, capsys):
    out = tmp_path / "bench"
    argv = ["benchmark", "--benchmarks", "fruit-2x3", "--methods", "pca-hdbscan",
            "--seeds", "0,1", "--transitions", "12", "-Q", "50", "--jobs", "1", "--out",
            str(out), "--quiet", "--param", "pca-hdbscan.min_cluster_size=2,3"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "2 computed, 0 reused" in text
    assert "| fruit-2x3 (\\|D\\|=12" in text
    assert "PCA-HDBSCAN (paper) | 100.0 | 100.0 | 100.0 | 100.0 | n/a" in text
    assert (out / "table1.csv").is_file() and (out / "table1.md").is_file()
    cell = json.loads((out / "cells" / "fruit-2x3__pca-hdbscan__s0.json").read_text())
    row = cell["row"]
    assert row["transitions"] == 12 and row["nodes"] >= 2
    assert 0.0 <= row["opt_path"] <= row["any_path"] <= 1.0
    trace = load_trace(out / "traces" / "fruit-2x3-d12-s0.npz")
    sol = read_solution(row["solution"])
    verify_solution(sol, trace)
    assert {r["min_cluster_size"] for r in sol.extra["grid"]} == {2, 3}

    assert main(argv) == 0  # resumed: every cell reused
    assert "0 computed, 2 reused" in capsys.readouterr().out
    changed = [a if a != "50" else "60" for a in argv]  # other settings: recomputed
    assert main(changed) == 0
    assert "2 computed, 0 reused" in capsys.readouterr().out


def test_cells_and_table_layout(tmp_path):
    cfg = BenchmarkConfig(tmp_path, ("fruit-2x3", "blocks-2"), ("pca-hdbscan", "lsr"), (0,),
                          transitions=10, queries=10)
    jobs = cell_jobs(cfg)
    assert [(j.benchmark, j.method) for j in jobs] == [
        ("fruit-2x3", "pca-hdbscan"), ("fruit-2x3", "lsr"),
        ("blocks-2", "pca-hdbscan"), ("blocks-2", "lsr")]
    rows = [{"benchmark": "fruit-2x3", "method": m, "seed": 0, "transitions": 10,
             "paper_states": 6, "true_states": 5, "nodes": n, "seconds": 1.0,
             "opt_path": p, "any_path": p, "trans_prec": 1.0, "trans_cov": 1.0, "exec": p}
            for m, n, p in (("greedy", 6, 1.0), ("cpsat", 0, None))]
    md = table_markdown(rows)
    assert "| VGGC greedy (ours) | 100.0 | 100.0 | 100.0 | 100.0 | 100.0 | 6 / 5 |" in md
    # the paper's published row beside ours (fruit-2x3: 100 everywhere); a benchmark the paper
    # does not report reads n/a
    assert "| VGGC (paper) | 100.0 | 100.0 | 100.0 | 100.0 | n/a | n/a | n/a |" in md
    other = table_markdown([dict(r, benchmark="not-in-paper") for r in rows])
    assert "| VGGC (paper) | n/a | n/a | n/a | n/a |" in other
    assert "| VGGC CP-SAT (ours) | – | – |" in md
    assert "CP-SAT (paper)" not in md
    csv, md_path = write_tables(rows, tmp_path, 12.0)
    assert "Wall time of the run: 12 s" in md_path.read_text()


def test_bad_settings_fail_clearly(tmp_path):
    with pytest.raises(VggcError, match="known: .*lsr"):
        BenchmarkConfig(tmp_path, ("fruit-2x3",), ("kmeans",))
    with pytest.raises(VggcError, match="benchmark"):
        BenchmarkConfig(tmp_path, ("fruit-9x9",), ("lsr",))
    with pytest.raises(VggcError, match="jobs"):
        BenchmarkConfig(tmp_path, ("fruit-2x3",), ("lsr",), jobs=0)
    assert set(METHODS) == {"greedy", "cpsat", "pca-hdbscan", "lsr", "merge", "cpsat-merge"}


@pytest.mark.skipif(importlib.util.find_spec("distributed") is not None,
                    reason="dask is installed here")
def test_missing_cluster_backend_says_how_to_install(tmp_path, capsys):
    with pytest.raises(VggcError, match="vggc-cp\\[cluster\\]"):
        check_backend("dask")
    assert main(["benchmark", "--benchmarks", "fruit-2x3", "--methods", "lsr", "--backend",
                 "dask", "--out", str(tmp_path)]) == 2
    assert "pip install" in capsys.readouterr().err
    assert not (tmp_path / "traces").exists()


@pytest.mark.slow
@pytest.mark.skipif(not HAS_VISION, reason="vggc_cp.vision (distances) not installed")
def test_colouring_methods_run(tmp_path):
    cfg = BenchmarkConfig(tmp_path, ("fruit-2x3",), ("greedy", "cpsat"), (0,), transitions=16,
                          queries=50, options={"cpsat": {"params": "max_time_in_seconds:5"}})
    run = run_benchmark(cfg, progress=False)
    assert run.computed == 2
    for row in run.rows:
        assert row["status"] in ("feasible", "optimal")
        assert row["exactly_one"] == 0 and row["nodes"] >= 2
        assert row["seconds_distances"] >= 0


def test_merge_and_its_exact_counterpart(tmp_path):
    cfg = BenchmarkConfig(tmp_path, ("fruit-2x3",), ("merge", "cpsat-merge"), (0,),
                          transitions=24, queries=50)
    rows = {r["method"]: r for r in run_benchmark(cfg, progress=False).rows}
    merge, exact = rows["merge"], rows["cpsat-merge"]
    assert merge["exactly_one"] == 0 and exact["exactly_one"] == 0
    assert exact["merge_nodes"] == merge["nodes"]
    # CP-SAT never needs more nodes than the merge colouring it was handed as a witness
    assert exact["minimal_nodes"] <= merge["nodes"] and exact["nodes"] == exact["minimal_nodes"]
    assert isinstance(exact["proved_minimal"], bool) and exact["cannot_link"] > 0
    assert "threshold" in merge
    md = table_markdown([merge, exact])
    assert "merge + cascade (ours)" in md and "CP-SAT, fewest nodes under merge" in md


@pytest.mark.skipif(not HAS_VISION, reason="needs vggc_cp.vision")
def test_attention_auto_gives_fruit_keypoints_and_blocks_saliency(tmp_path):
    auto = BenchmarkConfig(tmp_path, ("fruit-2x3", "blocks-2"), ("merge", "pca-hdbscan"), (0,),
                           transitions=24, queries=50, attention="auto")
    plain = BenchmarkConfig(tmp_path, ("fruit-2x3", "blocks-2"), ("merge", "pca-hdbscan"),
                            (0,), transitions=24, queries=50)
    a = {(j.benchmark, j.method): j for j in cell_jobs(auto)}
    p = {(j.benchmark, j.method): j for j in cell_jobs(plain)}
    assert a["fruit-2x3", "merge"].attention == "keypoints"
    assert a["blocks-2", "merge"].attention == "saliency"
    # other distances, other files and cell keys; blocks and the baselines are unchanged
    assert a["fruit-2x3", "merge"].distances_path != p["fruit-2x3", "merge"].distances_path
    assert a["fruit-2x3", "merge"].key != p["fruit-2x3", "merge"].key
    assert a["blocks-2", "merge"].key == p["blocks-2", "merge"].key
    assert a["fruit-2x3", "pca-hdbscan"].key == p["fruit-2x3", "pca-hdbscan"].key
    rows = run_benchmark(BenchmarkConfig(tmp_path, ("fruit-2x3",), ("merge",), (0,),
                                         transitions=24, queries=50, attention="keypoints"),
                         progress=False).rows
    assert rows[0]["attention"] == "keypoints" and rows[0]["exactly_one"] == 0
    assert "merge + cascade (ours, keypoints attention)" in table_markdown(rows)
    # a cell not run yet is marked with its attention too
    pending, _ = collect_rows(BenchmarkConfig(tmp_path, ("fruit-2x3",), ("greedy",), (0,),
                                              transitions=24, queries=50, attention="auto"))
    assert "| VGGC greedy (ours, keypoints attention) | not finished |" in table_markdown(pending)
    with pytest.raises(VggcError, match="attention backend"):
        BenchmarkConfig(tmp_path, ("fruit-2x3",), ("merge",), attention="sharpest")


def test_table_only_marks_unfinished_cells(tmp_path, capsys):
    argv = ["benchmark", "--benchmarks", "fruit-2x3", "--methods", "pca-hdbscan", "--seeds",
            "0", "--transitions", "12", "-Q", "50", "--jobs", "1", "--out", str(tmp_path),
            "--quiet"]
    assert main(argv) == 0
    capsys.readouterr()
    assert main([*argv[:4], "pca-hdbscan,lsr", *argv[5:], "--table-only"]) == 0
    out = capsys.readouterr().out
    assert "1 cached, 1 not finished" in out
    assert "| LSR (ours) | not finished |" in out
    assert "| PCA-HDBSCAN (ours) | " in out and not (tmp_path / "cells" / "fruit-2x3__lsr__s0.json").exists()


@pytest.mark.slow  # trains a localizer per cell: minutes on two cores
def test_i2p_phase_trains_evaluates_and_resumes(tmp_path, capsys):
    out = tmp_path / "bench"
    argv = ["benchmark", "--benchmarks", "fruit-2x3", "--methods", "pca-hdbscan",
            "--transitions", "16", "-Q", "50", "--jobs", "1", "--out", str(out), "--quiet",
            "--i2p", "pca-hdbscan", "--novel", "12", "--i2p-queries", "20"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "| Localization | I2P | Exec-I2P |" in text
    figures = json.loads((out / "i2p" / "fruit-2x3__pca-hdbscan__s0.json").read_text())
    fig = figures["figures"]
    assert fig["i2p_images"] == 12 and fig["i2p_queries"] == 20
    for k in ("localization", "i2p", "exec_i2p"):
        assert 0.0 <= fig[k] <= 1.0
    assert fig["i2p"] <= fig["localization"] or fig["i2p"] <= 1.0
    assert (out / "models" / "fruit-2x3__pca-hdbscan__s0.pt").is_file()
    row = next(r for r in __import__("csv").DictReader(open(out / "table1.csv"))
               if r["method"] == "pca-hdbscan")
    assert float(row["localization"]) == pytest.approx(fig["localization"])
    mtime = (out / "i2p" / "fruit-2x3__pca-hdbscan__s0.json").stat().st_mtime_ns
    assert main(argv) == 0  # resumed: nothing retrained
    assert (out / "i2p" / "fruit-2x3__pca-hdbscan__s0.json").stat().st_mtime_ns == mtime
    assert "| Localization | I2P | Exec-I2P |" in capsys.readouterr().out
    assert main(argv + ["--table-only"]) == 0
    assert "| Localization | I2P | Exec-I2P |" in capsys.readouterr().out


def test_i2p_needs_a_method_of_the_run(tmp_path):
    with pytest.raises(VggcError, match="--i2p lsr"):
        BenchmarkConfig(tmp_path, ("fruit-2x3",), ("pca-hdbscan",), i2p=("lsr",))


def test_counterpart_too_large_is_reported_not_run():
    from conftest import make_trace

    from vggc_cp.solvers import Problem
    from vggc_cp.solvers.merge import threshold_path
    from vggc_cp.solvers.merge_exact import exact_counterpart

    names = ("pick_L", "pick_R", "place_L", "place_R")
    trace = make_trace([["L", "pick_L", "H", "place_R", "R", "pick_R", "H", "place_L", "L"]],
                       names)
    roles = trace.roles()
    mats = [np.ones((int((roles == r).sum()),) * 2) - np.eye(int((roles == r).sum()))
            for r in (0, 1)]
    problem = Problem.from_trace(trace.without_states(), *mats)
    merge = threshold_path(problem, [0.5]).best
    out = exact_counterpart(problem, merge, max_clauses=0)
    assert out.skipped and out.minimal_nodes is None and not out.proved
    assert out.best.n_nodes == merge.n_nodes and "not decided" in out.summary()


def test_a_trace_explored_under_other_settings_is_generated_again(tmp_path, capsys):
    from vggc_cp.experiments.table1 import trace_is_current

    out = tmp_path / "bench"
    argv = ["benchmark", "--benchmarks", "fruit-2x3", "--methods", "pca-hdbscan",
            "--seeds", "0", "--transitions", "12", "-Q", "20", "--jobs", "1", "--out",
            str(out), "--quiet"]
    assert main(argv) == 0
    path = out / "traces" / "fruit-2x3-d12-s0.npz"
    assert trace_is_current(path, "fruit-2x3")
    assert main(argv) == 0 and "0 computed, 1 reused" in capsys.readouterr().out
    # a trace from an older exploration (other episode lengths): stale, so its cells are redone
    old = load_trace(path)
    old.meta["episode_length"] = [1, 2]
    from vggc_cp.trace import save_trace

    save_trace(old, path)
    assert not trace_is_current(path, "fruit-2x3")
    assert main(argv) == 0 and "1 computed, 0 reused" in capsys.readouterr().out
    assert trace_is_current(path, "fruit-2x3")
    assert load_trace(path).meta["episode_length"] == [4, 12]
