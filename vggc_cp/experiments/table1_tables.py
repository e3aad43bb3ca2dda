"""The tables of the Table 1 run (:mod:`vggc_cp.experiments.table1`): ``table1.csv`` (one
row per cell) and ``table1.md`` (means over seeds, the paper's rows beside ours)."""

from __future__ import annotations

import math
from pathlib import Path

from vggc_cp.atomic import write_text
from vggc_cp.evaluate.paper import PAPER_METHODS, PAPER_METRICS, PAPER_TABLE1
from vggc_cp.experiments.table1 import METHOD_TITLES, NOT_FINISHED


def _pct(x) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.1f}"


def _attention_note(g) -> str:
    """``", keypoints attention"`` for rows measured on distances of a backend other than the
    default ``saliency`` (empty otherwise)."""
    if "attention" not in g:
        return ""
    names = [a for a in dict.fromkeys(g["attention"]) if isinstance(a, str)]
    return f", {names[0]} attention" if len(names) == 1 and names[0] != "saliency" else ""


def table_markdown(rows: list[dict]) -> str:
    """Table 1 as markdown: per benchmark, one row per method (ours: mean over seeds) and
    the paper's row beside it (``n/a`` where :data:`PAPER_TABLE1` holds no checked value).

    Columns: OptPath, AnyPath, TransPrec, TransCov (%), then Exec (%), nodes / |V*| (|V*| of
    our trace, the paper's in the benchmark cell) and seconds (distances + method).
    """
    import pandas as pd

    df = pd.DataFrame.from_records(rows)
    head = ("| benchmark | method | OptPath | AnyPath | TransPrec | TransCov | Exec "
            "| nodes / \\|V*\\| | seconds |")
    lines = [head, "|" + "---|" * 9]
    for bench in dict.fromkeys(df["benchmark"]):
        sub = df[df["benchmark"] == bench]
        d = int(sub["transitions"].iloc[0])
        paper_v = int(sub["paper_states"].iloc[0])
        label = f"{bench} (\\|D\\|={d}, paper \\|V*\\|={paper_v})"
        for method in dict.fromkeys(sub["method"]):
            g = sub[sub["method"] == method]
            n_seeds = len(g)
            seeds = f" ({n_seeds} seeds)" if n_seeds > 1 else ""
            title = f"{METHOD_TITLES.get(method, method)} (ours{_attention_note(g)}){seeds}"
            if "status" in g and (g["status"] == NOT_FINISHED).any():
                lines.append(f"| {label} | {title} | " + " | ".join([NOT_FINISHED] * 7) + " |")
            else:
                vals = {m: g[m].astype(float).mean() if g[m].notna().all() else None
                        for m in (*PAPER_METRICS, "exec")}
                nodes = f"{g['nodes'].mean():.0f} / {g['true_states'].mean():.0f}"
                lines.append(f"| {label} | {title} | "
                             + " | ".join(_pct(vals[m]) for m in (*PAPER_METRICS, "exec"))
                             + f" | {nodes} | {g['seconds'].mean():.1f} |")
            label = ""
            if method in PAPER_METHODS:
                paper = PAPER_TABLE1.get((bench, method), {})
                cells = [_pct(paper[m]) if m in paper else "n/a" for m in PAPER_METRICS]
                lines.append(f"|  | {PAPER_METHODS[method]} (paper) | " + " | ".join(cells)
                             + " | n/a | n/a | n/a |")
    return "\n".join(lines) + "\n"


def write_tables(rows: list[dict], out: Path, wall_seconds: float | None = None) -> tuple[Path, Path]:
    """Write ``table1.csv`` (one row per cell) and ``table1.md`` into ``out``."""
    import pandas as pd

    out = Path(out)
    csv = out / "table1.csv"
    md = out / "table1.md"
    write_text(csv, pd.DataFrame.from_records(rows).to_csv(index=False))
    note = ("Metrics in %; ours evaluated with Q queries on the simulator's dynamics "
            "(Exec); '–' where a method found no graph.")
    if wall_seconds is not None:
        note += f" Wall time of the run: {wall_seconds:.0f} s."
    text = table_markdown(rows) + "\n" + note + "\n"
    if any("i2p" in r for r in rows):
        text += "\n" + i2p_markdown(rows)
    write_text(md, text)
    return csv, md


def i2p_markdown(rows: list[dict]) -> str:
    """The image-to-plan table: per benchmark and localized method, localization accuracy,
    I2P and Exec-I2P (%, means over seeds) and the localizer's training seconds."""
    import pandas as pd

    df = pd.DataFrame.from_records([r for r in rows if "i2p" in r])
    lines = ["| benchmark | method | Localization | I2P | Exec-I2P | nodes / \\|V*\\| "
             "| training seconds |", "|" + "---|" * 7]
    for (bench, method), g in df.groupby(["benchmark", "method"], sort=False):
        title = METHOD_TITLES.get(method, method) + _attention_note(g)
        lines.append(f"| {bench} | {title} | "
                     + " | ".join(_pct(g[m].astype(float).mean())
                                  for m in ("localization", "i2p", "exec_i2p"))
                     + f" | {g['nodes'].mean():.0f} / {g['true_states'].mean():.0f} "
                     f"| {g['seconds_localizer'].mean():.1f} |")
    return "\n".join(lines) + "\n"

