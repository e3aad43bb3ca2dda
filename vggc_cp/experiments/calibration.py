"""How well the ground-truth-free warning matches the pass rule, from a robustness table.

``vggc-cp calibration robustness.csv`` (:func:`read_rows`, :func:`calibration_markdown`)
reads the rows of ``vggc-cp robustness`` (``OUT/robustness.csv``) and counts, per split and
look, the four outcomes of :data:`vggc_cp.experiments.robustness.CALIBRATION`: passed and
quiet, passed and warned (a **false alarm**), missed and warned (caught), missed and quiet (a
**silent failure**). Two verdicts are compared on the same runs:

* ``new`` -- the row's ``suspect``: what the solver said (since this module, the chance of
  change of :mod:`vggc_cp.solvers.confidence`);
* ``old`` -- the former fixed thresholds (:data:`OLD_RULE`: description-length margin < 0.01
  nats per transition, plateau < 3, held-out contradicted > 5 % or predicted < 60 %, fewer
  than 2 observations per node), recomputed from the row's ``margin``, ``plateau``,
  ``heldout_*`` and ``obs_per_node``.

A second table bins the runs by ``p_change`` and gives the share that passed in each bin:
what the number means on the suite. Nothing here reads a trace or a ground-truth state
beyond the row's own ``passed`` figures.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

from vggc_cp.errors import VggcError
from vggc_cp.experiments.robustness import SPLITS, passes
from vggc_cp.solvers.confidence import FIXED_CHECKS, FORMER_MARGIN

#: The fixed thresholds the warning used before the chance of change (the former
#: ``WarningRule`` defaults, the description-length margin among them).
OLD_RULE = {"min_margin": FORMER_MARGIN, **FIXED_CHECKS}
VERDICTS = ("old", "new")
#: Bins of ``p_change`` (upper bounds, inclusive) of :func:`reliability_rows`.
P_BINS = (0.0, 0.1, 0.2, 0.3, 0.5, 1.0)
_NUMBERS = ("seed", "transitions", "observations", "true_states", "nodes", "nodes_ratio", "exec",
            "opt_path", "any_path", "trans_prec", "trans_cov", "threshold", "margin", "plateau",
            "heldout_predicted", "heldout_contradicted", "obs_per_node", "obs_per_state",
            "p_change", "runs", "changed", "doubts", "i2p", "localization", "exec_i2p")


def _value(field: str, text: str):
    if text == "" or text is None:
        return None
    if field == "suspect":
        if text in ("True", "true", "1"):
            return True
        if text in ("False", "false", "0"):
            return False
        raise ValueError(f"{text!r} is not True or False")
    if field in _NUMBERS:
        v = float(text)
        return int(v) if field in ("seed", "transitions", "observations", "true_states",
                                   "nodes", "plateau", "runs", "changed", "doubts") else v
    return text


def read_rows(path: str | Path) -> list[dict]:
    """The rows of a ``robustness.csv``.

    Raises
    ------
    VggcError
        When the file cannot be read or a row lacks ``benchmark``, ``look``, ``split`` or
        ``suspect``, or holds a value that is not a number where one is expected (names
        the file, row and field).
    """
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            fields = reader.fieldnames or []
            for need in ("benchmark", "look", "split", "suspect", "exec", "nodes",
                         "true_states"):
                if need not in fields:
                    raise VggcError(f"{path}: no column {need!r} (is it a robustness.csv?)")
            rows = []
            for i, rec in enumerate(reader):
                row = {}
                for k, text in rec.items():
                    try:
                        row[k] = _value(k, text)
                    except ValueError as exc:
                        raise VggcError(f"{path}: row {i}, field {k!r}: {exc}") from None
                rows.append(row)
    except OSError as exc:
        raise VggcError(f"{path}: cannot read it ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise VggcError(f"{path}: not a text file") from None
    return rows


def _checks_fail(row: dict, r: dict, margin_low) -> bool:
    """Whether one of the checks of ``r`` fails on the row's figures; ``margin_low(margin,
    row)`` says whether the margin is too low (a missing figure fails nothing)."""
    margin, plateau = row.get("margin"), row.get("plateau")
    pred, contr = row.get("heldout_predicted"), row.get("heldout_contradicted")
    opn = row.get("obs_per_node")
    return bool((plateau is not None and plateau < r["min_plateau"])
                or (margin is not None and math.isfinite(margin) and margin_low(margin, row))
                or (contr is not None and contr > r["max_contradicted"])
                or (pred is not None and pred < r["min_predicted"])
                or (opn is not None and opn < r["min_obs_per_node"]))


def old_suspect(row: dict) -> bool:
    """The former fixed-threshold verdict (:data:`OLD_RULE`: the margin per transition) from
    the row's figures."""
    return _checks_fail(row, OLD_RULE, lambda m, _: m < OLD_RULE["min_margin"])


