"""The execution layer (``vggc_cp.parallel``): local, local processes and a real dask
``LocalCluster`` give the same results, cells and bytes; missing or inapplicable backends exit 2
with one line."""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from vggc_cp.cli import main
from vggc_cp.errors import VggcError
from vggc_cp.parallel import Backend, Executor, ProcessExecutor, open_executor
from vggc_cp.trace import load_trace
from vggc_cp.vision.distances import DistanceConfig, compute_distances_full
from vggc_cp.vision.sinkhorn import block_problems, row_blocks

DATA = Path(__file__).resolve().parent.parent / "data" / "fruit-2x3.npz"
HAS_DASK = importlib.util.find_spec("distributed") is not None
needs_dask = pytest.mark.skipif(not HAS_DASK, reason="dask.distributed is not installed")
#: CP-SAT settings that give the same answer on every run (one search worker, no time race).
CPSAT = "num_workers:1,max_time_in_seconds:60"


@pytest.fixture(scope="module")
def cluster():
    """A real dask cluster of two single-threaded workers, reached by its address (the path
    of an existing scheduler)."""
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None) as c:
        yield c.scheduler_address


def test_executors_keep_the_items_order():
    seen = []
    for ex in (Executor(), ProcessExecutor(2)):
        seen.clear()
        assert ex.map(abs, [-3, 1, -2, 5], lambda i, r: seen.append(i)) == [3, 1, 2, 5]
        assert sorted(seen) == [0, 1, 2, 3]


def test_backend_refuses_bad_settings():
    with pytest.raises(VggcError, match="local, dask, ray|dask, local, ray"):
        Backend("spark")
    with pytest.raises(VggcError, match="--scheduler applies"):
        Backend("local", scheduler="tcp://h:8786")
    with pytest.raises(VggcError, match="--jobs"):
        Backend("dask", jobs=0)


def test_scheduler_defaults_to_the_environment(monkeypatch):
    monkeypatch.setenv("VGGC_CP_SCHEDULER", "tcp://example:8786")
    assert Backend("dask").address == "tcp://example:8786"
    assert Backend("dask", scheduler="tcp://other:1").address == "tcp://other:1"
    assert Backend("local").address is None


def test_row_blocks_cover_every_pair_once_in_the_matrix_order():
    m = 11
    iu, ju = np.triu_indices(m, 1)
    src, dst = block_problems(m, 0, m)
    assert np.array_equal(src, np.concatenate([np.arange(m), iu]))
    assert np.array_equal(dst, np.concatenate([np.arange(m), ju]))
    pairs = [p for a, b in row_blocks(m, 4) for p in zip(*block_problems(m, a, b))]
    assert row_blocks(m, 4) == [(0, 4), (4, 8), (8, 11)] and row_blocks(m) == [(0, m)]
    assert sorted(pairs) == sorted(zip(src.tolist(), dst.tolist()))


