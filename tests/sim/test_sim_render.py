"""PyBullet rendering: shape, noise, visible objects, regions at distinct pixels."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.sim import benchmark_names, get_benchmark
from vggc_cp.sim.arrange import Arrangement, fresh_arrangement
from vggc_cp.sim.render import Scene, scene_layout


@pytest.fixture(scope="module")
def fruit_scene():
    with Scene(get_benchmark("fruit-2x3"), 64) as scene:
        yield scene


def red_mask(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return (r > 120) & (g < 70) & (b < 70)


def test_render_shape_and_dtype(fruit_scene):
    b = fruit_scene.bench
    img = fruit_scene.render(fresh_arrangement(b, "rr-|-", np.random.default_rng(0)))
    assert img.shape == (64, 64, 3) and img.dtype == np.uint8
    assert img.std() > 10  # not a blank frame


def test_noise_makes_two_renders_of_one_state_differ(fruit_scene):
    b = fruit_scene.bench
    rng = np.random.default_rng(0)
    a = fruit_scene.render(fresh_arrangement(b, "r-r|-", rng))
    c = fruit_scene.render(fresh_arrangement(b, "r-r|-", rng))
    assert not np.array_equal(a, c)
    # but the same arrangement renders the same pixels
    arr = fresh_arrangement(b, "r-r|-", np.random.default_rng(5))
    assert np.array_equal(fruit_scene.render(arr), fruit_scene.render(arr))


def test_regions_give_distinct_pixel_positions(fruit_scene):
    centroids = []
    for r in range(3):
        stacks = tuple((0,) if k == r else () for k in range(3))
        # fruit 1 held so exactly one fruit lies on the table
        arr = Arrangement(stacks, 1, ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
        mask = red_mask(fruit_scene.render(arr))
        held_row = mask[:28]  # the gripper sits in the upper part of the image
        table = mask.copy()
        table[:28] = False
        assert table.sum() >= 6, "the fruit on the table is visible"
        assert held_row.sum() >= 6, "the held fruit is visible"
        ys, xs = np.nonzero(table)
        centroids.append(xs.mean())
    assert centroids[0] + 8 < centroids[1] < centroids[2] - 8


def test_held_object_changes_the_image(fruit_scene):
    rng = np.random.default_rng(1)
    b = fruit_scene.bench
    held = fruit_scene.render(fresh_arrangement(b, "--r|r", rng))
    free = fruit_scene.render(fresh_arrangement(b, "r-r|-", rng))
    assert red_mask(held)[:28].sum() > red_mask(free)[:28].sum() + 5


@pytest.mark.parametrize("name", benchmark_names())
def test_every_benchmark_renders_and_regions_fit(name):
    b = get_benchmark(name)
    lay = scene_layout(b)
    assert lay.centres.shape == (b.spec.R, 2)
    assert len({tuple(c) for c in lay.centres.round(6)}) == b.spec.R
    rng = np.random.default_rng(0)
    with Scene(b, 32) as scene:
        imgs = [scene.render(fresh_arrangement(b, s, rng)) for s in b.all_states()[:4]]
    assert all(i.shape == (32, 32, 3) for i in imgs)
    assert len({i.tobytes() for i in imgs}) == len(imgs)


def test_blocks_stack_settles_in_place():
    b = get_benchmark("blocks-3")
    with Scene(b, 32) as scene:
        arr = fresh_arrangement(b, "300|-", np.random.default_rng(0))
        scene.pose(arr)
        p = scene._p
        zs = sorted(p.getBasePositionAndOrientation(body, physicsClientId=scene._cid)[0][2]
                    for body in scene._bodies)
    assert np.allclose(zs, [0.025, 0.075, 0.125], atol=0.004)
