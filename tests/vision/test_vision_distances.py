"""The distance stage (``vggc_cp.vision.distances``): shapes, cache, CLI."""

from __future__ import annotations

import argparse
import json
from dataclasses import replace

import numpy as np
import pytest

from vggc_cp.cli import main
from vggc_cp.cli.options import add_distance_arguments, config_from_args
from vggc_cp.errors import UnknownNameError, VggcError
from vggc_cp.trace import Trace, save_trace
from vggc_cp.vision import (
    DistanceConfig,
    affinity,
    cache_path,
    compute_distances,
    compute_distances_full,
)

FAST = dict(grid=4, threads=1)


def scene_trace(n_episodes: int = 3, size: int = 32, seed: int = 0) -> Trace:
    """One bright square on a textured table, alternating between two spots per episode."""
    rng = np.random.default_rng(seed)
    table = rng.integers(90, 110, size=(size, size, 3))
    spots = [(4, 4), (4, 20), (20, 12)]
    obs, acts, states = [], [], []
    names = ("pick_a", "place_b")
    for e in range(n_episodes):
        if e:
            acts.append(-1)
        for k, spot in enumerate([spots[e % 3], None, spots[(e + 1) % 3]]):
            img = table.copy()
            if spot is not None:
                r, c = spot
                img[r:r + 8, c:c + 8] = (220, 40, 40)
            obs.append(np.clip(img + rng.integers(-3, 4, img.shape), 0, 255).astype(np.uint8))
            states.append(f"s{e}{k}")
            if k < 2:
                acts.append(k)
    return Trace(np.stack(obs), np.array(acts, dtype=np.int64), names, np.array(states))


