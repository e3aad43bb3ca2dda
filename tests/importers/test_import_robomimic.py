"""``vggc-cp import robomimic``: fruit-2x3 written as robomimic HDF5 (demos numbered so that
their natural order is not their names' order), imported back with string labels and with
integer labels plus a names attribute; malformed files refused naming the dataset."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from recordings import SHIPPED, assert_same_trace, refused, run, solved_graph, write_robomimic

from vggc_cp.trace import load_trace

ARGS = ("--camera", "agentview_image", "--labels", "action_labels")


@pytest.mark.slow
def test_round_trip_with_string_labels_solves_to_the_same_graph(original, tmp_path, capsys):
    f = write_robomimic(original, tmp_path / "demos.hdf5")
    out = tmp_path / "t.npz"
    rc, text, _ = run(capsys, "robomimic", f, *ARGS, "-o", out)
    assert rc == 0 and "6 episodes" in text
    got = load_trace(out)
    assert_same_trace(got, original)
    assert got.meta["source"] == {"format": "robomimic", "file": "demos.hdf5",
                                  "camera": "agentview_image", "labels": "action_labels",
                                  "frames": 56, "episodes": 6}
    assert solved_graph(out, tmp_path / "b.json") == solved_graph(SHIPPED, tmp_path / "a.json")


def test_integer_labels_with_names_one_per_transition_and_states(original, tmp_path, capsys):
    f = write_robomimic(original, tmp_path / "demos.hdf5", int_labels=True)
    with h5py.File(f, "a") as h:
        for e, (first, last) in enumerate(original.episodes()):
            h.create_dataset(f"data/demo_{2 ** e}/states",
                             data=original.states[first:last + 1].astype(object),
                             dtype=h5py.string_dtype())
    out = tmp_path / "t.npz"
    assert run(capsys, "robomimic", f, *ARGS, "--states", "states", "-o", out,
               "--quiet")[0] == 0
    assert_same_trace(load_trace(out), original, states=True)


@pytest.fixture
def demos(original, tmp_path):
    return write_robomimic(original, tmp_path / "demos.hdf5")


def test_wrong_camera_key(demos, tmp_path, capsys):
    line = refused(capsys, tmp_path / "t.npz", "robomimic", demos, "--camera", "eye",
                   "--labels", "action_labels")
    assert f"{demos}: data/demo_1/obs/eye: no such dataset (data/demo_1/obs holds: " \
           f"agentview_image)" in line


def test_wrong_labels_key(demos, tmp_path, capsys):
    line = refused(capsys, tmp_path / "t.npz", "robomimic", demos, "--camera",
                   "agentview_image", "--labels", "labels")
    assert f"{demos}: data/demo_1/labels: no such dataset" in line and "action_labels" in line


def test_bad_label_in_a_demo(demos, tmp_path, capsys):
    with h5py.File(demos, "a") as f:
        ds = f["data/demo_4/action_labels"]
        labels = ds.asstr()[()]
        labels[3] = "grasp"
        del f["data/demo_4/action_labels"]
        f.create_dataset("data/demo_4/action_labels", data=labels.astype(object),
                         dtype=h5py.string_dtype())
    line = refused(capsys, tmp_path / "t.npz", "robomimic", demos, *ARGS)
    assert f"{demos}: data/demo_4/obs/agentview_image[3]: action label 'grasp'" in line


def test_frames_not_images_and_labels_of_wrong_length(demos, tmp_path, capsys):
    with h5py.File(demos, "a") as f:
        del f["data/demo_2/obs/agentview_image"]
        f.create_dataset("data/demo_2/obs/agentview_image", data=np.zeros((5, 8, 8), np.float32))
    line = refused(capsys, tmp_path / "t.npz", "robomimic", demos, *ARGS)
    assert f"{demos}: data/demo_2/obs/agentview_image: dtype float32" in line
    with h5py.File(demos, "a") as f:
        del f["data/demo_2"]
        f.create_dataset("data/demo_2/obs/agentview_image", data=np.zeros((5, 8, 8, 3), np.uint8))
        f.create_dataset("data/demo_2/action_labels", data=np.zeros(9, np.int64))
    line = refused(capsys, tmp_path / "t.npz", "robomimic", demos, *ARGS)
    assert f"{demos}: data/demo_2/action_labels: shape (9,), expected (5,) or (4,)" in line


def test_not_hdf5_and_no_demos(tmp_path, capsys):
    fake = tmp_path / "x.hdf5"
    fake.write_bytes(b"nope" * 100)
    line = refused(capsys, tmp_path / "t.npz", "robomimic", fake, *ARGS)
    assert f"{fake}: not a readable HDF5 file" in line
    empty = tmp_path / "e.hdf5"
    with h5py.File(empty, "w") as f:
        f.create_group("data/mask")
    line = refused(capsys, tmp_path / "t.npz", "robomimic", empty, *ARGS)
    assert f"{empty}: data holds no demo_K group (it holds: mask)" in line
