"""What learning a graph takes and gives: its settings and its result.

:class:`LearnConfig` holds every setting of :func:`vggc_cp.pipeline.learn_graph`, validated
when built (an unknown name lists the known ones, a value out of range names its field).
:class:`Candidate` is one evidence's threshold path with its selected graph and that graph's
confidence; :class:`Learned`, what :func:`~vggc_cp.pipeline.learn_graph` returns, holds the
chosen candidate and every one tried, and writes the solution JSON
(:func:`solution_record`). The stages that make them live in :mod:`vggc_cp.pipeline`.

Examples
--------
>>> LearnConfig(steps=12).steps
12
>>> LearnConfig(folds=1)
Traceback (most recent call last):
...
vggc_cp.errors.VggcError: LearnConfig field 'folds' must be 0 (no held-out prediction) or an integer of at least 2, got 1
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from vggc_cp.errors import VggcError, lookup
from vggc_cp.graph import TaskGraph
from vggc_cp.solvers.base import Problem, SolveResult
from vggc_cp.solvers.coded import CodedProblem
from vggc_cp.solvers.confidence import Confidence, WarningRule
from vggc_cp.solvers.doubts import Doubt
from vggc_cp.solvers.merge import PATH_SELECTIONS, ThresholdPath
from vggc_cp.trace import Trace
from vggc_cp.vision.distances import DistanceConfig
from vggc_cp.vision.evidence import evidence_names, get_evidence
from vggc_cp.vision.footprints import FootprintConfig

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
    """Every setting of :func:`~vggc_cp.pipeline.learn_graph`; validated when built.

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
        Merge thresholds, positive; None: :func:`~vggc_cp.pipeline.threshold_grid`.
    steps : int
        Thresholds of the default grid (at least 1).
    folds : int
        Each re-run of the confidence leaves out ``1 / folds`` of the episodes; the first
        ``folds`` re-runs are the held-out folds (0: no re-runs, no confidence; else at
        least 2).
    warning : WarningRule
        When the graph is flagged: its chance of change above ``max_change`` (with another
        check only, where ``change_alone`` is off), or a fixed check
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
    """What :func:`~vggc_cp.pipeline.learn_graph` returns: the chosen candidate and all that
    were tried.

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


def solution_record(problem: Problem, best: SolveResult, **extra) -> dict:
    """The solution JSON object of a selected result (required fields, then ``extra``)."""
    from vggc_cp.solution import solution_dict

    return solution_dict(best.labels, problem.roles, problem.graph(best.labels),
                         k_pick=best.k_pick, k_place=best.k_place, J=best.J,
                         solver=best.solver, status=best.status, **extra)
