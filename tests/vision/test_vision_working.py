"""Footprint frames at a working resolution, converted in chunks (issue 27)."""

from __future__ import annotations

import tracemalloc
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from vggc_cp.trace import load_trace
from vggc_cp.vision.footprints import footprint_distances
from vggc_cp.vision.working import normalise_frames, working_factor

DATA = Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz"


def test_working_factor():
    assert working_factor(64, 64) == 1
    assert working_factor(32, 32) == 1
    assert working_factor(480, 640) == 8                # 80x60: as many pixels as 64x64
    assert working_factor(120, 160) == 2
    assert working_factor(256, 256) == 4


def test_averaging_down_replicated_pixels_gives_the_small_frames_back():
    obs = load_trace(DATA).observations[:40]
    big = obs.repeat(4, axis=1).repeat(4, axis=2)
    assert np.array_equal(normalise_frames(big, 4, chunk_bytes=1 << 20), normalise_frames(obs))


def test_a_large_trace_is_read_in_chunks_and_gives_the_small_traces_distances():
    trace = load_trace(DATA).without_states()
    big = replace(trace, observations=trace.observations.repeat(4, axis=1).repeat(4, axis=2))
    float_copy = big.observations.size * 4          # every frame as float32 at once
    tracemalloc.start()
    try:
        dist = footprint_distances(big)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < float_copy / 3, (peak, float_copy)
    for a, b in zip(dist, footprint_distances(trace)):
        assert np.array_equal(a, b)


def test_block_sums_are_exact_in_both_integer_widths():
    from vggc_cp.vision.working import _block_sums

    rng = np.random.default_rng(0)
    for f, shape in ((16, (2, 32, 48, 3)), (17, (2, 34, 51, 3)), (3, (4, 9, 6, 3))):
        x = rng.integers(0, 256, shape, dtype=np.uint8)
        h, w = shape[1] // f, shape[2] // f
        plain = x.reshape(shape[0], h, f, w, f, 3).sum(axis=(2, 4), dtype=np.uint64)
        assert np.array_equal(_block_sums(x, f), plain)


def test_block_sums_in_cache_sized_pieces_are_the_same(monkeypatch):
    from vggc_cp.vision import working

    rng = np.random.default_rng(4)
    x = rng.integers(0, 256, (7, 24, 16, 3), dtype=np.uint8)
    whole = working._block_sums(x, 4)
    monkeypatch.setattr(working, "SUM_BYTES", 2 * 24 * 16 * 3)  # two frames at a time
    assert np.array_equal(working._block_sums(x, 4), whole)


def _half_table(n: int = 6) -> np.ndarray:
    """Frames of a white background over half the image and a brown table over the other
    half, a dark object moving across the table: each frame's own median sits on one mode or
    the other as the object covers a little more or less of the table."""
    obs = np.empty((n, 16, 16, 3), dtype=np.uint8)
    obs[:, :8] = 255
    obs[:, 8:] = (144, 109, 74)
    for t in range(n):
        obs[t, 8:10 + t % 2, 2 * t:2 * t + 3] = (20, 20, 20)
        obs[t, 7 - t % 2:8, 0:1] = (144, 109, 74) if t % 2 else 255
    return obs


def test_a_frame_whose_own_median_jumps_between_modes_is_not_rescaled():
    obs = _half_table()
    med = np.median(obs.reshape(len(obs), -1, 3).astype(float), axis=1)[:, 0]
    assert len(set(med.tolist())) > 1           # a per-frame median would rescale frames
    x = normalise_frames(obs)
    table = x[:, 12, 15]                        # a table pixel nothing touches
    assert np.allclose(table, table[0], atol=1e-6)


def test_a_per_frame_gain_and_tint_cancel():
    obs = _half_table()
    lit = obs.astype(np.float32)
    lit[1::2] *= np.array([0.7, 0.8, 0.9], np.float32)   # every other frame dimmer and tinted
    lit = np.clip(lit.round(), 0, 255).astype(np.uint8)
    plain, x = normalise_frames(obs), normalise_frames(lit)
    table = x[:, 12, 15]
    assert np.allclose(table, table[0], atol=0.02)
    assert np.allclose(x[:, 8:], plain[:, 8:], atol=0.03)  # what is not clipped reads alike


