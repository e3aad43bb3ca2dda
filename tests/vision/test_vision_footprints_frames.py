"""Footprint frames at a working resolution, converted in chunks (issue 27)."""

from __future__ import annotations

import tracemalloc
from dataclasses import replace
from pathlib import Path

import numpy as np

from vggc_cp.trace import load_trace
from vggc_cp.vision.footprints import (
    footprint_distances,
    normalise_frames,
    working_factor,
)

DATA = Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz"


def test_working_factor():
    assert working_factor(64, 64) == 1
    assert working_factor(32, 32) == 1
    assert working_factor(480, 640) == 7
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
    from vggc_cp.vision.footprints import _block_sums

    rng = np.random.default_rng(0)
    for f, shape in ((16, (2, 32, 48, 3)), (17, (2, 34, 51, 3)), (3, (4, 9, 6, 3))):
        x = rng.integers(0, 256, shape, dtype=np.uint8)
        h, w = shape[1] // f, shape[2] // f
        plain = x.reshape(shape[0], h, f, w, f, 3).sum(axis=(2, 4), dtype=np.uint64)
        assert np.array_equal(_block_sums(x, f), plain)
