"""The default way to learn a task graph from a trace, decided by the trace itself.

``trace -> evidence (distances) -> Problem -> merge threshold path -> selection -> confidence``

* **Evidence.** ``footprints`` (:mod:`vggc_cp.vision.footprints`, no weights, the trace's
  actions localize where states differ) first. With ``evidence="auto"``, when the footprint
  graph is suspect (below), the ``keypoints`` attention distances (Sinkhorn divergences,
  :mod:`vggc_cp.vision.distances`) are tried too and kept only if their graph is not
  suspect (:func:`choose`); when another evidence gives a graph of another size, the chosen
  graph is flagged (the evidences disagree).
* **Threshold.** Congruence-closure merging (:mod:`vggc_cp.solvers.merge`) over a geometric
  grid of thresholds from the noise scale (the median nearest-neighbour distance, at least a
  hundredth of the top) up to a high quantile of all distances.
* **Selection.** Least description length (:mod:`vggc_cp.solvers.mdl`) along one evidence's
  path: no threshold rule fitted to a benchmark.
* **Confidence.** Margin, plateau and held-out prediction
  (:mod:`vggc_cp.solvers.confidence`); the graph is flagged *suspect* with reasons.
* **Doubts.** The chosen graph's decisions that neither the images nor the actions settle
  (:mod:`vggc_cp.solvers.doubts`): nodes that might be one state, a node that might be two.

Everything here reads observations and actions only, never ground-truth ``states``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.graph import TaskGraph
from vggc_cp.solvers.base import Problem, SolveResult
from vggc_cp.solvers.confidence import (
    Confidence,
    WarningRule,
    assess,
    heldout_prediction,
    plateau_length,
)
from vggc_cp.solvers.doubts import Doubt, find_doubts
from vggc_cp.solvers.mdl import description_length
from vggc_cp.solvers.merge import ThresholdPath, noise_scale, threshold_path
from vggc_cp.trace import Trace
from vggc_cp.vision.distances import DistanceConfig, compute_distances
from vggc_cp.vision.footprints import FootprintConfig, footprint_distances

#: Evidence names: ``footprints``, or an attention backend of the Sinkhorn distances.
FOOTPRINTS = "footprints"
AUTO = "auto"
#: What ``vggc-cp solve --evidence`` accepts (``attention``: the backend of ``--attention``).
EVIDENCES = (AUTO, FOOTPRINTS, "attention")
#: Attention backends that ``auto`` tries when the footprint graph is suspect.
AUTO_FALLBACK = ("keypoints",)


@dataclass(frozen=True)
class LearnConfig:
    """Every setting of :func:`learn_graph`.

    Attributes
    ----------
    evidence : str
        ``auto`` (footprints, then attention backends when suspect), ``footprints``, or an
        attention backend (``saliency``, ``keypoints``, ``dinov2``) of the Sinkhorn distances.
    distance : DistanceConfig
        Settings of the Sinkhorn distances (its ``backend`` is replaced by the evidence).
    footprint : FootprintConfig
    rule : str
        Path selection rule (``mdl`` default; ``cascade``, ``fewest``).
    thresholds : tuple of float or None
        Merge thresholds; None: :func:`threshold_grid`.
    steps : int
        Thresholds of the default grid.
    folds : int
        Episode folds of the held-out prediction (0: skip it).
    warning : WarningRule
    """

    evidence: str = AUTO
    distance: DistanceConfig = field(default_factory=DistanceConfig)
    footprint: FootprintConfig = field(default_factory=FootprintConfig)
    rule: str = "mdl"
    thresholds: tuple[float, ...] | None = None
    steps: int = 24
    folds: int = 5
    warning: WarningRule = field(default_factory=WarningRule)


@dataclass(frozen=True, eq=False)
class Candidate:
    """One evidence's threshold path, its selected graph and that graph's confidence."""

    evidence: str
    problem: Problem
    path: ThresholdPath
    description_lengths: tuple[float, ...]
    confidence: Confidence
    seconds: float

    @property
    def best(self) -> SolveResult:
        return self.path.results[self.path.selected]

    @property
    def description_length(self) -> float:
        return self.description_lengths[self.path.selected]


@dataclass(frozen=True, eq=False)
class Learned:
    """What :func:`learn_graph` returns: the chosen candidate and all that were tried."""

    chosen: Candidate
    candidates: tuple[Candidate, ...]
    seconds: float
    skipped: tuple[str, ...] = ()
    #: the chosen graph's doubtful decisions (:mod:`vggc_cp.solvers.doubts`), closest first
    doubts: tuple[Doubt, ...] = ()

    @property
    def labels(self) -> np.ndarray:
        return self.chosen.best.labels

    @property
    def problem(self) -> Problem:
        return self.chosen.problem

    @property
    def confidence(self) -> Confidence:
        return self.chosen.confidence

    @property
    def graph(self) -> TaskGraph:
        return self.problem.graph(self.labels)

    @property
    def threshold(self) -> float:
        return self.chosen.path.thresholds[self.chosen.path.selected]

    def path_records(self) -> list[dict]:
        """The chosen evidence's threshold path, one JSON-ready row per threshold, with the
        description length of each graph."""
        rows = self.chosen.path.records()
        for row, dl in zip(rows, self.chosen.description_lengths):
            row["description_length"] = round(float(dl), 4)
        return rows

    def solution_fields(self) -> dict:
        """The fields of the solution JSON that describe how the graph was chosen
        (``select``, ``threshold``, ``evidence``, ``confidence``, ``candidates``, ``grid``)."""
        return {"select": self.chosen.path.rule, "threshold": self.threshold,
                "evidence": self.chosen.evidence, "confidence": self.confidence.as_dict(),
                "candidates": [{"evidence": c.evidence, "nodes": c.best.n_nodes,
                                "description_length": round(c.description_length, 4),
                                "suspect": c.confidence.suspect} for c in self.candidates],
                "grid": self.path_records(),
                "doubts": [d.as_dict() for d in self.doubts]}


def threshold_grid(problem: Problem, steps: int = 24, top_quantile: float = 0.9) -> np.ndarray:
    """Geometric grid from the noise scale to the ``top_quantile`` of all within-role
    distances (``steps`` values, ascending)."""
    ups = [d[np.triu_indices(len(d), 1)] for d in (problem.dist_pick, problem.dist_place)
           if len(d) > 1]
    values = np.concatenate(ups) if ups else np.zeros(0)
    lo = noise_scale(problem)
    hi = float(np.quantile(values, top_quantile)) if len(values) else 0.0
    # near-duplicate renders may be at distance ~0: the grid then starts two decades below
    # the top, so that its steps stay where distances are
    lo = max(lo, hi / 100) if hi > 0 else (lo if lo > 0 else 1e-3)
    hi = max(hi, lo * 1.01)
    return np.geomspace(lo, hi, int(steps))


def evidence_distances(trace: Trace, evidence: str, options: LearnConfig,
                       progress: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Within-role distances of ``trace`` under ``evidence`` (``footprints`` or an attention
    backend)."""
    if evidence == FOOTPRINTS:
        return footprint_distances(trace, options.footprint)
    cfg = replace(options.distance, backend=evidence)
    return compute_distances(trace, cfg, progress=progress)


