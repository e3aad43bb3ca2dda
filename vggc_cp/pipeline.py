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
* **Read cuts.** Every graph of the path, chosen or not, is then cut where the sites' readings
  show a node to hold two states and the cut keeps the graph deterministic and its code
  shorter (:mod:`vggc_cp.solvers.read_splits`), and an episode that runs on nodes of its
  own, more such episodes than chance gives, is moved onto the path its actions walk on the
  rest of the graph where that code is shorter too (:mod:`vggc_cp.solvers.episodes`); the
  threshold stays the one chosen on the merges' own graphs.
* **Confidence.** The chance that a recording of the same kind would change the graph: re-runs
  of the merge at the chosen threshold with a fifth of the episodes left out
  (:mod:`vggc_cp.solvers.confidence`); above 30 % the graph is flagged *suspect* with reasons.
* **Doubts** (one stage, :func:`vggc_cp.solvers.verdict.verdict`). The chosen graph's
  decisions that neither the images nor the actions settle (:mod:`vggc_cp.solvers.doubts`):
  nodes that might be one state, a node that might be two.
  Two more flag the graph: nodes that only an untrustworthy reading of the images sets apart,
  or an episode that only such a reading puts on its path
  (:func:`~vggc_cp.solvers.read_doubts.read_doubts`,
  :func:`~vggc_cp.solvers.read_doubts.episode_doubts`, listed first), and a join the images and
  the actions both favour that a constraint forbids
  (:func:`~vggc_cp.solvers.doubt_checks.doubt_forbidden`). Episodes none of whose nodes
  another episode visits, more of them than chance gives, flag it too, each with the path
  its actions take on the rest of the graph (:mod:`vggc_cp.solvers.lone_episodes`, listed
  first of all).

Its settings and its result (:class:`~vggc_cp.learned.LearnConfig`,
:class:`~vggc_cp.learned.Learned`) are defined in :mod:`vggc_cp.learned`. Everything here
reads observations and actions only, never ground-truth ``states``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from vggc_cp.errors import EvidenceNotApplicable, VggcError
from vggc_cp.learned import (
    AUTO,
    AUTO_FALLBACK,
    CODES_SHARE,
    FOOTPRINTS,
    Candidate,
    LearnConfig,
    Learned,
)
from vggc_cp.solvers.base import Problem, Readings, SiteReads, SolveResult
from vggc_cp.solvers.coded import CodedProblem, coded_threshold_grid
from vggc_cp.solvers.confidence import (
    Confidence,
    assess,
    plateau_length,
    resample,
)
from vggc_cp.solvers.doubts import Doubt
from vggc_cp.solvers.mdl import description_length, sure_reading_gap
from vggc_cp.solvers.merge import ThresholdPath, noise_scale, threshold_path
from vggc_cp.solvers.pairs import coded_threshold_path
from vggc_cp.solvers.verdict import graph_doubts, runner_up, verdict
from vggc_cp.trace import Trace
from vggc_cp.vision.attention import ATTENTION_BACKENDS
from vggc_cp.vision.distances import DistanceConfig
from vggc_cp.vision.evidence import footprint_evidence, get_evidence
from vggc_cp.vision.footprints import action_footprints, footprint_codes
from vggc_cp.vision.holdings import site_readings, site_reads


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
                       progress: bool = False, executor=None) -> tuple[np.ndarray, np.ndarray]:
    """Within-role distances of ``trace`` under the registered ``evidence``
    (:mod:`vggc_cp.vision.evidence`); ``executor`` runs an attention evidence's row blocks."""
    if executor is not None and evidence in ATTENTION_BACKENDS:
        from vggc_cp.vision.distances import compute_distances_full

        cfg = replace(options.distance, backend=evidence)
        res = compute_distances_full(trace, cfg, progress=progress, executor=executor)
        return res.dist_pick, res.dist_place
    return get_evidence(evidence).distances(trace, options, progress)


def evidence_problem(trace: Trace, evidence: str, options: LearnConfig,
                     progress: bool = False, executor=None) -> Problem | CodedProblem:
    """The problem of ``trace`` under ``evidence``: a :class:`CodedProblem` (descriptor
    codes, no N x N matrix) for the footprints unless ``options.candidates`` is ``dense``,
    else a :class:`Problem` of the distance matrices. The footprints also give every action
    its colour, so that a place node's hand holds one colour
    (:attr:`~vggc_cp.solvers.base.Problem.action_colour`). ``executor``
    (:func:`vggc_cp.parallel.open_executor`, e.g. a dask cluster) converts the frames in
    blocks (footprints) or computes the distance row blocks (attention); same numbers."""
    if evidence == FOOTPRINTS and get_evidence(evidence).distances is footprint_evidence:
        fp = action_footprints(trace, options.footprint, executor)   # the built-in one
        codes, tables = footprint_codes(fp, trace.roles())
        res = fp.resolution
        notes = (f"working resolution {res.describe()}",) if res and res.bound > 1 else ()
        reads = site_reads(fp)
        coded = CodedProblem.from_trace(trace, codes, tables, notes, fp.colour,
                                        Readings.from_rows(site_readings(fp), None if reads is None
                                                           else SiteReads(*reads)))
        if options.candidates == "codes" and all(
                len(t) <= CODES_SHARE * max(len(c), 1) for c, t in zip(codes, tables)):
            return coded
        # descriptors that do not repeat (continuous presence): the dense matrices, the
        # same numbers (table[code, code] is the distance bit for bit)
        return coded.dense()
    dp, dq = evidence_distances(trace, evidence, options, progress, executor)
    return Problem.from_trace(trace, dp, dq)


