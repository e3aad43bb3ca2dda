"""The calibration of the warning from a robustness table: old verdict recomputed, counts per
split and look, bins of the chance of change, the CLI."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from vggc_cp.cli import main
from vggc_cp.errors import VggcError
from vggc_cp.experiments import calibration as cal
from vggc_cp.experiments.robustness import passes

NOTEBOOKS = Path(__file__).resolve().parents[2] / "notebooks"


def _row(look, ok, suspect, p_change, split="tuning", **figures):
    row = {"benchmark": "fruit-2x3", "look": look, "seed": 0, "split": split,
           "true_states": 6, "nodes": 6 if ok else 9, "exec": 1.0 if ok else 0.4,
           "opt_path": 1.0, "any_path": 1.0, "suspect": suspect, "p_change": p_change,
           "margin": 0.2, "plateau": 10, "heldout_predicted": 0.9,
           "heldout_contradicted": 0.0, "obs_per_node": 9.0}
    row.update(figures)
    return row


def _write(path, rows):
    fields = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fields)
        w.writeheader()
        for r in rows:
            w.writerow({k: "" if r.get(k) is None else r[k] for k in fields})
    return path


ROWS = [_row("clean", True, False, 0.0),
        _row("clean", True, False, 0.2, margin=0.005),          # old false alarm, new quiet
        _row("clean", False, True, 1.0),
        _row("robot", False, True, 0.35, plateau=1),
        _row("robot", True, True, 0.4),                         # new false alarm
        _row("robot", False, False, None, split="held-out")]    # silent under both


def test_counts_per_split_look_and_verdict(tmp_path):
    rows = cal.read_rows(_write(tmp_path / "r.csv", ROWS))
    assert [passes(r) for r in rows] == [True, True, False, False, True, False]
    assert [cal.old_suspect(r) for r in rows] == [False, True, False, True, False, False]
    table = {(c["split"], c["look"], c["verdict"]): c for c in cal.calibration_rows(rows)}
    assert (table["tuning", "clean", "old"]["false_alarms"],
            table["tuning", "clean", "new"]["false_alarms"]) == (1, 0)
    new_all = table["tuning", "all", "new"]
    assert (new_all["runs"], new_all["passed"], new_all["false_alarms"], new_all["missed"],
            new_all["caught"], new_all["silent"]) == (5, 3, 1, 2, 2, 0)
    assert new_all["false_alarm_share"] == pytest.approx(1 / 3)
    assert table["held-out", "all", "new"]["silent"] == 1
    bins = {(b["split"], b["p_change"]): (b["runs"], b["passed"])
            for b in cal.reliability_rows(rows)}
    assert bins["tuning", "0.0"] == (1, 1) and bins["tuning", "(0.1, 0.2]"] == (1, 1)
    assert bins["tuning", "(0.3, 0.5]"] == (2, 1) and bins["held-out", "n/a"] == (1, 0)
    md = cal.calibration_markdown(rows)
    assert "| tuning | all | new | 5 | 3 | 1 / 3 (33.3 %) | 2 | 2 | 0 |" in md


MARGIN = "description-length margin 0.50 nats (< ln 20 = 3.00): a graph of another size"
CHANGE = "the graph changes in 4 of 5 re-runs with 1/5 of the episodes left out"
ADVICE = "`vggc-cp doubts SOLUTION TRACE -o doubts.png` shows the contested decisions"


def test_the_margin_in_nats_and_which_runs_another_check_warns():
    row = _row("clean", True, True, 0.0, margin=0.005, transitions=100, reasons=MARGIN)
    assert cal.margin_nats(row) == pytest.approx(0.5) and not cal.other_warning(row)
    assert cal.other_warning(dict(row, reasons=f"{CHANGE}: nodes 1, 2; {ADVICE}; {MARGIN}"))
    assert not cal.other_warning(dict(row, reasons=f"{MARGIN}; {ADVICE}"))
    assert not cal.other_warning(dict(row, reasons=None))
    assert cal.margin_nats(dict(row, margin=float("inf"))) == float("inf")
    assert cal.margin_nats(dict(row, transitions=None)) is None
    assert cal.margin_nats(dict(row, margin=None)) is None


def test_the_margin_binned_against_the_chance_it_implies_and_its_bar_moved(tmp_path):
    rows = [_row("clean", True, True, 0.0, margin=0.005, transitions=100, reasons=MARGIN),
            _row("clean", False, True, 0.0, margin=0.005, transitions=100, reasons=MARGIN),
            _row("robot", False, True, 0.8, margin=0.05, transitions=100, reasons=CHANGE),
            _row("clean", True, False, 0.0, margin=0.2, transitions=100, reasons="")]
    rows = cal.read_rows(_write(tmp_path / "m.csv", rows))
    bins = {b["margin"]: b for b in cal.margin_rows(rows)}
    low = bins["(0.25, 1]"]
    assert (low["runs"], low["quiet_else"], low["missed"]) == (2, 2, 1)
    assert low["implied"] == pytest.approx(1 / (1 + math.exp(0.5)))
    mid = bins["(3, 6]"]       # 5 nats, warned by the re-runs: not among the quiet ones
    assert (mid["runs"], mid["quiet_else"], mid["implied"]) == (1, 0, None)
    assert bins["(12, inf]"]["runs"] == 1
    trade = {t["bar"]: t for t in cal.margin_tradeoff_rows(rows, bars=(0.0, 1.0, 30.0))}
    assert [(trade[b]["false_alarms"], trade[b]["silent"]) for b in (0.0, 1.0, 30.0)] == [
        (0, 1), (1, 0), (2, 0)]
    assert trade[0.0]["passed"] == 2 and trade[0.0]["missed"] == 2
    md = cal.calibration_markdown(rows)
    assert "| tuning | (0.25, 1] | 2 | 2 | 1 / 2 (50.0 %) | 37.8 % |" in md
    assert "| tuning | 1 | 1 / 2 (50.0 %) | 0 / 2 |" in md
    assert "margin" not in cal.calibration_markdown(cal.read_rows(_write(tmp_path / "r.csv",
                                                                        ROWS)))


@pytest.mark.parametrize("name", ["robustness-tasks-tuning.csv", "robustness-tasks-heldout.csv",
                                  "robustness-tasks-fresh.csv", "robustness-tasks-seeds11-12.csv",
                                  "robustness-tasks-seeds13-14.csv",
                                  "robustness-tasks-seeds15-16.csv",
                                  "robustness-tasks-seeds17-18.csv",
                                  "robustness-tasks-seeds19-20.csv",
                                  "robustness-tasks-seeds21-22.csv",
                                  "robustness-tasks-tuning-session12.csv"])
def test_the_fixed_checks_recomputed_from_a_row_agree_with_its_verdict(name):
    """The committed tables were written with the fixed checks on beside the chance of change:
    every run they flag (the margin in nats), recomputed from the row's figures, is flagged; a
    run flagged beyond them is one whose re-runs changed the graph (chance above 0.3, or a
    corroborated doubt)."""
    rows = cal.read_rows(NOTEBOOKS / name)
    assert rows and all(r["suspect"] for r in rows if cal.fixed_suspect(r))
    beyond = [r for r in rows if r["suspect"] and not cal.fixed_suspect(r)]
    assert all(r["p_change"] > 0.3 or "re-runs change" in (r.get("reasons") or "")
               for r in beyond)


def test_the_command_prints_writes_and_refuses_bad_input(tmp_path, capsys):
    src = _write(tmp_path / "r.csv", ROWS)
    md = tmp_path / "c.md"
    assert main(["calibration", str(src), "-o", str(md)]) == 0
    out = capsys.readouterr().out
    assert "| tuning | all | old |" in out and md.read_text() in out
    bad = tmp_path / "bad.csv"
    _write(bad, [dict(ROWS[0], exec="high")])
    with pytest.raises(VggcError, match=r"bad.csv: row 0, field 'exec'"):
        cal.read_rows(bad)
    assert main(["calibration", str(bad)]) == 2
    assert main(["calibration", str(tmp_path / "none.csv")]) == 2
    err = capsys.readouterr().err
    assert "vggc-cp: error:" in err and "none.csv" in err


@pytest.mark.slow
def test_the_command_draws_the_plot(tmp_path):
    png = tmp_path / "c.png"
    assert main(["calibration", str(_write(tmp_path / "r.csv", ROWS)), "--png", str(png)]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 1000
    with_reasons = [dict(r, transitions=100, reasons=MARGIN if r["suspect"] else "")
                    for r in ROWS]
    png2 = tmp_path / "c2.png"
    assert main(["calibration", str(_write(tmp_path / "m.csv", with_reasons)),
                 "--png", str(png2)]) == 0
    assert png2.read_bytes()[:4] == b"\x89PNG" and png2.stat().st_size > 1000
