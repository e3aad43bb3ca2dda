"""``vggc-cp generate | envs | render | bench generate``."""

from __future__ import annotations

import numpy as np

from vggc_cp.cli import main
from vggc_cp.trace import load_trace


def test_envs_lists_every_benchmark(capsys):
    assert main(["envs"]) == 0
    out = capsys.readouterr().out
    assert "fruit-6x8" in out and "blocks-3" in out
    line = next(x for x in out.splitlines() if x.startswith("multifruit-4x6"))
    assert line.split()[1:9] == ["4", "2", "6", "24", "210", "58", "400", "keypoints"]
    assert line.endswith("2-8 from 1 home")
    blocks = next(x for x in out.splitlines() if x.startswith("blocks-2"))
    assert blocks.split()[8] == "saliency"


def test_generate_unknown_benchmark_exits_2(tmp_path, capsys):
    assert main(["generate", "fruit-9x9", "-o", str(tmp_path / "t.npz")]) == 2
    err = capsys.readouterr().err
    assert "unknown benchmark" in err and "fruit-2x3" in err
    assert not (tmp_path / "t.npz").exists()


def test_generate_bad_size_exits_2(tmp_path, capsys):
    assert main(["generate", "fruit-2x3", "-o", str(tmp_path / "t.npz"), "--size", "3"]) == 2
    assert "--size" in capsys.readouterr().err


def test_generate_then_render(tmp_path, capsys):
    out = tmp_path / "t.npz"
    assert main(["generate", "blocks-2", "-o", str(out), "--transitions", "9", "--size", "32",
                 "--seed", "4", "--novel", "5", "--quiet"]) == 0
    tr = load_trace(out)
    assert tr.n_transitions == 9 and tr.meta["seed"] == 4
    with np.load(tmp_path / "t.novel.npz") as data:
        assert data["observations"].shape == (5, 32, 32, 3)
    sheet = tmp_path / "sheet.png"
    assert main(["render", str(out), "-o", str(sheet), "--max", "6"]) == 0
    assert sheet.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["render", str(tmp_path / "missing.npz"), "-o", str(sheet)]) == 2


def test_bench_generate_prints_time_and_ratio(capsys):
    assert main(["bench", "generate", "--transitions", "20", "--size", "32"]) == 0
    out = capsys.readouterr().out
    assert "ms per frame" in out and "ratio" in out


def test_generate_beyond_the_memory_cap_renders_into_a_file(tmp_path, capsys, monkeypatch):
    """Frames of more than VGGC_CP_MAX_BYTES are rendered into a temporary file beside the
    output and written in pieces: the same bytes, nothing left behind; the frame cap still
    bounds them."""
    held = tmp_path / "held.npz"
    argv = ["generate", "fruit-2x3", "--transitions", "30", "--size", "96x80", "--quiet"]
    assert main([*argv, "-o", str(held)]) == 0
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", "100000")  # 31 frames of 96x80: 714,240 bytes
    out = tmp_path / "out"
    out.mkdir()
    assert main([*argv, "-o", str(out / "t.npz")]) == 0
    assert (out / "t.npz").read_bytes() == held.read_bytes()
    assert [p.name for p in out.iterdir()] == ["t.npz"]
    monkeypatch.setenv("VGGC_CP_MAX_FRAME_BYTES", "100000")
    assert main([*argv, "-o", str(out / "u.npz")]) == 2
    assert "VGGC_CP_MAX_FRAME_BYTES" in capsys.readouterr().err
