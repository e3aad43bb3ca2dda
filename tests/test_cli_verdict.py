"""``vggc-cp doubts`` and ``vggc-cp suggest`` end to end on the shipped fruit-2x3 trace."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vggc_cp.cli import main
from vggc_cp.sim.tasks import get_benchmark
from vggc_cp.solution import labels_solution, write_solution
from vggc_cp.solvers.doubts import MERGE, Doubt
from vggc_cp.trace import load_trace

SHIPPED = Path(__file__).resolve().parents[1] / "data" / "fruit-2x3.npz"


@pytest.fixture(scope="module")
def trace():
    return load_trace(SHIPPED)


def _solution(trace, folder, doubts=None, name="s.json"):
    _, labels = np.unique(trace.states, return_inverse=True)
    extra = {"trace_sha256": trace.content_hash()}
    if doubts is not None:
        extra["doubts"] = doubts
    path = folder / name
    write_solution(path, labels_solution(trace, labels, **extra))
    return path, labels


def _merge_doubt(trace, labels):
    pick = sorted({int(u) for u in labels[trace.roles() == 0]})
    a, b = pick[0], pick[1]
    obs = [tuple(int(o) for o in np.flatnonzero(labels == u)[:3]) for u in (a, b)]
    return Doubt(MERGE, (a, b), tuple(obs), {"distance": 0.05, "threshold": 0.04,
                                             "dl_change": 0.01, "thresholds_apart": 20,
                                             "thresholds_together": 4}).as_dict()


def _read_doubt(trace, labels, sites=("pick_red_0", "place_red_0")):
    rec = _merge_doubt(trace, labels)
    rec["evidence"].update(read_sites=list(sites), read_kappa=0.2)
    return rec


@pytest.mark.slow  # matplotlib's first figure
def test_doubts_draws_one_row_per_doubt(trace, tmp_path, capsys):
    _, labels = _solution(trace, tmp_path)
    sol, _ = _solution(trace, tmp_path, [_merge_doubt(trace, labels), _read_doubt(trace, labels)],
                       "d.json")
    out = tmp_path / "doubts.png"
    assert main(["doubts", str(sol), str(SHIPPED), "-o", str(out)]) == 0
    assert "2 doubt(s)" in capsys.readouterr().out
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow  # matplotlib's first figure
def test_doubts_draws_the_first_n_and_says_of_how_many(trace, tmp_path, capsys):
    """A solution lists more doubts than a sheet should hold (up to DoubtRule.listed):
    ``--first N`` draws the N most pressing and says how many there are; ``--first 0`` all;
    a negative N is refused in one line."""
    _, labels = _solution(trace, tmp_path)
    sol, _ = _solution(trace, tmp_path, [_merge_doubt(trace, labels)] * 3, "d.json")
    out = tmp_path / "doubts.png"
    assert main(["doubts", str(sol), str(SHIPPED), "-o", str(out), "--first", "2"]) == 0
    assert "(2 of 3 doubt(s))" in capsys.readouterr().out
    small = out.read_bytes()
    assert main(["doubts", str(sol), str(SHIPPED), "-o", str(out), "--first", "0"]) == 0
    assert "(3 doubt(s))" in capsys.readouterr().out
    assert out.read_bytes() != small
    assert main(["doubts", str(sol), str(SHIPPED), "-o", str(tmp_path / "x.png"),
                 "--first", "-1"]) == 2
    err = capsys.readouterr().err
    assert "--first" in err and "Traceback" not in err
    assert not (tmp_path / "x.png").exists()


def test_solve_prints_the_first_doubts_and_counts_the_rest(trace, tmp_path, capsys):
    """The doubts table after a solve holds SHOWN_DOUBTS rows; the rest are counted and
    left to the solution (``suggest`` reads them all)."""
    from vggc_cp.cli.solve_cmds import _print_doubts
    from vggc_cp.solvers.doubt_text import SHOWN_DOUBTS
    from vggc_cp.solvers.doubts import parse_doubts

    _, labels = _solution(trace, tmp_path)
    doubts = parse_doubts([_merge_doubt(trace, labels)] * (SHOWN_DOUBTS + 3))
    _print_doubts(doubts)
    out = capsys.readouterr().out
    assert f"{SHOWN_DOUBTS + 3} decision(s)" in out
    assert "... and 3 more in the solution" in out
    assert sum(line.lstrip().startswith(f"{SHOWN_DOUBTS - 1} ") for line in out.splitlines()) == 1
    assert not any(line.lstrip().startswith(f"{SHOWN_DOUBTS} ") for line in out.splitlines())
    _print_doubts(doubts[:SHOWN_DOUBTS])
    assert "more in the solution" not in capsys.readouterr().out


def test_a_read_doubt_is_outlined_where_its_sites_lie(trace, tmp_path):
    """The sheet outlines a read doubt's sites: the footprint sites of the actions it names,
    summed (an action the trace does not have counts nothing); a doubt without read sites,
    and a sheet without read doubts, get no outline."""
    from vggc_cp.cli.verdict_cmds import _read_outlines
    from vggc_cp.solvers.doubts import parse_doubts
    from vggc_cp.vision.footprints import action_footprints

    _, labels = _solution(trace, tmp_path)
    plain = _merge_doubt(trace, labels)
    assert _read_outlines(trace, parse_doubts([plain])) is None
    name = next(n for n in trace.action_names if n.startswith("pick"))
    doubts = parse_doubts([plain, _read_doubt(trace, labels, (name, "pick_nothing_9"))])
    none, outline = _read_outlines(trace, doubts)
    assert none is None
    site = action_footprints(trace.without_states()).sites[trace.action_names.index(name)]
    np.testing.assert_allclose(outline, site)
    assert outline.max() > 0


def test_no_doubts_writes_nothing(trace, tmp_path, capsys):
    sol, _ = _solution(trace, tmp_path)  # a solution without the field is read as none
    out = tmp_path / "doubts.png"
    assert main(["doubts", str(sol), str(SHIPPED), "-o", str(out)]) == 0
    assert "no doubts" in capsys.readouterr().out and not out.exists()
    assert main(["suggest", str(sol), str(SHIPPED), "-o", str(tmp_path / "n.json")]) == 0
    doc = json.loads((tmp_path / "n.json").read_text())
    assert doc["episodes"] == [] and doc["trace_sha256"] == trace.content_hash()


def test_suggest_writes_episodes_whose_plans_execute(trace, tmp_path, capsys):
    _, labels = _solution(trace, tmp_path)
    sol, _ = _solution(trace, tmp_path, [_merge_doubt(trace, labels)], "d.json")
    out = tmp_path / "next.json"
    assert main(["suggest", str(sol), str(SHIPPED), "-o", str(out), "--max-episodes", "4"]) == 0
    assert "episode(s)" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    assert doc["format"] == "vggc-episodes/1" and 1 <= len(doc["episodes"]) <= 4
    bench = get_benchmark(trace.meta["benchmark"])
    for ep in doc["episodes"]:
        valid, _ = bench.apply(str(trace.states[ep["start_observation"]]), ep["actions"])
        assert all(valid[:-1]) and ep["doubt"] == 0


@pytest.mark.parametrize("bad, field", [
    ([{"kind": "merge", "nodes": [0, 99], "observations": [[0], [1]], "evidence": {}}],
     "doubts[0].nodes"),
    ([{"kind": "split", "nodes": [0], "observations": [[0], [10**6]], "evidence": {}}],
     "doubts[0].observations"),
    ([{"kind": "unsure", "nodes": [0], "observations": [[0], [1]]}], "doubts[0].kind"),
])
def test_bad_doubts_are_refused_in_one_line(trace, tmp_path, capsys, bad, field):
    sol, _ = _solution(trace, tmp_path, bad, "bad.json")
    out = tmp_path / "next.json"
    assert main(["suggest", str(sol), str(SHIPPED), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0] and not out.exists()


@pytest.mark.slow
def test_solve_suggest_append_solve(trace, tmp_path, capsys):
    """The loop on the shipped trace: solve prints its doubts table (or says there is none),
    suggest proposes episodes for a doubt, generate records them, and solve runs again on the
    longer trace, whose first observations are the shipped ones."""
    s0, t1, s1 = tmp_path / "s0.json", tmp_path / "t1.npz", tmp_path / "s1.json"
    nxt = tmp_path / "next.json"
    assert main(["solve", str(SHIPPED), "-o", str(s0), "--evidence", "footprints",
                 "--quiet"]) == 0
    assert "\ndoubts " in capsys.readouterr().out
    assert isinstance(json.loads(s0.read_text())["doubts"], list)
    _, labels = _solution(trace, tmp_path)
    sol, _ = _solution(trace, tmp_path, [_merge_doubt(trace, labels)], "d.json")
    assert main(["suggest", str(sol), str(SHIPPED), "-o", str(nxt)]) == 0
    assert json.loads(nxt.read_text())["episodes"]
    assert main(["generate", "--episodes", str(nxt), "--append", str(SHIPPED), "-o",
                 str(t1), "--quiet"]) == 0
    longer = load_trace(t1)
    assert longer.n_transitions > trace.n_transitions
    np.testing.assert_array_equal(longer.observations[:trace.n_obs], trace.observations)
    assert main(["solve", str(t1), "-o", str(s1), "--evidence", "footprints", "--quiet"]) == 0
