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
  shorter (:mod:`vggc_cp.solvers.read_splits`); the threshold stays the one chosen on the
  merges' own graphs.
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

Everything here reads observations and actions only, never ground-truth ``states``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields, replace

import numpy as np

from vggc_cp.errors import EvidenceNotApplicable, VggcError, lookup
from vggc_cp.graph import TaskGraph
from vggc_cp.solvers.base import Problem, Readings, SiteReads, SolveResult
from vggc_cp.solvers.confidence import (
    Confidence,
    WarningRule,
    assess,
    plateau_length,
    resample,
)
from vggc_cp.solvers.doubts import Doubt
from vggc_cp.solvers.mdl import description_length
from vggc_cp.solvers.merge import PATH_SELECTIONS, ThresholdPath, noise_scale, threshold_path
from vggc_cp.solvers.pairs import CodedProblem, coded_threshold_grid, coded_threshold_path
from vggc_cp.solvers.verdict import graph_doubts, runner_up, verdict
from vggc_cp.trace import Trace
from vggc_cp.vision.attention import ATTENTION_BACKENDS
from vggc_cp.vision.distances import DistanceConfig
from vggc_cp.vision.evidence import evidence_names, footprint_evidence, get_evidence
from vggc_cp.vision.footprints import (
    FootprintConfig,
    action_footprints,
    footprint_codes,
    site_readings,
    site_reads,
)

#: The first evidence ``auto`` tries (the others only when its graph is suspect).
FOOTPRINTS = "footprints"
AUTO = "auto"
#: ``evidence="attention"`` (``vggc-cp solve --evidence attention``): the attention backend
#: of ``LearnConfig.distance`` (``--attention``).
ATTENTION = "attention"
#: Evidences that ``auto`` tries after the footprints (when :data:`FALLBACKS` says so).
AUTO_FALLBACK = ("keypoints",)
#: When ``auto`` runs its fallback evidences (``LearnConfig.fallback``, ``solve --fallback``).
#: A fallback can change the answer only by passing its own checks where the footprints fail
#: theirs; measured on the robustness suite, where its graph differed from a suspect footprint
#: graph it was wrong, and its Sinkhorn distances cost 10-70 times the footprints' (fruit-6x8,
#: |D| = 1500: 187 s against 8 s). So by default it runs only where the footprints cannot read
#: the trace at all.
FALLBACKS = {
    "refused": "the fallback evidences run only when the footprints cannot read the trace",
    "suspect": "also when the footprint graph is suspect (kept only if their graph passes its "
               "checks; any size disagreement flags the graph); costs their Sinkhorn distances",
    "never": "footprints only; a trace they cannot read is refused",
}


#: How the merge path meets candidate pairs (:attr:`LearnConfig.candidates`).
CANDIDATES = ("codes", "dense")
#: Codes are used when each role has at most this share of codes per observation (renders of
#: one situation repeat their descriptor); otherwise the dense matrices serve better.
CODES_SHARE = 0.25


def evidence_choices() -> tuple[str, ...]:
    """Every value ``LearnConfig.evidence`` (and ``solve --evidence``) accepts: ``auto``,
    ``attention`` and the names of the evidence registry (:mod:`vggc_cp.vision.evidence`)."""
    return (AUTO, ATTENTION, *evidence_names())


def _positive_number(x) -> bool:
    return (isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)
            and math.isfinite(float(x)) and float(x) > 0)


def _integer(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool)


