"""Contact sheets: a trace's observations in a grid, each with its index and action label."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vggc_cp.atomic import atomic_path
from vggc_cp.errors import VggcError
from vggc_cp.trace import Trace


def tile_labels(trace: Trace, count: int, show_states: bool = True) -> list[str]:
    """Label of each of the first ``count`` observations: ``"i: action"`` (the action taken
    after it; ``new episode`` before a break, ``end`` for the last), and its state key."""
    n = trace.n_obs
    out = []
    for i in range(count):
        if i == n - 1:
            act = "end"
        elif trace.actions[i] < 0:
            act = "| new episode"
        else:
            act = f"-> {trace.action_names[int(trace.actions[i])]}"
        label = f"{i} {act}"
        if show_states and trace.states is not None:
            label += f"\n{trace.states[i]}"
        out.append(label)
    return out


def contact_sheet(trace: Trace, path: str | Path, max_images: int = 48, columns: int = 8,
                  show_states: bool = True) -> int:
    """Draw the first ``max_images`` observations of ``trace`` to an image file (PNG, ...).

    Returns
    -------
    int
        Number of observations drawn.
    """
    if max_images < 1:
        raise VggcError(f"--max must be at least 1, got {max_images}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    count = min(max_images, trace.n_obs)
    cols = min(columns, count)
    rows = int(np.ceil(count / cols))
    labels = tile_labels(trace, count, show_states)
    fig, axes = plt.subplots(rows, cols, figsize=(1.9 * cols, 2.2 * rows), squeeze=False)
    for k, ax in enumerate(axes.flat):
        ax.axis("off")
        if k < count:
            ax.imshow(trace.observations[k], interpolation="nearest")
            ax.set_title(labels[k], fontsize=7)
    title = trace.meta.get("benchmark", "") if trace.meta else ""
    fig.suptitle(f"{title}  ({count} of {trace.n_obs} observations)".strip(), fontsize=10)
    fig.tight_layout()
    target = Path(path)
    try:
        with atomic_path(target) as tmp:
            fig.savefig(tmp, dpi=80, format=target.suffix.lstrip(".") or "png")
    except ValueError as exc:
        raise VggcError(f"{target}: cannot write an image ({exc})") from None
    finally:
        plt.close(fig)
    return count


def pair_sheet(trace: Trace, rows: list[tuple[list[int], list[int], str]], path: str | Path,
               outlines: list | None = None) -> int:
    """One row per ``(left observations, right observations, title)``: the left ones, a gap,
    the right ones, each tile titled with its observation index, the row with ``title``
    (a sheet a person judges at a glance: are the two sides one situation?).

    ``outlines`` (one per row, or None) is a map of shape (h, w) at any resolution, or None:
    its half-maximum contour is drawn over every tile of the row, stretched to the image
    (where a doubt's evidence lies, e.g. the sites only a reading sets apart).

    Returns
    -------
    int
        Number of rows drawn.
    """
    if not rows:
        raise VggcError("nothing to draw")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    width = max(len(a) for a, _, _ in rows) + 1 + max(len(b) for _, b, _ in rows)
    left = max(len(a) for a, _, _ in rows)
    fig, axes = plt.subplots(len(rows), width, figsize=(max(1.6 * width, 7.0), 2.1 * len(rows)),
                             squeeze=False)
    for r, (a, b, title) in enumerate(rows):
        for ax in axes[r]:
            ax.axis("off")
        outline = None if outlines is None else outlines[r]
        tiles = [(c, o) for c, o in enumerate(a)] + [(left + 1 + c, o) for c, o in enumerate(b)]
        for c, o in tiles:
            img = trace.observations[o]
            axes[r][c].imshow(img, interpolation="nearest")
            axes[r][c].set_title(f"{o}", fontsize=7)
            if outline is not None and np.max(outline) > 0:
                h, w = img.shape[:2]
                axes[r][c].contour(outline, levels=[0.5 * float(np.max(outline))],
                                   colors="yellow", linewidths=0.8,
                                   extent=(-0.5, w - 0.5, h - 0.5, -0.5), origin="upper")
        axes[r][0].text(0.0, 1.25, title, transform=axes[r][0].transAxes, fontsize=7,
                        ha="left", va="bottom")
    fig.subplots_adjust(left=0.02, right=0.98, bottom=0.02, top=1 - 0.45 / (2.1 * len(rows)),
                        wspace=0.1, hspace=0.8)
    target = Path(path)
    try:
        with atomic_path(target) as tmp:
            fig.savefig(tmp, dpi=80, format=target.suffix.lstrip(".") or "png")
    except ValueError as exc:
        raise VggcError(f"{target}: cannot write an image ({exc})") from None
    finally:
        plt.close(fig)
    return len(rows)