@pytest.mark.skipif(importlib.util.find_spec("ray") is not None, reason="ray is installed here")
def test_missing_ray_says_how_to_install(tmp_path, capsys):
    rc = main(["compare", str(DATA), "--backend", "ray", "--quiet",
               "--cache-dir", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and "pip install ray" in err and err.count("\n") == 1
    assert not any(tmp_path.iterdir())  # refused before any work


@pytest.mark.slow
@needs_dask
def test_merge_solve_on_a_cluster_gives_the_local_graph(cluster, tmp_path):
    """``solve --backend dask`` (the default merge path, issue 27): the evidence's blocks on the
    cluster, the same labels and graph."""
    import json

    out = [tmp_path / "local.json", tmp_path / "dask.json"]
    assert main(["solve", str(DATA), "-o", str(out[0]), "--quiet"]) == 0
    assert main(["solve", str(DATA), "-o", str(out[1]), "--quiet", "--backend", "dask",
                 "--scheduler", cluster]) == 0
    a, b = (json.loads(p.read_text()) for p in out)
    assert a["labels"] == b["labels"] and a["edges"] == b["edges"]


@pytest.mark.slow
@needs_dask
def test_distance_blocks_on_a_cluster_equal_local(cluster):
    trace = load_trace(DATA)
    cfg = DistanceConfig(rows=9, use_cache=False)
    local = compute_distances_full(trace, cfg, progress=False)
    with open_executor(Backend("dask", scheduler=cluster)) as ex:
        remote = compute_distances_full(trace, cfg, progress=False, executor=ex)
    for a, b in ((local.dist_pick, remote.dist_pick), (local.dist_place, remote.dist_place)):
        assert a.shape == (28, 28) and np.array_equal(a, b)
    assert remote.stats["pick"]["problems"] == 28 * 29 // 2


@needs_dask
@pytest.mark.slow  # 7-16 s: the whole default grid twice
def test_compare_on_a_cluster_equals_local(cluster, tmp_path, capsys):
    def run(*extra):
        out = tmp_path / f"cmp{len(extra)}.csv"
        rc = main(["compare", str(DATA), "--quiet", "--cpsat-params", CPSAT,
                   "--cache-dir", str(tmp_path / "cache"), "--csv", str(out), *extra])
        assert rc == 0
        text = capsys.readouterr().out.splitlines()[2:-1]  # no seconds, no csv path
        rows = [{k: v for k, v in r.items() if not k.endswith("seconds")}
                for r in csv.DictReader(out.open())]
        return text, rows

    local = run()
    remote = run("--backend", "dask", "--scheduler", cluster)
    assert local == remote
    assert len(local[1]) == 400 and any(r["cpsat_status"] == "optimal" for r in local[1])


@needs_dask
@pytest.mark.slow  # 7-14 s
def test_greedy_solve_on_a_cluster_writes_the_same_bytes(cluster, tmp_path, capsys):
    paths = [tmp_path / "local.json", tmp_path / "dask.json"]
    common = ["--solver", "greedy", "--quiet", "--cache-dir", str(tmp_path / "cache")]
    assert main(["solve", str(DATA), "-o", str(paths[0]), *common]) == 0
    assert main(["solve", str(DATA), "-o", str(paths[1]), *common, "--backend", "dask",
                 "--scheduler", cluster]) == 0
    assert paths[0].read_bytes() == paths[1].read_bytes()


@pytest.mark.slow
@needs_dask
def test_default_learning_on_a_cluster_equals_local(cluster, monkeypatch):
    """The footprint evidence converts its frames in blocks on the cluster's workers (issue
    27): the same codes, tables and graph as in this process."""
    from vggc_cp.learned import LearnConfig
    from vggc_cp.pipeline import evidence_problem, learn_graph
    from vggc_cp.vision import working

    trace = load_trace(DATA).without_states()
    options = LearnConfig(evidence="footprints")
    local = learn_graph(trace, options)
    # blocks of 16 frames: the 56 frames of the shipped trace go out in 4 blocks
    monkeypatch.setattr(working, "BLOCK_FRAMES", 16)
    with open_executor(Backend("dask", scheduler=cluster)) as ex:
        frames = working.working_frames(trace.observations, ex)
        remote = learn_graph(trace, options, executor=ex)
        coded = evidence_problem(trace, "footprints", options, executor=ex)
    assert np.array_equal(frames, working.working_frames(trace.observations))
    assert np.array_equal(local.labels, remote.labels)
    assert local.confidence == remote.confidence
    assert np.array_equal(coded.table_pick, local.problem.table_pick)
    assert np.array_equal(coded.codes_place, local.problem.codes_place)


@pytest.mark.slow
@needs_dask
def test_frames_read_from_the_file_are_converted_on_the_cluster_in_waves(cluster, tmp_path,
                                                                         monkeypatch):
    """A trace too large to hold (its frames streamed from the file) is inflated here in one
    pass and converted on the workers wave by wave: the same working frames and graph as in
    this process, and the solution's hash computed beside it."""
    from dataclasses import replace

    from vggc_cp.frames import StreamedFrames
    from vggc_cp.learned import LearnConfig
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.trace import save_trace
    from vggc_cp.vision import working

    small = load_trace(DATA).without_states()
    big = replace(small, observations=small.observations.repeat(4, axis=1).repeat(4, axis=2))
    path = tmp_path / "big.npz"
    save_trace(big, path)
    want_hash = big.content_hash()
    options = LearnConfig(evidence="footprints")
    local = learn_graph(big, options)
    want = working.working_frames(big.observations)  # 64x64 again
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(big.observations.nbytes // 2))
    # blocks of 8 frames, waves of 3 blocks: the 56 frames go out in 3 waves, 7 blocks
    monkeypatch.setattr(working, "BLOCK_BYTES", 8 * 256 * 256 * 3)
    monkeypatch.setattr(working, "WAVE_BYTES", 24 * 256 * 256 * 3)
    from distributed import get_task_stream

    trace = load_trace(path)
    assert isinstance(trace.observations, StreamedFrames)
    with open_executor(Backend("dask", scheduler=cluster)) as ex:
        with get_task_stream(ex.client) as stream:
            frames = working.working_frames(trace.observations, ex)
        ran = [t["key"] for t in stream.data]
        assert len(ran) == 7 and all("_block_means_of" in str(k) for k in ran), ran
        remote = learn_graph(trace, options, executor=ex)
    assert np.array_equal(frames, want)
    assert np.array_equal(local.labels, remote.labels)
    assert trace.content_hash() == want_hash
