"""The robot look: seeded, an arm that rests above the region it last acted on and carries the
held object, a bounded camera shake, a slow lighting drift, a distractor off the regions."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from conftest import generated_twice

from vggc_cp.cli import main
from vggc_cp.sim import benchmark_names, get_benchmark
from vggc_cp.sim.arrange import arrangement_after, fresh_arrangement
from vggc_cp.sim.explore import generate, look_streams
from vggc_cp.sim.looks import (
    ARM_MODEL,
    DISTRACTOR_COLOURS,
    DISTRACTOR_HEIGHT,
    DISTRACTOR_MOVE,
    DISTRACTOR_RADIUS,
    DRIFT_AMPLITUDE,
    DRIFT_PERIOD,
    SHAKE_PX,
    finish_frame,
    make_look,
    sample_look,
    shift_image,
)
from vggc_cp.sim.novel import novel_path
from vggc_cp.sim.render import REGION_SIDE, Scene
from vggc_cp.trace import load_trace, save_trace


def robot_look(name: str, seed: int = 0, n_frames: int = 100):
    b = get_benchmark(name)
    return b, make_look("robot", b, look_streams(seed)[0], n_frames)


def calm(look):
    """``look`` without per-frame gain, tint, noise, shake and drift."""
    return replace(look, frame_gain=(1.0, 1.0), frame_tint=0.0, noise_sigma=0.0, shake_px=0,
                   drift=(0.0, 1.0, 0.0))


def red_mask(img: np.ndarray) -> np.ndarray:
    r, g, b = (img[..., i].astype(int) for i in range(3))
    return (r > 100) & (r > 2 * g) & (r > 2 * b)


def window(img: np.ndarray, col: float, row: float, half: int) -> np.ndarray:
    c, r = int(round(col)), int(round(row))
    return img[max(r - half, 0):r + half + 1, max(c - half, 0):c + half + 1]


@pytest.fixture(scope="module")
def fruit_robot():
    b, lk = robot_look("fruit-4x6")
    with Scene(b, 64, lk) as scene:
        yield scene


def test_robot_same_seed_same_bytes(tmp_path):
    paths = generated_twice(tmp_path, "multifruit-2x3", 6, 3, 2, look="robot")
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert novel_path(paths[0]).read_bytes() == novel_path(paths[1]).read_bytes()
    # the trace does not depend on the number of novel renders
    alone = generate("multifruit-2x3", 6, seed=3, size=32, look="robot").trace
    assert np.array_equal(alone.observations, load_trace(paths[0]).observations)
    other = generate("multifruit-2x3", 6, seed=4, size=32, look="robot").trace
    assert not np.array_equal(alone.observations[:3], other.observations[:3])


def test_robot_extends_randomized_and_records_its_draws(tmp_path):
    rand = generate("fruit-2x3", 8, seed=2, size=32, look="randomized").trace
    g = generate("fruit-2x3", 8, seed=2, size=32, look="robot")
    out = tmp_path / "t.npz"
    save_trace(g.trace, out)
    robot = load_trace(out)
    assert robot.states.tolist() == rand.states.tolist()  # the walk is the seed's
    assert robot.meta["look"] == "robot"
    pr, pa = rand.meta["look_params"], robot.meta["look_params"]
    json.dumps(pa)
    for key, value in pr.items():  # everything randomized draws, drawn alike
        assert pa[key] == value, key
    assert pa["arm"] == ARM_MODEL and pa["shake_px"] == SHAKE_PX
    amp, period = pa["drift"]["amplitude"], pa["drift"]["period_frames"]
    assert DRIFT_AMPLITUDE[0] <= amp <= DRIFT_AMPLITUDE[1]
    n = robot.n_obs
    assert DRIFT_PERIOD[0] * n - 1e-3 <= period <= DRIFT_PERIOD[1] * n + 1e-3
    assert 0.0 <= pa["drift"]["phase"] <= 2 * math.pi + 1e-3
    mug = pa["distractor"]
    assert mug["colour"] in DISTRACTOR_COLOURS and mug["move_prob"] == DISTRACTOR_MOVE
    assert DISTRACTOR_RADIUS[0] <= mug["radius_m"] <= DISTRACTOR_RADIUS[1]
    assert DISTRACTOR_HEIGHT[0] <= mug["height_m"] <= DISTRACTOR_HEIGHT[1]
    assert pa["distractor_spots"][0][0] == 0
    starts = [0] + [t + 1 for t, a in enumerate(robot.actions) if a < 0]
    assert [f for f, _ in pa["arm_start_regions"]] == starts
    assert all(0 <= r < 3 for _, r in pa["arm_start_regions"])


def test_fresh_arrangement_draws_the_arm_region_last():
    b = get_benchmark("fruit-4x6")
    plain = fresh_arrangement(b, "rr-r-r|-", np.random.default_rng(3))
    rng = np.random.default_rng(3)
    with_arm = fresh_arrangement(b, "rr-r-r|-", rng, arm=True)
    assert plain.last_region == -1 and 0 <= with_arm.last_region < b.spec.R
    assert (plain.stacks, plain.held, plain.offsets) == (
        with_arm.stacks, with_arm.held, with_arm.offsets)
    drawn = {fresh_arrangement(b, "rr-r-r|-", rng, arm=True).last_region for _ in range(60)}
    assert drawn == set(range(b.spec.R))
    after = arrangement_after(b, with_arm, "pick_red_3", rng)
    assert after.last_region == 3 and after.held >= 0
    assert arrangement_after(b, after, "place_red_2", rng).last_region == 2


def test_arm_is_visible_where_it_rests(fruit_robot):
    """Frames of one state with the arm above region r and above r' differ at the hand."""
    scene = fruit_robot
    b = scene.bench
    arr = fresh_arrangement(b, "r-rr-r|-", np.random.default_rng(0),
                            scene.look.placement_jitter)
    imgs, hands = [], []
    for r in range(b.spec.R):
        a = replace(arr, last_region=r)
        imgs.append(scene.render(a).astype(int))
        target = scene.arm_target(a)
        assert np.allclose(scene.grasp_point(), target, atol=0.01)  # IK reached it
        hands.append(scene.project((target[0], target[1], target[2] + 0.06)))  # the hand
    for r in range(b.spec.R):
        for q in range(b.spec.R):
            if q == r:
                continue
            diff = np.abs(imgs[r] - imgs[q]).sum(axis=2)
            assert window(diff, *hands[r], 2).mean() > 60, (r, q)
    # the hand sits over its region in the image: left regions left, right regions right
    cols = [c for c, _ in hands]
    assert cols[0] + 8 < cols[1] < cols[2] - 8 and cols[3] + 8 < cols[4] < cols[5] - 8