def run_candidate(trace: Trace, evidence: str, options: LearnConfig,
                  progress: bool = False) -> Candidate:
    """Distances, merge path, selection and confidence under one evidence."""
    t0 = time.perf_counter()
    dp, dq = evidence_distances(trace, evidence, options, progress)
    problem = Problem.from_trace(trace, dp, dq)
    ts = (np.asarray(options.thresholds, dtype=np.float64) if options.thresholds is not None
          else threshold_grid(problem, options.steps))
    path = threshold_path(problem, ts, options.rule, progress=progress)
    dls = tuple(description_length(problem, r.labels) for r in path.results)
    k = path.selected
    best = path.results[k]
    others = [dl for dl, r in zip(dls, path.results) if r.n_nodes != best.n_nodes]
    n_trans = max(len(problem.act), 1)
    margin = (min(others) - dls[k]) / n_trans if others else float("inf")
    plateau = plateau_length([r.labels for r in path.results], k)
    heldout = (heldout_prediction(problem, path.thresholds[k], trace.episode_index(),
                                  options.folds) if options.folds >= 2 else None)
    conf = assess(margin, plateau, heldout, problem.n_obs / max(best.n_nodes, 1),
                  options.warning, criterion=options.rule)
    return Candidate(evidence, problem, path, dls, conf, time.perf_counter() - t0)


