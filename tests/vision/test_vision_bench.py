"""``vggc-cp bench distance`` at a small size (the figures themselves are in the notes)."""

from __future__ import annotations

import re

import pytest

from vggc_cp.cli import main


@pytest.mark.slow
def test_bench_distance_prints_rates_ratios_and_agreement(capsys):
    argv = ["bench", "distance", "--maps", "30", "--grid", "8", "--pairs", "300",
            "--naive-pairs", "6", "--batch-pairs", "12", "--threads", "1"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    for label in ("ours", "naive", "POT batched", "ratio naive", "ratio batched"):
        assert re.search(rf"^{label}\s+\d", out, re.M), label
    rel = float(re.search(r"max rel diff\s+(\S+)", out).group(1))
    assert rel < 1e-3
