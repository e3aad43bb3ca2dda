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


@pytest.mark.parametrize("shape,f", [((5, 6, 8, 3), 1), ((4, 7, 5, 3), 1), ((3, 4, 6, 3), 8),
                                     ((6, 3, 3, 3), 16)])
def test_channel_medians_are_numpys_median_bit_for_bit(shape, f):
    from vggc_cp.vision.working import _channel_medians

    rng = np.random.default_rng(sum(shape) + f)
    top = 255 * f * f
    block = rng.integers(0, top + 1, shape).astype(np.uint8 if f == 1 else np.uint32)
    block[0] = block[0, :1, :1]  # a flat frame: ties everywhere
    x = block.astype(np.float32) / (255.0 * f * f)
    want = np.median(x.reshape(len(x), -1, 3), axis=1)
    got = _channel_medians(block, f)
    assert got.dtype == want.dtype == np.float32
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))


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
    from vggc_cp.pipeline import LearnConfig, learn_graph
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
