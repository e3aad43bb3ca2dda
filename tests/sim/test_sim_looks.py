"""Looks: the clean renderer unchanged, the randomized look seeded, varied and visible."""

from __future__ import annotations

import hashlib
import json
from dataclasses import replace

import numpy as np
import pytest
from conftest import generated_twice

from vggc_cp.cli import main
from vggc_cp.errors import VggcError
from vggc_cp.sim import get_benchmark
from vggc_cp.sim.arrange import FRUIT_JITTER, fresh_arrangement
from vggc_cp.sim.explore import generate, look_streams, seed_streams
from vggc_cp.sim.looks import (
    CELL_HALF,
    CLASS_SHAPES,
    FOOTPRINT,
    JITTER_SCALE,
    LOOKS,
    SIZE_SCALE,
    clean_look,
    finish_frame,
    make_look,
    png_bytes,
    sample_look,
    texture_image,
)
from vggc_cp.sim.novel import novel_path
from vggc_cp.sim.render import Scene
from vggc_cp.trace import load_trace, save_trace

#: sha256 of ``generate(name, 6, seed=5, size=32, novel=2)``'s trace then novel observations,
#: computed with the renderer before looks existed (commit a8a222f): the clean look must
#: render the same pixels. (PyBullet's tiny renderer is CPU-only and deterministic; a
#: different PyBullet build could in principle change these.)
CLEAN_HASHES = {
    "fruit-2x3": "6eb309c120dcf4ea817738ee8d9c03eadc85761920db7329f9ef8e7cb927913d",
    "multifruit-2x3": "f586e29f132e3e7f0c0e54c4cd2b38d1da3ad7e90271ac57caa67fc977285372",
    "blocks-2": "f1d72c274b149789e1b390ac81d6201326b39e7a8bdc4cad2fe45df663f33081",
}

#: The same for the randomized look, computed before the robot look existed (commit
#: 8314881): adding the robot look (its arm region, frame index and distractor draws) must
#: not change a randomized trace.
RANDOMIZED_HASHES = {
    "fruit-2x3": "193ceb62f075c77971cb0e31795a08129551df1867bde3c7baa17a22dd9f51d2",
    "multifruit-2x3": "f9a059edc3392252dde7bad0e2752fd5af76926d9536570fefcbcd736af26680",
    "blocks-2": "6e957b29d400986c688d5885eef2736c3d17d48f99e8d6e03f7d8c19d468e780",
}


def _hash(g) -> str:
    return hashlib.sha256(g.trace.observations.tobytes()
                          + g.novel_observations.tobytes()).hexdigest()


@pytest.mark.parametrize("name", sorted(CLEAN_HASHES))
def test_clean_look_renders_the_old_pixels(name):
    g = generate(name, 6, seed=5, size=32, novel=2, look="clean")
    assert _hash(g) == CLEAN_HASHES[name]
    assert g.trace.meta["look"] == "clean" and "look_params" not in g.trace.meta


@pytest.mark.parametrize("name", sorted(RANDOMIZED_HASHES))
def test_randomized_look_renders_the_old_pixels(name):
    g = generate(name, 6, seed=5, size=32, novel=2, look="randomized")
    assert _hash(g) == RANDOMIZED_HASHES[name]
    assert "arm" not in g.trace.meta["look_params"]


def test_clean_is_the_default_and_matches_a_plain_scene():
    name, seed = "fruit-4x6", 2
    default = generate(name, 6, seed=seed, size=32)
    clean = generate(name, 6, seed=seed, size=32, look="clean")
    assert np.array_equal(default.trace.observations, clean.trace.observations)
    # the old code path: a look-less Scene, the walk and noise streams, no per-frame effects
    b = get_benchmark(name)
    _, noise_rng, _ = seed_streams(seed)
    tr = clean.trace
    with Scene(b, 32) as scene:
        arr = fresh_arrangement(b, str(tr.states[0]), noise_rng)
        assert np.array_equal(scene.render(arr), tr.observations[0])


def test_randomized_same_seed_same_bytes(tmp_path):
    paths = generated_twice(tmp_path, "multifruit-4x6", 6, 3, 3, look="randomized")
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert novel_path(paths[0]).read_bytes() == novel_path(paths[1]).read_bytes()
    # novel renders have their own streams: the trace does not depend on K
    alone = generate("multifruit-4x6", 6, seed=3, size=32, look="randomized").trace
    assert np.array_equal(alone.observations, load_trace(paths[0]).observations)


