"""Every figure the command line and the notebooks draw (matplotlib, Agg backend, files only)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vggc_cp.atomic import atomic_path


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_sweep_grid(k_pick: list[int], k_place: list[int], J: np.ndarray, path: str | Path, *,
                    selected: tuple[int, int] | None = None, title: str | None = None) -> None:
    """Heatmap of the visual score J over a ``(k_pick, k_place)`` grid.

    Parameters
    ----------
    k_pick, k_place : list of int
        Row and column values.
    J : ndarray, shape (len(k_pick), len(k_place))
        NaN where the cell has no colouring; those cells stay blank.
    path : path
        PNG (or any format matplotlib infers from the suffix), written atomically.
    selected : (k_pick, k_place), optional
        The selected cell, outlined.
    title : str, optional
    """
    plt = _pyplot()
    J = np.asarray(J, dtype=float)
    fig, ax = plt.subplots(figsize=(1.0 + 0.45 * len(k_place), 0.8 + 0.4 * len(k_pick)),
                           constrained_layout=True)
    masked = np.ma.masked_invalid(J)
    cmap = plt.get_cmap("viridis").with_extremes(bad=(0.0, 0.0, 0.0, 0.0))
    im = ax.imshow(masked, origin="lower", cmap=cmap, aspect="auto")
    ax.set_xticks(range(len(k_place)), [str(k) for k in k_place])
    ax.set_yticks(range(len(k_pick)), [str(k) for k in k_pick])
    ax.set_xlabel("k_place")
    ax.set_ylabel("k_pick")
    if selected is not None and selected[0] in k_pick and selected[1] in k_place:
        y, x = k_pick.index(selected[0]), k_place.index(selected[1])
        ax.add_patch(plt.Rectangle((x - 0.5, y - 0.5), 1, 1, fill=False, edgecolor="red",
                                   linewidth=2))
    if np.isfinite(J).any():
        fig.colorbar(im, ax=ax, label="J (blank: no colouring)")
    ax.set_title(title or "visual score J over the grid")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format=Path(path).suffix.lstrip(".") or "png")
    plt.close(fig)


def plot_image_strip(images, titles, path: str | Path, *, suptitle: str | None = None,
                     outlines=None) -> None:
    """A row of images with a title above each (the ``vggc-cp demo`` picture strip).

    Parameters
    ----------
    images : sequence of ndarray, uint8, shape (H, W, 3)
    titles : sequence of str
        One (multi-line allowed) per image.
    path : path
        PNG, written atomically.
    suptitle : str, optional
        A line above the whole strip.
    outlines : sequence of str or None, optional
        A frame colour per image (None: no frame), e.g. green for a reached goal.
    """
    plt = _pyplot()
    n = len(images)
    fig, axes = plt.subplots(1, n, figsize=(1.9 * n, 2.6 if suptitle else 2.3),
                             constrained_layout=True, squeeze=False)
    outlines = outlines or [None] * n
    for ax, img, title, colour in zip(axes[0], images, titles, outlines):
        ax.imshow(np.asarray(img), interpolation="nearest")
        ax.set_title(title, fontsize=7)
        ax.set_xticks([])
        ax.set_yticks([])
        for spine in ax.spines.values():
            spine.set_visible(colour is not None)
            if colour is not None:
                spine.set_edgecolor(colour)
                spine.set_linewidth(3)
    if suptitle:
        fig.suptitle(suptitle, fontsize=9)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format=Path(path).suffix.lstrip(".") or "png")
    plt.close(fig)


def plot_compare_grids(k_pick: list[int], k_place: list[int], J_greedy: np.ndarray,
                       J_cpsat: np.ndarray, cpsat_status: dict, path: str | Path, *,
                       selected: list | None = None, title: str | None = None) -> None:
    """Greedy and CP-SAT J over one ``(k_pick, k_place)`` grid, side by side, one colour scale.

    Parameters
    ----------
    k_pick, k_place : list of int
    J_greedy, J_cpsat : ndarray, shape (len(k_pick), len(k_place))
        NaN where the solver has no colouring (blank).
    cpsat_status : dict
        ``(k_pick, k_place) -> status``; CP-SAT cells are marked ``*`` proved optimal,
        ``x`` proved infeasible, ``?`` unknown.
    path : path
        Written atomically.
    selected : [greedy cell or None, CP-SAT cell or None], optional
        Outlined in red.
    """
    plt = _pyplot()
    mats = [np.asarray(J_greedy, dtype=float), np.asarray(J_cpsat, dtype=float)]
    finite = np.concatenate([m[np.isfinite(m)] for m in mats])
    vmin, vmax = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    w = 1.0 + 0.32 * len(k_place)
    fig, axes = plt.subplots(1, 2, figsize=(2 * w + 1.0, 1.0 + 0.3 * len(k_pick)),
                             constrained_layout=True)
    cmap = plt.get_cmap("viridis").with_extremes(bad=(0.0, 0.0, 0.0, 0.0))
    marks = {"optimal": "*", "infeasible": "x", "unknown": "?"}
    im = None
    for idx, (ax, mat, name) in enumerate(zip(axes, mats, ("greedy", "CP-SAT"))):
        im = ax.imshow(np.ma.masked_invalid(mat), origin="lower", cmap=cmap, aspect="auto",
                       vmin=vmin, vmax=vmax)
        ax.set_xticks(range(len(k_place)), [str(k) for k in k_place], fontsize=7)
        ax.set_yticks(range(len(k_pick)), [str(k) for k in k_pick], fontsize=7)
        ax.set_xlabel("k_place")
        ax.set_ylabel("k_pick")
        ax.set_title(name + (" (* optimal, x infeasible, ? unknown)" if idx else
                             " (blank: no colouring)"), fontsize=9)
        if idx:
            for (a, b), status in cpsat_status.items():
                if status in marks and a in k_pick and b in k_place:
                    ax.text(k_place.index(b), k_pick.index(a), marks[status], ha="center",
                            va="center", fontsize=7,
                            color="white" if status == "optimal" else "black")
        cell = None if selected is None else selected[idx]
        if cell is not None and cell[0] in k_pick and cell[1] in k_place:
            y, x = k_pick.index(cell[0]), k_place.index(cell[1])
            ax.add_patch(plt.Rectangle((x - 0.5, y - 0.5), 1, 1, fill=False, edgecolor="red",
                                       linewidth=2))
    if finite.size:
        fig.colorbar(im, ax=list(axes), label="J")
    if title:
        fig.suptitle(title)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format=Path(path).suffix.lstrip(".") or "png")
    plt.close(fig)


# ---------------------------------------------------------------- research notebooks


def _save(fig, path: str | Path) -> None:
    plt = _pyplot()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format=Path(path).suffix.lstrip(".") or "png")
    plt.close(fig)


def plot_feasibility_heatmaps(panels: list[list[dict]], path: str | Path, *,
                              title: str | None = None) -> None:
    """A grid of ``(k_pick, k_place)`` feasibility heatmaps (rows: solvers/models, columns: |D|).

    Parameters
    ----------
    panels : list of rows, each a list of dicts
        Each dict: ``k_pick``, ``k_place`` (lists of int), ``feasible`` (share of seeds with a
        colouring, shape (len(k_pick), len(k_place))), optional ``proved`` (share of seeds
        proved infeasible; cells proved in every seed are marked ``x``) and ``title``.
    path : path
        Written atomically.
    """
    plt = _pyplot()
    nrows, ncols = len(panels), max(len(r) for r in panels)
    fig, axes = plt.subplots(nrows, ncols, figsize=(2.3 * ncols + 0.8, 2.2 * nrows + 0.4),
                             squeeze=False, constrained_layout=True)
    im = None
    for i, row in enumerate(panels):
        for j in range(ncols):
            ax = axes[i][j]
            if j >= len(row):
                ax.axis("off")
                continue
            p = row[j]
            kp, kq = list(p["k_pick"]), list(p["k_place"])
            feas = np.asarray(p["feasible"], dtype=float)
            im = ax.imshow(np.ma.masked_invalid(feas), origin="lower", cmap="Greens",
                           vmin=0, vmax=1, aspect="auto")
            proved = p.get("proved")
            if proved is not None:
                proved = np.asarray(proved, dtype=float)
                ys, xs = np.nonzero(proved >= 1.0 - 1e-9)
                ax.scatter(xs, ys, marker="x", s=10, c="firebrick", linewidths=0.8)
            step = max(1, len(kq) // 6)
            ax.set_xticks(range(0, len(kq), step), [str(k) for k in kq[::step]], fontsize=7)
            step = max(1, len(kp) // 6)
            ax.set_yticks(range(0, len(kp), step), [str(k) for k in kp[::step]], fontsize=7)
            ax.set_title(p.get("title", ""), fontsize=8)
            if i == nrows - 1:
                ax.set_xlabel("k_place", fontsize=8)
            if j == 0:
                ax.set_ylabel("k_pick", fontsize=8)
    if im is not None:
        fig.colorbar(im, ax=axes, shrink=0.6,
                     label="share of seeds with a colouring (x: proved infeasible, all seeds)")
    if title:
        fig.suptitle(title, fontsize=10)
    _save(fig, path)


def plot_min_k(series: list[dict], path: str | Path, *, title: str | None = None) -> None:
    """Minimal total K against |D| (left) and against the number of visited states (right).

    Parameters
    ----------
    series : list of dict
        Each: ``label``, ``transitions``, ``states``, ``K`` (equal-length sequences; NaN where
        no colouring was found), optional ``proved`` (bools: filled markers where proved
        minimal, hollow otherwise) and ``marker``.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    for idx, s in enumerate(series):
        colour = f"C{idx}"
        d = np.asarray(s["transitions"], dtype=float)
        v = np.asarray(s["states"], dtype=float)
        k = np.asarray(s["K"], dtype=float)
        proved = np.asarray(s.get("proved", np.ones(len(k), bool)), dtype=bool)
        jitter = (idx - (len(series) - 1) / 2) * 0.012
        for ax, x, logx in ((axes[0], d, True), (axes[1], v, False)):
            xs = x * (1 + jitter) if logx else x + jitter * 40
            ax.scatter(xs[proved], k[proved], color=colour, marker=s.get("marker", "o"),
                       label=s["label"], s=28)
            ax.scatter(xs[~proved], k[~proved], facecolors="none", edgecolors=colour,
                       marker=s.get("marker", "o"), s=28)
            ok = np.isfinite(k)
            if ok.any():
                ux = np.unique(x[ok])
                means = [np.nanmean(k[ok][x[ok] == u]) for u in ux]
                ax.plot(ux * (1 + jitter) if logx else ux, means, color=colour, alpha=0.5)
    axes[0].set_xscale("log")
    ticks = sorted({int(t) for s in series for t in np.asarray(s["transitions"]).tolist()})
    axes[0].set_xticks(ticks, [str(t) for t in ticks])
    axes[0].minorticks_off()
    axes[0].set_xlabel("|D| (transitions)")
    axes[1].set_xlabel("distinct true states visited |V*|")
    lim = [0, max(1.0, float(np.nanmax([np.nanmax(np.asarray(s["states"], float))
                                        for s in series])) * 1.05)]
    axes[1].plot(lim, lim, ls=":", color="grey", label="K = |V*|")
    for ax in axes:
        ax.set_ylabel("minimal total K = k_pick + k_place")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7, loc="upper left")
    if title:
        fig.suptitle(title + " (hollow: not proved minimal)")
    _save(fig, path)


