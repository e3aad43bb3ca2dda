"""The robustness study's tables: ``robustness.csv`` (one row per cell) and ``robustness.md``
(per split: by task family, by kind of drawn task and by task, each per look; the share
passing, the warning's calibration and the missed runs), from the rows of
:func:`vggc_cp.experiments.robustness.run_robustness` and its pass rule."""

from __future__ import annotations

from functools import cache
from pathlib import Path

from vggc_cp.atomic import write_text
from vggc_cp.errors import VggcError
from vggc_cp.evaluate.metrics import MIN_EXEC
from vggc_cp.experiments.robustness import (
    CALIBRATION,
    CALIBRATION_TITLES,
    HELDOUT_FROM_SEED,
    HELDOUT_TASK_FROM,
    I2P_FIELDS,
    MIN_ANY_PATH,
    MIN_I2P,
    MIN_OBS_PER_STATE,
    MIN_OPT_PATH,
    NODES_HIGH,
    NODES_LOW,
    ROW_FIELDS,
    SPLITS,
    TUNING,
    calibration,
    failures,
    measured,
    passes,
    percent,
    task_seed,
)
from vggc_cp.sim import get_spec
from vggc_cp.sim.specs import TASK


def calibration_line(counts: dict[str, int]) -> str:
    return "Calibration: " + ", ".join(f"{counts[k]} {CALIBRATION_TITLES[k]}"
                                       for k in CALIBRATION) + "."


def _ranges(values: list[int]) -> str:
    """``[0, 1, 2, 5]`` -> ``"0-2, 5"``."""
    out: list[str] = []
    for v in values:
        if out and out[-1].split("-")[-1] == str(v - 1):
            out[-1] = out[-1].split("-")[0] + f"-{v}"
        else:
            out.append(str(v))
    return ", ".join(out)


def _mean(rows: list[dict], key: str):
    vals = [float(r[key]) for r in rows if measured(r.get(key))]
    return sum(vals) / len(vals) if vals else None


def _ratio_range(rows: list[dict]) -> str:
    ratios = [r["nodes"] / r["true_states"] for r in rows if r.get("true_states")]
    if not ratios:
        return "–"
    lo, hi = min(ratios), max(ratios)
    return f"{lo:.2f}" if abs(hi - lo) < 5e-3 else f"{lo:.2f}–{hi:.2f}"


def split_markdown(rows: list[dict]) -> str:
    """One split's table: per benchmark x look, runs, passed, mean Exec / OptPath / AnyPath
    (%), the range of nodes / |V*|, warned runs (and mean I2P where measured)."""
    i2p = any(measured(r.get("i2p")) for r in rows)
    head = ("| benchmark | look | \\|D\\| | runs | passed | Exec | OptPath | AnyPath "
            "| nodes / \\|V*\\| | warned |" + (" I2P |" if i2p else ""))
    lines = [head, "|" + "---|" * (10 + i2p)]
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((r["benchmark"], r["look"]), []).append(r)
    for (bench, look), g in groups.items():
        d = "/".join(str(x) for x in dict.fromkeys(r["transitions"] for r in g))
        cells = [bench, look, d, str(len(g)), str(sum(passes(r) for r in g)),
                 percent(_mean(g, "exec")), percent(_mean(g, "opt_path")),
                 percent(_mean(g, "any_path")),
                 _ratio_range(g), str(sum(bool(r.get("suspect")) for r in g))]
        if i2p:
            cells.append(percent(_mean(g, "i2p")))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _family(r: dict) -> str:
    """The row's task family (rows cached before families were recorded: from the name)."""
    if r.get("family"):
        return str(r["family"])
    try:
        return get_spec(r["benchmark"]).family
    except VggcError:
        return "?"


def _group_markdown(title: str, groups: dict[tuple[str, str], list[dict]]) -> str:
    """Per group x look (``groups``: ``(group, look) -> rows``): runs, passed (share),
    warned, silent failures, mean Exec."""
    lines = [f"| {title} | look | runs | passed | share | warned | silent | Exec |",
             "|---|---|---|---|---|---|---|---|"]
    for (name, look), g in sorted(groups.items()):
        ok = sum(passes(r) for r in g)
        silent = sum(not passes(r) and not r.get("suspect") for r in g)
        lines.append(f"| {name} | {look} | {len(g)} | {ok} | {100 * ok / len(g):.1f} % | "
                     f"{sum(bool(r.get('suspect')) for r in g)} | {silent} | "
                     f"{percent(_mean(g, 'exec'))} |")
    return "\n".join(lines) + "\n"