def test_held_object_moves_with_the_arm(fruit_robot):
    scene = fruit_robot
    b = scene.bench
    p = scene._p
    arr = fresh_arrangement(b, "rr-r--|r", np.random.default_rng(1),
                            scene.look.placement_jitter)
    body = scene._bodies[arr.held]
    spots = []
    for r in (0, 2, 3, 5):
        a = replace(arr, last_region=r)
        img = scene.render(a)
        pos = p.getBasePositionAndOrientation(body, physicsClientId=scene._cid)[0]
        assert np.allclose(pos, scene.grasp_point(), atol=1e-6)  # in the hand
        cx, cy = scene.layout.centres[r]
        assert abs(pos[0] - cx) < 0.01 and abs(pos[1] - cy) < 0.01 and pos[2] > 0.05
        spots.append(pos)
        # the held fruit is seen just below the hand
        col, row = scene.project((pos[0], pos[1], pos[2] - 0.02))
        assert red_mask(window(img, col, row, 3)).sum() >= 3, r
    assert len({tuple(np.round(s, 3)) for s in spots}) == 4


@pytest.mark.slow
def test_every_benchmark_arm_reaches_and_holds():
    """Every region of every benchmark: the hand within 1 cm of its target, the held object
    (a cube for blocks) in the hand."""
    for name in benchmark_names():
        b, lk = robot_look(name)
        rng = np.random.default_rng(0)
        held_states = [s for s in b.all_states() if not s.endswith("|-")][:2]
        with Scene(b, 32, lk) as scene:
            for state in held_states:
                arr = fresh_arrangement(b, state, rng, lk.placement_jitter, arm=True)
                for r in range(b.spec.R):
                    a = replace(arr, last_region=r)
                    scene.pose(a)
                    assert np.allclose(scene.grasp_point(), scene.arm_target(a), atol=0.01)
                    pos = scene._p.getBasePositionAndOrientation(
                        scene._bodies[a.held], physicsClientId=scene._cid)[0]
                    assert np.allclose(pos, scene.grasp_point(), atol=1e-6), (name, r)
                    # the hand clears what stands on the region
                    top = max((scene._stack_top(a, r),), default=0.0)
                    assert pos[2] - scene._rest[a.held] > top + 0.02, (name, r)


