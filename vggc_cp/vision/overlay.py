"""The attention picture of ``vggc-cp show-attention``: maps overlaid on their images."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def draw_attention(images: np.ndarray, maps: np.ndarray, titles: list[str],
                   path: str | Path, alpha: float = 0.8) -> None:
    """Save a PNG with one column per image: the image, then the image with its map on top.

    Parameters
    ----------
    images : ndarray, uint8, shape (K, H, W, 3)
    maps : ndarray, shape (K, g*g), rows summing to 1
    titles : list of str, length K
    path : output file (written atomically)
    alpha : opacity of the map layer where the map is largest
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vggc_cp.atomic import atomic_path

    k = len(images)
    g = int(round(np.sqrt(maps.shape[1])))
    h, w = images.shape[1:3]
    fig, axes = plt.subplots(2, k, figsize=(2.4 * k, 5.0), squeeze=False)
    for c in range(k):
        att = maps[c].reshape(g, g)
        axes[0, c].imshow(images[c])
        axes[0, c].set_title(titles[c], fontsize=8)
        axes[1, c].imshow(images[c])
        rgba = plt.get_cmap("inferno")(att / att.max())
        rgba[..., 3] = alpha * att / att.max()  # opacity follows the mass: low mass stays clear
        axes[1, c].imshow(rgba, extent=(-0.5, w - 0.5, h - 0.5, -0.5), interpolation="nearest")
        axes[1, c].set_title(f"max {att.max():.3f}", fontsize=8)
        for r in range(2):
            axes[r, c].set_xticks([])
            axes[r, c].set_yticks([])
    fig.tight_layout()
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
