"""Attention maps ``M(o)``: one histogram on a ``g x g`` patch grid per observation.

Every backend maps uint8 images ``(N, H, W, 3)`` to float64 maps ``(N, g*g)`` (row-major
patches, the order of :func:`vggc_cp.vision.sinkhorn.patch_centres`), non-negative, each
summing to 1, strictly positive thanks to a floor: ``M = (1 - floor) A / sum(A) + floor / g^2``
(a uniform map when ``A`` is all zero), so no map is empty and every Sinkhorn problem is
well posed.

Backends (registry :data:`ATTENTION_BACKENDS`, ``--attention NAME``):

``saliency`` (default, no weights)
    Object-agnostic foreground: how much each patch differs from the trace's background.

    1. Background ``B``: the per-pixel median over the trace's images (at most
       ``MAX_BACKGROUND_IMAGES`` of them, evenly spaced). Objects that move are a minority at
       every pixel, so the median shows the empty table (where an object rests in more than
       half of the images, the map shows the hole it leaves when gone instead).
    2. Gain: per image and channel ``c``, the robust gain ``g_c = median(I_c / B_c)`` over
       pixels that are lit and clipped in neither image; the background as this camera would
       see it is ``P = min(g B, 1)`` (clipped like the sensor). This undoes a global
       brightness or tint change (camera gain, white balance), saturated pixels included.
    3. Deviation per pixel: intensity ``|I - P| / g`` averaged over channels, plus chromatic
       ``||chroma(I) - chroma(P)||_1 * mean(B)`` with ``chroma(x) = x / sum_c x_c``, so an
       object that matches the table's brightness but not its hue still stands out.
    4. Noise: the deviation is soft-thresholded at ``k sigma`` with ``sigma`` the image's robust
       noise level (``1.4826 * MAD`` of the deviation, most pixels being background), and at
       least ``min_contrast``; sensor noise and residual gain errors fall below it.
    5. Patch pooling (mean over each patch's pixels), then the floor.

Colour channels (:func:`colour_channel_maps`, ``--colour auto``)
    The saliency map is blind to colour: swapping a red and a yellow fruit leaves it unchanged.
    Each salient pixel's foreground strength, times its saturation, is split over
    :data:`COLOUR_BINS` hue bins centred on red, yellow, green, cyan, blue and magenta; every
    bin holding at least ``min_share`` of the trace's chromatic foreground mass becomes a
    channel map (pooled, floored like the others). Channels are kept only when at least two
    bins qualify: with one object colour a channel repeats the saliency map. Grey parts (the
    gripper) have no saturation and drop out.

``keypoints`` (no weights)
    Object-centric and instance-invariant: every blob of the chromatic foreground (saliency
    against the bare table of :func:`background_bare`, times saturation where it is at least
    :data:`KEYPOINT_MIN_SATURATION`; 8-connected, at least :data:`KEYPOINT_MIN_AREA` of the
    image) becomes one unit of mass at its weighted centroid (split bilinearly over the four
    nearest pixels, then blurred by a Gaussian of :data:`KEYPOINT_SIGMA` patches), so a small
    and a large object weigh the same and two kinds of one colour (strawberry and apple) that
    swap places leave the map unchanged. A placement jitter moves a keypoint a little; moving
    an object to another region moves a quarter (with four objects) of the mass far. With
    ``--colour auto`` the colour channels are keypoint maps of each hue bin, and with two or
    more of them the distance uses the channels alone (:mod:`.distances`). Grey parts (the
    gripper) carry no weight, but an object held in the gripper is a blob of its own.
    Meant for scenes of separate coloured objects (the fruit benchmarks); a stack of blocks
    is one blob whose centroid only rises with its height.

``dinov2``
    The last-layer CLS-to-patch attention of a DINOv2 ViT (:mod:`vggc_cp.vision.dinov2`),
    averaged over heads, the image resized to ``14 g`` pixels; weights from ``--weights`` or
    ``$VGGC_CP_DINOV2_WEIGHTS``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import lookup

#: Images used for the per-pixel median background.
MAX_BACKGROUND_IMAGES = 256

#: Channel value (in [0, 1]) from which a pixel counts as clipped by the sensor.
SATURATED = 0.98


@dataclass(frozen=True)
class AttentionConfig:
    """Parameters of the attention backends (part of the distance cache key).

    Attributes
    ----------
    grid : int
        Patches per side ``g``.
    floor : float
        Mass spread uniformly over all patches, in ``(0, 1)``.
    noise_k : float
        Saliency: soft threshold in multiples of the robust noise level.
    min_contrast : float
        Saliency: smallest deviation (intensity units in [0, 1]) that counts as foreground.
    weights : str or None
        DINOv2: weights file.
    batch_size : int
        DINOv2: images per forward pass (does not change the maps).
    """

    grid: int = 16
    floor: float = 0.01
    noise_k: float = 3.0
    min_contrast: float = 0.04
    weights: str | None = None
    batch_size: int = 32


def finish_maps(raw: np.ndarray, floor: float) -> np.ndarray:
    """Normalise non-negative ``raw`` ``(N, n)`` maps and add the floor; rows sum to 1."""
    raw = np.clip(np.asarray(raw, dtype=np.float64), 0.0, None)
    n = raw.shape[1]
    total = raw.sum(axis=1, keepdims=True)
    safe = np.where(total > 0, total, 1.0)
    shape = np.where(total > 0, raw / safe, 1.0 / n)
    out = (1.0 - floor) * shape + floor / n
    return out / out.sum(axis=1, keepdims=True)


def pool_to_grid(x: np.ndarray, grid: int) -> np.ndarray:
    """Mean of ``x`` ``(N, H, W)`` over a ``grid x grid`` partition of the pixels -> ``(N, g*g)``.

    Patch ``(r, c)`` covers rows ``[floor(r H / g), floor((r+1) H / g))`` (likewise columns);
    works for any ``H, W >= g``.
    """
    n, h, w = x.shape
    if h < grid or w < grid:
        raise ValueError(f"images of {h}x{w} pixels are smaller than the {grid}x{grid} grid")
    rb = (np.arange(h) * grid) // h
    cb = (np.arange(w) * grid) // w
    rows = np.zeros((n, grid, w))
    for r in range(grid):
        rows[:, r] = x[:, rb == r].mean(axis=1)
    out = np.empty((n, grid, grid))
    for c in range(grid):
        out[:, :, c] = rows[:, :, cb == c].mean(axis=2)
    return out.reshape(n, grid * grid)


def background(images: np.ndarray) -> np.ndarray:
    """Per-pixel median of (at most :data:`MAX_BACKGROUND_IMAGES`) images, float ``(H, W, 3)``."""
    n = len(images)
    idx = np.unique(np.linspace(0, n - 1, min(n, MAX_BACKGROUND_IMAGES)).round().astype(int))
    return np.median(images[idx].astype(np.float32), axis=0) / 255.0


#: ``keypoints`` background: per pixel, the colour of the frame at this quantile of the
#: pixel's saturation over the trace (a low one: the bare table, even where an object rests
#: most of the time).
KEYPOINT_BACKGROUND_QUANTILE = 0.05


def background_bare(images: np.ndarray) -> np.ndarray:
    """Per pixel, the colour of a frame where that pixel is least chromatic, ``(H, W, 3)``.

    Of (at most :data:`MAX_BACKGROUND_IMAGES`) frames, the one at
    :data:`KEYPOINT_BACKGROUND_QUANTILE` of the pixel's HSV saturation. Coloured objects are
    saturated and the table is not, so a region where an object stands in most frames (a home
    position) shows the bare table here, where the median shows the object and its absence
    would become a blob of its own.
    """
    n = len(images)
    idx = np.unique(np.linspace(0, n - 1, min(n, MAX_BACKGROUND_IMAGES)).round().astype(int))
    x = images[idx].astype(np.float32) / 255.0
    _, sat = hue_bins(x)
    k = int(np.floor(KEYPOINT_BACKGROUND_QUANTILE * (len(idx) - 1)))
    pick = np.argsort(sat, axis=0, kind="stable")[k]  # (H, W): frame index per pixel
    rows, cols = np.indices(pick.shape)
    return x[pick, rows, cols]


def saliency_raw(images: np.ndarray, bg: np.ndarray, params: AttentionConfig) -> np.ndarray:
    """Per-pixel foreground strength of ``images`` (uint8 ``(N, H, W, 3)``) -> ``(N, H, W)``."""
    x = images.astype(np.float32) / 255.0
    # 2. robust per-channel gain against the background, from pixels that are lit and
    #    saturated in neither image (a clipped pixel hides its gain)
    lit = bg.mean(axis=2) > 0.05
    ok = lit[None] & (x.max(axis=3) < SATURATED) & (bg.max(axis=2) < SATURATED)[None]
    ratio = x / np.maximum(bg, 1e-3)[None]
    gain = np.empty((len(x), 3), dtype=np.float32)
    for i in range(len(x)):
        use = ok[i] if ok[i].sum() >= 0.01 * ok[i].size else lit
        gain[i] = np.median(ratio[i][use], axis=0)
    gain = np.maximum(gain, 1e-3)
    # the background as this camera would see it (clipped like the sensor), in image units
    pred = np.minimum(bg[None] * gain[:, None, None, :], 1.0)
    # 3. intensity and chromatic deviation, in background units
    inten = (np.abs(x - pred) / gain[:, None, None, :]).mean(axis=3)
    pred_sum = pred.sum(axis=3, keepdims=True)
    chroma_pred = pred / np.maximum(pred_sum, 1e-3)
    chroma_x = x / np.maximum(x.sum(axis=3, keepdims=True), 1e-3)
    chrom = np.abs(chroma_x - chroma_pred).sum(axis=3) * bg.mean(axis=2)[None]
    dev = inten + chrom
    # 4. soft threshold relative to the robust noise level
    flat = dev.reshape(len(dev), -1)
    med = np.median(flat, axis=1)
    sigma = 1.4826 * np.median(np.abs(flat - med[:, None]), axis=1)
    thr = np.maximum(med + params.noise_k * sigma, params.min_contrast)
    return np.clip(dev - thr[:, None, None], 0.0, None)


def saliency_maps(images: np.ndarray, params: AttentionConfig,
                  progress: Callable[[int], None] | None = None) -> np.ndarray:
    """The ``saliency`` backend: ``(N, H, W, 3)`` uint8 -> ``(N, g*g)`` maps (module docstring)."""
    bg = background(images)
    out = np.empty((len(images), params.grid * params.grid))
    step = 64
    for s in range(0, len(images), step):
        raw = saliency_raw(images[s:s + step], bg, params)
        out[s:s + step] = finish_maps(pool_to_grid(raw, params.grid), params.floor)
        if progress is not None:
            progress(min(step, len(images) - s))
    return out


def dinov2_maps(images: np.ndarray, params: AttentionConfig,
                progress: Callable[[int], None] | None = None) -> np.ndarray:
    """The ``dinov2`` backend: CLS-to-patch attention of the last block, ``(N, g*g)``."""
    import torch

    from vggc_cp.vision.dinov2 import load_dinov2, preprocess, resolve_weights

    model, arch = load_dinov2(resolve_weights(params.weights))
    size = params.grid * int(arch.get("patch_size", 14))
    out = np.empty((len(images), params.grid * params.grid))
    with torch.inference_mode():
        for s in range(0, len(images), params.batch_size):
            x = preprocess(images[s:s + params.batch_size], size)
            att = model.cls_attention(x).reshape(len(x), -1).double().numpy()
            out[s:s + len(x)] = finish_maps(att, params.floor)
            if progress is not None:
                progress(len(x))
    return out


#: Hue bins of the colour channels (bin 0 centred on red, then every 60 degrees).
COLOUR_BINS = 6


def hue_bins(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hue bin (int, :data:`COLOUR_BINS` bins centred on red) and HSV saturation of float RGB
    pixels ``(..., 3)`` in [0, 1]."""
    mx, mn = x.max(axis=-1), x.min(axis=-1)
    chroma = np.maximum(mx - mn, 1e-6)
    r, g, b = x[..., 0], x[..., 1], x[..., 2]
    hue = np.where(mx == r, ((g - b) / chroma) % 6,
                   np.where(mx == g, (b - r) / chroma + 2, (r - g) / chroma + 4)) / 6
    bins = np.floor(hue * COLOUR_BINS + 0.5).astype(np.int64) % COLOUR_BINS
    sat = np.where(mx > 0, (mx - mn) / np.maximum(mx, 1e-6), 0.0)
    return bins, sat