def plot_solver_bars(labels: list[str], values: dict, path: str | Path, *, ylabel: str = "",
                     title: str | None = None, log: bool = False, ylim=None) -> None:
    """Grouped bars: one group per label (benchmark), one bar per series (solver).

    Parameters
    ----------
    labels : list of str
    values : dict
        ``series name -> sequence of float`` (len(labels) each; NaN: no bar).
    """
    plt = _pyplot()
    n = len(values)
    width = 0.8 / max(n, 1)
    fig, ax = plt.subplots(figsize=(1.2 + 1.1 * len(labels), 3.4), constrained_layout=True)
    x = np.arange(len(labels))
    for i, (name, vals) in enumerate(values.items()):
        ax.bar(x + (i - (n - 1) / 2) * width, np.asarray(vals, dtype=float), width, label=name)
    ax.set_xticks(x, labels, rotation=20, fontsize=8)
    ax.set_ylabel(ylabel)
    if log:
        ax.set_yscale("log")
    if ylim is not None:
        ax.set_ylim(*ylim)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7)
    if title:
        ax.set_title(title, fontsize=10)
    _save(fig, path)


def plot_metric_panels(labels: list[str], metrics: dict, path: str | Path, *,
                       title: str | None = None) -> None:
    """One panel per planning metric, grouped bars per label, one bar per solver.

    Parameters
    ----------
    labels : list of str
        Groups (benchmarks).
    metrics : dict
        ``metric title -> {solver -> sequence of float in [0, 1]}``.
    """
    plt = _pyplot()
    names = list(metrics)
    fig, axes = plt.subplots(1, len(names), figsize=(2.6 * len(names) + 0.5, 3.3),
                             squeeze=False, constrained_layout=True, sharey=True)
    x = np.arange(len(labels))
    for ax, name in zip(axes[0], names):
        series = metrics[name]
        width = 0.8 / max(len(series), 1)
        for i, (solver, vals) in enumerate(series.items()):
            ax.bar(x + (i - (len(series) - 1) / 2) * width, np.asarray(vals, dtype=float),
                   width, label=solver)
        ax.set_xticks(x, labels, rotation=60, fontsize=7)
        ax.set_title(name, fontsize=9)
        ax.set_ylim(0, 1.05)
        ax.grid(axis="y", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    if title:
        fig.suptitle(title)
    _save(fig, path)


def plot_scalability(transitions: list[int], curves: dict, seconds: dict, path: str | Path, *,
                     title: str | None = None) -> None:
    """The paper's scalability figure: metrics against |D| (left), runtime split (right).

    Parameters
    ----------
    transitions : list of int
        |D| values (x axis, log scale).
    curves : dict
        ``label -> sequence of float`` (e.g. ``"TransCov greedy"``), one value per |D|.
    seconds : dict
        ``solver -> {"distances": seq, "search": seq}``: stacked bars per |D| and solver.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.9), constrained_layout=True)
    styles = ["-o", "--s", "-^", "--v", "-D", "--x"]
    for i, (label, vals) in enumerate(curves.items()):
        axes[0].plot(transitions, np.asarray(vals, dtype=float), styles[i % len(styles)],
                     label=label, color=f"C{i // 2}" if len(curves) > 2 else None,
                     alpha=0.85)
    axes[0].set_xscale("log")
    axes[0].set_xlabel("|D| (transitions)")
    axes[0].set_ylabel("rate")
    axes[0].set_ylim(0, 1.05)
    axes[0].grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    ax = axes[1]
    x = np.arange(len(transitions))
    n = len(seconds)
    width = 0.8 / max(n, 1)
    for i, (solver, parts) in enumerate(seconds.items()):
        dist = np.asarray(parts["distances"], dtype=float)
        search = np.asarray(parts["search"], dtype=float)
        pos = x + (i - (n - 1) / 2) * width
        ax.bar(pos, dist, width, color="lightgrey", edgecolor=f"C{i}",
               label="distances" if i == 0 else None)
        ax.bar(pos, search, width, bottom=dist, color=f"C{i}", label=f"search ({solver})")
    ax.set_xticks(x, [str(t) for t in transitions])
    ax.set_xlabel("|D| (transitions)")
    ax.set_ylabel("seconds")
    ax.set_yscale("log")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7)
    if title:
        fig.suptitle(title)
    _save(fig, path)


def _is_number(x) -> bool:
    return x is not None and not (isinstance(x, float) and np.isnan(x))


def plot_exec(rows: list[dict], path: str | Path, *, title: str | None = None) -> None:
    """Exec of every run, grouped by benchmark, one colour per look; warned runs drawn as
    crosses, quiet ones as dots; the dashed line is :data:`vggc_cp.evaluate.metrics.MIN_EXEC`."""
    from vggc_cp.evaluate.metrics import MIN_EXEC

    plt = _pyplot()
    benches = list(dict.fromkeys(r["benchmark"] for r in rows))
    looks = list(dict.fromkeys(r["look"] for r in rows))
    fig, ax = plt.subplots(figsize=(1.6 + 1.2 * len(benches), 3.6), constrained_layout=True)
    width = 0.7 / max(len(looks), 1)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j, look in enumerate(looks):
        for warned, marker in ((False, "o"), (True, "X")):
            pts = [(benches.index(r["benchmark"]) + (j - (len(looks) - 1) / 2) * width,
                    100 * float(r["exec"]))
                   for r in rows if r["look"] == look and bool(r.get("suspect")) == warned
                   and _is_number(r.get("exec"))]
            if not pts:
                continue
            x, y = np.array(pts).T
            x = x + np.linspace(-0.25, 0.25, len(x)) * width
            ax.scatter(x, y, marker=marker, s=46 if warned else 26,
                       color=colours[j % len(colours)], edgecolors="black" if warned else "none",
                       label=f"{look}{' (warned)' if warned else ''}", zorder=3)
    ax.axhline(100 * MIN_EXEC, color="grey", ls="--", lw=1)
    ax.set_xticks(np.arange(len(benches)), benches, rotation=20, fontsize=8)
    ax.set_xlim(-0.6, len(benches) - 0.4)
    ax.set_ylabel("Exec (%)")
    ax.set_ylim(-3, 103)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title(title or "default solve: Exec per run", fontsize=10)
    _save(fig, path)


def plot_scale(rows: list[dict], path: str | Path, *, title: str | None = None) -> None:
    """Time per stage against |D| on log-log axes, with the fitted growth exponent of the
    total (rows of :func:`vggc_cp.experiments.scale.record_rows`, square images only), and
    the peak memory against |D|. CPU seconds when every row has them (a shared machine's
    wall time says more about the other jobs), else wall seconds."""
    from vggc_cp.experiments.scale import growth_exponent

    plt = _pyplot()
    rows = [r for r in rows if r["height"] == r["width"]]
    sizes = sorted({r["transitions"] for r in rows})
    stages = list(dict.fromkeys(r["stage"] for r in rows))
    key = "cpu_seconds" if all(np.isfinite(r["cpu_seconds"]) for r in rows) else "seconds"
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.9), constrained_layout=True)
    total = [sum(r[key] for r in rows if r["transitions"] == n) for n in sizes]
    for i, stage in enumerate(stages):
        secs = [sum(r[key] for r in rows if r["transitions"] == n and r["stage"] == stage)
                for n in sizes]
        axes[0].plot(sizes, secs, "-o", label=stage, color=f"C{i}", alpha=0.85)
    k = growth_exponent(sizes, total)
    axes[0].plot(sizes, total, "-s", color="k", label=f"total (~|D|^{k:.2f})")
    peak = [max(r["peak_bytes"] for r in rows if r["transitions"] == n) / 2 ** 30 for n in sizes]
    axes[1].plot(sizes, peak, "-o", color="C3")
    for ax, label in ((axes[0], "CPU seconds" if key == "cpu_seconds" else "wall seconds"),
                      (axes[1], "peak resident memory (GiB)")):
        ax.set_xscale("log")
        ax.set_xlabel("|D| (transitions)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both")
    axes[0].set_yscale("log")
    axes[0].legend(fontsize=7)
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_calibration(table: list[dict], rows: list[dict], path: str | Path, *,
                     title: str | None = None) -> None:
    """Left: per split and look, passed runs warned (false alarms, share of passing) and
    missed runs not warned (silent failures, share of missed), old verdict against new
    (:func:`vggc_cp.experiments.calibration.calibration_rows`). Middle: every run's chance of
    change against whether it passed (jittered), with the bar of the warning. Right: false
    alarms (share of passing) and silent failures per split with the description-length
    margin check at other bars (:func:`vggc_cp.experiments.calibration.margin_tradeoff_rows`),
    the current bar dashed; left empty when the rows record no warning reasons."""
    from vggc_cp.experiments.calibration import margin_tradeoff_rows
    from vggc_cp.experiments.robustness import passes
    from vggc_cp.solvers.confidence import FIXED_CHECKS, WarningRule

    plt = _pyplot()
    groups = list(dict.fromkeys((c["split"], c["look"]) for c in table))
    fig, (ax, bx, cx) = plt.subplots(1, 3, figsize=(7 + 0.9 * len(groups), 3.8),
                                     constrained_layout=True,
                                     gridspec_kw={"width_ratios": [max(len(groups), 2), 3, 3]})
    x = np.arange(len(groups))
    w = 0.2
    styles = (("old", "false_alarms", "passed", -1.5, "#d98c8c", "old: false alarms"),
              ("new", "false_alarms", "passed", -0.5, "#b22222", "new: false alarms"),
              ("old", "silent", "missed", 0.5, "#8ca6d9", "old: silent failures"),
              ("new", "silent", "missed", 1.5, "#1f3f99", "new: silent failures"))
    top = 0.0
    for which, key, base, off, colour, label in styles:
        vals, texts = [], []
        for g in groups:
            c = next(c for c in table if (c["split"], c["look"]) == g and c["verdict"] == which)
            vals.append(100 * c[key] / c[base] if c[base] else 0.0)
            texts.append(f"{c[key]}/{c[base]}")
        bars = ax.bar(x + off * w, vals, w, color=colour, label=label)
        ax.bar_label(bars, texts, fontsize=5, rotation=90, padding=1)
        top = max(top, *vals)
    ax.axhline(5, color="grey", ls="--", lw=1)
    ax.set_xticks(x, [f"{s}\n{lk}" for s, lk in groups], fontsize=7)
    ax.set_ylabel("% of passing (false alarms) / of missed (silent)")
    ax.set_ylim(0, max(30.0, top * 1.3))
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("warning against the pass rule", fontsize=9)
    rng = np.random.default_rng(0)
    looks = list(dict.fromkeys(r["look"] for r in rows))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j, look in enumerate(looks):
        for warned, marker in ((False, "o"), (True, "X")):
            pts = [(float(r["p_change"]), 1.0 if passes(r) else 0.0) for r in rows
                   if r["look"] == look and _is_number(r.get("p_change"))
                   and bool(r.get("suspect")) == warned]
            if not pts:
                continue
            p, y = np.array(pts).T
            bx.scatter(p, y + rng.uniform(-0.15, 0.15, len(y)), s=26 if warned else 16,
                       alpha=0.75, marker=marker, color=colours[j % len(colours)],
                       label=f"{look}{' (warned)' if warned else ''}")
    bx.axvline(WarningRule().max_change, color="grey", ls="--", lw=1)
    bx.set_yticks([0, 1], ["missed", "passed"])
    bx.set_xlabel("chance of change (re-runs changing the graph)", fontsize=8)
    bx.set_xlim(-0.03, 1.03)
    if bx.get_legend_handles_labels()[0]:
        bx.legend(fontsize=7, loc="center right")
    bx.set_title("chance of change per run", fontsize=9)
    # the other reasons are read from the rows: without them the curve would be made up
    trade = margin_tradeoff_rows(rows) if any(r.get("reasons") is not None for r in rows) else []
    if not trade:
        cx.text(0.5, 0.5, "no warning reasons recorded", ha="center", va="center",
                transform=cx.transAxes, fontsize=8)
    sx = cx.twinx()
    for j, split in enumerate(dict.fromkeys(t["split"] for t in trade)):
        ts = [t for t in trade if t["split"] == split]
        bars = [t["bar"] for t in ts]
        colour = colours[j % len(colours)]
        cx.plot(bars, [100 * t["false_alarms"] / t["passed"] if t["passed"] else 0.0
                       for t in ts], "o-", color=colour, label=f"{split}: false alarms")
        sx.plot(bars, [t["silent"] for t in ts], "s:", color=colour,
                label=f"{split}: silent failures")
    cx.axhline(5, color="grey", ls="--", lw=1)
    cx.axvline(FIXED_CHECKS["min_margin_nats"], color="grey", ls="--", lw=1)
    cx.set_xlabel("bar of the margin check (nats)", fontsize=8)
    cx.set_ylabel("false alarms, % of passing", fontsize=8)
    sx.set_ylabel("silent failures (runs)", fontsize=8)
    handles = cx.get_legend_handles_labels()[0] + sx.get_legend_handles_labels()[0]
    if handles:
        cx.legend(handles, [h.get_label() for h in handles], fontsize=6, loc="upper left")
    cx.set_title("moving the margin's bar", fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10)
    _save(fig, path)
