"""Colour channels: scenes that differ only by which coloured object stands where."""

from __future__ import annotations

import numpy as np

from vggc_cp.trace import Trace
from vggc_cp.vision import DistanceConfig, compute_distances
from vggc_cp.vision.attention import AttentionConfig, colour_channel_maps

RED = (200, 30, 30)
YELLOW = (220, 200, 30)
TABLE = (120, 90, 60)


def scene(left, right, size=48, rng=None):
    img = np.empty((size, size, 3), dtype=np.uint8)
    img[:] = TABLE
    yy, xx = np.mgrid[:size, :size]
    for colour, cx in ((left, size // 4), (right, 3 * size // 4)):
        if colour is not None:
            img[(yy - size // 2) ** 2 + (xx - cx) ** 2 <= 25] = colour
    if rng is not None:
        img = np.clip(img + rng.integers(-3, 4, img.shape), 0, 255).astype(np.uint8)
    return img


def trace_of(images):
    # alternate pick/place so that every image is a pick observation after each place
    n = len(images)
    actions = np.array([0 if t % 2 == 0 else 1 for t in range(n - 1)], dtype=np.int64)
    return Trace(np.stack(images), actions, ("pick_x", "place_x"))


def test_two_colours_make_channels_and_one_colour_none():
    rng = np.random.default_rng(0)
    two = np.stack([scene(RED, YELLOW, rng=rng), scene(YELLOW, RED, rng=rng),
                    scene(None, None, rng=rng)] * 3)
    maps, kept = colour_channel_maps(two, AttentionConfig(grid=8))
    assert kept == [0, 1] and maps.shape == (9, 2, 64)
    assert np.allclose(maps.sum(axis=2), 1) and (maps > 0).all()
    one = np.stack([scene(RED, None, rng=rng), scene(None, RED, rng=rng),
                    scene(None, None, rng=rng)] * 3)
    maps, kept = colour_channel_maps(one, AttentionConfig(grid=8))
    assert kept == [] and maps.shape == (9, 0, 64)


def test_swapped_colours_are_far_only_with_colour(tmp_path):
    rng = np.random.default_rng(1)
    # pick observations (even indices): red|yellow, yellow|red, red|yellow again
    images = []
    for left, right in ((RED, YELLOW), (YELLOW, RED), (RED, YELLOW)):
        images += [scene(left, right, rng=rng), scene(None, None, rng=rng)]
    trace = trace_of(images[:-1])
    assert trace.roles()[[0, 2, 4]].tolist() == [0, 0, 0]
    off = compute_distances(trace, DistanceConfig(grid=8, colour="off"), cache_dir=tmp_path,
                            progress=False)[0]
    auto = compute_distances(trace, DistanceConfig(grid=8), cache_dir=tmp_path,
                             progress=False)[0]
    # the colour channels add a large divergence to the swap and little to the repeat
    assert auto[0, 1] - off[0, 1] > 1.0 * off[0, 1]
    assert auto[0, 2] - off[0, 2] < 0.1 * (auto[0, 1] - off[0, 1])
    assert auto[0, 1] > 20 * auto[0, 2]
    assert len(list(tmp_path.glob("*.npz"))) == 2  # separate cache entries