def test_randomized_differs_from_clean_and_between_seeds():
    clean = generate("fruit-4x6", 6, seed=3, size=32).trace
    a = generate("fruit-4x6", 6, seed=3, size=32, look="randomized").trace
    b = generate("fruit-4x6", 6, seed=4, size=32, look="randomized").trace
    # the walk is the seed's, whatever the look
    assert a.states.tolist() == clean.states.tolist()
    assert not np.array_equal(a.observations, clean.observations)
    assert not np.array_equal(a.observations, b.observations)
    pa, pb = a.meta["look_params"], b.meta["look_params"]
    assert pa["table_rgba"] != pb["table_rgba"]
    assert pa["camera_shift"] != pb["camera_shift"]
    assert pa["light_direction"] != pb["light_direction"]
    assert [o["scale"] for o in pa["objects"]] != [o["scale"] for o in pb["objects"]]


def test_looks_vary_over_seeds_within_their_ranges():
    b = get_benchmark("multifruit-4x6")
    looks = [sample_look(look_streams(s)[0], b) for s in range(40)]
    assert len({lk.table_rgba for lk in looks}) == 40
    assert {lk.table_texture for lk in looks} == {"grain", "noise", "checker"}
    for lk in looks:
        classes = [b.spec.object_class(i) for i in range(b.spec.m)]
        for obj, cls in zip(lk.objects, classes):
            assert obj.kind in CLASS_SHAPES[cls]
            assert SIZE_SCALE[0] <= obj.scale <= SIZE_SCALE[1]
            r, g, bl = obj.rgba[:3]
            if cls == "red":
                assert r > 0.6 and g < 0.2 and bl < 0.2
            else:
                assert r > 0.85 and g > 0.7 and bl < 0.3
        assert max(abs(v) for v in lk.camera_turn) <= 1.0
        assert lk.light_direction[2] > 0.5
    assert len({obj.kind for lk in looks for obj in lk.objects}) == 6


def test_single_class_objects_take_different_shapes():
    b = get_benchmark("fruit-4x6")
    for seed in range(10):
        lk = sample_look(look_streams(seed)[0], b)
        kinds = [o.kind for o in lk.objects]
        assert set(kinds) == set(CLASS_SHAPES["red"]), kinds  # 4 objects, 3 shapes: all used


def test_placement_jitter_larger_but_inside_the_cell():
    b = get_benchmark("multifruit-4x6")
    seen = []
    for seed in range(40):
        lk = sample_look(look_streams(seed)[0], b)
        for obj in lk.objects:
            assert obj.jitter <= JITTER_SCALE * FRUIT_JITTER + 1e-12
            assert FOOTPRINT[obj.kind] * obj.scale + obj.jitter <= CELL_HALF + 1e-12
            seen.append((obj.kind, obj.jitter))
        # the arrangement obeys the per-body half-ranges
        arr = fresh_arrangement(b, "rryy--|-", np.random.default_rng(seed), lk.placement_jitter)
        for bodies in arr.stacks:
            for body in bodies:
                dx, dy, _ = arr.offsets[body]
                assert max(abs(dx), abs(dy)) <= lk.objects[body].jitter
    round_ones = [j for kind, j in seen if kind in ("apple", "strawberry", "tomato", "pear")]
    assert max(round_ones) > FRUIT_JITTER  # larger than clean where there is room
    assert clean_look(b).placement_jitter is None


def test_per_frame_gain_moves_the_mean_brightness():
    b = get_benchmark("multifruit-2x3")
    lk = sample_look(np.random.default_rng(0), b)
    with Scene(b, 32, lk) as scene:
        img = scene.render(fresh_arrangement(b, "ry-|-", np.random.default_rng(0),
                                             lk.placement_jitter))
    rng = np.random.default_rng(1)
    means = np.array([finish_frame(img, lk, rng).mean() for _ in range(30)])
    assert means.max() - means.min() > 0.12 * img.mean()
    # tint and noise alone move the mean far less
    rng = np.random.default_rng(1)
    flat = np.array([finish_frame(img, replace(lk, frame_gain=(1.0, 1.0)), rng).mean()
                     for _ in range(30)])
    assert flat.max() - flat.min() < 0.05 * img.mean()
    noisy = finish_frame(img, replace(lk, frame_gain=(1.0, 1.0), frame_tint=0.0), rng)
    assert 2.0 < np.abs(noisy.astype(float) - img).mean() < 6.0  # sigma 4 sensor noise
    clean = clean_look(b)
    assert finish_frame(img, clean, rng) is img