def test_shake_is_a_whole_pixel_shift_of_at_most_two():
    b, lk = robot_look("fruit-2x3")
    img = np.random.default_rng(0).integers(0, 256, (40, 40, 3), dtype=np.uint8)
    look = replace(calm(lk), shake_px=lk.shake_px)
    rng = np.random.default_rng(1)
    seen = set()
    for _ in range(80):
        out = finish_frame(img, look, rng)
        found = [(dx, dy) for dx in range(-3, 4) for dy in range(-3, 4)
                 if np.array_equal(out, shift_image(img, dx, dy))]
        assert len(found) == 1
        dx, dy = found[0]
        assert max(abs(dx), abs(dy)) <= SHAKE_PX
        seen.add(found[0])
    assert len(seen) >= 15  # most of the 25 shifts occur
    # edge pixels are replicated
    moved = shift_image(img, 2, -1)
    assert np.array_equal(moved[:, 0], moved[:, 2]) and np.array_equal(moved[-1], moved[-2])
    assert np.array_equal(moved[:-1, 2:], img[1:, :-2])


def test_drift_is_slow_and_large_over_the_recording():
    b = get_benchmark("fruit-2x3")
    for seed in range(6):
        lk = make_look("robot", b, look_streams(seed)[0], 300)
        amp, period, _ = lk.drift
        look = replace(calm(lk), drift=lk.drift)
        grey = np.full((8, 8, 3), 150, dtype=np.uint8)
        rng = np.random.default_rng(seed)
        means = np.array([finish_frame(grey, look, rng, t).mean() for t in range(300)])
        assert np.abs(np.diff(means)).max() <= 1.0  # neighbouring frames: within rounding
        assert means.max() - means.min() >= 150 * amp * 0.9  # far frames differ
        assert 240 <= period <= 450


def test_randomized_ignores_the_frame_index():
    b = get_benchmark("fruit-2x3")
    lk = sample_look(look_streams(0)[0], b)
    img = np.full((8, 8, 3), 120, dtype=np.uint8)
    a = finish_frame(img, lk, np.random.default_rng(5), 0)
    c = finish_frame(img, lk, np.random.default_rng(5), 77)
    assert np.array_equal(a, c)


def test_distractor_moves_sometimes_but_never_onto_a_region():
    g = generate("fruit-2x3", 40, seed=1, size=32, look="robot", novel=3)
    tr = g.trace
    params = tr.meta["look_params"]
    spots = params["distractor_spots"]
    frames = [s[0] for s in spots]
    assert frames[0] == 0 and frames == sorted(set(frames))
    assert 2 <= len(spots) <= tr.n_obs // 2  # some frames, not most (p = 0.15)
    b, lk = robot_look("fruit-2x3")
    with Scene(b, 32, lk) as scene:
        centres = scene.layout.centres
        clear = REGION_SIDE / 2 + params["distractor"]["radius_m"]
        for _, x, y, _ in spots:
            assert np.max(np.abs(centres - (x, y)), axis=1).min() > clear
        rng = np.random.default_rng(0)
        for _ in range(100):
            assert scene.move_distractor(rng)
            x, y, _ = scene.distractor_spot
            assert scene.distractor_ok(x, y)
            assert np.max(np.abs(centres - (x, y)), axis=1).min() > clear
            col, row = scene.project((x, y, 0.0))
            assert 0 <= col < 32 and 0 <= row < 32