def fixed_suspect(row: dict) -> bool:
    """The current fixed checks (:data:`~vggc_cp.solvers.confidence.FIXED_CHECKS`: the
    margin in nats over the row's transitions) recomputed from the row's figures."""
    return _checks_fail(row, FIXED_CHECKS, lambda m, r: bool(r.get("transitions"))
                        and m * r["transitions"] < FIXED_CHECKS["min_margin_nats"])


def verdict(row: dict, which: str) -> bool:
    """``new`` (the row's ``suspect``) or ``old`` (:func:`old_suspect`)."""
    if which == "new":
        return bool(row.get("suspect"))
    if which == "old":
        return old_suspect(row)
    raise VggcError(f"unknown verdict {which!r}; known: {', '.join(VERDICTS)}")


def calibration_rows(rows: list[dict]) -> list[dict]:
    """Per split, look (and ``all`` looks) and verdict: runs, passed, false alarms (passed
    and warned), their share of passing runs, missed, caught and silent failures."""
    out = []
    splits = [s for s in (*SPLITS, *sorted({r.get("split") for r in rows} - set(SPLITS)))
              if any(r.get("split") == s for r in rows)]
    for split in splits:
        sub = [r for r in rows if r.get("split") == split]
        looks = sorted({r["look"] for r in sub})
        for look in (*looks, "all"):
            g = [r for r in sub if look == "all" or r["look"] == look]
            ok = [r for r in g if passes(r)]
            miss = [r for r in g if not passes(r)]
            for which in VERDICTS:
                fa = sum(verdict(r, which) for r in ok)
                silent = sum(not verdict(r, which) for r in miss)
                out.append({"split": split, "look": look, "verdict": which, "runs": len(g),
                            "passed": len(ok), "false_alarms": fa,
                            "false_alarm_share": fa / len(ok) if ok else None,
                            "missed": len(miss), "caught": len(miss) - silent,
                            "silent": silent})
    return out


def reliability_rows(rows: list[dict]) -> list[dict]:
    """Runs binned by ``p_change`` (:data:`P_BINS`; runs without one in ``n/a``): per split
    and bin, runs, passed and the share that passed."""
    out = []
    for split in sorted({r.get("split") for r in rows}, key=lambda s: (s not in SPLITS, s)):
        sub = [r for r in rows if r.get("split") == split]
        lo = None
        for hi in P_BINS:
            g = [r for r in sub if r.get("p_change") is not None
                 and (lo is None and r["p_change"] <= hi
                      or lo is not None and lo < r["p_change"] <= hi)]
            name = f"{hi:.1f}" if lo is None else f"({lo:.1f}, {hi:.1f}]"
            out.append({"split": split, "p_change": name, "runs": len(g),
                        "passed": sum(passes(r) for r in g)})
            lo = hi
        g = [r for r in sub if r.get("p_change") is None]
        if g:
            out.append({"split": split, "p_change": "n/a", "runs": len(g),
                        "passed": sum(passes(r) for r in g)})
    return out


def _share(k: int, n: int) -> str:
    return f"{k} / {n} ({100 * k / n:.1f} %)" if n else f"{k} / 0"


def calibration_markdown(rows: list[dict], source: str = "robustness.csv") -> str:
    """The calibration tables (:func:`calibration_rows`, :func:`reliability_rows`) as
    markdown."""
    recorded = ("the default verdict: the chance of change, and the fixed checks where the "
                "rows were written with them" if any(r.get("p_change") is not None for r in rows)
                else "no `p_change` in these rows: written by the fixed thresholds, so both "
                     "verdicts agree")
    lines = [f"Calibration of the warning on {source} ({len(rows)} runs): 'old' = the former "
             f"fixed thresholds recomputed from the row, 'new' = the row's `suspect` "
             f"({recorded}).", "",
             "| split | look | verdict | runs | passed | false alarms (share of passing) | "
             "missed | caught | silent |", "|---|---|---|---|---|---|---|---|---|"]
    for c in calibration_rows(rows):
        lines.append(f"| {c['split']} | {c['look']} | {c['verdict']} | {c['runs']} | "
                     f"{c['passed']} | {_share(c['false_alarms'], c['passed'])} | "
                     f"{c['missed']} | {c['caught']} | {c['silent']} |")
    warned = [r for r in rows if r.get("suspect") and r.get("doubts") is not None]
    if warned:
        with_doubt = sum(r["doubts"] > 0 for r in warned)
        lines += ["", f"Warned runs whose solution lists at least one doubt: "
                      f"{_share(with_doubt, len(warned))}."]
    rel = reliability_rows(rows)
    if any(r["runs"] for r in rel if r["p_change"] != "n/a"):
        lines += ["", "Runs by chance of change (`p_change`) and the share that passed:", "",
                  "| split | p_change | runs | passed | share passed |", "|---|---|---|---|---|"]
        for r in rel:
            share = f"{100 * r['passed'] / r['runs']:.0f} %" if r["runs"] else "-"
            lines.append(f"| {r['split']} | {r['p_change']} | {r['runs']} | {r['passed']} | "
                         f"{share} |")
    return "\n".join(lines) + "\n"