def colour_channel_maps(images: np.ndarray, params: AttentionConfig, min_share: float = 0.1,
                        progress: Callable[[int], None] | None = None,
                        keypoints: bool = False) -> tuple[np.ndarray, list[int]]:
    """Colour-channel maps of the salient foreground (module docstring).

    Parameters
    ----------
    images : uint8 ndarray, shape (N, H, W, 3)
    params : AttentionConfig
    min_share : float
        Smallest share of the trace's chromatic foreground mass that makes a hue bin a channel.
    keypoints : bool
        Each channel is a keypoint map of its hue bin's blobs (:func:`keypoint_raw`) instead of
        the pooled foreground; which bins are kept is decided on the foreground mass either way.

    Returns
    -------
    maps : float64 ndarray, shape (N, C, g*g)
        One strictly positive map per kept channel, rows summing to 1 (C may be 0).
    bins : list of int
        The hue bins kept.
    """
    images = np.asarray(images)
    bg = background_bare(images) if keypoints else background(images)
    g2 = params.grid * params.grid
    pooled = np.empty((len(images), COLOUR_BINS, g2))
    mass = np.zeros(COLOUR_BINS)  # foreground mass per bin: decides the channels
    step = 64
    for s in range(0, len(images), step):
        chunk = images[s:s + step]
        raw = saliency_raw(chunk, bg, params)
        bins, sat = hue_bins(chunk.astype(np.float32) / 255.0)
        weight = raw * (chromatic(sat) if keypoints else sat)
        for c in range(COLOUR_BINS):
            fg = weight * (bins == c)
            pooled[s:s + step, c] = pool_to_grid(fg, params.grid)
            mass[c] += pooled[s:s + step, c].sum()
            if keypoints:
                pooled[s:s + step, c] = pool_to_grid(keypoint_raw(fg, params.grid), params.grid)
        if progress is not None:
            progress(len(chunk))
    share = mass / max(float(mass.sum()), 1e-12)
    kept = [c for c in range(COLOUR_BINS) if share[c] >= min_share]
    if len(kept) < 2:
        return np.zeros((len(images), 0, g2)), []
    maps = np.stack([finish_maps(pooled[:, c], params.floor) for c in kept], axis=1)
    return maps, kept


