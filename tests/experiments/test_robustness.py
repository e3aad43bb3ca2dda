"""The robustness study: a tiny real run, resumption, the pass rule, calibration, the CLI."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import pandas as pd
import pytest

from vggc_cp import plots
from vggc_cp.cli import main
from vggc_cp.experiments import robustness as rob
from vggc_cp.experiments import robustness_tables as rtab
from vggc_cp.trace import load_trace

D = 50
Q = 60


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """fruit-2x3, |D| 50, clean, seeds 0 and 1 (seed 1 held out), one worker (two workers:
    :func:`test_two_workers_give_the_same_rows`)."""
    out = tmp_path_factory.mktemp("robustness")
    cfg = rob.RobustnessConfig(out, ("fruit-2x3",), (0, 1), ("clean",), transitions=D,
                               n_queries=Q, jobs=1, heldout_seeds=(1,), tasks=())
    run = rob.run_robustness(cfg, progress=False)
    return cfg, run


def test_rows_have_the_fields_and_the_truth(study):
    cfg, run = study
    assert (run.computed, run.reused) == (2, 0)
    assert [(r["benchmark"], r["look"], r["seed"], r["split"]) for r in run.rows] == [
        ("fruit-2x3", "clean", 0, "tuning"), ("fruit-2x3", "clean", 1, "held-out")]
    for r in run.rows:
        assert set(rob.ROW_FIELDS) - {"passed"} <= set(r)
        assert r["transitions"] == D and r["true_states"] == 6
        assert r["nodes_ratio"] == pytest.approx(r["nodes"] / 6)
        assert 0.0 <= r["exec"] <= 1.0 and 0.0 <= r["any_path"] <= 1.0
        assert isinstance(r["suspect"], bool) and isinstance(r["reasons"], str)
        assert r["dynamics"] == "sim"
        assert "i2p" not in r
    # the clean fruit-2x3 at the paper's |D| is recovered exactly by the default solve
    first = run.rows[0]
    assert (first["nodes"], first["exec"], first["any_path"]) == (6, 1.0, 1.0)
    assert rob.passes(first)
    trace = load_trace(cfg.trace_path("fruit-2x3", "clean", 0))
    assert trace.n_transitions == D and trace.meta.get("look", "clean") == "clean"
    assert (cfg.out / "cells" / "fruit-2x3-clean-s1.json").is_file()
    assert json.loads((cfg.out / "solutions" / "fruit-2x3-clean-s0.json").read_text())["labels"]


@pytest.mark.slow
def test_two_workers_give_the_same_rows(study, tmp_path):
    """The study in two worker processes (their start-up costs seconds on 2 cores)."""
    cfg, run = study
    two = rob.run_robustness(replace(cfg, out=tmp_path, jobs=2), progress=False)
    assert two.computed == len(run.rows)

    def untimed(rows):
        return sorted(({k: v for k, v in r.items() if not k.startswith("seconds")}
                       for r in rows), key=lambda r: r["seed"])

    assert untimed(two.rows) == untimed(run.rows)


def test_tables_have_both_splits(study):
    cfg, run = study
    csv, md = rtab.write_tables(run.rows, cfg.out)
    df = pd.read_csv(csv)
    assert len(df) == 2 and list(df.columns[:4]) == ["benchmark", "family", "look", "seed"]
    assert list(df["split"]) == ["tuning", "held-out"]
    text = md.read_text()
    assert "## Tuning split: trace seeds 0" in text and "## Held-out split" in text
    assert text.count("| fruit-2x3 | clean | 50 | 1 |") == 2
    assert "Calibration:" in text and "silent failure" in text and "## Overall" in text
    tables = [ln for ln in text.splitlines() if ln.startswith("|")]
    assert tables and max(len(ln) for ln in tables) <= 120


def test_rerun_computes_nothing_and_a_changed_setting_recomputes(study):
    cfg, run = study
    stamps = sorted(p.stat().st_mtime_ns for p in (cfg.out / "cells").iterdir())
    again = rob.run_robustness(cfg, progress=False)
    assert (again.computed, again.reused) == (0, 2)
    assert again.rows == run.rows
    assert sorted(p.stat().st_mtime_ns for p in (cfg.out / "cells").iterdir()) == stamps
    # another Q, |D| or look is another cell: no cached row
    for changed in (replace(cfg, n_queries=Q + 1), replace(cfg, transitions=D + 1)):
        assert all(rob.cached_row(j) is None for j in rob.cell_jobs(changed))
    # the split is not part of the key: re-splitting reuses the rows and relabels them
    resplit = rob.run_robustness(replace(cfg, heldout_seeds=None), progress=False)
    assert resplit.computed == 0 and {r["split"] for r in resplit.rows} == {"tuning"}


def good(**kw) -> dict:
    row = {"benchmark": "b", "look": "clean", "seed": 0, "split": "tuning", "exec": 1.0,
           "opt_path": 1.0, "any_path": 1.0, "nodes": 10, "true_states": 10, "suspect": False,
           "reasons": "", "transitions": 50}
    return row | kw


@pytest.mark.parametrize("kw, ok", [
    ({}, True),
    ({"exec": 0.90}, True), ({"exec": 0.899}, False), ({"exec": None}, False),
    ({"nodes": 11}, True), ({"nodes": 9}, True), ({"nodes": 12}, False), ({"nodes": 8}, False),
    ({"nodes": 0}, False),
    ({"opt_path": 0.95}, True), ({"opt_path": 0.949}, False),
    ({"any_path": 1.0 - 1e-12}, True), ({"any_path": 0.999}, False),
    ({"i2p": 0.90}, True), ({"i2p": 0.5}, False), ({"i2p": None}, True),
    ({"i2p": math.nan}, True),
])
def test_passes(kw, ok):
    assert rob.passes(good(**kw)) is ok
    assert (rob.failures(good(**kw)) == []) is ok


def test_calibration_counts_and_the_silent_failure():
    rows = [good(), good(suspect=True, reasons="x"),                       # pass quiet, alarm
            good(exec=0.2, suspect=True, reasons="plateau"),               # caught
            good(nodes=4, split="held-out"),                               # silent (held out)
            good(split="held-out"), good(i2p=0.1, suspect=True, split="held-out")]
    cal = rob.calibration(rows)
    assert cal["tuning"] == {"passed_quiet": 1, "false_alarm": 1, "caught": 1, "silent": 0}
    assert cal["held-out"] == {"passed_quiet": 1, "false_alarm": 0, "caught": 1, "silent": 1}
    assert cal["all"] == {"passed_quiet": 2, "false_alarm": 1, "caught": 2, "silent": 1}
    text = rtab.table_markdown(rows)
    assert "Passing: 2 / 3 runs (66.7 %)" in text and "Passing: 3 / 6 runs (50.0 %)" in text
    assert "1 missed & quiet (silent failure)" in text
    assert "- b clean seed 0: nodes 4 / 10 outside" in text
    assert "no warning (silent failure)" in text and "warned: plateau" in text


def test_plot_exec_draws_every_look_and_skips_unmeasured_runs(tmp_path):
    rows = [good(), good(look="randomized", suspect=True), good(benchmark="c", exec=None),
            good(benchmark="c", exec=math.nan, look="randomized")]
    path = tmp_path / "exec.png"
    plots.plot_exec(rows, path, title="t")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("argv, phrase", [
    (["--benchmarks", "nope"], "unknown benchmark"),
    (["--seeds", "4:1"], "--seeds"),
    (["--seeds", "x"], "--seeds"),
    (["--looks", "fancy"], "unknown look"),
    (["--jobs", "0"], "--jobs"),
    (["--queries", "0"], "--queries"),
    (["--transitions", "0"], "--transitions"),
])
def test_cli_bad_values_exit_2_with_one_line(argv, phrase, tmp_path, capsys):
    assert main(["robustness", "--out", str(tmp_path / "o"), *argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("vggc-cp: error:") and phrase in err
    assert not (tmp_path / "o").exists()


def test_cli_seeds_parse():
    from vggc_cp.cli.options import parse_seeds

    assert parse_seeds("0:4") == (0, 1, 2, 3, 4)
    assert parse_seeds("3") == (3,) and parse_seeds("0, 2") == (0, 2)


def test_cli_reuses_the_study_and_prints_the_summary(study, capsys):
    cfg, _ = study
    argv = ["robustness", "--out", str(cfg.out), "--benchmarks", "fruit-2x3", "--seeds", "0:1",
            "--looks", "clean", "--transitions", str(D), "--queries", str(Q), "--jobs", "1",
            "--tasks", "none", "--quiet"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "# Robustness of the default" in out and "0 computed, 2 reused" in out
    assert f"wrote {cfg.out / 'robustness.md'}" in out


def test_randomized_look_cell(tmp_path):
    cfg = rob.RobustnessConfig(tmp_path, ("fruit-2x3",), (0,), ("randomized",), transitions=D,
                               n_queries=Q, tasks=())
    (row,) = rob.run_robustness(cfg, progress=False).rows
    assert row["look"] == "randomized" and row["true_states"] == 6
    meta = load_trace(cfg.trace_path("fruit-2x3", "randomized", 0)).meta
    assert meta["look"] == "randomized"
    assert isinstance(row["suspect"], bool) and 0.0 <= row["exec"] <= 1.0


@pytest.mark.slow
def test_i2p_cell_measures_and_is_reused_without_i2p(tmp_path):
    """A localizer trained on the learned labels (about a minute on 2 cores)."""
    cfg = rob.RobustnessConfig(tmp_path, ("fruit-2x3",), (0,), ("clean",), transitions=D,
                               n_queries=Q, i2p=True, novel=20, i2p_queries=20,
                               tasks=())
    (row,) = rob.run_robustness(cfg, progress=False).rows
    assert {"localization", "i2p", "exec_i2p"} <= set(row) and 0.0 <= row["i2p"] <= 1.0
    assert cfg.novel_path("fruit-2x3", "clean", 0).is_file()
    again = rob.run_robustness(replace(cfg, i2p=False), progress=False)
    assert again.computed == 0 and again.rows[0]["i2p"] == row["i2p"]
    other = rob.cell_jobs(replace(cfg, i2p_queries=21))
    assert rob.cached_row(other[0]) is None


# ---------------------------------------------------------------- tasks beyond the seven


def test_the_default_study_holds_the_seven_and_thirty_random_tasks_split_by_task_and_seed(
        tmp_path):
    cfg = rob.RobustnessConfig(tmp_path, looks=("clean",))
    cells = cfg.cells()
    assert len(cells) == 7 * 5 + 30
    tasks = sorted({rob.task_seed(b) for b, _ in cells} - {None})
    assert tasks == [*range(10), *range(100, 120)]
    split = {(b, s): cfg.split(s, b) for b, s in cells}
    # the seven: by trace seed
    assert split[("fruit-4x6", 2)] == rob.TUNING and split[("fruit-4x6", 3)] == rob.HELDOUT
    # random tasks: by task seed (trace seed 0 everywhere)
    assert split[("random-9", 0)] == rob.TUNING and split[("random-100", 0)] == rob.HELDOUT
    assert cfg.split(3, "random-2") == rob.HELDOUT  # a held-out trace seed of a tuning task
    jobs = rob.cell_jobs(cfg)
    assert len({j.cell_path for j in jobs}) == len(jobs) == len(cells)
    assert {j.split for j in jobs if j.benchmark == "random-105"} == {rob.HELDOUT}


def test_held_out_tasks_are_never_the_tuning_tasks():
    tuning = {b for b in (f"random-{t}" for t in rob.DEFAULT_TASKS)
              if rob.task_seed(b) < rob.HELDOUT_TASK_FROM}
    from vggc_cp.sim import get_spec
    from vggc_cp.sim.tasks import format_spec

    held = {format_spec(get_spec(f"random-{t}")) for t in rob.DEFAULT_TASKS
            if t >= rob.HELDOUT_TASK_FROM}
    assert len(tuning) == 10 and len(held) == 20
    assert not held & {format_spec(get_spec(b)) for b in tuning}


def test_a_spec_string_task_gets_a_file_safe_cell_name(tmp_path):
    text = "task:regions=3,layout=row,height=1,starts=0,episode=4-12,transitions=30," \
           "objects=red/apple+blue/cube"
    cfg = rob.RobustnessConfig(tmp_path, (text,), (0,), ("clean",), tasks=())
    (job,) = rob.cell_jobs(cfg)
    assert job.cell_path.name.startswith("task-") and "/" not in job.cell_path.name
    assert rob.slug("random-3") == "random-3" and rob.slug("fruit-2x3") == "fruit-2x3"


def test_tables_by_family_and_look_count_silent_failures():
    base = {"exec": 1.0, "opt_path": 1.0, "any_path": 1.0, "true_states": 10, "nodes": 10,
            "suspect": False, "seed": 0, "transitions": 100}
    rows = [base | {"benchmark": "fruit-2x3", "look": "clean", "split": rob.TUNING},
            base | {"benchmark": "random-3", "look": "robot", "split": rob.TUNING,
                    "nodes": 5},
            base | {"benchmark": "random-101", "look": "robot", "split": rob.HELDOUT,
                    "nodes": 5, "suspect": True}]
    text = rtab.family_markdown(rows)
    assert "| fruit | clean | 1 | 1 | 100.0 % | 0 | 0 |" in text
    assert "| task | robot | 2 | 0 | 0.0 % | 1 | 1 |" in text
    md = rtab.table_markdown(rows)
    assert "random tasks of task seeds 3" in md and "random tasks of task seeds 101" in md
    assert "By task family and look:" in md


def test_drawn_tasks_are_tabled_by_kind():
    """Where episodes start and whether objects stack: random-9 starts at home states,
    random-1 anywhere and stacks; the seven are no kind."""
    base = {"exec": 1.0, "opt_path": 1.0, "any_path": 1.0, "true_states": 10, "nodes": 10,
            "suspect": False, "seed": 0, "transitions": 100, "split": rob.TUNING}
    rows = [base | {"benchmark": "random-9", "look": "robot", "nodes": 5, "suspect": True},
            base | {"benchmark": "random-9", "look": "clean"},
            base | {"benchmark": "random-1", "look": "robot", "nodes": 5},
            base | {"benchmark": "fruit-2x3", "look": "robot"}]
    text = rtab.kind_markdown(rows)
    assert "| home starts | robot | 1 | 0 | 0.0 % | 1 | 0 |" in text
    assert "| home starts | clean | 1 | 1 | 100.0 % | 0 | 0 |" in text
    assert "| any start, stacking | robot | 1 | 0 | 0.0 % | 0 | 1 |" in text
    assert "fruit" not in text
    assert "Drawn tasks by kind" in rtab.table_markdown(rows)
    assert rtab.kind_markdown(rows[3:]) == ""
    assert "Drawn tasks by kind" not in rtab.table_markdown(rows[3:])


def test_a_cells_code_key_covers_every_module_of_the_learning_packages():
    """A module split out of another (the held-out prediction, the partition closure) is part
    of the key without being listed; the CLI and the tables are not."""
    names = {p.as_posix().rsplit("/vggc_cp/", 1)[1] for p in rob.code_files()}
    assert {"solvers/heldout.py", "solvers/closure.py", "vision/holdings.py",
            "learned.py"} <= names
    assert not any(n.startswith(("cli/", "experiments/")) for n in names)
    assert rob.code_digest() == rob.code_digest() and len(rob.code_digest()) == 12
