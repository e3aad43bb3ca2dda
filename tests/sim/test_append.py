"""``vggc-cp generate --episodes next.json --append t.npz``: exactly the requested episodes,
from the true start states, in the trace's look; same inputs, same bytes; bad episode files
refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vggc_cp.cli import main
from vggc_cp.sim.explore import generate
from vggc_cp.sim.tasks import get_benchmark
from vggc_cp.trace import load_trace, save_trace


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """A fruit-2x3 trace of 12 transitions at 16 px (randomized look: per-trace colours,
    per-frame gain and noise, all rebuilt from the seed)."""
    folder = tmp_path_factory.mktemp("append")
    trace = generate("fruit-2x3", 12, seed=5, size=16, look="randomized").trace
    path = folder / "t.npz"
    save_trace(trace, path)
    return folder, path, trace


def _episodes(folder, trace, episodes, name="next.json", sha=None):
    path = folder / name
    path.write_text(json.dumps({"format": "vggc-episodes/1",
                                "trace_sha256": sha or trace.content_hash(),
                                "episodes": episodes}))
    return path


def _legal_run(trace, start, n):
    """``n`` actions legal in a row from the true state of observation ``start``."""
    bench = get_benchmark(trace.meta["benchmark"])
    state, out = str(trace.states[start]), []
    for _ in range(n):
        name = bench.valid_actions(state)[0]
        out.append(name)
        state = bench.step(state, name)
    return out


def test_append_records_exactly_the_episodes_and_is_deterministic(small, capsys):
    folder, path, trace = small
    bench = get_benchmark(trace.meta["benchmark"])
    first = _legal_run(trace, 0, 3)
    start2 = trace.episodes()[-1][0]
    second = _legal_run(trace, start2, 2)
    state2 = str(trace.states[start2])
    bad = next(a for a in bench.action_names
               if bench.step(bench.step(bench.step(state2, second[0]), second[1]), a) is None)
    never = next(a for a in bench.action_names if bench.step(str(trace.states[3]), a) is None)
    eps = _episodes(folder, trace, [
        {"start_observation": 0, "actions": first, "doubt": 0, "why": "test"},
        {"start_observation": start2, "actions": [*second, bad, first[0]]},
        {"start_observation": 3, "actions": [never]},
    ])
    outs = [folder / "t2.npz", folder / "t2b.npz"]
    for out in outs:
        assert main(["generate", "--episodes", str(eps), "--append", str(path), "-o",
                     str(out)]) == 0
    text = capsys.readouterr().out
    assert "episode 1: action 2" in text and "episode 2: action 0" in text
    assert outs[0].read_bytes() == outs[1].read_bytes()
    new = load_trace(outs[0])  # validates
    n = trace.n_obs
    np.testing.assert_array_equal(new.observations[:n], trace.observations)
    np.testing.assert_array_equal(new.actions[:n - 1], trace.actions)
    np.testing.assert_array_equal(new.states[:n], trace.states)
    # two episodes recorded (3 and 2 actions), the third refused at its first action
    assert new.n_obs == n + 4 + 3 and new.n_transitions == trace.n_transitions + 5
    names = [new.action_names[a] for a in new.actions[n:] if a >= 0]
    assert names == first + second
    assert new.states[n] == trace.states[0] and new.states[n + 4] == state2
    for t in range(n, new.n_obs - 1):  # the states follow the dynamics
        if new.actions[t] >= 0:
            assert bench.step(str(new.states[t]), new.action_names[new.actions[t]]) == \
                new.states[t + 1]
    (rnd,) = new.meta["appended"]
    assert rnd["observations"] == n and rnd["transitions"] == 5
    assert [e["executed"] for e in rnd["episodes"]] == [first, second, []]
    assert [e["illegal_at"] for e in rnd["episodes"]] == [None, 2, 0]
    assert new.meta["look_params"] == trace.meta["look_params"]
    # frames are rendered in the trace's look: a fresh render of the start state looks like
    # the trace's renders of it (same colours: closer than to any other state's renders)
    dist = np.abs(new.observations[n].astype(float)[None] - trace.observations.astype(float))
    dist = dist.mean(axis=(1, 2, 3))
    same = trace.states == trace.states[0]
    assert dist[same].min() < dist[~same].min()


def test_a_second_round_draws_afresh(small):
    folder, path, trace = small
    acts = _legal_run(trace, 0, 2)
    eps = _episodes(folder, trace, [{"start_observation": 0, "actions": acts}], "r1.json")
    assert main(["generate", "--episodes", str(eps), "--append", str(path), "-o",
                 str(folder / "r1.npz"), "--quiet"]) == 0
    t1 = load_trace(folder / "r1.npz")
    eps2 = _episodes(folder, t1, [{"start_observation": 0, "actions": acts}], "r2.json")
    assert main(["generate", "fruit-2x3", "--episodes", str(eps2), "--append",
                 str(folder / "r1.npz"), "-o", str(folder / "r2.npz"), "--quiet"]) == 0
    t2 = load_trace(folder / "r2.npz")
    assert len(t2.meta["appended"]) == 2 and t2.meta["appended"][1]["observations"] == t1.n_obs
    assert t2.n_obs == t1.n_obs + 3
    assert not np.array_equal(t2.observations[t1.n_obs:], t1.observations[trace.n_obs:])


@pytest.mark.parametrize("change, field", [
    ({"sha": "0" * 64}, "trace_sha256"),
    ({"episodes": [{"start_observation": 0, "actions": ["jump"]}]}, "episodes[0].actions[0]"),
    ({"episodes": [{"start_observation": 10**6, "actions": []}]},
     "episodes[0].start_observation"),
    ({"format": "other/1"}, "format"),
])
def test_bad_episode_files_are_refused_in_one_line(small, capsys, change, field):
    folder, path, trace = small
    doc = {"format": change.get("format", "vggc-episodes/1"),
           "trace_sha256": change.get("sha", trace.content_hash()),
           "episodes": change.get("episodes", [])}
    eps = folder / "bad.json"
    eps.write_text(json.dumps(doc))
    out = folder / "never.npz"
    assert main(["generate", "--episodes", str(eps), "--append", str(path), "-o",
                 str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("vggc-cp: error: ") and field in err[0]
    assert not out.exists()


def test_append_needs_a_generated_trace_and_both_options(small, tmp_path, capsys):
    folder, path, trace = small
    bare = tmp_path / "bare.npz"
    save_trace(trace.without_states(), bare)
    eps = _episodes(tmp_path, trace, [])
    assert main(["generate", "--episodes", str(eps), "--append", str(bare), "-o",
                 str(tmp_path / "o.npz")]) == 2
    assert "field 'states'" in capsys.readouterr().err
    assert main(["generate", "--append", str(path), "-o", str(tmp_path / "o.npz")]) == 2
    assert "--episodes and --append go together" in capsys.readouterr().err
    assert main(["generate", "blocks-3", "--episodes", str(eps), "--append", str(path), "-o",
                 str(tmp_path / "o.npz")]) == 2
    assert "meta.benchmark" in capsys.readouterr().err
