"""Exploration and generated traces: validity, |V*|, determinism, novel renders."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from conftest import generated_twice

from vggc_cp.errors import VggcError
from vggc_cp.sim import benchmark_names, get_benchmark
from vggc_cp.sim.dynamics import Benchmark
from vggc_cp.sim.explore import generate, random_walk, seed_streams
from vggc_cp.sim.novel import load_novel, novel_path, save_novel
from vggc_cp.trace import compute_roles, load_trace, save_trace, validate

#: |V*| of the paper where a trace covers the whole space (multifruit-4x6 does not).
COVERED = {"fruit-2x3": 6, "multifruit-2x3": 12, "fruit-4x6": 35, "fruit-6x8": 84,
           "blocks-2": 9, "blocks-3": 16}


@pytest.mark.parametrize("name", sorted(COVERED))
def test_paper_size_walk_visits_the_papers_state_count(name):
    b = get_benchmark(name)
    walk = random_walk(b, b.spec.default_transitions, seed_streams(0)[0])
    assert walk.n_transitions == b.spec.default_transitions
    assert walk.distinct_states() == COVERED[name] == len(b.all_states())


def test_home_starts_keep_multifruit_4x6_near_the_papers_state_count():
    b = get_benchmark("multifruit-4x6")
    assert b.spec.start_states == 1
    counts = []
    for seed in range(4):
        walk = random_walk(b, b.spec.default_transitions, seed_streams(seed)[0])
        firsts = {walk.states[0]} | {walk.states[t + 1] for t in np.flatnonzero(walk.actions < 0)}
        assert len(firsts) == 1  # every episode begins at the home state
        counts.append(walk.distinct_states())
    # the paper's trace visits 58 of the 210 states; starting anywhere would visit ~165
    assert all(40 <= c <= 80 for c in counts), counts
    uniform = replace(b.spec, start_states=0)
    wide = random_walk(Benchmark(uniform), b.spec.default_transitions, seed_streams(0)[0])
    assert wide.distinct_states() > 2 * max(counts)


@pytest.mark.parametrize("name", benchmark_names())
def test_walk_is_valid_and_alternates(name):
    b = get_benchmark(name)
    walk = random_walk(b, 60, np.random.default_rng(3))
    assert len(walk.states) == len(walk.actions) + 1
    for t, a in enumerate(walk.actions):
        if a >= 0:
            assert b.step(walk.states[t], b.action_names[a]) == walk.states[t + 1]
    roles = compute_roles(walk.actions, b.action_names)
    assert set(roles.tolist()) <= {0, 1}
    for s, r in zip(walk.states, roles):
        assert b.is_pick_state(s) == (r == 0)


@pytest.mark.parametrize("name", benchmark_names())
def test_small_generated_trace_validates(name):
    totals = []
    g = generate(name, 12, seed=1, size=32, novel=3, on_frame=totals.append)
    tr = g.trace
    validate(tr)
    # one call per frame, each with the same total: the episodes' extra observations included
    assert totals == [tr.n_obs + 3] * (tr.n_obs + 3) and tr.n_obs > 13
    assert tr.n_transitions == 12
    assert tr.observations.shape[1:] == (32, 32, 3)
    assert tr.meta["benchmark"] == name and tr.meta["seed"] == 1
    assert tr.meta["image_size"] == [32, 32] and "camera" in tr.meta
    b = get_benchmark(name)
    assert tr.action_names == b.action_names
    for t, a in enumerate(tr.actions):
        if a >= 0:
            assert b.step(str(tr.states[t]), tr.action_names[a]) == tr.states[t + 1]
    assert g.novel_observations.shape == (3, 32, 32, 3)
    assert set(g.novel_states.tolist()) <= set(tr.states.tolist())


def test_same_seed_same_bytes(tmp_path):
    paths = generated_twice(tmp_path, "blocks-3", 20, 7, 4)
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert novel_path(paths[0]).read_bytes() == novel_path(paths[1]).read_bytes()
    # the novel renders draw from their own stream: the trace does not depend on K
    assert np.array_equal(generate("blocks-3", 20, seed=7, size=32).trace.observations,
                          load_trace(paths[0]).observations)
    other = generate("blocks-3", 20, seed=8, size=32).trace
    assert not np.array_equal(other.observations, load_trace(paths[0]).observations)


def test_novel_file_format(tmp_path):
    g = generate("fruit-2x3", 10, seed=0, size=32, novel=8)
    out = tmp_path / "t.npz"
    assert novel_path(out) == tmp_path / "t.novel.npz"
    save_novel(novel_path(out), g.novel_observations, g.novel_states)
    with np.load(novel_path(out), allow_pickle=False) as data:
        assert sorted(data.files) == ["observations", "states"]
        assert data["observations"].dtype == np.uint8
        assert data["observations"].shape == (8, 32, 32, 3)
        assert data["states"].dtype.kind == "U" and data["states"].shape == (8,)
    obs, states = load_novel(novel_path(out))
    # every visited state appears before any appears twice
    assert len(set(states[:len(set(g.trace.states.tolist()))].tolist())) == min(
        8, len(set(g.trace.states.tolist())))
    # fresh renders, not copies of trace frames
    flat = g.trace.observations.reshape(g.trace.n_obs, -1)
    for img in obs:
        assert not (flat == img.reshape(1, -1)).all(axis=1).any()


def test_bad_arguments_raise():
    with pytest.raises(VggcError):
        generate("nope", 5)
    with pytest.raises(VggcError):
        generate("fruit-2x3", 5, size=4)
    with pytest.raises(VggcError):
        generate("fruit-2x3", 0)
    with pytest.raises(VggcError):
        generate("fruit-2x3", 5, novel=-1)


@pytest.mark.slow
@pytest.mark.parametrize("name", benchmark_names())
def test_paper_size_trace(name, tmp_path):
    b = get_benchmark(name)
    g = generate(name, seed=0, size=64)
    out = tmp_path / f"{name}.npz"
    save_trace(g.trace, out)
    tr = load_trace(out)
    assert tr.n_transitions == b.spec.default_transitions
    distinct = len(set(tr.states.tolist()))
    if name in COVERED:
        assert distinct == COVERED[name]
    else:  # multifruit-4x6: the paper visits 58 of 210; episodes from one home state
        assert abs(distinct - b.spec.paper_states) <= 15 and distinct < len(b.all_states()) / 2
