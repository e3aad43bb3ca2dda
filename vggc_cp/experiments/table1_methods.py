"""The methods of the Table 1 run (:mod:`vggc_cp.experiments.table1`) and one cell: learn a
graph with a method, write its solution, evaluate it against ground truth, cache the row.

The run imports this module, never the other way round: a cell's job (:class:`CellJob`) and
the phase workers live here, the run's configuration and scheduling there.

Methods (:data:`METHODS`, by name): ``greedy``, ``cpsat``, ``merge``, ``cpsat-merge``,
``pca-hdbscan`` and ``lsr``; see :mod:`vggc_cp.experiments.table1`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vggc_cp.atomic import write_bytes, write_text
from vggc_cp.errors import VggcError, lookup
from vggc_cp.evaluate.paper import PAPER_METRICS
from vggc_cp.solution import jsonable
from vggc_cp.solvers.base import SolveResult
from vggc_cp.trace import Trace, load_trace, save_trace

#: Methods that need the visual distances of a trace.
VISUAL_METHODS = ("greedy", "cpsat", "merge", "cpsat-merge")


@dataclass(frozen=True)
class CellJob:
    """Everything a worker needs for one (benchmark, method, seed) cell (picklable).

    Attributes
    ----------
    benchmark, method : str
    seed : int
    trace_path, distances_path, solution_path, cell_path : Path
    queries : int
    options : dict
        The method's options.
    key : dict
        The settings a cached row must match to be reused.
    """

    benchmark: str
    method: str
    seed: int
    trace_path: Path
    distances_path: Path
    solution_path: Path
    cell_path: Path
    queries: int
    options: dict
    key: dict
    attention: str = "saliency"


@dataclass(frozen=True, eq=False)
class MethodRun:
    """What a method returns: the selected result, its solution JSON and timed phases."""

    result: SolveResult | None
    solution: dict | None
    seconds: dict


MethodFn = Callable[[Trace, CellJob], MethodRun]
METHODS: dict[str, MethodFn] = {}


def register_method(name: str) -> Callable[[MethodFn], MethodFn]:
    """Decorator: add a benchmark method ``(trace, job) -> MethodRun`` under ``name``."""
    def deco(fn: MethodFn) -> MethodFn:
        METHODS[name] = fn
        return fn
    return deco


def compute_trace_distances(trace_path: Path, distances_path: Path,
                            attention: str = "saliency") -> float:
    """Compute (or take from the vision cache) and store the VGGC distances of a trace with
    the default settings and the ``attention`` backend; returns the seconds of their
    computation.

    On a cache hit the seconds are those the cache file recorded when it was computed
    (attention + Sinkhorn); the stored file says ``cached``.
    """
    import io

    from vggc_cp.pipeline import visual_problem
    from vggc_cp.vision import DistanceConfig

    vp = visual_problem(load_trace(trace_path), DistanceConfig(backend=attention),
                        cache_dir=distances_path.parent / "cache")
    seconds = vp.compute_seconds
    buf = io.BytesIO()
    np.savez(buf, dist_pick=vp.problem.dist_pick, dist_place=vp.problem.dist_place,
             seconds=np.float64(seconds), cached=np.bool_(vp.cached))
    write_bytes(distances_path, buf.getvalue())
    return seconds


def _visual_problem(trace: Trace, job: CellJob):
    """The solver's problem (no ground truth) from the stored distances of a cell's trace:
    ``(problem, distance seconds, cached)``."""
    from vggc_cp.solvers import Problem

    with np.load(job.distances_path, allow_pickle=False) as data:
        dist_pick, dist_place = data["dist_pick"], data["dist_place"]
        t_dist = float(data["seconds"])
        cached = bool(data["cached"]) if "cached" in data.files else False
    return Problem.from_trace(trace.without_states(), dist_pick, dist_place), t_dist, cached


def _solved(problem, best: SolveResult, seconds: dict, **extra) -> MethodRun:
    """The method run of a selected result, with its solution JSON."""
    from vggc_cp.learned import solution_record

    return MethodRun(best, solution_record(problem, best, seconds=seconds, **extra), seconds)


def _colouring(trace: Trace, job: CellJob, solver_name: str) -> MethodRun:
    import vggc_cp.solvers.cpsat  # noqa: F401  (registers the solvers)
    import vggc_cp.solvers.greedy  # noqa: F401
    from vggc_cp.pipeline import grid_sweep
    from vggc_cp.solvers import get_solver

    problem, t_dist, cached = _visual_problem(trace, job)
    try:
        solver = get_solver(solver_name, **job.options)
    except TypeError as exc:
        raise VggcError(f"method {solver_name}: bad option ({exc})") from None
    grid = grid_sweep(problem, solver, select="fewest")
    seconds = {"distances": round(t_dist, 3), "method": round(grid.seconds, 3),
               "distances_cached": cached}
    best = grid.best
    if best is None:
        return MethodRun(None, None, seconds)
    return _solved(problem, best, seconds, select="fewest", grid=grid.sweep.records())


@register_method("greedy")
def run_greedy(trace: Trace, job: CellJob) -> MethodRun:
    """VGGC with the greedy solver over the whole default grid."""
    return _colouring(trace, job, "greedy")


@register_method("cpsat")
def run_cpsat(trace: Trace, job: CellJob) -> MethodRun:
    """VGGC with CP-SAT: greedy sweep, then :func:`vggc_cp.solvers.cpsat.exact_sweep`."""
    return _colouring(trace, job, "cpsat")


def _baseline(trace: Trace, job: CellJob, name: str) -> MethodRun:
    from vggc_cp.baselines import BASELINES, baseline_solution, get_baseline

    cls = BASELINES[name]
    try:
        config = cls.config_class(**job.options)
    except TypeError as exc:
        raise VggcError(f"method {name}: bad option ({exc})") from None
    result = get_baseline(name, config=config).fit(trace.without_states())
    seconds = {"distances": 0.0, "method": round(result.seconds, 3)}
    return MethodRun(result, baseline_solution(trace, result) | {"seconds": seconds}, seconds)


@register_method("merge")
def run_merge(trace: Trace, job: CellJob) -> MethodRun:
    """Congruence-closure merging over the threshold path, ``cascade`` selection."""
    from vggc_cp.solvers.merge import threshold_path

    problem, t_dist, cached = _visual_problem(trace, job)
    path = threshold_path(problem, **job.options)
    seconds = {"distances": round(t_dist, 3), "method": round(path.seconds, 3),
               "distances_cached": cached}
    best = path.best
    return _solved(problem, best, seconds, select=path.rule,
                   threshold=best.stats["threshold"], grid=path.records())


@register_method("cpsat-merge")
def run_cpsat_merge(trace: Trace, job: CellJob) -> MethodRun:
    """The exact counterpart of ``merge``: the merge path, then CP-SAT's fewest nodes under
    determinism, co-determinism, Exactly-One and the merge's widest within-cluster distance as
    cannot-link (:func:`vggc_cp.solvers.merge_exact.exact_counterpart`); its seconds include
    the merge path."""
    from vggc_cp.solvers.merge import threshold_path
    from vggc_cp.solvers.merge_exact import exact_counterpart

    problem, t_dist, cached = _visual_problem(trace, job)
    options = dict(job.options)
    path = threshold_path(problem, rule=options.pop("rule", "cascade"))
    try:
        exact = exact_counterpart(problem, path.best, **options)
    except TypeError as exc:
        raise VggcError(f"method cpsat-merge: bad option ({exc})") from None
    seconds = {"distances": round(t_dist, 3), "method": round(path.seconds + exact.seconds, 3),
               "distances_cached": cached}
    best = exact.best
    return _solved(problem, best, seconds, select="fewest", merge_nodes=exact.merge_nodes,
                   minimal_nodes=exact.minimal_nodes, proved_minimal=exact.proved,
                   cannot_link=exact.cannot_link, exact_skipped=exact.skipped,
                   grid=exact.sweep.records())


@register_method("pca-hdbscan")
def run_pca_hdbscan(trace: Trace, job: CellJob) -> MethodRun:
    """The PCA-HDBSCAN roadmap baseline."""
    return _baseline(trace, job, "pca-hdbscan")


@register_method("lsr")
def run_lsr(trace: Trace, job: CellJob) -> MethodRun:
    """The Latent Space Roadmap baseline."""
    return _baseline(trace, job, "lsr")


# ---------------------------------------------------------------- one cell


def run_cell(job: CellJob) -> dict:
    """Learn, write the solution, evaluate and cache one cell; returns its row.

    The row holds the metrics as fractions, ``nodes``, ``true_states`` (|V*| of the trace),
    ``paper_states``, ``status``, ``exactly_one`` (violations), and ``seconds`` (distances,
    method, evaluation).
    """
    from vggc_cp.evaluate import evaluate_trace
    from vggc_cp.graph import check
    from vggc_cp.sim import get_spec
    from vggc_cp.solution import write_solution

    trace = load_trace(job.trace_path)
    run = lookup(METHODS, job.method, "method")(trace, job)
    row = {"benchmark": job.benchmark, "method": job.method, "seed": job.seed,
           "transitions": trace.n_transitions, "observations": trace.n_obs,
           "paper_states": get_spec(job.benchmark).paper_states,
           "true_states": int(len(np.unique(trace.states))),
           "seconds_distances": run.seconds.get("distances", 0.0),
           "seconds_method": run.seconds.get("method", 0.0),
           "distances_cached": run.seconds.get("distances_cached"),
           "attention": job.attention if job.method in VISUAL_METHODS else None}
    t0 = time.perf_counter()
    if run.result is None or not run.result.found:
        row |= {"status": run.result.status if run.result else "unknown", "nodes": 0,
                "edges": 0, "k_pick": None, "k_place": None, "exactly_one": None,
                **{m: None for m in (*PAPER_METRICS, "exec", "plan_found")}}
    else:
        res = run.result
        write_solution(job.solution_path, run.solution)
        src, act, dst = trace.transitions()
        from vggc_cp.graph import TaskGraph

        graph = TaskGraph.from_labels(res.labels, trace.roles(), src, act, dst,
                                      trace.action_names)
        metrics, dynamics = evaluate_trace(trace, graph, res.labels, n_queries=job.queries,
                                           seed=0, dynamics="auto")
        counts = graph.count_by_role()
        row |= {"status": res.status, "nodes": graph.n_nodes, "edges": graph.n_edges,
                "k_pick": counts["pick"], "k_place": counts["place"],
                "exactly_one": len(check(graph).of_kind("exactly_one")),
                "opt_path": metrics.opt_path, "any_path": metrics.any_path,
                "trans_prec": metrics.trans_prec, "trans_cov": metrics.trans_cov,
                "exec": metrics.exec, "plan_found": metrics.plan_found, "dynamics": dynamics,
                "solution": str(job.solution_path)}
        for k in ("threshold", "merge_nodes", "minimal_nodes", "proved_minimal", "cannot_link",
                  "exact_skipped"):
            if k in run.solution:
                row[k] = run.solution[k]
    row["seconds_evaluate"] = round(time.perf_counter() - t0, 3)
    row["seconds"] = round(row["seconds_distances"] + row["seconds_method"], 3)
    from vggc_cp.experiments.cells import file_sha256

    record = {"key": job.key, "trace_sha256": file_sha256(job.trace_path), "row": jsonable(row)}
    write_text(job.cell_path, json.dumps(record, indent=1) + "\n")
    return jsonable(row)


# ---------------------------------------------------------------- phase workers


def generate_trace(args: tuple[str, int, int, str]) -> str:
    """Phase 1: generate ``(benchmark, |D|, seed, path)``'s trace and save it; returns the path."""
    from vggc_cp.sim.explore import generate

    bench, transitions, seed, path = args
    save_trace(generate(bench, transitions, seed).trace, path)
    return path


def store_distances(args: tuple[str, str, str]) -> str:
    """Phase 2: :func:`compute_trace_distances` of ``(trace path, distances path, attention)``."""
    compute_trace_distances(Path(args[0]), Path(args[1]), args[2])
    return args[1]


def render_novel(args: tuple[str, int, int, int, str]) -> str:
    """Phase 4: ``novel`` fresh renders of ``(benchmark, |D|, seed, novel, path)``'s states."""
    from vggc_cp.sim.explore import generate
    from vggc_cp.sim.novel import save_novel

    bench, transitions, seed, novel, path = args
    g = generate(bench, transitions, seed, novel=novel)
    save_novel(path, g.novel_observations, g.novel_states)
    return path
