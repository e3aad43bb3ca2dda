"""``vggc-cp import images``: fruit-2x3 written as PNGs + a log, imported back bit-exact, and
solved to the same graph; malformed logs refused with one line naming the row."""

from __future__ import annotations

import json

import numpy as np
import pytest
from recordings import (
    SHIPPED,
    after,
    assert_same_trace,
    refused,
    run,
    solved_graph,
    write_images_layout,
    write_log,
    write_png,
)

from vggc_cp.cli import main
from vggc_cp.importers import ImportConfig, import_recording
from vggc_cp.trace import load_trace


@pytest.fixture(scope="module")
def layout(original, tmp_path_factory):
    return write_images_layout(original, tmp_path_factory.mktemp("images"), states=True)


def test_round_trip_is_bit_exact_and_solves_to_the_same_graph(original, layout, tmp_path,
                                                              capsys):
    out = tmp_path / "t.npz"
    rc, text, _ = run(capsys, "images", layout, "-o", out)
    assert rc == 0 and "N = 56" in text and "|D| = 50" in text and "6 episodes" in text
    got = load_trace(out)
    assert_same_trace(got, original, states=True)
    assert got.meta["source"] == {"format": "images", "file": "log.csv", "frames": 56,
                                  "episodes": 6}
    assert main(["inspect", str(out)]) == 0
    assert solved_graph(out, tmp_path / "b.json") == solved_graph(SHIPPED, tmp_path / "a.json")


def test_same_recording_same_bytes_and_jsonl_reads_alike(original, layout, tmp_path, capsys):
    a, b = tmp_path / "a.npz", tmp_path / "b.npz"
    assert run(capsys, "images", layout, "-o", a, "--quiet")[0] == 0
    assert run(capsys, "images", layout, "-o", b, "--quiet")[0] == 0
    assert a.read_bytes() == b.read_bytes()
    rows = [dict(zip(("frame", "action", "episode"), line.split(",")))
            for line in layout.read_text().splitlines()[1:]]
    jl = write_log(layout.parent / "log.jsonl", rows)
    c = tmp_path / "c.npz"
    assert run(capsys, "images", jl, "-o", c, "--quiet")[0] == 0
    assert_same_trace(load_trace(c), original)


def test_size_downsamples_by_area_average(original, layout):
    t = import_recording("images", ImportConfig(size=(32, 32)), log=layout)
    want = original.observations.reshape(56, 32, 2, 32, 2, 3).astype(float).mean(axis=(2, 4))
    assert t.observations.shape == (56, 32, 32, 3) and t.meta["source"]["size"] == [32, 32]
    assert np.abs(t.observations.astype(float) - want).max() <= 1  # fixed-point rounding
    wide = import_recording("images", ImportConfig(size=(32, 16)), log=layout)
    assert wide.image_shape == (16, 32)


def test_label_map_from_json_and_csv(original, tmp_path, capsys):
    rec = tmp_path / "rec"
    log = write_images_layout(original, rec)
    rename = {n: f"grip_{n}" for n in original.action_names}
    text = log.read_text()
    for name, label in rename.items():
        text = text.replace(f",{name},", f",{label},")
    log.write_text(text)
    out = tmp_path / "t.npz"
    refused(capsys, out, "images", log)  # labels that are not pick/place need a map
    (tmp_path / "map.json").write_text(json.dumps({v: k for k, v in rename.items()}))
    assert run(capsys, "images", log, "-o", out, "--map", tmp_path / "map.json")[0] == 0
    assert_same_trace(load_trace(out), original)
    assert load_trace(out).meta["source"]["map"] == "map.json"
    (tmp_path / "map.csv").write_text("label,action\n" + "".join(
        f"{v},{k}\n" for k, v in rename.items()))
    out2 = tmp_path / "t2.npz"
    assert run(capsys, "images", log, "-o", out2, "--map", tmp_path / "map.csv")[0] == 0
    assert_same_trace(load_trace(out2), original)


# ------------------------------------------------------------------ malformed input


@pytest.fixture
def small(original, tmp_path):
    """The first two episodes as PNGs; returns (folder, rows) for a test to damage."""
    folder = tmp_path / "rec"
    (folder / "f").mkdir(parents=True)
    last = original.episodes()[1][1]
    acts, eps = after(original), original.episode_index()
    rows = []
    for t in range(last + 1):
        write_png(folder / "f" / f"{t}.png", original.observations[t])
        rows.append({"frame": f"f/{t}.png", "action": acts[t], "episode": str(eps[t])})
    return folder, rows


def damaged(small, change, suffix=".csv"):
    folder, rows = small
    rows = [dict(r) for r in rows]
    change(rows)
    return write_log(folder / f"log{suffix}", rows)