def test_shapes_follow_roles_and_states_are_not_needed(tmp_path):
    trace = scene_trace()
    dp, dq = compute_distances(trace, DistanceConfig(**FAST), cache_dir=tmp_path,
                               progress=False)
    roles = trace.roles()
    assert dp.shape == (np.sum(roles == 0),) * 2 and dq.shape == (np.sum(roles == 1),) * 2
    for d in (dp, dq):
        assert d.dtype == np.float64
        assert np.array_equal(d, d.T) and np.all(np.diag(d) == 0) and d.min() >= 0
    dp2, dq2 = compute_distances(trace.without_states(), DistanceConfig(**FAST, use_cache=False),
                                 progress=False)
    np.testing.assert_allclose(dp2, dp, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(dq2, dq, rtol=1e-6, atol=1e-9)
    assert affinity(dp, 0.1).max() == 1.0


def test_cache_is_reused_and_invalidated(tmp_path):
    trace = scene_trace()
    cfg = DistanceConfig(**FAST)
    first = compute_distances_full(trace, cfg, cache_dir=tmp_path, progress=False)
    assert not first.cached and first.path.is_file()
    again = compute_distances_full(trace.without_states(), cfg, cache_dir=tmp_path,
                                   progress=False)
    assert again.cached and again.path == first.path
    np.testing.assert_array_equal(again.dist_pick, first.dist_pick)
    # every result-changing parameter gives another file
    for change in (dict(eps=0.1), dict(grid=8), dict(floor=0.02), dict(tol=1e-7),
                   dict(dtype="float64"), dict(noise_k=2.0)):
        other = compute_distances_full(trace, replace(cfg, **change), cache_dir=tmp_path,
                                       progress=False)
        assert not other.cached and other.path != first.path, change
    # speed-only parameters share it
    same = compute_distances_full(trace, replace(cfg, threads=2, block=64), cache_dir=tmp_path,
                                  progress=False)
    assert same.cached
    # another trace
    obs = trace.observations.copy()
    obs[0, 0, 0, 0] ^= 1
    other = compute_distances_full(replace(trace, observations=obs), cfg, cache_dir=tmp_path,
                                   progress=False)
    assert not other.cached and other.path != first.path
    # a file whose stored key disagrees (collision, tampering) is recomputed, then rewritten
    with np.load(first.path) as data:
        members = {k: data[k] for k in data.files}
    key = json.loads(str(members["key"]))
    key["config"]["eps"] = 123.0
    members["key"] = np.array(json.dumps(key))
    members["dist_pick"] = members["dist_pick"] + 1
    np.savez(first.path, **members)
    fresh = compute_distances_full(trace, cfg, cache_dir=tmp_path, progress=False)
    assert not fresh.cached
    np.testing.assert_array_equal(fresh.dist_pick, first.dist_pick)
    assert compute_distances_full(trace, cfg, cache_dir=tmp_path, progress=False).cached


def test_cache_file_format(tmp_path):
    trace = scene_trace()
    cfg = DistanceConfig(**FAST)
    res = compute_distances_full(trace, cfg, cache_dir=tmp_path, progress=False)
    path, key = cache_path(trace, cfg, tmp_path)
    assert path == res.path
    with np.load(path, allow_pickle=False) as data:
        assert set(data.files) == {"dist_pick", "dist_place", "key", "stats"}
        stored = json.loads(str(data["key"]))
        assert stored["format"] == "vggc-distances/1"
        assert stored["trace"] == trace.content_hash()
        assert stored["config"]["eps"] == cfg.eps and stored["config"]["backend"] == "saliency"
        assert "threads" not in stored["config"] and "cache_dir" not in stored["config"]
        assert "pick" in json.loads(str(data["stats"]))
    assert not list(tmp_path.glob(".*"))  # no temporary file left behind


def test_default_cache_dir_and_env(tmp_path, monkeypatch):
    trace = scene_trace()
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("VGGC_CP_CACHE", raising=False)
    res = compute_distances_full(trace, DistanceConfig(**FAST), progress=False)
    assert res.path.parent.resolve() == (tmp_path / ".cache" / "vggc-cp" / "distances").resolve()
    monkeypatch.setenv("VGGC_CP_CACHE", str(tmp_path / "elsewhere"))
    res = compute_distances_full(trace, DistanceConfig(**FAST), progress=False)
    assert res.path.parent == tmp_path / "elsewhere" / "distances"


def test_arguments_round_trip():
    parser = argparse.ArgumentParser()
    add_distance_arguments(parser)
    assert config_from_args(parser.parse_args([])) == DistanceConfig()
    args = parser.parse_args(["--attention", "saliency", "--eps", "0.1", "--grid", "8",
                              "--cache-dir", "x", "--no-cache", "--sinkhorn-threads", "1"])
    cfg = config_from_args(args)
    assert (cfg.eps, cfg.grid, cfg.cache_dir, cfg.use_cache, cfg.threads) == \
        (0.1, 8, "x", False, 1)
    with pytest.raises(UnknownNameError, match="saliency"):
        DistanceConfig(backend="nope")
    with pytest.raises(VggcError):
        DistanceConfig(eps=0)


def test_cli_distances_and_show_attention(tmp_path, capsys):
    path = tmp_path / "t.npz"
    save_trace(scene_trace(), path)
    cache = tmp_path / "cache"
    argv = ["distances", str(path), "--quiet", "--grid", "4", "--cache-dir", str(cache)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "written to" in out and "pick" in out and "median" in out
    assert main(argv) == 0
    assert "loaded from" in capsys.readouterr().out
    png = tmp_path / "att.png"
    assert main(["show-attention", str(path), "-i", "0,1,2", "-o", str(png), "--grid", "8"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("argv", [
    ["show-attention", "{trace}", "-i", "0,99", "-o", "{tmp}/a.png"],
    ["show-attention", "{trace}", "-i", "x", "-o", "{tmp}/a.png"],
    ["show-attention", "{trace}", "--attention", "nope", "-o", "{tmp}/a.png"],
    ["distances", "{trace}", "--attention", "nope", "--quiet"],
    ["distances", "{trace}", "--attention", "dinov2", "--quiet", "--no-cache"],
    ["distances", "{tmp}/missing.npz", "--quiet"],
])
def test_cli_errors_exit_2(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.delenv("VGGC_CP_DINOV2_WEIGHTS", raising=False)
    path = tmp_path / "t.npz"
    save_trace(scene_trace(), path)
    argv = [a.format(trace=path, tmp=tmp_path) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("vggc-cp: error:") and len(err.strip().splitlines()) == 1