def test_distractor_is_seen_and_moves_in_the_image():
    b, lk = robot_look("multifruit-2x3")
    look = calm(lk)
    with Scene(b, 64, look) as scene:
        arr = fresh_arrangement(b, "ry-|-", np.random.default_rng(0), look.placement_jitter,
                                arm=True)
        rng = np.random.default_rng(2)
        scene.move_distractor(rng)
        first = scene.distractor_spot
        a = scene.render(arr).astype(int)
        while np.hypot(*np.subtract(scene.distractor_spot[:2], first[:2])) < 0.15:
            scene.move_distractor(rng)
        c = scene.render(arr).astype(int)
        diff = np.abs(a - c).sum(axis=2)
        for spot in (first, scene.distractor_spot):
            col, row = scene.project((spot[0], spot[1], 0.04))
            assert window(diff, col, row, 1).mean() > 40
        # nothing else changed: the arm, the regions and the objects stay
        assert (diff > 0).mean() < 0.05


def test_novel_renders_get_the_arm():
    g = generate("fruit-2x3", 6, seed=0, size=32, novel=6, look="robot")
    r = generate("fruit-2x3", 6, seed=0, size=32, novel=6, look="randomized")
    assert g.novel_states.tolist() == r.novel_states.tolist()
    # the same states, the arm in every render: whitish pixels in the upper half
    for img in g.novel_observations:
        top = img[:16].astype(int)
        assert ((top.min(axis=2) > 150) & (np.ptp(top, axis=2) < 40)).sum() > 10


def test_cli_look_robot(tmp_path):
    out = tmp_path / "t.npz"
    assert main(["generate", "blocks-2", "-o", str(out), "--transitions", "4", "--size", "32",
                 "--look", "robot", "--novel", "2", "--quiet"]) == 0
    meta = load_trace(out).meta
    assert meta["look"] == "robot" and meta["look_params"]["arm"] == ARM_MODEL
    assert (tmp_path / "t.novel.npz").exists()


def test_armless_is_the_robot_trace_without_its_arm():
    """The armless look draws everything the robot look draws (the walk, the look, the arm's
    rest regions, the mug's moves), renders the fixed gripper instead of the arm, and is
    seeded like the rest."""
    robot = generate("fruit-2x3", 8, seed=2, size=32, look="robot").trace
    armless = generate("fruit-2x3", 8, seed=2, size=32, look="armless").trace
    assert armless.meta["look"] == "armless"
    assert np.array_equal(robot.actions, armless.actions)
    assert robot.states.tolist() == armless.states.tolist()
    pr, pa = robot.meta["look_params"], armless.meta["look_params"]
    assert pa.pop("arm_hidden") is True and "arm_hidden" not in pr
    assert pa == pr                                   # the same draws, the arm's included
    diff = np.abs(robot.observations.astype(int) - armless.observations.astype(int)).sum(-1)
    assert (diff > 60).mean(axis=(1, 2)).min() > 0.01  # the arm is missing from every frame
    again = generate("fruit-2x3", 8, seed=2, size=32, look="armless").trace
    assert np.array_equal(again.observations, armless.observations)


def test_armless_frames_do_not_depend_on_where_the_arm_rests():
    b = get_benchmark("fruit-4x6")
    looks = {name: make_look(name, b, look_streams(0)[0], 100) for name in ("robot", "armless")}
    arr = fresh_arrangement(b, "r-rr-r|-", np.random.default_rng(0),
                            looks["armless"].placement_jitter)
    for name, look in looks.items():
        with Scene(b, 32, calm(look)) as scene:
            imgs = [scene.render(replace(arr, last_region=r)).astype(int) for r in (0, 5)]
        moved = np.abs(imgs[0] - imgs[1]).sum()
        assert (moved > 0) == (name == "robot"), name


def test_the_suite_asks_for_armless_by_name(tmp_path):
    from vggc_cp.experiments.robustness import RobustnessConfig, suite_looks

    assert suite_looks() == ("clean", "randomized", "robot")
    cfg = RobustnessConfig(tmp_path, ("blocks-2",), (0,), ("robot", "armless"))
    assert cfg.looks == ("robot", "armless")
