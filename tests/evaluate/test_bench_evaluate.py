"""``vggc-cp bench evaluate`` runs on a given trace and the two computations agree."""

from __future__ import annotations

from conftest import make_trace
from test_metrics import EPISODES, NAMES

from vggc_cp.cli import main
from vggc_cp.evaluate import GroundTruth
from vggc_cp.evaluate.bench import bench_evaluate, coarse_labels
from vggc_cp.trace import save_trace


def test_bench_evaluate_agrees_with_enumeration(tmp_path, capsys):
    trace = make_trace(EPISODES, NAMES)
    gt = GroundTruth.from_trace(trace)
    res = bench_evaluate(trace, coarse_labels(gt, trace.roles(), 2), n_queries=300,
                         reference_queries=50)
    assert res.agree and res.queries == 300 and res.reference_queries == 50
    path = tmp_path / "t.npz"
    save_trace(trace, path)
    assert main(["bench", "evaluate", "--trace", str(path), "-Q", "100"]) == 0
    out = capsys.readouterr().out
    assert out.count("agree: True") == 3 and "ratio" in out
