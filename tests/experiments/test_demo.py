"""``vggc-cp demo`` end to end (slow: renders, distances, sweep, training)."""

from __future__ import annotations

import pytest

from vggc_cp.cli import main


@pytest.mark.slow
def test_demo_reaches_the_goal_and_draws_a_strip(tmp_path, capsys):
    pytest.importorskip("pybullet")
    out = tmp_path / "demo.png"
    rc = main(["demo", "-o", str(out), "--seed", "0", "--threads", "1", "--quiet",
               "--workdir", str(tmp_path / "work")])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "reached goal   yes" in text
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for name in ("fruit-2x3.npz", "solution.json", "localizer.pt", "start.png", "goal.png"):
        assert (tmp_path / "work" / name).is_file()