def test_missing_column(small, tmp_path, capsys):
    folder, rows = small
    log = folder / "log.csv"
    log.write_text("frame,action\n" + "".join(f"{r['frame']},{r['action']}\n" for r in rows))
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: no column 'episode'" in line


def test_missing_frame_file(small, tmp_path, capsys):
    log = damaged(small, lambda rows: rows[3].update(frame="f/nope.png"))
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: row 4: frame" in line and "nope.png" in line and "no such file" in line


def test_not_an_image(small, tmp_path, capsys):
    (small[0] / "f" / "2.png").write_bytes(b"not a png")
    log = damaged(small, lambda rows: None)
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: row 3: frame" in line and "not a readable image" in line


def test_bad_action_label(small, tmp_path, capsys):
    log = damaged(small, lambda rows: rows[5].update(action="grasp"))
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: row 6: action label 'grasp'" in line and "--map" in line


def test_two_picks_in_a_row(small, original, tmp_path, capsys):
    def two_picks(rows):
        rows[1]["action"] = rows[0]["action"]  # rows[0] is a pick: now rows[1] is one too
    log = damaged(small, two_picks)
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: row 2: action" in line and "two picks in a row" in line


def test_action_on_an_episode_last_frame_and_none_inside(small, tmp_path, capsys):
    last0 = [r["episode"] for r in small[1]].count("0")  # rows of episode 0
    log = damaged(small, lambda rows: rows[last0 - 1].update(action=rows[0]["action"]))
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"row {last0}: action" in line and "last frame of episode '0'" in line
    log = damaged(small, lambda rows: rows[2].update(action=""))
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: row 3: no action" in line


def test_episode_that_comes_back(small, tmp_path, capsys):
    log = damaged(small, lambda rows: rows[-1].update(episode="0"))
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"row {len(small[1])}: episode '0' appears again" in line


def test_frames_of_two_sizes(small, tmp_path, capsys):
    write_png(small[0] / "f" / "4.png", np.zeros((32, 32, 3), np.uint8))
    log = damaged(small, lambda rows: None)
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: row 5: the frame is 32x32" in line and "--size" in line


def test_jsonl_row_without_a_key_and_bad_json(small, tmp_path, capsys):
    log = damaged(small, lambda rows: rows[2].pop("episode"), suffix=".jsonl")
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: row 3: no key 'episode'" in line
    log.write_text(log.read_text().replace("{", "[", 1))
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: row 1" in line


def test_csv_row_with_too_few_fields(small, tmp_path, capsys):
    log = damaged(small, lambda rows: None)
    lines = log.read_text().splitlines()
    lines[4] = lines[4].rsplit(",", 1)[0]
    log.write_text("\n".join(lines) + "\n")
    line = refused(capsys, tmp_path / "t.npz", "images", log)
    assert f"{log}: row 4: 2 fields, the header has 3" in line


def test_bad_size_and_map_options(small, tmp_path, capsys):
    log = damaged(small, lambda rows: None)
    assert "--size 'big'" in refused(capsys, tmp_path / "t.npz", "images", log, "--size", "big")
    line = refused(capsys, tmp_path / "t.npz", "images", log, "--size", "128")
    assert "row 1" in line and "only downsamples" in line
    bad = tmp_path / "map.json"
    bad.write_text(json.dumps({"grasp": "grab"}))
    line = refused(capsys, tmp_path / "t.npz", "images", log, "--map", bad)
    assert f"{bad}: key 'grasp': maps 'grasp' to 'grab'" in line


def test_output_may_not_replace_the_log(small, capsys):
    log = damaged(small, lambda rows: None)
    before = log.read_bytes()
    rc, _, err = run(capsys, "images", log, "-o", log)
    assert rc == 2 and "same file as the input" in err and log.read_bytes() == before


def test_frames_beyond_the_memory_cap_spill_to_a_temporary_file(original, layout, tmp_path,
                                                                 capsys, monkeypatch):
    """A recording whose frames exceed VGGC_CP_MAX_BYTES is imported through a temporary file
    beside the output (vggc_cp.frames.FrameSpool): the same bytes, no file left behind; the
    library without a spool file refuses it, naming the frame and the cap."""
    held = tmp_path / "held.npz"
    assert run(capsys, "images", layout, "-o", held, "--quiet")[0] == 0
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(original.observations.nbytes // 3))
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    spilled = out_dir / "spilled.npz"
    assert run(capsys, "images", layout, "-o", spilled, "--quiet")[0] == 0
    assert spilled.read_bytes() == held.read_bytes()
    assert sorted(p.name for p in out_dir.iterdir()) == ["spilled.npz"]
    with pytest.raises(Exception, match=r"VGGC_CP_MAX_BYTES"):
        import_recording("images", ImportConfig(), log=layout)
