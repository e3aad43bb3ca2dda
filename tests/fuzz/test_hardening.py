"""Issue 17 beyond the corpus: subprocess runs (no traceback), signals, stale temporary files,
the distance cache, trace identity, --dynamics auto, and hypothesis-driven traces/solutions."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from world import FAST, sha, toy_trace

from vggc_cp.cli import main
from vggc_cp.trace import Trace, save_trace, trace_to_bytes

ROOT = Path(__file__).resolve().parents[2]


def _run(*argv, cwd):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "vggc_cp", *map(str, argv)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.slow
def test_subprocess_refusals_have_no_traceback(tmp_path):
    t = tmp_path / "t.npz"
    save_trace(toy_trace(), t)
    deep = tmp_path / "deep.npz"
    tr = toy_trace()
    deep.write_bytes(trace_to_bytes(tr)[:0] or b"")
    from world import bad_traces

    deep.write_bytes(bad_traces(trace_to_bytes(tr))["meta-deep"][0])
    sol = tmp_path / "s.json"
    sol.write_text('{"format": "vggc-solution/1", "J": Infinity}')
    before = {p: sha(p) for p in (t, deep, sol)}
    for argv in (("inspect", deep), ("solve", t, "-o", t), ("plan", sol, "--start-obs", "0",
                                                           "--goal-obs", "1"),
                 ("inspect", "z" * 300)):
        res = _run(*argv, cwd=tmp_path)
        assert res.returncode == 2, res.stderr
        assert "Traceback" not in res.stdout + res.stderr
        assert len(res.stderr.splitlines()) == 1 and res.stderr.startswith("vggc-cp: error: ")
    assert {p: sha(p) for p in (t, deep, sol)} == before


def test_sigterm_removes_temporary_files(tmp_path):
    code = (
        "import os, signal, sys\n"
        "from vggc_cp.interrupts import guard\n"
        "from vggc_cp.atomic import atomic_path\n"
        "with guard():\n"
        f"    with atomic_path({str(tmp_path / 'out.json')!r}) as tmp:\n"
        "        tmp.write_text('partial')\n"
        "        os.kill(os.getpid(), signal.SIGTERM)\n"
        "        signal.pause()\n")
    res = subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(ROOT)},
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 143, res.stderr
    assert list(tmp_path.iterdir()) == []  # no temporary file, no partial output


def test_stale_temporary_files_are_swept(tmp_path, capsys):
    t = tmp_path / "t.npz"
    save_trace(toy_trace(), t)
    stale = tmp_path / ".b.json.vggctmp-abc123.json"
    fresh = tmp_path / ".b.json.vggctmp-def456.json"
    other = tmp_path / ".b.json.keepme"
    # the README: the output folder is swept of the tool's temporaries, whatever their target
    stale_other = tmp_path / ".t.npz.vggctmp-xyz789.npz"
    stale_probe = tmp_path / ".vggc-probe-0a1b2c"
    for p in (stale, fresh, other, stale_other, stale_probe):
        p.write_text("x")
    old = time.time() - 3 * 3600
    for p in (stale, stale_other, stale_probe):
        os.utime(p, (old, old))
    assert main(["baseline", "pca-hdbscan", str(t), "-o", str(tmp_path / "b.json")]) == 0
    assert not stale.exists() and fresh.exists() and other.exists()
    assert not stale_other.exists() and not stale_probe.exists()


@pytest.mark.slow
def test_damaged_cache_entry_is_ignored_with_a_warning(tmp_path, capsys):
    from vggc_cp.vision.distances import DistanceConfig, cache_path

    t = tmp_path / "t.npz"
    save_trace(toy_trace(), t)
    cache = tmp_path / "cache"
    argv = ["distances", str(t), "--quiet", "--cache-dir", str(cache), *FAST]
    assert main(argv) == 0
    capsys.readouterr()
    cfg = DistanceConfig(device="numpy", cache_dir=str(cache))
    path, key = cache_path(toy_trace(), cfg)
    with np.load(path) as data:
        members = dict(data)
    good = members["dist_pick"].copy()
    for bad in (-np.ones_like(good), np.full_like(good, np.nan), good[:1]):
        np.savez(path, **{**members, "dist_pick": bad})
        assert main(argv) == 0
        out, err = capsys.readouterr()
        assert "warning" in err and "damaged" in err and str(path) in err
        assert "written to" in out  # recomputed
        with np.load(path) as data:
            np.testing.assert_allclose(data["dist_pick"], good)


def test_unwritable_cache_goes_on_without_caching(tmp_path, capsys, monkeypatch):
    t = tmp_path / "t.npz"
    save_trace(toy_trace(), t)
    blocker = tmp_path / "file"
    blocker.write_text("x")
    monkeypatch.setenv("VGGC_CP_CACHE", str(blocker))  # the default cache is under a file
    assert main(["distances", str(t), "--quiet", *FAST]) == 0
    err = capsys.readouterr().err
    assert "without caching" in err and "Traceback" not in err


def test_action_names_cannot_make_two_traces_share_a_cache_key():
    t = toy_trace()
    a = Trace(t.observations, t.actions, ("pick_a", "pick_b\x00c", "place_x", "place_y"))
    b = Trace(t.observations, t.actions, ("pick_a\x00pick_b", "c", "place_x", "place_y"))
    assert a.identity_hash() != b.identity_hash()


def test_dynamics_auto_falls_back_on_foreign_state_keys(tmp_path, capsys):
    t = toy_trace()
    t = Trace(t.observations, t.actions, t.action_names, t.states, {"benchmark": "fruit-2x3"})
    path = tmp_path / "t.npz"
    save_trace(t, path)
    sol = tmp_path / "s.json"
    assert main(["solve", str(path), "-o", str(sol), "--quiet", "--solver", "greedy",
                 "--k-pick", "1:3", "--k-place", "1:2", "--cache-dir", str(tmp_path / "c"),
                 *FAST]) == 0
    capsys.readouterr()
    assert main(["evaluate", str(path), str(sol), "-Q", "20"]) == 0
    out, err = capsys.readouterr()
    assert "Exec on trace dynamics" in out
    assert len(err.splitlines()) == 1 and "own transitions" in err
    assert main(["evaluate", str(path), str(sol), "-Q", "20", "--dynamics", "sim"]) == 2


def test_dynamics_auto_says_when_the_benchmark_is_unknown(tmp_path, capsys):
    from vggc_cp.evaluate import resolve_dynamics
    from vggc_cp.evaluate.groundtruth import GroundTruth

    t = toy_trace()
    for bench in ("no-such-benchmark", ["a", "list"]):
        u = Trace(t.observations, t.actions, t.action_names, t.states, {"benchmark": bench})
        step, used = resolve_dynamics(u, GroundTruth.from_trace(u), "auto")
        err = capsys.readouterr().err
        assert (step, used) == (None, "trace")
        assert err.count("\n") == 1 and "does not know" in err and "own transitions" in err


@pytest.mark.slow
def test_a_server_that_is_not_a_dask_scheduler_is_one_line(tmp_path, capsys):
    """A loopback server answering garbage made dask's comm try to allocate exabytes."""
    import socket
    import threading

    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)
    port = srv.getsockname()[1]
    stop = threading.Event()

    def serve():
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                conn, _ = srv.accept()
            except OSError:
                continue
            try:
                conn.recv(1000)
                conn.sendall(b"HTTP/1.0 200 OK\r\n\r\n" + b"\xff" * 64)
            except OSError:
                pass

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    t = tmp_path / "t.npz"
    save_trace(toy_trace(), t)
    try:
        rc = main(["distances", str(t), "--backend", "dask", "--distance-rows", "4",
                   "--scheduler", f"tcp://127.0.0.1:{port}", "--no-cache", "--quiet", *FAST])
    finally:
        stop.set()
        thread.join(2)
        srv.close()
    err = capsys.readouterr().err
    assert rc == 2 and "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("vggc-cp: error: ")]
    assert len(lines) == 1 and f"127.0.0.1:{port}" in lines[0]


