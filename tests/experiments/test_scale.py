"""``vggc-cp bench scale`` and its experiment module (issue 27)."""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.cli import main
from vggc_cp.errors import VggcError
from vggc_cp.experiments.scale import (
    COLUMNS,
    PeakMemory,
    ScaleConfig,
    growth_exponent,
    read_rows,
)


def test_growth_exponent_of_a_power_law():
    n = np.array([1500, 3000, 6000, 12000])
    assert growth_exponent(n, 0.01 * n ** 1.25) == pytest.approx(1.25)
    assert np.isnan(growth_exponent([10], [1.0]))


def test_settings_and_csv_are_checked(tmp_path):
    with pytest.raises(VggcError, match="sizes"):
        ScaleConfig((0,))
    assert ScaleConfig((3000, 1500)).sizes == (1500, 3000)
    bad = tmp_path / "s.csv"
    bad.write_text("a,b\n")
    with pytest.raises(VggcError, match="header"):
        read_rows(bad)
    bad.write_text(",".join(COLUMNS) + "\n1,2,3\n")
    with pytest.raises(VggcError, match="line 2"):
        read_rows(bad)


def test_peak_memory_sees_an_allocation():
    with PeakMemory() as mem:
        block = np.ones(64 << 20, dtype=np.uint8)  # 64 MiB, touched
        block[::4096] = 2
        del block
    assert mem.peak > 64 << 20


@pytest.mark.slow  # the whole CLI parser twice
def test_bad_options_exit_2_before_any_work(tmp_path, capsys):
    for flags in (["--sizes", "a,b"], ["--camera", "640x"], ["--repeats", "0"]):
        assert main(["bench", "scale", "--cache-dir", str(tmp_path), *flags]) == 2
        assert capsys.readouterr().err.count("\n") == 1
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_bench_scale_small(tmp_path, capsys):
    out = tmp_path / "scale.csv"
    assert main(["bench", "scale", "--sizes", "30,60", "--camera", "96x64",
                 "--camera-transitions", "30", "--repeats", "2", "--cache-dir",
                 str(tmp_path / "traces"), "--csv", str(out)]) == 0
    text = capsys.readouterr().out
    assert "growth         wall time ~ |D|^" in text and "camera         96x64" in text
    # the camera trace and the 64 px one at its |D|, each twice, alternately
    assert text.count("\n     30      ") == 1 + 4 and "fastest of each; runs " in text
    rows = read_rows(out)
    assert {(r["transitions"], r["width"]) for r in rows} == {(30, 64), (60, 64), (30, 96)}
    assert {r["stage"] for r in rows} == {"load", "evidence", "merge path", "confidence",
                                          "trace hash"}
    assert all(r["peak_bytes"] > 0 and r["nodes"] > 0 for r in rows)
    # the traces are generated once and reused
    assert main(["bench", "scale", "--sizes", "30", "--camera", "none", "--cache-dir",
                 str(tmp_path / "traces")]) == 0
    assert "cached" in capsys.readouterr().out
