"""The research studies behind ``notebooks/``: each returns pandas DataFrames, nothing is drawn.

* :func:`feasibility_study` — when does a trace admit a structurally valid abstraction? For
  every ``|D|`` and seed, the ``(k_pick, k_place)`` grid ``1..k_max`` squared decided by the
  greedy solver (a colouring or nothing) and by CP-SAT (:func:`~vggc_cp.solvers.cpsat.exact_sweep`
  with ``objective="none"``: a colouring or an infeasibility *proof* per cell), optionally also
  under ``deterministic`` (one node and one action lead to one node); the exact minimal total
  ``K = k_pick + k_place`` and whether it is proved minimal.
* :func:`heuristic_vs_exact` — per benchmark: greedy and CP-SAT over the default grid, the J gap
  cell by cell, proved optimality, runtime, and the planning metrics of both selected graphs.
* :func:`scalability_study` — TransCov / TransPrec of both solvers' graphs against ``|D|`` and the
  runtime split: visual distances vs colouring search.

Every study builds its problems with :func:`make_instance` (simulator trace, visual distances
from :func:`vggc_cp.vision.compute_distances`, cached on disk) and treats the ground-truth
``states`` only through :mod:`vggc_cp.evaluate` and the count of visited states.

Minimal total K. Feasibility is monotone in both k (splitting a node never breaks
Exactly-One), so the smallest feasible ``k_pick + k_place`` of the grid is the fewest nodes a
valid abstraction can have; it is *proved* minimal when every grid cell of smaller total is
proved infeasible (the grid starts at 1, so no smaller cell is missing).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from vggc_cp.solvers.base import INFEASIBLE, OPTIMAL, Problem, SolveResult
from vggc_cp.trace import Trace

#: ``trace -> (dist_pick, dist_place)``; tests pass a cheap stand-in for the visual distances.
DistanceFn = Callable[[Trace], tuple[np.ndarray, np.ndarray]]
MODELS = ("base", "deterministic")


# ---------------------------------------------------------------- instances


@dataclass(frozen=True, eq=False)
class Instance:
    """One simulator trace with its problem.

    Attributes
    ----------
    benchmark : str
    transitions : int
        ``|D|``.
    seed : int
    trace : Trace
        With ground-truth ``states`` (read only by evaluation and :attr:`states_visited`).
    problem : Problem
        Built from the trace without its states.
    distance_seconds : float
        Time the visual distances took (attention + Sinkhorn), also when they came from the
        cache (the time recorded when they were computed).
    distance_cached : bool
    """

    benchmark: str
    transitions: int
    seed: int
    trace: Trace
    problem: Problem
    distance_seconds: float
    distance_cached: bool

    @property
    def states_visited(self) -> int:
        """``|V*|``: distinct ground-truth states the trace visits."""
        return int(len(np.unique(self.trace.states)))


def make_instance(benchmark: str, transitions: int, seed: int, *, size: int = 64,
                  distances=None, cache_dir=None) -> Instance:
    """Generate a trace with :func:`vggc_cp.sim.explore.generate` and its visual distances.

    Parameters
    ----------
    benchmark : str
    transitions : int
        ``|D|``.
    seed : int
    size : int
        Image side in pixels.
    distances : DistanceConfig, DistanceFn or None
        A :class:`vggc_cp.vision.DistanceConfig` (None: the default one), or any callable
        ``trace -> (dist_pick, dist_place)``.
    cache_dir : path, optional
        Distance cache folder (``compute_distances``' default when None).
    """
    from vggc_cp.sim.explore import generate

    trace = generate(benchmark, int(transitions), int(seed), int(size)).trace
    blind = trace.without_states()
    if callable(distances):
        t0 = time.perf_counter()
        dp, dq = distances(blind)
        return Instance(benchmark, int(transitions), int(seed), trace,
                        Problem.from_trace(blind, dp, dq), time.perf_counter() - t0, False)
    from vggc_cp.pipeline import visual_problem

    vp = visual_problem(blind, distances, cache_dir=cache_dir)
    return Instance(benchmark, int(transitions), int(seed), trace, vp.problem,
                    vp.compute_seconds, vp.cached)


def _params(time_limit: float, workers: int) -> str:
    return f"max_time_in_seconds:{float(time_limit)},num_workers:{int(workers)}"


def _bar(total: int, desc: str, progress: bool):
    if not progress:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, leave=False)


# ---------------------------------------------------------------- feasibility


@dataclass(frozen=True, eq=False)
class FeasibilityStudy:
    """What :func:`feasibility_study` returns.

    Attributes
    ----------
    cells : DataFrame
        One row per ``(transitions, seed, model, solver, k_pick, k_place)``: ``status``,
        ``feasible``, ``proved_infeasible``, ``decided_by`` (``solved``, ``inferred from
        (a, b)``, ``undecided``; greedy: ``solved``) and ``reason`` (the proof of an infeasible
        cell: a presolve argument, a CP-SAT search, or the dominating proved cell).
    summary : DataFrame
        One row per ``(transitions, seed, model)``: ``states`` visited, observations,
        ``a_pick, a_place`` (distinct actions), ``greedy_min_K``, ``cpsat_min_K``,
        ``proved_minimal``, ``min_cells`` (cells of the minimal total), counts of cells proved
        infeasible by ``proofs_presolve`` (the model's exact presolve) and ``proofs_cpsat``
        (a CP-SAT solve), ``inferred`` (dominated by a proved cell) and ``undecided`` cells,
        and the seconds of distances, greedy and CP-SAT.
    """

    cells: pd.DataFrame
    summary: pd.DataFrame


def _reason(r: SolveResult) -> str:
    decided = r.stats.get("decided_by", "")
    if r.status != INFEASIBLE:
        return ""
    if decided.startswith("inferred"):
        return decided
    if r.stats.get("status_name") == "PRESOLVE_INFEASIBLE":
        notes = r.stats.get("notes") or ["presolve"]
        return f"presolve: {notes[-1]}"
    return f"CP-SAT proof ({r.stats.get('conflicts', 0)} conflicts)"


def min_total(results: Sequence[SolveResult]) -> tuple[float, list]:
    """Smallest ``k_pick + k_place`` of a cell with a colouring, and those cells (NaN, [])."""
    found = [(r.k_pick + r.k_place, (r.k_pick, r.k_place)) for r in results if r.found]
    if not found:
        return math.nan, []
    low = min(t for t, _ in found)
    return low, sorted(c for t, c in found if t == low)


def feasibility_instance(inst: Instance, k_max: int, *, time_limit: float = 5.0,
                         workers: int = 2, models: Sequence[str] = MODELS
                         ) -> tuple[list[dict], list[dict]]:
    """Cells and summary rows of one instance (see :class:`FeasibilityStudy`)."""
    from vggc_cp.pipeline import greedy_then_exact
    from vggc_cp.solvers.brute import CellConstraints, split_colours, violations
    from vggc_cp.solvers.cpsat import CpSatSolver
    from vggc_cp.solvers.greedy import GreedySolver
    from vggc_cp.solvers.sweep import action_counts, run_sweep

    for m in models:
        if m not in MODELS:
            raise ValueError(f"unknown model {m!r}; known: {', '.join(MODELS)}")
    problem = inst.problem
    ks = range(1, int(k_max) + 1)
    greedy = run_sweep(problem, GreedySolver(), ks, ks)
    a_pick, a_place = action_counts(problem)
    base = {"benchmark": inst.benchmark, "transitions": inst.transitions, "seed": inst.seed}
    cells, summary = [], []
    for model in models:
        det = model == "deterministic"
        cons = CellConstraints(deterministic=det)
        g_ok = {}
        for r in greedy.results:
            ok = r.found and not (det and violations(problem, *split_colours(problem, r.labels),
                                                     cons))
            g_ok[(r.k_pick, r.k_place)] = ok
            cells.append(base | {"model": model, "solver": "greedy", "k_pick": r.k_pick,
                                 "k_place": r.k_place, "status": r.status if ok else "unknown",
                                 "feasible": ok, "proved_infeasible": False,
                                 "decided_by": "solved", "reason": ""})
        solver = CpSatSolver(objective="none", deterministic=det,
                             params=_params(time_limit, workers), hint="none")
        exact = greedy_then_exact(problem, ks, ks, solver, greedy=greedy).exact
        for r in exact.results:
            cells.append(base | {"model": model, "solver": "cpsat", "k_pick": r.k_pick,
                                 "k_place": r.k_place, "status": r.status, "feasible": r.found,
                                 "proved_infeasible": r.status == INFEASIBLE,
                                 "decided_by": r.stats.get("decided_by", ""),
                                 "reason": _reason(r)})
        g_min = min(((a + b) for (a, b), ok in g_ok.items() if ok), default=math.nan)
        c_min, c_cells = min_total(exact.results)
        below = [r for r in exact.results if r.k_pick + r.k_place < c_min]
        reasons = [_reason(r) for r in exact.results if r.status == INFEASIBLE]
        summary.append(base | {
            "model": model, "states": inst.states_visited, "observations": problem.n_obs,
            "a_pick": a_pick, "a_place": a_place, "greedy_min_K": g_min, "cpsat_min_K": c_min,
            "proved_minimal": bool(c_cells) and all(r.status == INFEASIBLE for r in below),
            "min_cells": " ".join(f"({a},{b})" for a, b in c_cells),
            "greedy_cells": int(sum(g_ok.values())),
            "cpsat_cells": int(sum(r.found for r in exact.results)),
            "proofs_presolve": sum(s.startswith("presolve") for s in reasons),
            "proofs_cpsat": sum(s.startswith("CP-SAT") for s in reasons),
            "inferred": sum(s.startswith("inferred") for s in reasons),
            "undecided": sum(r.status not in (INFEASIBLE,) and not r.found
                             for r in exact.results),
            "seconds_distances": inst.distance_seconds, "seconds_greedy": greedy.seconds,
            "seconds_cpsat": exact.seconds,
        })
    return cells, summary


def feasibility_study(sizes: Sequence[int], seeds: Sequence[int], *,
                      benchmark: str = "fruit-4x6", k_max: int = 16, time_limit: float = 5.0,
                      workers: int = 2, models: Sequence[str] = MODELS, size: int = 64,
                      distances=None, cache_dir=None, progress: bool = False
                      ) -> FeasibilityStudy:
    """The feasible region of the grid ``1..k_max`` squared for every ``|D|`` and seed.

    Parameters
    ----------
    sizes, seeds : sequences of int
        ``|D|`` values and seeds.
    benchmark : str
    k_max : int
        Largest ``k_pick`` and ``k_place`` of the grid.
    time_limit : float
        CP-SAT seconds per solved cell (an unfinished cell is ``unknown``).
    workers : int
        CP-SAT workers.
    models : sequence of {'base', 'deterministic'}
    size, distances, cache_dir :
        See :func:`make_instance`.
    """
    cells, summary = [], []
    bar = _bar(len(sizes) * len(seeds), "feasibility", progress)
    for d in sizes:
        for seed in seeds:
            inst = make_instance(benchmark, d, seed, size=size, distances=distances,
                                 cache_dir=cache_dir)
            c, s = feasibility_instance(inst, k_max, time_limit=time_limit, workers=workers,
                                        models=models)
            cells += c
            summary += s
            if bar is not None:
                bar.update(1)
    if bar is not None:
        bar.close()
    return FeasibilityStudy(pd.DataFrame.from_records(cells), pd.DataFrame.from_records(summary))


def feasible_fraction(cells: pd.DataFrame, transitions: int, model: str, solver: str
                      ) -> tuple[list[int], list[int], np.ndarray, np.ndarray]:
    """Heatmap data of one panel: ``(k_pick values, k_place values, share of seeds with a
    colouring, share of seeds proved infeasible)``, matrices of shape (len(kp), len(kq))."""
    sel = cells[(cells.transitions == transitions) & (cells.model == model)
                & (cells.solver == solver)]
    kp, kq = sorted(sel.k_pick.unique()), sorted(sel.k_place.unique())
    feas = sel.pivot_table(index="k_pick", columns="k_place", values="feasible",
                           aggfunc="mean").reindex(index=kp, columns=kq)
    proof = sel.pivot_table(index="k_pick", columns="k_place", values="proved_infeasible",
                            aggfunc="mean").reindex(index=kp, columns=kq)
    return ([int(k) for k in kp], [int(k) for k in kq], feas.to_numpy(float),
            proof.to_numpy(float))


def proof_table(study: FeasibilityStudy, transitions: int, model: str = "base",
                seed: int | None = None) -> pd.DataFrame:
    """CP-SAT's infeasible cells at ``|D| = transitions`` with their proof (one seed or all),
    solved proofs first; inferred cells only summarize which proved cell dominates them."""
    c = study.cells
    sel = c[(c.transitions == transitions) & (c.model == model) & (c.solver == "cpsat")
            & c.proved_infeasible]
    if seed is not None:
        sel = sel[sel.seed == seed]
    sel = sel.assign(solved=~sel.reason.str.startswith("inferred"))
    return (sel.sort_values(["seed", "solved", "k_pick", "k_place"],
                            ascending=[True, False, True, True])
            [["seed", "k_pick", "k_place", "reason"]].reset_index(drop=True))


# ---------------------------------------------------------------- heuristic vs exact


@dataclass(frozen=True, eq=False)
class HeuristicVsExact:
    """What :func:`heuristic_vs_exact` returns.

    Attributes
    ----------
    cells : DataFrame
        :func:`~vggc_cp.solvers.cpsat.compare_records` of every instance, with ``benchmark``,
        ``seed`` and ``J_gap = (greedy_J - cpsat_J) / greedy_J`` where both have a colouring.
    summary : DataFrame
        One row per ``(benchmark, seed, solver)``: the selected cell, ``nodes``, ``J``,
        ``status``, ``proved_optimal`` (CP-SAT: the selected cell proved optimal),
        ``proved_min_nodes`` (no grid cell of fewer nodes has a colouring, proved),
        ``seconds_distances``, ``seconds_search`` (CP-SAT: greedy sweep included, its hints),
        ``J_gap_selected`` (greedy's selected J relative to CP-SAT's), the mean and max cell
        gap over cells where CP-SAT optimized J and greedy has a colouring, and the planning
        metrics ``opt_path, any_path, trans_prec, trans_cov, exec``.
    """

    cells: pd.DataFrame
    summary: pd.DataFrame


METRICS = ("opt_path", "any_path", "trans_prec", "trans_cov", "exec")


def _metrics(inst: Instance, result: SolveResult | None, queries: int) -> dict:
    from vggc_cp.evaluate import evaluate_trace

    if result is None or not result.found:
        return {m: math.nan for m in METRICS} | {"edges": 0}
    graph = inst.problem.graph(result.labels)
    metrics, _ = evaluate_trace(inst.trace, graph, result.labels, n_queries=queries, seed=0)
    return {m: getattr(metrics, m) for m in METRICS} | {"edges": graph.n_edges}


def solve_both(inst: Instance, *, time_limit: float = 10.0, workers: int = 2,
               grid=None, optimize: str = "minimal"):
    """``(greedy sweep, CP-SAT exact sweep, greedy seconds, CP-SAT seconds)`` on one grid.

    The grid is :func:`~vggc_cp.solvers.sweep.default_grid` unless ``grid = (kp, kq)``; CP-SAT
    is warm-started by the greedy sweep, and its seconds include it.
    """
    from vggc_cp.pipeline import greedy_then_exact
    from vggc_cp.solvers.cpsat import CpSatSolver
    from vggc_cp.solvers.sweep import default_grid

    kp, kq = grid if grid is not None else default_grid(inst.problem)
    solver = CpSatSolver(objective="J", params=_params(time_limit, workers))
    sweeps = greedy_then_exact(inst.problem, kp, kq, solver, optimize=optimize)
    return sweeps.greedy, sweeps.exact, sweeps.greedy.seconds, sweeps.seconds


def heuristic_vs_exact(benchmarks: Sequence[str], seeds: Sequence[int] = (0,), *,
                       transitions=None, time_limit: float = 10.0, workers: int = 2,
                       queries: int = 1500, size: int = 64, distances=None, cache_dir=None,
                       progress: bool = False) -> HeuristicVsExact:
    """Greedy against CP-SAT on every benchmark (default grid, fewest-nodes selection).

    Parameters
    ----------
    benchmarks : sequence of str
    seeds : sequence of int
    transitions : int, dict or None
        ``|D|`` of every trace, per benchmark (dict; missing ones: the paper's), or the paper's.
    time_limit : float
        CP-SAT seconds per solved cell.
    queries : int
        Q of the planning metrics.
    """
    from vggc_cp.pipeline import GridSweeps, node_frontiers
    from vggc_cp.sim import get_spec
    from vggc_cp.solvers.cpsat import compare_records

    cells, summary = [], []
    bar = _bar(len(benchmarks) * len(seeds), "benchmarks", progress)
    for bench in benchmarks:
        if isinstance(transitions, dict):
            d = transitions.get(bench) or get_spec(bench).default_transitions
        else:
            d = transitions or get_spec(bench).default_transitions
        for seed in seeds:
            inst = make_instance(bench, d, seed, size=size, distances=distances,
                                 cache_dir=cache_dir)
            greedy, exact, t_g, t_c = solve_both(inst, time_limit=time_limit, workers=workers)
            base = {"benchmark": bench, "transitions": d, "seed": int(seed)}
            rows = compare_records(greedy, exact)
            for row in rows:
                gap = math.nan
                if row["greedy_J"] is not None and row["cpsat_J"] is not None \
                        and row["greedy_J"] > 0:
                    gap = (row["greedy_J"] - row["cpsat_J"]) / row["greedy_J"]
                cells.append(base | row | {"J_gap": gap})
            solved = [r for r in rows if r["decided_by"] == "solved"
                      and r["cpsat_J"] is not None and r["greedy_J"] is not None
                      and r["bound"] is not None]
            gaps = [(r["greedy_J"] - r["cpsat_J"]) / r["greedy_J"] for r in solved
                    if r["greedy_J"] > 0]
            g_best, c_best = greedy.best, exact.best
            sel_gap = math.nan
            if g_best is not None and c_best is not None and g_best.J > 0:
                sel_gap = (g_best.J - c_best.J) / g_best.J
            g_front, c_front = node_frontiers(inst.problem, GridSweeps(greedy, exact))
            for name, sweep, best, front, secs in (("greedy", greedy, g_best, g_front, t_g),
                                                   ("cpsat", exact, c_best, c_front, t_c)):
                summary.append(base | {
                    "solver": name, "states": inst.states_visited,
                    "k_pick": None if best is None else best.k_pick,
                    "k_place": None if best is None else best.k_place,
                    "nodes": 0 if best is None else best.n_nodes,
                    "J": math.nan if best is None else best.J,
                    "status": "none" if best is None else best.status,
                    "proved_optimal": best is not None and best.status == OPTIMAL,
                    "proved_min_nodes": front.proved,
                    "cells_with_colouring": sum(r.found for r in sweep.results),
                    "seconds_distances": inst.distance_seconds, "seconds_search": secs,
                    "J_gap_selected": sel_gap,
                    "J_gap_cells_mean": float(np.mean(gaps)) if gaps else math.nan,
                    "J_gap_cells_max": float(np.max(gaps)) if gaps else math.nan,
                    "gap_cells": len(gaps),
                } | _metrics(inst, best, queries))
            if bar is not None:
                bar.update(1)
    if bar is not None:
        bar.close()
    return HeuristicVsExact(pd.DataFrame.from_records(cells), pd.DataFrame.from_records(summary))


# ---------------------------------------------------------------- scalability


def scalability_study(sizes: Sequence[int], seeds: Sequence[int] = (0,), *,
                      benchmark: str = "fruit-4x6", time_limit: float = 10.0, workers: int = 2,
                      queries: int = 1500, size: int = 64, distances=None, cache_dir=None,
                      progress: bool = False) -> pd.DataFrame:
    """TransCov / TransPrec and the runtime split of both solvers against ``|D|``.

    Returns
    -------
    DataFrame
        One row per ``(transitions, seed, solver)``: ``states``, ``nodes``, ``status``,
        ``seconds_distances`` (attention + Sinkhorn, shared by both solvers),
        ``seconds_search`` (the default-grid sweep; CP-SAT's includes the greedy sweep that
        warm-starts it), ``seconds_total`` and the planning metrics.
    """
    rows = []
    bar = _bar(len(sizes) * len(seeds), "scalability", progress)
    for d in sizes:
        for seed in seeds:
            inst = make_instance(benchmark, d, seed, size=size, distances=distances,
                                 cache_dir=cache_dir)
            greedy, exact, t_g, t_c = solve_both(inst, time_limit=time_limit, workers=workers)
            for name, best, secs in (("greedy", greedy.best, t_g), ("cpsat", exact.best, t_c)):
                rows.append({
                    "benchmark": benchmark, "transitions": int(d), "seed": int(seed),
                    "solver": name, "states": inst.states_visited,
                    "observations": inst.problem.n_obs,
                    "nodes": 0 if best is None else best.n_nodes,
                    "status": "none" if best is None else best.status,
                    "seconds_distances": inst.distance_seconds, "seconds_search": secs,
                    "seconds_total": inst.distance_seconds + secs,
                } | _metrics(inst, best, queries))
            if bar is not None:
                bar.update(1)
    if bar is not None:
        bar.close()
    return pd.DataFrame.from_records(rows)


__all__ = ["MODELS", "METRICS", "FeasibilityStudy", "HeuristicVsExact", "Instance",
           "feasibility_instance", "feasibility_study", "feasible_fraction",
           "heuristic_vs_exact", "make_instance", "min_total", "proof_table",
           "scalability_study", "solve_both"]
