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
what the number means on the suite. Two more read the description-length margin ``m`` (nats
over the whole trace, :func:`margin_nats`):

* **is it a probability?** (:func:`margin_rows`) If the description length were a negative
  log posterior, the runner-up graph of another size would be the right one with chance
  ``1 / (1 + e^m)``. Per bin of ``m``, among the runs no other check flags, the share that
  missed against that chance;
* **what moving its bar would do** (:func:`margin_tradeoff_rows`): false alarms and silent
  failures with the margin check at other bars, every other reason a row records kept as
  it is. It shows whether any bar gets both to target, or whether the evidence must improve
  first.

Nothing here reads a trace or a ground-truth state beyond the row's own ``passed`` figures.
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
#: Bins of the description-length margin in nats (upper bounds, inclusive) of
#: :func:`margin_rows`.
MARGIN_BINS = (0.25, 1.0, 2.0, 3.0, 6.0, 12.0, math.inf)
#: Bars of the margin check (nats) that :func:`margin_tradeoff_rows` tries.
MARGIN_BARS = (0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0)
#: How a warning reason about the margin begins (:func:`vggc_cp.solvers.confidence.fixed_reasons`).
MARGIN_REASON = "description-length margin"
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


def _splits(rows: list[dict]) -> list:
    """The splits the rows hold: :data:`~vggc_cp.experiments.robustness.SPLITS` first, in
    their order, then any other by name."""
    have = {r.get("split") for r in rows}
    return [s for s in SPLITS if s in have] + sorted(have - set(SPLITS), key=str)


def reliability_rows(rows: list[dict]) -> list[dict]:
    """Runs binned by ``p_change`` (:data:`P_BINS`; runs without one in ``n/a``): per split
    and bin, runs, passed and the share that passed."""
    out = []
    for split in _splits(rows):
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


def margin_nats(row: dict) -> float | None:
    """The row's description-length margin over the whole trace (its ``margin`` is per
    transition): ``inf`` when no graph of another size was on the path, None when the row
    has no margin or no transition count."""
    m, n = row.get("margin"), row.get("transitions")
    if m is None or not n or (isinstance(m, float) and math.isnan(m)):
        return None
    return math.inf if math.isinf(m) else float(m) * n


def other_warning(row: dict) -> bool:
    """Whether the row's verdict warned for a reason other than the margin (the advice
    appended to a reason does not count on its own)."""
    reasons = [p for p in (row.get("reasons") or "").split("; ") if p.strip()]
    return any(not p.startswith(MARGIN_REASON) and not p.startswith("`vggc-cp ")
               for p in reasons)


def _bin_name(lo: float | None, hi: float) -> str:
    top = "inf" if math.isinf(hi) else f"{hi:g}"
    return f"<= {top}" if lo is None else f"({lo:g}, {top}]"


def margin_rows(rows: list[dict]) -> list[dict]:
    """Runs binned by the description-length margin in nats (:data:`MARGIN_BINS`), per split:
    runs, runs no other check flags (``quiet_else``), how many of those missed, and the mean
    chance ``1 / (1 + e^m)`` the description length gives the runner-up over them
    (``implied``; None for an empty bin)."""
    out = []
    for split in _splits(rows):
        sub = [(margin_nats(r), r) for r in rows if r.get("split") == split]
        lo = None
        for hi in MARGIN_BINS:
            g = [(m, r) for m, r in sub if m is not None and (lo is None or m > lo) and m <= hi]
            quiet = [(m, r) for m, r in g if not other_warning(r)]
            chance = [1.0 / (1.0 + math.exp(min(m, 700.0))) for m, _ in quiet]
            out.append({"split": split, "margin": _bin_name(lo, hi), "runs": len(g),
                        "quiet_else": len(quiet),
                        "missed": sum(not passes(r) for _, r in quiet),
                        "implied": sum(chance) / len(chance) if chance else None})
            lo = hi
    return out


def margin_tradeoff_rows(rows: list[dict], bars=MARGIN_BARS) -> list[dict]:
    """Per split and bar of the margin check (nats): passed, false alarms, missed and silent
    failures when a run is warned for a reason other than the margin
    (:func:`other_warning`) or for a margin below the bar. Rows without a margin keep their
    other reasons only."""
    out = []
    for split in _splits(rows):
        # (passed, warned for another reason, margin) of every run, read once
        runs = [(passes(r), other_warning(r), margin_nats(r)) for r in rows
                if r.get("split") == split]
        n_ok = sum(ok for ok, _, _ in runs)
        for bar in bars:
            warned = [other or (m is not None and m < bar) for _, other, m in runs]
            out.append({"split": split, "bar": float(bar), "passed": n_ok,
                        "false_alarms": sum(w for (ok, _, _), w in zip(runs, warned) if ok),
                        "missed": len(runs) - n_ok,
                        "silent": sum(not w for (ok, _, _), w in zip(runs, warned) if not ok)})
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
    lines += _margin_markdown(rows)
    return "\n".join(lines) + "\n"


def _margin_markdown(rows: list[dict]) -> list[str]:
    """The margin's two tables (:func:`margin_rows`, :func:`margin_tradeoff_rows`) as markdown
    lines; none when the rows record no margin or no reasons."""
    mrows = margin_rows(rows)
    if not any(r["runs"] for r in mrows) or not any(r.get("reasons") is not None for r in rows):
        return []
    lines = ["", "Is the description-length margin a probability? Runs by margin (nats over the "
                 "trace); among those no other check flags, the share that missed against the "
                 "chance 1 / (1 + e^m) it gives the runner-up graph:", "",
             "| split | margin (nats) | runs | no other warning | of them missed | "
             "chance it implies |", "|---|---|---|---|---|---|"]
    for r in mrows:
        if not r["runs"]:
            continue
        imp = "-" if r["implied"] is None else f"{100 * r['implied']:.1f} %"
        lines.append(f"| {r['split']} | {r['margin']} | {r['runs']} | {r['quiet_else']} | "
                     f"{_share(r['missed'], r['quiet_else'])} | {imp} |")
    lines += ["", "The margin check at other bars (every other reason as the rows record it):",
              "", "| split | bar (nats) | false alarms (share of passing) | silent failures |",
              "|---|---|---|---|"]
    for r in margin_tradeoff_rows(rows):
        lines.append(f"| {r['split']} | {r['bar']:g} | {_share(r['false_alarms'], r['passed'])} "
                     f"| {r['silent']} / {r['missed']} |")
    return lines