def family_markdown(rows: list[dict]) -> str:
    """Per task family x look: runs, passed (share), warned, silent failures, mean Exec."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        groups.setdefault((_family(r), r["look"]), []).append(r)
    return _group_markdown("family", groups)


@cache
def task_kind(benchmark: str) -> str | None:
    """What kind of drawn task ``benchmark`` is, by the two parts of its spec that tell most
    about how hard it is to learn: where its episodes start (``home starts``: at a few home
    states, so that most states are seen once or twice; ``any start``) and whether objects
    stack; None for one of the seven (or an unknown name). Cached per name: a drawn task's
    spec is drawn again from its seed on every call (tens of milliseconds), and a report
    asks once per row.

    >>> task_kind("random-9"), task_kind("random-1"), task_kind("fruit-2x3")
    ('home starts', 'any start, stacking', None)
    """
    try:
        spec = get_spec(benchmark)
    except VggcError:
        return None
    if spec.family != TASK:
        return None
    start = "home starts" if spec.start_states else "any start"
    return start + (", stacking" if spec.max_height > 1 else "")


def kind_markdown(rows: list[dict]) -> str:
    """Per kind of drawn task (:func:`task_kind`) x look: runs, passed (share), warned,
    silent failures, mean Exec; empty when no row is a drawn task."""
    groups: dict[tuple[str, str], list[dict]] = {}
    for r in rows:
        kind = task_kind(r["benchmark"])
        if kind is not None:
            groups.setdefault((kind, r["look"]), []).append(r)
    return _group_markdown("kind", groups) if groups else ""


def _missed_line(r: dict) -> str:
    sparse = (f" (sparse: {r['obs_per_state']:.1f} observations per state)"
              if measured(r.get("obs_per_state")) and r["obs_per_state"] < MIN_OBS_PER_STATE
              else "")
    warn = (f"warned: {r.get('reasons') or 'suspect'}" if r.get("suspect")
            else "**no warning (silent failure)**")
    return (f"- {r['benchmark']} {r['look']} seed {r['seed']}{sparse}: "
            + "; ".join(failures(r)) + f" -- {warn}")


def table_markdown(rows: list[dict], wall_seconds: float | None = None) -> str:
    """The whole report: the rule, then per split its table, share passing, calibration and
    missed runs, then the overall share and calibration."""
    seeds = {s: sorted({r["seed"] for r in rows if r.get("split") == s}) for s in SPLITS}
    tasks = {s: sorted({task_seed(r["benchmark"]) for r in rows if r.get("split") == s}
                       - {None}) for s in SPLITS}
    lines = ["# Robustness of the default `vggc-cp solve`", "",
             f"A run passes with Exec >= {percent(MIN_EXEC)} %, nodes within [{NODES_LOW}, "
             f"{NODES_HIGH}] x |V*|, OptPath >= {percent(MIN_OPT_PATH)} %, AnyPath "
             f"{percent(MIN_ANY_PATH)} %",
             f"and I2P >= {percent(MIN_I2P)} % where measured. Metrics in % (means over seeds); "
             "'warned': runs the solver flagged suspect.", ""]
    for split in SPLITS:
        sub = [r for r in rows if r.get("split") == split]
        title = "Tuning split" if split == TUNING else "Held-out split (kept out of tuning)"
        drawn = (f"; random tasks of task seeds {_ranges(tasks[split])}" if tasks[split]
                 else "")
        lines += [f"## {title}: trace seeds {', '.join(map(str, seeds[split])) or 'none'}"
                  f"{drawn}", ""]
        if not sub:
            lines += [f"No run in this split (by default trace seeds >= {HELDOUT_FROM_SEED} "
                      f"and tasks random-S with S >= {HELDOUT_TASK_FROM} are held out).", ""]
            continue
        n_ok = sum(passes(r) for r in sub)
        kinds = kind_markdown(sub)
        lines += ["By task family and look:", "", family_markdown(sub).rstrip("\n"), "",
                  *(["Drawn tasks by kind (where episodes start, whether objects stack) and "
                     "look:", "", kinds.rstrip("\n"), ""] if kinds else []),
                  "By task and look:", "", split_markdown(sub).rstrip("\n"), "",
                  f"Passing: {n_ok} / {len(sub)} runs ({100 * n_ok / len(sub):.1f} %).",
                  calibration_line(calibration(sub)[split]), ""]
        missed = [r for r in sub if not passes(r)]
        lines += (["Missed runs:", *[_missed_line(r) for r in missed], ""] if missed
                  else ["No run missed.", ""])
    if rows:
        n_ok = sum(passes(r) for r in rows)
        lines += ["## Overall", "",
                  f"Passing: {n_ok} / {len(rows)} runs ({100 * n_ok / len(rows):.1f} %).",
                  calibration_line(calibration(rows)["all"])]
        learn = sum(float(r.get("seconds_learn") or 0.0) for r in rows)
        lines.append(f"Learning time, summed over runs: {learn:.0f} s"
                     + (f"; wall time of this invocation (cached cells reused): "
                        f"{wall_seconds:.0f} s." if wall_seconds is not None else "."))
    return "\n".join(lines) + "\n"


def rows_frame(rows: list[dict]):
    """The rows as a pandas DataFrame with :data:`ROW_FIELDS` first and ``passed`` filled."""
    import pandas as pd

    recs = [r | {"passed": passes(r)} for r in rows]
    df = pd.DataFrame.from_records(recs)
    first = [c for c in (*ROW_FIELDS, *I2P_FIELDS) if c in df.columns]
    return df[first + [c for c in df.columns if c not in first]]


def write_tables(rows: list[dict], out: Path,
                 wall_seconds: float | None = None) -> tuple[Path, Path]:
    """Write ``robustness.csv`` (one row per cell) and ``robustness.md`` into ``out``."""
    out = Path(out)
    csv, md = out / "robustness.csv", out / "robustness.md"
    write_text(csv, rows_frame(rows).to_csv(index=False))
    write_text(md, table_markdown(rows, wall_seconds))
    return csv, md