def merge_path(problem: Problem | CodedProblem, options: LearnConfig,
               progress: bool = False) -> ThresholdPath:
    """The threshold grid (:func:`threshold_grid`, or ``options.thresholds``) and the merge
    path along it, on candidate pairs for a :class:`CodedProblem`."""
    coded = isinstance(problem, CodedProblem)
    if options.thresholds is not None:
        ts = np.asarray(options.thresholds, dtype=np.float64)
    else:
        ts = (coded_threshold_grid if coded else threshold_grid)(problem, options.steps)
    if coded:
        return coded_threshold_path(problem, ts, options.rule, progress=progress)
    return threshold_path(problem, ts, options.rule, progress=progress)


def run_candidate(trace: Trace, evidence: str, options: LearnConfig,
                  progress: bool = False, executor=None) -> Candidate:
    """Distances, merge path, selection and confidence under one evidence (``executor``:
    :func:`evidence_problem`)."""
    t0 = time.perf_counter()
    problem = evidence_problem(trace, evidence, options, progress, executor)
    path = merge_path(problem, options, progress)
    dls, conf = assess_path(trace, problem, path, options)
    return Candidate(evidence, problem, path, dls, conf, time.perf_counter() - t0)


def assess_path(trace: Trace, problem: Problem | CodedProblem, path: ThresholdPath,
                options: LearnConfig) -> tuple[tuple[float, ...], Confidence]:
    """Description length of every graph of ``path`` and the :class:`Confidence` of the
    selected one (its chance of change from re-runs of the merge, and the margin, plateau and
    held-out prediction beside it)."""
    dls = tuple(description_length(problem, path.merged_labels(i))
                for i in range(len(path.results)))
    k = path.selected
    best = path.results[k]
    other = runner_up(path, dls)
    n_trans = max(len(problem.act), 1)
    margin = float("inf")
    if other is not None:
        # in the code of the actions, stated facts and the readings that are surely right
        gap = sure_reading_gap(problem, path.merged_labels(k), path.merged_labels(other))
        margin = (dls[other] - dls[k] + max(gap, 0.0)) / n_trans
    plateau = plateau_length([r.labels for r in path.results], k)
    resampled = (resample(problem, path.thresholds[k], best.labels, trace.episode_index(),
                          options.folds, options.warning) if options.folds >= 2 else None)
    # the mdl rule took a graph the actions alone do not prefer: the readings broke a tie
    read_choice = options.rule == "mdl" and dls[k] > min(dls) + 1e-9
    conf = assess(margin, plateau, resampled, problem.n_obs / max(best.n_nodes, 1),
                  options.warning, criterion=options.rule, transitions=n_trans,
                  read_choice=read_choice)
    return dls, conf


def learn_graph(trace: Trace, options: LearnConfig | None = None,
                progress: bool = False, executor=None) -> Learned:
    """Learn the task graph of ``trace`` (module docstring).

    Parameters
    ----------
    trace : Trace
        Only observations and actions are read.
    options : LearnConfig, optional
    progress : bool
        Progress bars on stderr.
    executor : Executor, optional
        Where the evidence's blocks run (:func:`evidence_problem`); the same graph.

    Returns
    -------
    Learned

    Raises
    ------
    VggcError
        When the trace has no transition, or (``evidence="auto"``) no evidence applies to it.
    EvidenceNotApplicable
        When the one evidence asked for cannot read the trace.
    """
    options = options or LearnConfig()
    if not isinstance(options, LearnConfig):
        raise VggcError(f"learn_graph: options must be a LearnConfig, got "
                        f"{type(options).__name__}")
    if trace.n_transitions == 0:
        raise VggcError("the trace has no transition: nothing to learn")
    t0 = time.perf_counter()
    if options.evidence != AUTO:
        candidates = [run_candidate(trace, options.evidence, options, progress, executor)]
        skipped = []
    else:
        candidates, skipped = [], []
        order = (FOOTPRINTS,) if options.fallback == "never" else (FOOTPRINTS, *AUTO_FALLBACK)
        for evidence in order:
            try:
                candidates.append(run_candidate(trace, evidence, options, progress, executor))
            except EvidenceNotApplicable as exc:  # no localized change; images below a grid
                skipped.append(f"{evidence}: {exc}")
                continue
            if options.fallback != "suspect" or not candidates[-1].confidence.suspect:
                break
        if not candidates:
            raise VggcError("no visual evidence applies to this trace (" + "; ".join(skipped)
                            + ")")
    chosen = choose(candidates)
    chosen = _with_disagreement(chosen, candidates)
    conf, doubts = verdict(chosen.problem, chosen.path, chosen.best.labels, chosen.confidence,
                           chosen.description_lengths, trace)
    return Learned(replace(chosen, confidence=conf), tuple(candidates),
                   time.perf_counter() - t0, tuple(skipped), options, trace, doubts)


