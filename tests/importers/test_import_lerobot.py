"""``vggc-cp import lerobot``: fruit-2x3 written as a LeRobot dataset folder (v3.0: one
parquet and one mp4 for all episodes, located through meta/episodes; v2.1: one of each per
episode), imported back bit-exact; malformed folders refused naming the file and row."""

from __future__ import annotations

import json

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from recordings import CAMERA, SHIPPED, assert_same_trace, refused, run, solved_graph, write_lerobot

from vggc_cp.trace import load_trace

ARGS = ("--camera", CAMERA, "--labels", "action_label")


@pytest.mark.slow
def test_v3_round_trip_solves_to_the_same_graph(original, tmp_path, capsys):
    folder = write_lerobot(original, tmp_path / "ds")
    out = tmp_path / "t.npz"
    rc, text, _ = run(capsys, "lerobot", folder, *ARGS, "-o", out)
    assert rc == 0 and "6 episodes" in text
    got = load_trace(out)
    assert_same_trace(got, original)
    assert got.meta["source"] == {"format": "lerobot", "file": "ds", "camera": CAMERA,
                                  "labels": "action_label", "codebase_version": "v3.0",
                                  "frames": 56, "episodes": 6}
    assert solved_graph(out, tmp_path / "b.json") == solved_graph(SHIPPED, tmp_path / "a.json")


def test_v2_round_trip(original, tmp_path, capsys):
    folder = write_lerobot(original, tmp_path / "ds", version="v2.1")
    out = tmp_path / "t.npz"
    assert run(capsys, "lerobot", folder, *ARGS, "-o", out, "--quiet")[0] == 0
    assert_same_trace(load_trace(out), original)


@pytest.fixture(scope="module")
def dataset(original, tmp_path_factory):
    return write_lerobot(original, tmp_path_factory.mktemp("lerobot") / "ds")


def copy_of(dataset, tmp_path):
    import shutil

    return shutil.copytree(dataset, tmp_path / "ds")


def rewrite(path, change):
    table = pq.read_table(path)
    cols = {n: table.column(n).to_pylist() for n in table.column_names}
    change(cols)
    pq.write_table(pa.table({n: pa.array(v, table.schema.field(n).type)
                             for n, v in cols.items() if n in table.column_names}), path)


DATA = "data/chunk-000/file-000.parquet"


def test_missing_label_column_and_camera(dataset, tmp_path, capsys):
    line = refused(capsys, tmp_path / "t.npz", "lerobot", dataset, "--camera", CAMERA,
                   "--labels", "skill")
    assert f"{dataset / DATA}: no column 'skill' (columns: " in line
    line = refused(capsys, tmp_path / "t.npz", "lerobot", dataset, "--camera", "wrist",
                   "--labels", "action_label")
    assert "meta/info.json: no feature 'wrist' (cameras: observation.images.top)" in line


def test_missing_frame_index_column(dataset, tmp_path, capsys):
    ds = copy_of(dataset, tmp_path)
    table = pq.read_table(ds / DATA).drop_columns(["frame_index"])
    pq.write_table(table, ds / DATA)
    line = refused(capsys, tmp_path / "t.npz", "lerobot", ds, *ARGS)
    assert f"{ds / DATA}: no column 'frame_index'" in line


def test_bad_label_and_frame_gap(dataset, tmp_path, capsys):
    ds = copy_of(dataset, tmp_path)
    rewrite(ds / DATA, lambda c: c["action_label"].__setitem__(12, "grasp"))
    line = refused(capsys, tmp_path / "t.npz", "lerobot", ds, *ARGS)
    assert "data/chunk-000/file-000.parquet: row 12 (episode 1, frame" in line
    assert "action label 'grasp'" in line
    rewrite(ds / DATA, lambda c: (c["action_label"].__setitem__(12, "place_red_0"),
                                  c["frame_index"].__setitem__(3, 7)))
    line = refused(capsys, tmp_path / "t.npz", "lerobot", ds, *ARGS)
    assert "data/chunk-000/file-000.parquet: row" in line and "expected 3" in line


def test_timestamp_beyond_the_video(dataset, tmp_path, capsys):
    ds = copy_of(dataset, tmp_path)
    rewrite(ds / DATA, lambda c: c["timestamp"].__setitem__(-1, 99.0))
    line = refused(capsys, tmp_path / "t.npz", "lerobot", ds, *ARGS)
    assert "data/chunk-000/file-000.parquet: row 55 (episode 5, frame" in line
    assert "no frame of" in line and "file-000.mp4 at time" in line


def test_not_a_dataset_and_a_template_leading_out(dataset, tmp_path, capsys):
    line = refused(capsys, tmp_path / "t.npz", "lerobot", tmp_path, *ARGS)
    assert f"{tmp_path}: no meta/info.json" in line
    ds = copy_of(dataset, tmp_path)
    info = json.loads((ds / "meta/info.json").read_text())
    info["video_path"] = "../../{video_key}.mp4"
    (ds / "meta/info.json").write_text(json.dumps(info))
    line = refused(capsys, tmp_path / "t.npz", "lerobot", ds, *ARGS)
    assert "leads out of the dataset folder" in line


def test_image_features_in_parquet_and_a_states_column(original, tmp_path, capsys):
    """A camera of dtype ``image`` (PNG bytes in the parquet rows) and ``--states``."""
    import io

    from PIL import Image

    ds = write_lerobot(original, tmp_path / "ds", version="v2.1")
    info = json.loads((ds / "meta/info.json").read_text())
    info["features"][CAMERA]["dtype"] = "image"
    (ds / "meta/info.json").write_text(json.dumps(info))
    for e, (first, last) in enumerate(original.episodes()):
        path = ds / f"data/chunk-000/episode_{e:06d}.parquet"
        table = pq.read_table(path)
        pngs = []
        for image in original.observations[first:last + 1]:
            buf = io.BytesIO()
            Image.fromarray(image).save(buf, format="PNG")
            pngs.append({"bytes": buf.getvalue(), "path": None})
        table = table.append_column(CAMERA, pa.array(
            pngs, pa.struct([("bytes", pa.binary()), ("path", pa.string())])))
        table = table.append_column("state", pa.array(
            [str(s) for s in original.states[first:last + 1]], pa.string()))
        pq.write_table(table, path)
    (ds / "videos").rename(tmp_path / "no-videos")  # the frames come from the parquet rows
    out = tmp_path / "t.npz"
    assert run(capsys, "lerobot", ds, *ARGS, "--states", "state", "-o", out)[0] == 0
    assert_same_trace(load_trace(out), original, states=True)


@pytest.mark.slow
def test_av1_video_as_lerobot_writes_it(original, tmp_path, capsys):
    """LeRobot's default codec (AV1, yuv420p) is lossy: the frames come back close, the
    actions and episodes exactly."""
    import numpy as np

    ds = write_lerobot(original, tmp_path / "ds", av1=True)
    out = tmp_path / "t.npz"
    assert run(capsys, "lerobot", ds, *ARGS, "-o", out, "--quiet")[0] == 0
    got = load_trace(out)
    assert got.observations.shape == original.observations.shape
    assert got.action_names == original.action_names and got.episodes() == original.episodes()
    np.testing.assert_array_equal(got.actions, original.actions)
    error = np.abs(got.observations.astype(int) - original.observations.astype(int))
    assert error.mean() < 8
