"""The ``keypoints`` backend: one unit of mass per coloured blob, blind to which kind of one
colour stands where, and a bare-table background."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.trace import Trace
from vggc_cp.vision import DistanceConfig, compute_distances_full
from vggc_cp.vision.attention import (
    AttentionConfig,
    attention_maps,
    background,
    background_bare,
    keypoint_raw,
)

TABLE = (70, 70, 80)  # a dark, nearly grey table
RED = (210, 30, 30)
YELLOW = (220, 200, 30)
GREY = (150, 150, 150)
SIZE = 64
# four regions along a row (centres in pixels)
REGION_X = (8, 24, 40, 56)


def scene(objects, rng=None, jitter=0):
    """``objects``: per region None or ``(colour, radius)``; a disc of that colour and radius
    at the region's centre (moved by up to ``jitter`` pixels)."""
    img = np.empty((SIZE, SIZE, 3), dtype=np.uint8)
    img[:] = TABLE
    img[4:10, 28:36] = GREY  # a grey gripper, always there
    yy, xx = np.mgrid[:SIZE, :SIZE]
    for cx, obj in zip(REGION_X, objects):
        if obj is None:
            continue
        colour, radius = obj
        dx, dy = (rng.integers(-jitter, jitter + 1, 2) if rng is not None and jitter else (0, 0))
        img[(yy - 40 - dy) ** 2 + (xx - cx - dx) ** 2 <= radius ** 2] = colour
    if rng is not None:
        img = np.clip(img.astype(int) + rng.integers(-2, 3, img.shape), 0, 255).astype(np.uint8)
    return img


def test_each_blob_is_one_unit_at_its_centroid():
    w = np.zeros((2, 64, 64))
    w[0, 4:8, 4:8] = 1.0          # a 4x4 blob, centroid (5.5, 5.5)
    w[0, 20:30, 10:20] = 5.0      # a large, heavy blob, centroid (24.5, 14.5)
    w[1, 0, 0:2] = 1.0            # a two-pixel speck: below the smallest area (3 of 4096)
    out = keypoint_raw(w, grid=16)
    assert out[0].sum() == pytest.approx(2.0, abs=1e-6)  # one unit each, whatever its size
    assert out[1].sum() == 0.0
    yy, xx = np.mgrid[:64, :64]
    top = out[0] * (yy < 16)
    assert (top * yy).sum() / top.sum() == pytest.approx(5.5, abs=0.05)
    assert (top * xx).sum() / top.sum() == pytest.approx(5.5, abs=0.05)
    bottom = out[0] * (yy >= 16)
    assert bottom.sum() == pytest.approx(1.0, abs=1e-6)
    assert (bottom * yy).sum() / bottom.sum() == pytest.approx(24.5, abs=0.05)


def test_two_kinds_of_one_colour_swapping_places_leave_the_map_unchanged():
    # a small and a large red object (a strawberry and an apple) swap regions
    a = scene([(RED, 3), (RED, 6), None, (YELLOW, 4)])
    b = scene([(RED, 6), (RED, 3), None, (YELLOW, 4)])
    moved = scene([(RED, 6), None, (RED, 3), (YELLOW, 4)])
    empty = scene([None, None, None, None])
    images = np.stack([a, b, moved, empty] * 3)
    kp = attention_maps(images, "keypoints", AttentionConfig(grid=16))
    sal = attention_maps(images, "saliency", AttentionConfig(grid=16))
    assert np.allclose(kp.sum(axis=1), 1) and (kp > 0).all()
    # keypoints: the swap moves nothing; the saliency map weighs the large object more
    assert np.abs(kp[0] - kp[1]).sum() < 0.02
    assert np.abs(sal[0] - sal[1]).sum() > 0.2
    # moving an object to another region changes the keypoint map
    assert np.abs(kp[0] - kp[2]).sum() > 0.3
    # the grey gripper carries no mass: the empty scene's map is the uniform floor
    assert np.allclose(kp[3], 1 / 256)


def test_bare_background_shows_the_table_where_an_object_stands_most_of_the_time():
    rng = np.random.default_rng(0)
    # region 0 holds a red object in 8 of 10 frames (a home position)
    frames = [scene([(RED, 5) if i < 8 else None, None, None, None], rng=rng) for i in range(10)]
    images = np.stack(frames)
    median = background(images)
    bare = background_bare(images)
    centre = (40, REGION_X[0])
    assert median[centre][0] > 0.6   # the median keeps the object
    assert abs(bare[centre][0] - TABLE[0] / 255) < 0.03  # the bare table
    # so the frame without the object has no blob at region 0 under keypoints
    kp = attention_maps(images, "keypoints", AttentionConfig(grid=16))
    assert np.allclose(kp[9], 1 / 256)
    assert kp[0].max() > 0.05


def trace_of(images):
    n = len(images)
    actions = np.array([0 if t % 2 == 0 else 1 for t in range(n - 1)], dtype=np.int64)
    return Trace(np.stack(images), actions, ("pick_x", "place_x"))


def test_keypoint_distances_rank_a_swap_below_a_move(tmp_path):
    rng = np.random.default_rng(2)
    home = [(RED, 3), (RED, 6), None, (YELLOW, 4)]
    swap = [(RED, 6), (RED, 3), None, (YELLOW, 4)]
    move = [(RED, 3), None, (RED, 6), (YELLOW, 4)]
    images = []
    for objs in (home, swap, move, home):
        images += [scene(objs, rng=rng, jitter=1), scene([None] * 4, rng=rng)]
    trace = trace_of(images[:-1])
    cfg = DistanceConfig(backend="keypoints", grid=16)
    res = compute_distances_full(trace, cfg, cache_dir=tmp_path, progress=False)
    d = res.dist_pick  # pick observations 0, 2, 4, 6: home, swap, move, home
    assert d.shape == (4, 4)
    assert d[0, 1] < 0.25 * d[0, 2]   # the swap
    assert d[0, 3] < 0.5 * d[0, 2]    # the same scene with a pixel of jitter
    # two colours: the distance is the sum over the keypoint colour channels alone
    assert res.stats["colour_bins"] == [0, 1] and "colour_1" in res.stats
    assert "pick" not in res.stats
    # the saliency threshold shapes keypoint maps: it is part of the cache key
    assert "noise_k" in cfg.key() and cfg.key()["backend"] == "keypoints"
    again = compute_distances_full(trace, cfg, cache_dir=tmp_path, progress=False)
    assert again.cached and np.array_equal(again.dist_pick, d)
