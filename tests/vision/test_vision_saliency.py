"""The ``saliency`` attention backend: foreground maps robust to gain, tint and noise."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.vision import AttentionConfig, attention_maps, cost_matrix
from vggc_cp.vision.attention import finish_maps, pool_to_grid
from vggc_cp.vision.sinkhorn import sinkhorn_divergence_matrix

EPS = 0.05


def gain(img: np.ndarray, factors, rng, noise: float = 3.0) -> np.ndarray:
    out = img.astype(np.float64) * np.asarray(factors)[None, None, :]
    out += rng.normal(0.0, noise, img.shape)
    return np.clip(np.round(out), 0, 255).astype(np.uint8)


def divergences(maps: np.ndarray, grid: int) -> np.ndarray:
    S, _ = sinkhorn_divergence_matrix(maps, cost_matrix(grid), EPS, threads=1)
    return S


def test_maps_are_histograms_with_a_floor():
    rng = np.random.default_rng(0)
    imgs = rng.integers(0, 256, (6, 33, 47, 3), dtype=np.uint8)
    maps = attention_maps(imgs, "saliency", AttentionConfig(grid=5, floor=0.02))
    assert maps.shape == (6, 25)
    np.testing.assert_allclose(maps.sum(1), 1.0)
    assert maps.min() >= 0.02 / 25 * (1 - 1e-9)
    flat = finish_maps(np.zeros((1, 4)), 0.1)
    np.testing.assert_allclose(flat, 0.25)  # nothing salient: uniform, never empty
    x = np.arange(2 * 6 * 6, dtype=float).reshape(2, 6, 6)
    np.testing.assert_allclose(pool_to_grid(x, 3)[0, 0], x[0, :2, :2].mean())


def synthetic_scene(rng, size=64):
    """Textured table, and a trace where a red and a green object visit four spots."""
    table = np.clip(rng.normal(150, 6, (size, size, 3)) * [1.0, 0.9, 0.8], 0, 255)
    spots = [(8, 8), (8, 40), (40, 8), (40, 40)]

    def render(red, green):
        img = table.copy()
        r, c = spots[red]
        img[r:r + 14, c:c + 14] = (200, 50, 40)
        r, c = spots[green]
        img[r + 3:r + 11, c + 3:c + 11] = (60, 160, 60)
        return np.clip(img + rng.normal(0, 2, img.shape), 0, 255).astype(np.uint8)

    trace = np.stack([render(a, b) for a in range(4) for b in range(4) if a != b] * 2)
    return trace, render


def test_gain_tint_and_noise_do_not_move_the_map_synthetic():
    rng = np.random.default_rng(1)
    trace, render = synthetic_scene(rng)
    base = render(0, 1)
    views = [base, gain(base, [1.15] * 3, rng), gain(base, [0.85] * 3, rng),
             gain(base, [1.15, 1.0, 0.87], rng), render(3, 1)]
    maps = attention_maps(np.concatenate([trace, np.stack(views)]), "saliency",
                          AttentionConfig(grid=16))[-len(views):]
    # a global gain change does not spread mass over the table
    for m in maps[1:4]:
        assert np.abs(m - maps[0]).sum() < 0.15
    S = divergences(maps, 16)
    moved = S[0, 4]
    assert moved > 0
    assert max(S[0, 1], S[0, 2], S[0, 3]) < 0.05 * moved


def test_gain_change_without_normalisation_would_spread_mass():
    """Sanity check of the test above: the raw image difference does see the gain change."""
    rng = np.random.default_rng(2)
    _, render = synthetic_scene(rng)
    base = render(0, 1)
    brighter = gain(base, [1.15] * 3, rng)
    assert np.abs(brighter.astype(int) - base.astype(int)).mean() > 10


def real_scene():
    """A fruit-2x3 trace rendered by the simulator, and renders of one arrangement."""
    from vggc_cp.sim import get_benchmark
    from vggc_cp.sim.arrange import Arrangement, fresh_arrangement
    from vggc_cp.sim.explore import generate
    from vggc_cp.sim.render import Scene

    gen = generate("fruit-2x3", n_transitions=40, seed=0, size=64)
    bench = get_benchmark("fruit-2x3")
    arr = fresh_arrangement(bench, "rr-|-", np.random.default_rng(0))
    occupied = [r for r, s in enumerate(arr.stacks) if s]
    empty = [r for r, s in enumerate(arr.stacks) if not s][0]
    src = min(occupied, key=lambda r: abs(r - empty))  # the object next to the free region
    stacks = list(arr.stacks)
    stacks[empty], stacks[src] = stacks[src], ()
    moved = Arrangement(tuple(stacks), arr.held, arr.offsets)
    with Scene(bench, 64) as scene:
        return gen.trace.observations, scene.render(arr), scene.render(moved)


def test_rendered_scene_gain_and_noise_stay_far_closer_than_a_moved_object():
    pytest.importorskip("pybullet")
    rng = np.random.default_rng(3)
    trace, img, moved = real_scene()
    views = [img, gain(img, [1.15] * 3, rng), gain(img, [0.85] * 3, rng),
             gain(img, [1.15, 1.0, 0.87], rng), gain(img, [1.0] * 3, rng, noise=6.0), moved]
    maps = attention_maps(np.concatenate([trace, np.stack(views)]), "saliency",
                          AttentionConfig(grid=16))[-len(views):]
    S = divergences(maps, 16)
    far = S[0, 5]
    near = S[0, 1:5]
    assert far > 0.01
    assert near.max() < 0.02 * far, (near, far)