def test_per_frame_effects_in_a_trace():
    """Frames of one state in a randomized trace spread in brightness more than clean ones."""
    def spread(look):
        tr = generate("fruit-2x3", 30, seed=1, size=32, look=look).trace
        states = tr.states.tolist()
        common = max(set(states), key=states.count)
        idx = [i for i, s in enumerate(states) if s == common]
        return np.ptp([tr.observations[i].mean() for i in idx])

    assert spread("randomized") > 2 * spread("clean") + 5


@pytest.mark.parametrize("seed", range(4))
def test_classes_stay_visible_and_distinct(seed):
    b = get_benchmark("multifruit-2x3")
    lk = sample_look(np.random.default_rng(seed), b)
    with Scene(b, 64, lk) as scene:
        img = scene.render(fresh_arrangement(b, "ry-|-", np.random.default_rng(seed),
                                             lk.placement_jitter))
    img = finish_frame(img, lk, np.random.default_rng(seed)).astype(int)
    r, g, bl = img[..., 0], img[..., 1], img[..., 2]
    red = (r > 100) & (r > 2.2 * g) & (r > 2 * bl)
    yellow = (r > 150) & (g > 0.7 * r) & (bl < 0.4 * r)
    assert red.sum() >= 8 and yellow.sum() >= 8, (red.sum(), yellow.sum())


def test_randomized_cubes_of_several_sizes_stack():
    b = get_benchmark("blocks-3")
    lk = sample_look(np.random.default_rng(0), b)
    assert len({o.scale for o in lk.objects}) == 3
    with Scene(b, 32, lk) as scene:
        arr = fresh_arrangement(b, "300|-", np.random.default_rng(0), lk.placement_jitter)
        scene.pose(arr)
        p = scene._p
        zs = [p.getBasePositionAndOrientation(scene._bodies[body],
                                              physicsClientId=scene._cid)[0][2]
              for body in arr.stacks[0]]
    halves = [0.025 * lk.objects[body].scale for body in arr.stacks[0]]
    expect = [halves[0], 2 * halves[0] + halves[1], 2 * halves[0] + 2 * halves[1] + halves[2]]
    assert np.allclose(zs, expect, atol=0.004)


def test_meta_records_the_look(tmp_path):
    g = generate("multifruit-2x3", 6, seed=2, size=32, look="randomized")
    out = tmp_path / "t.npz"
    save_trace(g.trace, out)
    meta = load_trace(out).meta
    assert meta["look"] == "randomized"
    params = meta["look_params"]
    json.dumps(params)
    assert params["table_texture"] in ("grain", "noise", "checker")
    assert [o["kind"] for o in params["objects"]][0] in CLASS_SHAPES["red"]
    assert [o["kind"] for o in params["objects"]][1] in CLASS_SHAPES["yellow"]
    assert params["noise_sigma"] == 4.0
    # the meta camera is the one used, not the layout's
    assert meta["camera"] != generate("multifruit-2x3", 6, seed=2, size=32).trace.meta["camera"]


def test_texture_is_deterministic_and_a_png():
    a = texture_image("grain", 7)
    assert np.array_equal(a, texture_image("grain", 7))
    assert not np.array_equal(a, texture_image("grain", 8))
    for kind in ("grain", "noise", "checker"):
        t = texture_image(kind, 1)
        assert t.dtype == np.uint8 and t.shape == (128, 128, 3) and t.std() > 5
    assert png_bytes(a)[:8] == b"\x89PNG\r\n\x1a\n" and png_bytes(a) == png_bytes(a.copy())


def test_bad_look_name(tmp_path, capsys):
    with pytest.raises(VggcError) as err:
        generate("fruit-2x3", 5, look="photo")
    for name in LOOKS:
        assert name in str(err.value)
    with pytest.raises(VggcError):
        make_look("photo", get_benchmark("fruit-2x3"), np.random.default_rng(0))
    out = tmp_path / "t.npz"
    assert main(["generate", "fruit-2x3", "-o", str(out), "--look", "photo", "--quiet"]) == 2
    err_lines = capsys.readouterr().err.strip().splitlines()
    assert len(err_lines) == 1 and "unknown look 'photo'" in err_lines[0]
    assert "clean" in err_lines[0] and "randomized" in err_lines[0]
    assert not out.exists()


def test_cli_look_randomized(tmp_path):
    out = tmp_path / "t.npz"
    assert main(["generate", "fruit-2x3", "-o", str(out), "--transitions", "4", "--size", "32",
                 "--look", "randomized", "--novel", "2", "--quiet"]) == 0
    assert load_trace(out).meta["look"] == "randomized"
    assert (tmp_path / "t.novel.npz").exists()