def learned_doubts(chosen: Candidate, toward_runner_up: bool = False, disputed: bool = False,
                   differences: bool = False, read: bool = False) -> tuple[Doubt, ...]:
    """The doubts of a candidate's chosen graph
    (:func:`vggc_cp.solvers.verdict.graph_doubts`, whose flags these are)."""
    return graph_doubts(chosen.problem, chosen.path, chosen.best.labels,
                        chosen.description_lengths, chosen.confidence.heldout,
                        toward_runner_up=toward_runner_up, disputed=disputed,
                        differences=differences, read=read)


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
    merged = conf.flagged(reason)
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


@dataclass(frozen=True, eq=False)
class GridRun:
    """What :func:`grid_sweep` did: the grid, the sweep that selects, and the greedy sweep
    that warm-started it (CP-SAT only).

    Attributes
    ----------
    k_pick, k_place : range
        Grid values.
    sweep : Sweep
        The solver's sweep (:class:`~vggc_cp.solvers.sweep.Sweep`); its ``best`` is selected.
    greedy : Sweep or None
        CP-SAT's greedy warm start; None for the other solvers.
    """

    k_pick: range
    k_place: range
    sweep: object
    greedy: object | None = None

    @property
    def best(self) -> SolveResult | None:
        return self.sweep.best

    @property
    def seconds(self) -> float:
        """Seconds of the whole search (CP-SAT's include its greedy warm start)."""
        return self.sweep.seconds + (self.greedy.seconds if self.greedy is not None else 0.0)


def grid_sweep(problem: Problem, solver, k_pick: range | None = None,
               k_place: range | None = None, *, jobs: int = 1, select: str = "fewest",
               optimize: str = "minimal", progress: bool = False, executor=None) -> GridRun:
    """The grid solvers' path: sweep ``solver`` over the (k_pick, k_place) grid and select.

    Parameters
    ----------
    problem : Problem
    solver : Solver
        A grid solver (``greedy``, ``brute``, ...); a CP-SAT solver runs the greedy sweep first
        and warm-starts :func:`~vggc_cp.solvers.cpsat.exact_sweep` with it
        (:func:`greedy_then_exact`).
    k_pick, k_place : range, optional
        Grid values; None: :func:`~vggc_cp.solvers.sweep.default_grid`.
    jobs, select, progress, executor
        As :func:`~vggc_cp.solvers.sweep.run_sweep`.
    optimize : str
        CP-SAT only: the cells whose J is minimized (``minimal`` or ``all``).

    Returns
    -------
    GridRun
    """
    from vggc_cp.solvers.sweep import default_grid, run_sweep

    if k_pick is None or k_place is None:
        dp, dq = default_grid(problem)
        k_pick = dp if k_pick is None else k_pick
        k_place = dq if k_place is None else k_place
    if getattr(solver, "name", None) == "cpsat":
        sweeps = greedy_then_exact(problem, k_pick, k_place, solver, jobs=jobs, select=select,
                                   optimize=optimize, progress=progress, executor=executor)
        return GridRun(k_pick, k_place, sweeps.exact, sweeps.greedy)
    sweep = run_sweep(problem, solver, k_pick, k_place, jobs=jobs, select=select,
                      progress=progress, executor=executor)
    return GridRun(k_pick, k_place, sweep)


def node_frontiers(problem: Problem, sweeps: GridSweeps) -> tuple:
    """``(greedy, CP-SAT)`` :class:`~vggc_cp.solvers.cpsat.NodeFrontier`: the fewest nodes each
    found and whether that is proved minimal (CP-SAT's proofs serve both; cells with fewer
    colour pairs than a role's distinct actions are ruled out by counting)."""
    from vggc_cp.solvers.cpsat import node_frontier
    from vggc_cp.solvers.sweep import action_counts

    need = max(*action_counts(problem), 1)
    return (node_frontier(sweeps.greedy, proof=sweeps.exact, need=need),
            node_frontier(sweeps.exact, need=need))