# ------------------------------------------------------------------ hypothesis


def _check(rc, err, inputs, before):
    assert "Traceback" not in err
    if rc != 0:
        assert rc == 2 and len(err.splitlines()) == 1 and err.startswith("vggc-cp: error: ")
        assert any(str(p) in err for p in inputs)
    assert {str(p): sha(p) for p in inputs} == before


@st.composite
def traces(draw):
    n = draw(st.integers(1, 7))
    side = draw(st.sampled_from([1, 3, 4, 8]))
    dtype = draw(st.sampled_from([np.uint8, np.uint8, np.int16, np.float32]))
    obs = np.zeros((n, side, side, draw(st.sampled_from([3, 3, 1]))), dtype)
    names = draw(st.lists(st.sampled_from(["pick_a", "place_b", "pick_c", "place_d", "fly",
                                           "pick\x00", "place b", "pick_a"]),
                          min_size=0, max_size=4))
    acts = np.array(draw(st.lists(st.integers(-2, 4), min_size=max(n - 1, 0),
                                  max_size=max(n - 1, 0))), dtype=np.int64)
    meta = draw(st.recursive(st.none() | st.integers() | st.text(max_size=5),
                             lambda c: st.lists(c, max_size=3)
                             | st.dictionaries(st.text(max_size=3), c, max_size=3),
                             max_leaves=8))
    return obs, acts, names, meta