def learn_graph(trace: Trace, options: LearnConfig | None = None,
                progress: bool = False) -> Learned:
    """Learn the task graph of ``trace`` (module docstring).

    Parameters
    ----------
    trace : Trace
        Only observations and actions are read.
    options : LearnConfig, optional
    progress : bool
        Progress bars on stderr.

    Returns
    -------
    Learned

    Raises
    ------
    VggcError
        When the trace has no transition.
    """
    options = options or LearnConfig()
    if trace.n_transitions == 0:
        raise VggcError("the trace has no transition: nothing to learn")
    t0 = time.perf_counter()
    if options.evidence != AUTO:
        candidates = [run_candidate(trace, options.evidence, options, progress)]
        skipped = []
    else:
        candidates, skipped = [], []
        for evidence in (FOOTPRINTS, *AUTO_FALLBACK):
            try:
                candidates.append(run_candidate(trace, evidence, options, progress))
            except VggcError as exc:  # no localized change; images smaller than a grid
                skipped.append(f"{evidence}: {exc}")
                continue
            if not candidates[-1].confidence.suspect:
                break
        if not candidates:
            raise VggcError("no visual evidence applies to this trace (" + "; ".join(skipped)
                            + ")")
    chosen = choose(candidates)
    chosen = _with_disagreement(chosen, candidates)
    doubts = find_doubts(chosen.problem, chosen.path, chosen.best.labels)
    return Learned(chosen, tuple(candidates), time.perf_counter() - t0, tuple(skipped), doubts)


def choose(candidates: list[Candidate]) -> Candidate:
    """The first candidate (in the order tried: footprints first) whose graph passes its own
    checks; when none does, the first. Graphs from different distances are not compared by
    a score of their own making (description length and held-out prediction both favour
    graphs that merge states alike in what the robot did); a later evidence is taken only
    where the first one fails its checks and it passes them, and any two evidences that
    disagree on the graph's size flag it (:func:`_with_disagreement`)."""
    return next((c for c in candidates if not c.confidence.suspect), candidates[0])


def _with_disagreement(chosen: Candidate, candidates: list[Candidate]) -> Candidate:
    """``chosen`` with one more warning reason when another evidence gives a graph of another
    size: two readings of the images disagree."""
    others = [c for c in candidates if c is not chosen and c.best.n_nodes != chosen.best.n_nodes]
    if not others:
        return chosen
    other = others[0]
    conf = chosen.confidence
    reason = (f"the {other.evidence} evidence gives {other.best.n_nodes} nodes against "
              f"{chosen.best.n_nodes}: the evidences disagree")
    merged = replace(conf, suspect=True, reasons=(*conf.reasons, reason))
    return replace(chosen, confidence=merged)


# ---------------------------------------------------------------- the grid solvers' pipeline
# trace -> Sinkhorn distances -> Problem -> greedy sweep -> CP-SAT exact sweep -> frontiers:
# the one place every command, study and experiment does these steps.


@dataclass(frozen=True, eq=False)
class VisualProblem:
    """A trace's :class:`Problem` under the Sinkhorn distances, with their cost.

    Attributes
    ----------
    problem : Problem
    seconds : float
        Wall-clock seconds of this call (near zero on a cache hit).
    compute_seconds : float
        Seconds that computing the distances took (attention + Sinkhorn): on a cache hit the
        ones the cache entry recorded, else (or when it recorded none) ``seconds``.
    cached : bool
        Whether the distances came from the cache.
    """

    problem: Problem
    seconds: float
    compute_seconds: float
    cached: bool


def _recorded_seconds(stats: dict) -> float:
    return float(sum(stats.get("seconds", {}).values())) if stats else 0.0


def visual_problem(trace: Trace, cfg: DistanceConfig | None = None, *, cache_dir=None,
                   progress: bool = False, executor=None) -> VisualProblem:
    """The problem of ``trace`` (observations and actions only) under the Sinkhorn distances
    of ``cfg`` (default :class:`DistanceConfig`), computed or taken from the cache (its row
    blocks on ``executor`` when given)."""
    import json

    from vggc_cp.vision.distances import compute_distances_full

    t0 = time.perf_counter()
    res = compute_distances_full(trace, cfg or DistanceConfig(), cache_dir, progress, executor)
    seconds = time.perf_counter() - t0
    stats = res.stats
    if res.cached and res.path is not None:
        try:
            with np.load(res.path, allow_pickle=False) as data:
                stats = json.loads(str(data["stats"])) if "stats" in data.files else {}
        except Exception:  # an entry written without statistics
            stats = {}
    recorded = _recorded_seconds(stats)
    return VisualProblem(Problem.from_trace(trace, res.dist_pick, res.dist_place), seconds,
                         recorded if recorded > 0 else seconds, res.cached)