#: Smallest blob (share of the image's pixels) that the ``keypoints`` backend keeps: 3 pixels
#: of a 64 x 64 image; smaller specks are rendering noise.
KEYPOINT_MIN_AREA = 3 / 4096

#: Gaussian blur of a keypoint, in patches (a quarter patch: 1 pixel at 64 px and g = 16).
KEYPOINT_SIGMA = 0.25


#: Saturation below which a pixel is grey for the ``keypoints`` backend (the gripper, the
#: table's shading, the sky): it carries no chromatic weight at all.
KEYPOINT_MIN_SATURATION = 0.3


def chromatic(sat: np.ndarray) -> np.ndarray:
    """``keypoints`` chromatic weight of HSV saturations: ``sat`` from
    :data:`KEYPOINT_MIN_SATURATION` on, else 0."""
    return np.where(sat >= KEYPOINT_MIN_SATURATION, sat, 0.0)


def keypoint_raw(weight: np.ndarray, grid: int) -> np.ndarray:
    """Blobs of ``weight`` ``(N, H, W)`` (non-negative) -> unit masses at their centroids.

    Returns
    -------
    ndarray, float64, shape (N, H, W)
        Per image, every 8-connected component of ``weight > 0`` of at least
        :data:`KEYPOINT_MIN_AREA` ``* H * W`` pixels adds mass 1 at its ``weight``-weighted
        centroid (bilinear split), blurred by :data:`KEYPOINT_SIGMA` patches; all zero for an
        image without such a blob.
    """
    from scipy import ndimage

    weight = np.asarray(weight, dtype=np.float64)
    n, h, w = weight.shape
    min_px = max(1, int(round(KEYPOINT_MIN_AREA * h * w)))
    sigma = KEYPOINT_SIGMA * h / grid
    out = np.zeros((n, h, w))
    eight = np.ones((3, 3), dtype=bool)
    for i in range(n):
        labels, count = ndimage.label(weight[i] > 0, structure=eight)
        if count == 0:
            continue
        idx = np.arange(1, count + 1)
        size = ndimage.sum_labels(np.ones((h, w)), labels, idx)
        centres = ndimage.center_of_mass(weight[i], labels, idx)
        for px, (r, c) in zip(size, centres):
            if px < min_px:
                continue
            r0, c0 = int(np.floor(r)), int(np.floor(c))
            fr, fc = r - r0, c - c0
            for dr, wr in ((0, 1.0 - fr), (1, fr)):
                for dc, wc in ((0, 1.0 - fc), (1, fc)):
                    out[i, min(r0 + dr, h - 1), min(c0 + dc, w - 1)] += wr * wc
        if sigma > 0:
            out[i] = ndimage.gaussian_filter(out[i], sigma)
    return out


