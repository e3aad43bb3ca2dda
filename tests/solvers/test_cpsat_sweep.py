"""The exact CP-SAT grid sweep, its comparison with greedy, the compare CLI and its plot."""

from __future__ import annotations

import numpy as np
import pytest
from test_cpsat import EPISODES, NAMES, chain_problem  # same folder (rootdir-relative import mode)

from vggc_cp.graph import check
from vggc_cp.solvers.base import FEASIBLE, INFEASIBLE, OPTIMAL
from vggc_cp.solvers.brute import enumerate_cell
from vggc_cp.solvers.cpsat import (
    CpSatSolver,
    compare_records,
    exact_sweep,
    node_frontier,
)
from vggc_cp.solvers.greedy import GreedySolver
from vggc_cp.solvers.sweep import run_sweep
from vggc_cp.trace import PICK

FAST = "max_time_in_seconds:20,num_workers:1"


def _problem():
    # two visual groups per role (distance 0.05 inside, 1 across) on the hand-made episodes
    eps = EPISODES + [["pick_R", "place_R"]]
    p0 = chain_problem(eps, NAMES)
    rng = np.random.default_rng(0)
    groups = [rng.integers(0, 2, size=p0.n_pick), rng.integers(0, 2, size=p0.n_place)]

    def dist(role, i, j):
        g = groups[0 if role == PICK else 1]
        return 0.05 + 0.01 * ((i + j) % 3) if g[i] == g[j] else 1.0

    return chain_problem(eps, NAMES, dist)


@pytest.mark.parametrize("optimize", ["minimal", pytest.param("all", marks=pytest.mark.slow)])
def test_exact_sweep_decides_every_cell_like_brute_force(optimize):
    p = _problem()
    kp, kq = range(1, 5), range(1, 4)
    greedy = run_sweep(p, GreedySolver(), kp, kq)
    sweep = exact_sweep(p, kp, kq, CpSatSolver(params=FAST), greedy.results, optimize=optimize)
    assert len(sweep.results) == len(kp) * len(kq)
    by_cell = {(r.k_pick, r.k_place): r for r in sweep.results}
    for (a, b), r in by_cell.items():
        brute = enumerate_cell(p, a, b)
        assert r.status != "unknown"
        assert (r.status == INFEASIBLE) == (not brute.feasible), (a, b, r.stats)
        if r.found:
            assert check(p.graph(r.labels)).ok
            assert r.J >= brute.J - 1e-9
            g = greedy.cell(a, b)
            if g.found:  # never worse than the greedy colouring of the cell
                assert r.J <= g.J + 1e-12
        if r.status == OPTIMAL:
            assert r.J <= brute.J + r.stats["quantization_margin"]
    if optimize == "all":
        assert all(r.status in (OPTIMAL, INFEASIBLE) for r in sweep.results)
    front = node_frontier(sweep)
    assert front.proved
    best = sweep.best
    assert best is not None and best.n_nodes == front.nodes and best.status == OPTIMAL
    rows = compare_records(greedy, sweep)
    assert len(rows) == len(sweep.results)
    assert {"greedy_feasible", "greedy_J", "cpsat_status", "cpsat_J", "bound", "gap",
            "cpsat_seconds", "variables", "constraints"} <= set(rows[0])


def test_feasibility_only_sweep_has_no_bounds():
    p = _problem()
    sweep = exact_sweep(p, range(1, 4), range(1, 4),
                        CpSatSolver(params=FAST, objective="none"), ())
    assert all(r.status in (FEASIBLE, INFEASIBLE) for r in sweep.results)
    assert all(r.bound is None for r in sweep.results)
    for r in sweep.results:
        assert r.found == enumerate_cell(p, r.k_pick, r.k_place).feasible


def test_progress_bars_have_their_totals_from_the_start(capsys):
    p = _problem()
    exact_sweep(p, range(1, 4), range(1, 5), CpSatSolver(params=FAST), (), progress=True)
    err = capsys.readouterr().err
    assert "cpsat frontier:   0%|          | 0/3 [" in err  # one step per k_pick row
    assert "cpsat J:   0%|          | 0/1 [" in err  # the cells of the fewest nodes


def test_compare_plot(tmp_path):
    from vggc_cp.plots import plot_compare_grids

    p = _problem()
    kp, kq = range(1, 4), range(1, 4)
    greedy = run_sweep(p, GreedySolver(), kp, kq)
    sweep = exact_sweep(p, kp, kq, CpSatSolver(params=FAST), greedy.results)
    k1, k2, jg = greedy.j_matrix()
    _, _, jc = sweep.j_matrix()
    out = tmp_path / "cmp.png"
    plot_compare_grids(k1, k2, jg, jc, {(r.k_pick, r.k_place): r.status for r in sweep.results},
                       out, selected=[None, (sweep.best.k_pick, sweep.best.k_place)], title="t")
    assert out.stat().st_size > 1000


def test_sweep_with_undecided_cells_stays_sound():
    """Starved of time, cells end undecided; the bisection past them claims nothing false."""
    p = _problem()
    kp, kq = range(1, 5), range(1, 6)
    greedy = run_sweep(p, GreedySolver(), kp, kq)
    starved = CpSatSolver(params="max_time_in_seconds:0.0,num_workers:1")
    sweep = exact_sweep(p, kp, kq, starved, greedy.results)
    assert len(sweep.results) == len(kp) * len(kq)
    for r in sweep.results:
        brute = enumerate_cell(p, r.k_pick, r.k_place)
        if r.status == INFEASIBLE:
            assert not brute.feasible
        if r.found:
            assert brute.feasible and check(p.graph(r.labels)).ok
            assert r.J >= brute.J - 1e-9
        g = greedy.cell(r.k_pick, r.k_place)
        if g.found:
            assert r.found and r.J <= g.J + 1e-12
