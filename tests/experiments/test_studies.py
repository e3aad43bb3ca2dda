"""The research studies (vggc_cp.experiments.studies) on tiny traces, with a cheap pixel distance."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vggc_cp import plots
from vggc_cp.experiments import studies
from vggc_cp.solvers import Problem
from vggc_cp.trace import PICK, PLACE


def pixel_distances(trace):
    """Euclidean pixel distance within each role (a stand-in for the visual distances)."""
    x = trace.observations.reshape(trace.n_obs, -1).astype(float) / 255.0
    roles = trace.roles()
    out = []
    for role in (PICK, PLACE):
        y = x[roles == role]
        sq = (y ** 2).sum(1)
        out.append(np.sqrt(np.maximum(sq[:, None] + sq[None] - 2 * y @ y.T, 0.0)))
    return tuple(out)


def toy_instance(trace):
    dp, dq = pixel_distances(trace)
    return studies.Instance("handmade", trace.n_transitions, 0, trace,
                            Problem.from_trace(trace.without_states(), dp, dq), 0.0, False)


@pytest.fixture(scope="module")
def small_study():
    return studies.feasibility_study([12], [0, 1], benchmark="fruit-2x3", k_max=4,
                                     time_limit=2.0, workers=1, size=16,
                                     distances=pixel_distances)


def test_toy_minimal_total_is_proved(toy_trace):
    cells, summary = studies.feasibility_instance(toy_instance(toy_trace), 3, time_limit=2.0,
                                                  workers=1)
    by_model = {s["model"]: s for s in summary}
    assert set(by_model) == set(studies.MODELS)
    base, det = by_model["base"], by_model["deterministic"]
    # L and R are pick states, H the only place state: two pick colours and one place colour
    # with distinct edges per pair are needed and suffice.
    assert base["cpsat_min_K"] == 3 and base["proved_minimal"]
    assert det["cpsat_min_K"] >= base["cpsat_min_K"]
    assert base["states"] == 3
    # every cell of smaller total is proved infeasible, with a reason
    for c in cells:
        if c["solver"] == "cpsat" and c["model"] == "base" and c["k_pick"] + c["k_place"] < 3:
            assert c["proved_infeasible"] and c["reason"]


def test_cpsat_region_contains_greedy_region(small_study):
    c = small_study.cells
    for model in studies.MODELS:
        g = c[(c.model == model) & (c.solver == "greedy")].set_index(["transitions", "seed",
                                                                       "k_pick", "k_place"])
        x = c[(c.model == model) & (c.solver == "cpsat")].set_index(["transitions", "seed",
                                                                      "k_pick", "k_place"])
        assert len(g) == len(x) == 2 * 16
        assert not (g.feasible & ~x.feasible).any()
        assert not (x.feasible & x.proved_infeasible).any()


def test_feasible_region_is_monotone(small_study):
    c = small_study.cells
    x = c[(c.solver == "cpsat") & (c.model == "base") & (c.seed == 0)]
    ok = {(r.k_pick, r.k_place): r.feasible for r in x.itertuples()}
    for (a, b), f in ok.items():
        if f:
            assert ok.get((a + 1, b), True) and ok.get((a, b + 1), True)


def test_summary_minimum_matches_cells(small_study):
    c, s = small_study.cells, small_study.summary
    assert len(s) == 2 * len(studies.MODELS)
    for row in s.itertuples():
        x = c[(c.solver == "cpsat") & (c.model == row.model) & (c.seed == row.seed)]
        found = x[x.feasible]
        expect = (found.k_pick + found.k_place).min() if len(found) else math.nan
        assert (math.isnan(expect) and math.isnan(row.cpsat_min_K)) or expect == row.cpsat_min_K
        if row.proved_minimal:
            below = x[x.k_pick + x.k_place < row.cpsat_min_K]
            assert below.proved_infeasible.all()
        assert row.states >= 1 and row.seconds_cpsat >= 0


def test_heatmap_data_and_proofs(small_study, tmp_path):
    kp, kq, feas, proved = studies.feasible_fraction(small_study.cells, 12, "base", "cpsat")
    assert kp == kq == [1, 2, 3, 4]
    assert feas.shape == proved.shape == (4, 4)
    assert ((feas >= 0) & (feas <= 1)).all() and (feas + proved <= 1 + 1e-9).all()
    table = studies.proof_table(small_study, 12, "base")
    assert list(table.columns) == ["seed", "k_pick", "k_place", "reason"]
    assert table.reason.str.len().gt(0).all()
    panel = {"k_pick": kp, "k_place": kq, "feasible": feas, "proved": proved, "title": "t"}
    plots.plot_feasibility_heatmaps([[panel, panel], [panel]], tmp_path / "h.png")
    s = small_study.summary
    plots.plot_min_k([{"label": "cpsat", "transitions": s.transitions, "states": s.states,
                       "K": s.cpsat_min_K, "proved": s.proved_minimal}], tmp_path / "k.png")
    assert (tmp_path / "h.png").stat().st_size > 0 and (tmp_path / "k.png").stat().st_size > 0


def test_heuristic_vs_exact_rows(tmp_path):
    hve = studies.heuristic_vs_exact(["fruit-2x3"], [0], transitions=14, time_limit=2.0,
                                     workers=1, queries=20, size=16, distances=pixel_distances)
    s = hve.summary
    assert list(s.solver) == ["greedy", "cpsat"]
    g, x = s.iloc[0], s.iloc[1]
    assert x.nodes <= g.nodes or g.nodes == 0
    for m in studies.METRICS:
        assert 0.0 <= x[m] <= 1.0
    cells = hve.cells
    both = cells[cells.greedy_J.notna() & cells.cpsat_J.notna() & (cells.decided_by == "solved")]
    assert (both.cpsat_J <= both.greedy_J + 1e-6).all()
    labels = ["fruit-2x3"]
    plots.plot_metric_panels(labels, {"TransCov": {"greedy": [g.trans_cov], "cpsat":
                                                   [x.trans_cov]}}, tmp_path / "m.png")
    plots.plot_solver_bars(labels, {"greedy": [1.0], "cpsat": [2.0]}, tmp_path / "b.png",
                           log=True)
    assert (tmp_path / "m.png").exists() and (tmp_path / "b.png").exists()


def test_scalability_rows(tmp_path):
    df = studies.scalability_study([10, 16], [0], benchmark="fruit-2x3", time_limit=2.0,
                                   workers=1, queries=20, size=16, distances=pixel_distances)
    assert len(df) == 4
    assert set(df.solver) == {"greedy", "cpsat"}
    assert (df.seconds_search >= 0).all() and (df.seconds_distances >= 0).all()
    assert (df.seconds_total >= df.seconds_search).all()
    ds = sorted(df.transitions.unique())
    plots.plot_scalability(ds, {"TransCov greedy": [0.5, 0.6], "TransPrec greedy": [1, 1]},
                           {"greedy": {"distances": [0.1, 0.2], "search": [0.3, 0.4]}},
                           tmp_path / "s.png")
    assert (tmp_path / "s.png").exists()


def test_unknown_model_is_rejected(toy_trace):
    with pytest.raises(ValueError, match="unknown model"):
        studies.feasibility_instance(toy_instance(toy_trace), 2, models=("nope",))


@pytest.mark.slow
def test_bench_solve_times_the_default_the_footprints_alone_and_the_previous_default():
    from pathlib import Path

    from vggc_cp.experiments.perf import bench_solve
    from vggc_cp.trace import load_trace

    trace = load_trace(Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz")
    t = bench_solve(trace.without_states(), repeats=2)
    assert t.repeats == 2
    assert t.default_nodes == t.footprints_nodes == 6 and t.default_evidence == "footprints"
    assert t.default_seconds > 0 and t.footprints_seconds > 0 and t.previous_seconds > 0
    assert t.footprints_ratio == t.default_seconds / t.footprints_seconds


def test_bench_solve_needs_one_run_at_least(toy_trace):
    from vggc_cp.experiments.perf import bench_solve

    with pytest.raises(ValueError, match="repeats must be at least 1"):
        bench_solve(toy_trace, repeats=0)
