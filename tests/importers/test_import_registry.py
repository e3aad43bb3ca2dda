"""The importer registry: the four layouts, a new layout reaching ``vggc-cp import`` by its
registration alone, a missing optional reader named with its install command, settings."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from recordings import SHIPPED, write_robomimic

from vggc_cp.cli import main
from vggc_cp.errors import UnknownNameError, VggcError
from vggc_cp.importers import (
    IMPORTERS,
    Argument,
    ImportConfig,
    Importer,
    get_importer,
    parse_size,
    register_importer,
)
from vggc_cp.importers.base import RecordingBuilder
from vggc_cp.trace import load_trace


def test_the_four_layouts_are_registered():
    assert set(IMPORTERS) >= {"images", "video", "robomimic", "lerobot"}
    with pytest.raises(UnknownNameError, match="known: images, lerobot, robomimic, video"):
        get_importer("zip")


def test_a_new_layout_needs_only_its_registration(tmp_path, capsys):
    source = load_trace(SHIPPED)

    def read_npy(config, array, every):
        b = RecordingBuilder(config)
        b.start_episode("only")
        frames = np.load(array)
        for t, image in enumerate(frames):
            b.add(image, None if t == len(frames) - 1 else
                  ("pick_a" if t % 2 == 0 else "place_a") * int(every), f"{array}: frame {t}")
        return b.trace({"format": "npy", "file": "x.npy"})

    register_importer(Importer("npy", "frames in a .npy file", "Frames in a .npy file.",
                               (Argument("array", "the .npy file"),
                                Argument("--every", "a flag")), read_npy))
    try:
        np.save(tmp_path / "x.npy", source.observations[:5])
        out = tmp_path / "t.npz"
        assert main(["import", "npy", str(tmp_path / "x.npy"), "--every", "1", "-o",
                     str(out)]) == 0
        t = load_trace(out)
        assert t.n_transitions == 4 and t.action_names == ("pick_a", "place_a")
    finally:
        IMPORTERS.pop("npy")


def test_a_missing_reader_names_the_extra(tmp_path, capsys, monkeypatch):
    f = write_robomimic(load_trace(SHIPPED), tmp_path / "d.hdf5")
    monkeypatch.setitem(sys.modules, "h5py", None)  # import h5py now raises ImportError
    rc = main(["import", "robomimic", str(f), "--camera", "agentview_image", "--labels",
               "action_labels", "-o", str(tmp_path / "t.npz")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and len(err.splitlines()) == 1
    assert "'h5py'" in err and "pip install -e '.[import]'" in err


def test_sizes_and_settings():
    assert parse_size("64") == (64, 64) and parse_size("96x48") == (96, 48)
    for bad in ("", "x", "1x2x3", "-4", "a"):
        with pytest.raises(VggcError, match="--size"):
            parse_size(bad) if bad != "-4" else ImportConfig(size=parse_size(bad))
    with pytest.raises(VggcError, match="at least"):
        ImportConfig(size=(2, 64))
    with pytest.raises(VggcError, match="neither 'pick' nor 'place'"):
        ImportConfig(label_map={"grasp": "grab"})


def test_the_last_label_of_an_episode_is_refused_or_ignored():
    frames = load_trace(SHIPPED).observations[:3]
    labels = ["pick_a", "place_a", "pick_a"]  # a label on the last frame too

    def build(last_label):
        b = RecordingBuilder(ImportConfig(), last_label=last_label)
        b.start_episode("e")
        for t, (image, label) in enumerate(zip(frames, labels)):
            b.add(image, label, f"rec: frame {t}")
        return b.trace({"format": "test", "file": "rec"})

    t = build("ignore")
    assert t.actions.tolist() == [0, 1] and t.action_names == ("pick_a", "place_a")
    with pytest.raises(VggcError, match=r"rec: frame 2: action 'pick_a' on the last frame"):
        build("empty")