@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck))
@given(traces())
def test_hypothesis_traces(tmp_path_factory, capsys, data):
    from vggc_cp.trace import npz_bytes

    obs, acts, names, meta = data
    path = tmp_path_factory.mktemp("h") / "t.npz"
    arrays = {"observations": obs, "actions": acts,
              "action_names": np.array(names, dtype=str) if names else np.array([], dtype=str),
              "meta": np.array(json.dumps({"m": meta}))}
    path.write_bytes(npz_bytes(arrays))
    before = {str(path): sha(path)}
    capsys.readouterr()
    rc = main(["inspect", str(path)])
    _check(rc, capsys.readouterr().err, [path], before)


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    root = tmp_path_factory.mktemp("solved")
    t = root / "t.npz"
    save_trace(toy_trace(), t)
    s = root / "s.json"
    assert main(["solve", str(t), "-o", str(s), "--quiet", "--solver", "greedy", "--k-pick",
                 "1:3", "--k-place", "1:2", "--cache-dir", str(root / "c"), *FAST]) == 0
    return t, json.loads(s.read_text())


_JSON = st.recursive(st.none() | st.booleans() | st.integers(-2**80, 2**80)
                     | st.floats(allow_nan=False) | st.text(max_size=6),
                     lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=4), c,
                                                                         max_size=3),
                     max_leaves=6)


@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck))
@given(key=st.sampled_from(["format", "labels", "roles", "edges", "k_pick", "k_place", "J",
                            "solver", "status", "trace_sha256", "constraints"]),
       value=_JSON, cmd=st.sampled_from(["evaluate", "plan"]))
def test_hypothesis_solutions(solved, tmp_path_factory, capsys, key, value, cmd):
    trace, valid = solved
    data = dict(valid)
    data[key] = value
    path = tmp_path_factory.mktemp("hs") / "s.json"
    path.write_text(json.dumps(data))
    before = {str(p): sha(p) for p in (path, trace)}
    capsys.readouterr()
    argv = (["evaluate", str(trace), str(path), "-Q", "5"] if cmd == "evaluate" else
            ["plan", str(path), "--start-obs", "0", "--goal-obs", "1"])
    rc = main(argv)
    if rc == 1 and cmd == "plan":  # a valid file whose goal is unreachable
        rc = 0
    _check(rc, capsys.readouterr().err, [path, trace], before)


def test_an_unwritable_out_folder_is_refused_before_any_work(tmp_path, capsys, monkeypatch):
    """A read-only folder (as root a chmod does not stop writing, so the probe's failure is
    simulated the way a read-only file system answers)."""
    import contextlib
    import errno

    from vggc_cp import safeio

    @contextlib.contextmanager
    def read_only(folder, prefix, suffix=""):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(folder))
        yield  # pragma: no cover

    monkeypatch.setattr(safeio, "temp_file", read_only)
    out = tmp_path / "study"
    rc = main(["robustness", "--out", str(out), "--benchmarks", "fruit-2x3", "--seeds", "0",
               "--tasks", "none"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "Read-only file system" in err
    assert not out.exists()