@dataclass(frozen=True)
class LearnConfig:
    """Every setting of :func:`learn_graph`; validated when built.

    Attributes
    ----------
    evidence : str
        ``auto`` (footprints, then the :data:`AUTO_FALLBACK` evidences as ``fallback`` says), a
        registered evidence (:func:`~vggc_cp.vision.evidence.evidence_names`: ``footprints``,
        ``saliency``, ``keypoints``, ``dinov2``, ...), or ``attention``: the backend of
        ``distance`` (replaced by that name when the object is built).
    distance : DistanceConfig
        Settings of the Sinkhorn distances (its ``backend`` is replaced by the evidence).
    footprint : FootprintConfig
    rule : str
        Path selection rule (``mdl`` default; ``cascade``, ``fewest``).
    thresholds : tuple of float or None
        Merge thresholds, positive; None: :func:`threshold_grid`.
    steps : int
        Thresholds of the default grid (at least 1).
    folds : int
        Each re-run of the confidence leaves out ``1 / folds`` of the episodes; the first
        ``folds`` re-runs are the held-out folds (0: no re-runs, no confidence; else at
        least 2).
    warning : WarningRule
        When the graph is flagged: its chance of change above ``max_change`` with another
        check (alone with ``change_alone``), or a fixed check
        (:mod:`vggc_cp.solvers.confidence`).
    fallback : str
        When ``auto`` tries its fallback evidences (:data:`FALLBACKS`): ``refused``
        (default: only where the footprints cannot read the trace), ``suspect`` (also where
        their graph is suspect), ``never``.
    candidates : str
        ``codes`` (default): an evidence that describes observations by discrete descriptors
        (footprints) is merged on candidate pairs of descriptor codes, without N x N matrices
        (:mod:`vggc_cp.solvers.pairs`; the same partitions), when the descriptors repeat
        (:data:`CODES_SHARE`); ``dense``: every evidence through the ``(n, n)`` distance
        matrices.

    Raises
    ------
    UnknownNameError
        An unknown ``evidence`` or ``rule``, naming the known ones.
    VggcError
        A value out of range, naming the field.

    Examples
    --------
    >>> LearnConfig(rule="MDL")
    Traceback (most recent call last):
    ...
    vggc_cp.errors.UnknownNameError: unknown path selection rule 'MDL'; known: cascade, fewest, mdl
    >>> LearnConfig(evidence="attention").evidence   # the backend of distance
    'saliency'
    """

    evidence: str = AUTO
    distance: DistanceConfig = field(default_factory=DistanceConfig)
    footprint: FootprintConfig = field(default_factory=FootprintConfig)
    rule: str = "mdl"
    thresholds: tuple[float, ...] | None = None
    steps: int = 24
    folds: int = 5
    warning: WarningRule = field(default_factory=WarningRule)
    fallback: str = "refused"
    candidates: str = "codes"

    def __post_init__(self) -> None:
        for name, kind in (("distance", DistanceConfig), ("footprint", FootprintConfig),
                           ("warning", WarningRule)):
            if not isinstance(getattr(self, name), kind):
                raise VggcError(f"LearnConfig field {name!r} must be a {kind.__name__}, got "
                                f"{type(getattr(self, name)).__name__}")
        if not isinstance(self.evidence, str):
            raise VggcError(f"LearnConfig field 'evidence' must be a name, got "
                            f"{self.evidence!r}")
        lookup({e: e for e in evidence_choices()}, self.evidence, "evidence")
        lookup(FALLBACKS, self.fallback, "fallback")
        lookup({c: c for c in CANDIDATES}, self.candidates, "candidates")
        if self.evidence == ATTENTION:
            object.__setattr__(self, "evidence", self.distance.backend)
        if not isinstance(self.rule, str):
            raise VggcError(f"LearnConfig field 'rule' must be a name, got {self.rule!r}")
        lookup(PATH_SELECTIONS, self.rule, "path selection rule")
        if self.thresholds is not None:
            ts = (tuple(self.thresholds) if isinstance(self.thresholds, (list, tuple, np.ndarray))
                  else None)
            if not ts:
                raise VggcError(f"LearnConfig field 'thresholds' must be a non-empty sequence "
                                f"of positive numbers or None, got {self.thresholds!r}")
            for i, t in enumerate(ts):
                if not _positive_number(t):
                    raise VggcError(f"LearnConfig field 'thresholds'[{i}] must be a positive "
                                    f"finite number, got {t!r}")
            object.__setattr__(self, "thresholds", tuple(float(t) for t in ts))
        if not _integer(self.steps) or self.steps < 1:
            raise VggcError(f"LearnConfig field 'steps' must be an integer of at least 1, got "
                            f"{self.steps!r}")
        if not _integer(self.folds) or self.folds < 0 or self.folds == 1:
            raise VggcError(f"LearnConfig field 'folds' must be 0 (no held-out prediction) or "
                            f"an integer of at least 2, got {self.folds!r}")

    @classmethod
    def from_settings(cls, config: LearnConfig | None = None, **settings) -> LearnConfig:
        """``config`` (default: the defaults) with ``settings`` replaced; an unknown setting
        names the known ones."""
        base = config if config is not None else cls()
        if not isinstance(base, cls):
            raise VggcError(f"expected a LearnConfig, got {type(base).__name__}")
        known = {f.name for f in fields(cls)}
        for name in settings:
            lookup({k: k for k in known}, name, "LearnConfig setting")
        return replace(base, **settings) if settings else base

    def evidence_settings(self, evidence: str):
        """The settings object ``evidence`` ran under (the solution's ``distances`` field)."""
        return get_evidence(evidence).settings(self)


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

    @property
    def notes(self) -> tuple[str, ...]:
        """What the evidence says about how it ran (e.g. the footprints' working
        resolution on frames larger than the tuned 64 px)."""
        return tuple(self.problem.notes)


