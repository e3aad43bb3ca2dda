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