def cpsat_solver(*, params: str = "", objective: str = "J", deterministic: bool = False,
                 max_actions: int | None = None, codeterministic: bool = False,
                 cannot_link: float | None = None, tau: float | None = None,
                 hint: str | None = None, n_obs: int | None = None):
    """The :class:`~vggc_cp.solvers.cpsat.CpSatSolver` of these settings (bad ``params``:
    :class:`VggcError`).

    ``tau`` is the greedy solver's K_vis temperature (its warm start). ``hint`` is a solution
    JSON whose labels are offered to every cell; with ``n_obs`` (the trace's observation
    count) it must label exactly that many observations.
    """
    from vggc_cp.solvers.cpsat import CpSatSolver

    hints = []
    if hint:
        from vggc_cp.solution import read_solution

        labels = read_solution(hint).labels
        if n_obs is not None and len(labels) != n_obs:
            raise VggcError(f"{hint}: field 'labels' has {len(labels)} entries, the trace "
                            f"has {n_obs} observations")
        hints.append((f"--hint {hint}", labels))
    return CpSatSolver(objective=objective, deterministic=deterministic,
                       max_actions=max_actions, params=params,
                       greedy_options={} if tau is None else {"tau": tau},
                       codeterministic=codeterministic, cannot_link=cannot_link, hints=hints)


@dataclass(frozen=True, eq=False)
class GridSweeps:
    """The greedy sweep of a grid and the CP-SAT exact sweep it warm-starts."""

    greedy: object
    exact: object

    @property
    def seconds(self) -> float:
        """Both sweeps' seconds (CP-SAT's time includes its warm start)."""
        return self.greedy.seconds + self.exact.seconds


def greedy_then_exact(problem: Problem, k_pick, k_place, solver, *, greedy=None,
                      jobs: int = 1, select: str = "fewest", optimize: str = "minimal",
                      progress: bool = False, executor=None) -> GridSweeps:
    """Greedy sweep over the grid (with ``solver.greedy_options``; or the given ``greedy``
    sweep), then :func:`~vggc_cp.solvers.cpsat.exact_sweep` warm-started by its results.

    ``executor`` (:func:`vggc_cp.parallel.open_executor`, e.g. a dask cluster) runs the greedy
    cells and the exact sweep's independent J cells; without one the greedy cells run in
    ``jobs`` local processes and the exact sweep here. Same results either way."""
    from vggc_cp.solvers.cpsat import exact_sweep
    from vggc_cp.solvers.greedy import GreedySolver
    from vggc_cp.solvers.sweep import run_sweep

    if greedy is None:
        greedy = run_sweep(problem, GreedySolver(**solver.greedy_options), k_pick, k_place,
                           jobs=jobs, select=select, progress=progress, executor=executor)
    exact = exact_sweep(problem, k_pick, k_place, solver, greedy.results, optimize=optimize,
                        select=select, progress=progress, executor=executor)
    return GridSweeps(greedy, exact)


def node_frontiers(problem: Problem, sweeps: GridSweeps) -> tuple:
    """``(greedy, CP-SAT)`` :class:`~vggc_cp.solvers.cpsat.NodeFrontier`: the fewest nodes each
    found and whether that is proved minimal (CP-SAT's proofs serve both; cells with fewer
    colour pairs than a role's distinct actions are ruled out by counting)."""
    from vggc_cp.solvers.cpsat import node_frontier
    from vggc_cp.solvers.sweep import action_counts

    need = max(*action_counts(problem), 1)
    return (node_frontier(sweeps.greedy, proof=sweeps.exact, need=need),
            node_frontier(sweeps.exact, need=need))


def solution_record(problem: Problem, best: SolveResult, **extra) -> dict:
    """The solution JSON object of a selected result (required fields, then ``extra``)."""
    from vggc_cp.solution import solution_dict

    return solution_dict(best.labels, problem.roles, problem.graph(best.labels),
                         k_pick=best.k_pick, k_place=best.k_place, J=best.J,
                         solver=best.solver, status=best.status, **extra)