@dataclass(frozen=True, eq=False)
class Learned:
    """What :func:`learn_graph` returns: the chosen candidate and all that were tried.

    Attributes
    ----------
    chosen : Candidate
    candidates : tuple of Candidate
        Every evidence tried, in order.
    seconds : float
    skipped : tuple of str
        Evidences that did not apply, with the reason.
    options : LearnConfig
        The settings it was learned with.
    trace : Trace or None
        The trace it was learned from (its ``source`` names the file in :meth:`save`).
    """

    chosen: Candidate
    candidates: tuple[Candidate, ...]
    seconds: float
    skipped: tuple[str, ...] = ()
    options: LearnConfig | None = None
    trace: Trace | None = None
    #: the chosen graph's doubtful decisions (:mod:`vggc_cp.solvers.doubts`), closest first
    doubts: tuple[Doubt, ...] = ()

    @property
    def labels(self) -> np.ndarray:
        """Node of every observation, int64 array of shape (N,)."""
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

    def medoids(self) -> dict[int, int]:
        """The most typical observation of every node: the member of least total distance to
        the node's other members under the chosen evidence (the first of equal ones)."""
        return evidence_medoids(self.problem, self.labels)

    def to_networkx(self):
        """The learned graph as a :class:`networkx.MultiDiGraph`
        (:func:`vggc_cp.graph.to_networkx`): nodes with ``role``, ``size`` and ``medoid``,
        edges keyed by action name with ``action`` and ``support``."""
        from vggc_cp.graph import to_networkx

        return to_networkx(self.graph, self.medoids())

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
                "doubts": [d.as_dict() for d in self.doubts],
                **({"evidence_notes": list(self.chosen.notes)} if self.chosen.notes else {})}

    def solution_record(self, **extra) -> dict:
        """The solution JSON object of ``vggc-cp solve`` (required fields, the settings of the
        chosen evidence, the trace's file and hash, how the graph was chosen, ``extra``)."""
        from vggc_cp.solution import jsonable, settings_record

        if self.trace is None or self.options is None:
            raise VggcError("this Learned holds no trace or settings: learn it with "
                            "learn_graph to write its solution")
        best = self.chosen.best
        return solution_record(
            self.problem, best,
            distances=settings_record(self.options.evidence_settings(self.chosen.evidence)),
            trace=str(self.trace.source), trace_sha256=self.trace.content_hash(),
            stats=jsonable(best.stats), **jsonable(self.solution_fields()),
            seconds={"learn": round(self.seconds, 3), "merge": round(self.chosen.path.seconds, 3)},
            **extra)

    def save(self, path, timings: bool = False, **extra) -> None:
        """Write the solution JSON, the same bytes as ``vggc-cp solve TRACE -o PATH``
        (atomically; wall-clock seconds only with ``timings``)."""
        from vggc_cp.solution import write_solution

        write_solution(path, self.solution_record(**extra), timings=timings)


def evidence_medoids(problem: Problem | CodedProblem, labels: np.ndarray) -> dict[int, int]:
    """``{node: observation}``: each node's member of least summed within-role distance to
    its other members (the first of equal ones; a node of mixed roles: among its first role's
    members)."""
    labels = np.asarray(labels)
    out = {}
    for u in np.unique(labels):
        members = np.flatnonzero(labels == u)
        role = problem.roles[members[0]]
        members = members[problem.roles[members] == role]
        loc = problem.local[members]
        if isinstance(problem, CodedProblem):  # distances of codes: a node's own block only
            codes = problem.codes_pick if role == 0 else problem.codes_place
            table = problem.table_pick if role == 0 else problem.table_place
            block = table[np.ix_(codes[loc], codes[loc])]
        else:
            d = problem.dist_pick if role == 0 else problem.dist_place
            block = d[np.ix_(loc, loc)]
        out[int(u)] = int(members[int(np.argmin(block.sum(axis=1)))])
    return out


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
    margin = (dls[other] - dls[k]) / n_trans if other is not None else float("inf")
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


def solution_record(problem: Problem, best: SolveResult, **extra) -> dict:
    """The solution JSON object of a selected result (required fields, then ``extra``)."""
    from vggc_cp.solution import solution_dict

    return solution_dict(best.labels, problem.roles, problem.graph(best.labels),
                         k_pick=best.k_pick, k_place=best.k_place, J=best.J,
                         solver=best.solver, status=best.status, **extra)