def _wide_view(trace, side: int = 256):
    """``trace`` seen by a wider camera: its 64 px frames pasted unchanged into a larger,
    textured frame (the objects keep their ~6 px; the image grows)."""
    rng = np.random.default_rng(0)
    canvas = rng.integers(90, 140, size=(side, side, 3)).astype(np.uint8)
    obs = np.repeat(canvas[None], trace.n_obs, axis=0)
    h, w = trace.image_shape
    obs[:, 100:100 + h, 80:80 + w] = trace.observations
    return replace(trace, observations=obs)


def test_small_footprints_in_a_wide_view_are_worked_finer_than_the_image_size_bound():
    from vggc_cp.learned import LearnConfig
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.vision.footprints import FootprintConfig, action_footprints
    from vggc_cp.vision.working import FOOTPRINT_SIDE

    trace = load_trace(DATA).without_states()
    wide = _wide_view(trace)
    assert working_factor(256, 256) == 4
    res = action_footprints(wide).resolution
    assert res.bound == 4 and res.factor < 4, res       # 6 px objects would be 1.5 px at 4
    assert res.reason == "footprints' scale" and res.side >= FOOTPRINT_SIDE, res
    assert res.shape == (256 // res.factor, 256 // res.factor)
    # the image-size bound alone leaves the footprints under the width the defaults know
    from vggc_cp.vision.footprints import footprint_maps, footprint_side
    from vggc_cp.vision.working import working_frames

    src, act, dst = wide.transitions()
    coarse = footprint_maps(working_frames(wide.observations, factor=4), wide.roles(), src,
                            act, dst, wide.n_actions, FootprintConfig())
    assert footprint_side(coarse) < FOOTPRINT_SIDE
    options = LearnConfig(evidence="footprints")
    small, seen_wide = learn_graph(trace, options), learn_graph(wide, options)
    assert seen_wide.chosen.best.n_nodes == small.chosen.best.n_nodes
    assert len(set(zip(small.labels.tolist(), seen_wide.labels.tolist()))) == \
        small.chosen.best.n_nodes                        # the same partition
    assert any("footprints' scale" in n for n in seen_wide.chosen.notes)
    assert seen_wide.solution_record()["evidence_notes"] == list(seen_wide.chosen.notes)
    assert small.chosen.notes == () and "evidence_notes" not in small.solution_record()


def test_the_memory_cap_bounds_how_fine_and_says_so(monkeypatch):
    from vggc_cp.vision.footprints import action_footprints
    from vggc_cp.vision.working import finest_factor, working_bytes

    wide = _wide_view(load_trace(DATA).without_states())
    limit = working_bytes(wide.observations.shape, 3)    # factor 3 fits, 2 does not
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(limit))
    assert finest_factor(wide.observations.shape) == 3
    res = action_footprints(wide).resolution
    assert (res.factor, res.reason) == (3, "memory cap"), res
    assert "raise VGGC_CP_MAX_BYTES" in res.describe()


def test_frames_scaled_up_whole_keep_the_image_size_bound():
    from vggc_cp.vision.footprints import action_footprints

    trace = load_trace(DATA).without_states()
    big = replace(trace, observations=trace.observations.repeat(4, axis=1).repeat(4, axis=2))
    res = action_footprints(big).resolution
    assert (res.factor, res.bound, res.reason) == (4, 4, "image size"), res
    assert action_footprints(trace).resolution.reason == "image size"


@pytest.mark.slow
def test_a_scene_half_background_is_learned_right_with_its_gains_against_the_recording():
    """random-678 clean (two objects, four scattered regions, 100 transitions): the white
    background fills about half of every frame, so each frame's own median jumped between
    background and table (red 144 or 214 from one frame to the next) and, read as change
    everywhere, shrank the top region's footprint to two pixels; an episode was misread and
    the wrong graph was quiet. Against the recording the gains hold still and the graph is
    the true one."""
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.sim.explore import generate

    trace = generate("random-678", 100, 0, look="clean").trace
    med = np.median(trace.observations.reshape(trace.n_obs, -1, 3), axis=1)[:, 0]
    assert med.max() / med.min() > 1.3                    # the frames' own medians jump
    learned = learn_graph(trace.without_states())
    _, truth = np.unique(trace.states, return_inverse=True)
    pairs = set(zip(learned.labels.tolist(), truth.tolist()))
    assert len(pairs) == len(set(learned.labels.tolist())) == len(set(truth.tolist()))