def keypoint_maps(images: np.ndarray, params: AttentionConfig,
                  progress: Callable[[int], None] | None = None) -> np.ndarray:
    """The ``keypoints`` backend: one unit of mass per chromatic blob, ``(N, g*g)``."""
    bg = background_bare(images)
    out = np.empty((len(images), params.grid * params.grid))
    step = 64
    for s in range(0, len(images), step):
        chunk = images[s:s + step]
        _, sat = hue_bins(chunk.astype(np.float32) / 255.0)
        weight = saliency_raw(chunk, bg, params) * chromatic(sat)
        out[s:s + step] = finish_maps(pool_to_grid(keypoint_raw(weight, params.grid),
                                                   params.grid), params.floor)
        if progress is not None:
            progress(len(chunk))
    return out


AttentionFn = Callable[..., np.ndarray]

#: name -> ``fn(images, params, progress=None) -> (N, g*g)`` maps.
ATTENTION_BACKENDS: dict[str, AttentionFn] = {
    "saliency": saliency_maps,
    "dinov2": dinov2_maps,
    "keypoints": keypoint_maps,
}

#: Backends whose colour channels are keypoint maps too (:func:`colour_channel_maps`).
KEYPOINT_BACKENDS = frozenset({"keypoints"})

#: Backends built on the trace's saliency foreground: their maps need the whole trace (its
#: background) and depend on the saliency threshold.
SALIENCY_BACKENDS = frozenset({"saliency", "keypoints"})

#: Backends whose maps depend on a weights file (hashed into the cache key).
NEEDS_WEIGHTS = frozenset({"dinov2"})


def attention_maps(images: np.ndarray, backend: str = "saliency",
                   params: AttentionConfig | None = None,
                   progress: Callable[[int], None] | None = None) -> np.ndarray:
    """Attention maps of ``images`` (uint8 ``(N, H, W, 3)``) with a registered backend.

    Returns
    -------
    ndarray, float64, shape (N, g*g): strictly positive rows summing to 1.
    """
    fn = lookup(ATTENTION_BACKENDS, backend, "attention backend")
    return fn(np.asarray(images), params or AttentionConfig(), progress)
