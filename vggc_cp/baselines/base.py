"""What every baseline shares: the :class:`Baseline` interface, its registry, the sweep record,
the ground-truth-free selection rule, and the solution JSON.

A baseline learns a task graph from the trace's *images* (not from the VGGC distances): it
clusters the pick observations and the place observations separately, one node per cluster,
and takes the edges induced by the observed transitions (:meth:`TaskGraph.from_labels`). It
does **not** enforce Exactly-One, so its graphs may violate it; the solution JSON says so with
``"constraints": "none"`` and ``vggc-cp evaluate`` then reports the violations instead of
refusing the file.

Hyperparameters are swept; the winner is chosen without ground truth by
:func:`selection_key`: fewest transitions involved in Exactly-One violations (transitions on an
ordered node pair that carries more than one action label), then fewest nodes, then the
earliest grid point. This mirrors the VGGC rule
(feasible first, then fewest nodes) on graphs that need not be feasible.
"""

from __future__ import annotations

import abc
import time
from collections.abc import Callable
from dataclasses import dataclass, field, fields

import numpy as np

from vggc_cp.errors import VggcError, lookup
from vggc_cp.graph import TaskGraph, check
from vggc_cp.solution import labels_solution
from vggc_cp.solvers.base import FEASIBLE, SolveResult
from vggc_cp.trace import PICK, PLACE, Trace

#: Value of the solution JSON field ``constraints`` for graphs that need not obey Exactly-One.
NO_CONSTRAINTS = "none"


@dataclass(frozen=True)
class GraphStats:
    """Size and constraint violations of an induced task graph.

    Attributes
    ----------
    nodes, pick_nodes, place_nodes, edges : int
    exactly_one : int
        Ordered node pairs that carry more than one action label.
    exactly_one_transitions : int
        Transitions supporting an edge of such a pair.
    nondeterministic : int
        (node, action) pairs leading to more than one node (reported, never enforced).
    """

    nodes: int
    pick_nodes: int
    place_nodes: int
    edges: int
    exactly_one: int
    exactly_one_transitions: int
    nondeterministic: int

    def as_dict(self) -> dict:
        return {"nodes": self.nodes, "pick_nodes": self.pick_nodes,
                "place_nodes": self.place_nodes, "edges": self.edges,
                "exactly_one": self.exactly_one,
                "exactly_one_transitions": self.exactly_one_transitions,
                "nondeterministic": self.nondeterministic}


def graph_stats(graph: TaskGraph) -> GraphStats:
    """Count nodes, edges and violations of ``graph`` (via :func:`vggc_cp.graph.check`)."""
    report = check(graph)
    by_role = graph.count_by_role()
    pairs: dict[tuple[int, int], list[np.ndarray]] = {}
    for (u, _a, v), support in graph.edges.items():
        pairs.setdefault((u, v), []).append(support)
    bad_transitions = sum(sum(len(s) for s in sup) for sup in pairs.values() if len(sup) > 1)
    return GraphStats(graph.n_nodes, by_role["pick"], by_role["place"], graph.n_edges,
                      len(report.of_kind("exactly_one")), int(bad_transitions),
                      len(report.of_kind("determinism")))


def induced_graph(trace: Trace, labels: np.ndarray) -> TaskGraph:
    """The task graph ``labels`` (shape (N,)) induce on the trace's transitions."""
    src, act, dst = trace.transitions()
    return TaskGraph.from_labels(labels, trace.roles(), src, act, dst, trace.action_names)


def labels_from_roles(roles: np.ndarray, pick_clusters: np.ndarray,
                      place_clusters: np.ndarray) -> np.ndarray:
    """Global node ids from per-role cluster ids.

    Parameters
    ----------
    roles : ndarray of int8, shape (N,)
    pick_clusters : ndarray of int, shape (n_pick,)
        Cluster of each pick observation, in observation order.
    place_clusters : ndarray of int, shape (n_place,)

    Returns
    -------
    ndarray of int64, shape (N,)
        Pick clusters become nodes ``0..`` and place clusters follow, each numbered by first
        appearance, so ids are unique across roles.
    """
    labels = np.empty(len(roles), dtype=np.int64)
    offset = 0
    for role, clusters in ((PICK, pick_clusters), (PLACE, place_clusters)):
        idx = np.flatnonzero(roles == role)
        clusters = np.asarray(clusters)
        if len(idx) == 0:
            continue
        _, first, inverse = np.unique(clusters, return_index=True, return_inverse=True)
        rank = np.empty(len(first), dtype=np.int64)
        rank[np.argsort(first, kind="stable")] = np.arange(len(first))
        labels[idx] = rank[inverse.reshape(-1)] + offset
        offset += len(first)
    return labels


def within_role_score(roles: np.ndarray, labels: np.ndarray, features: np.ndarray,
                      p: int) -> float:
    """J of a labelling on the baseline's own feature distances (``p``-norm, 1 or 2).

    The paper's visual score (sum over clusters of the mean intra-cluster distance,
    :func:`vggc_cp.score.visual_score`), on the Minkowski distances between the rows of
    ``features`` (shape (N, F)) that the baseline clustered. Computed cluster by cluster.
    """
    from scipy.spatial.distance import pdist

    total = 0.0
    for u in np.unique(labels):
        mem = features[labels == u]
        m = len(mem)
        if m < 2:
            continue
        total += float(pdist(mem, "cityblock" if p == 1 else "euclidean").mean())
    return total


@dataclass(frozen=True)
class Candidate:
    """One point of a baseline's hyperparameter sweep.

    Attributes
    ----------
    params : dict
        The hyperparameters (JSON values).
    labels : ndarray of int64, shape (N,)
    stats : GraphStats
    J : float
        Visual score on the baseline's own feature distances.
    seconds : float
        Time spent on this point (clustering; training is attributed to its first point).
    """

    params: dict
    labels: np.ndarray = field(repr=False)
    stats: GraphStats
    J: float
    seconds: float

    def grid_row(self) -> dict:
        """The solution JSON's ``grid`` entry (``k_pick``, ``k_place``, ``status``, ``J``,
        ``seconds``, then the hyperparameters and graph statistics)."""
        return {"k_pick": self.stats.pick_nodes, "k_place": self.stats.place_nodes,
                "status": FEASIBLE, "J": None if np.isnan(self.J) else float(self.J),
                "seconds": round(self.seconds, 4), **self.params, **self.stats.as_dict()}


def selection_key(c: Candidate) -> tuple[int, int, int]:
    """Ground-truth-free ranking: fewest transitions involved in Exactly-One violations, then
    fewest nodes, then fewest violating node pairs.

    Counting transitions rather than violating pairs matters: merging everything into one node
    per role gives few violating pairs but involves every transition.
    """
    return (c.stats.exactly_one_transitions, c.stats.nodes, c.stats.exactly_one)


def select(candidates: list[Candidate]) -> Candidate:
    """The winner of :func:`selection_key` (first on ties, i.e. the earliest grid point)."""
    return min(candidates, key=selection_key)


def _parse_scalar(text: str, like, key: str):
    text = text.strip()
    if text.lower() == "none":
        return None
    try:
        if isinstance(like, bool):
            if text.lower() not in ("true", "false", "1", "0"):
                raise ValueError(text)
            return text.lower() in ("true", "1")
        if isinstance(like, int):
            return int(text)
        if isinstance(like, float):
            return float(text)
    except ValueError:
        raise VggcError(f"--param {key}: cannot read {text!r} as {type(like).__name__}") from None
    return text


def parse_params(config_cls, items: list[str]) -> dict:
    """Options of a frozen config dataclass from ``KEY=VALUE[,VALUE...]`` strings.

    Tuple-valued fields (sweep grids) take comma-separated values; the element type follows
    the field's default (``none`` gives None). Unknown keys list the known ones.
    """
    defaults = {f.name: f.default for f in fields(config_cls)}
    out: dict = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep:
            raise VggcError(f"--param {item!r}: expected KEY=VALUE")
        if key not in defaults:
            raise VggcError(f"unknown parameter {key!r} of {config_cls.__name__}; known: "
                            f"{', '.join(sorted(defaults))}")
        default = defaults[key]
        if isinstance(default, tuple):
            like = next((x for x in default if x is not None), "")
            out[key] = tuple(_parse_scalar(v, like, key) for v in value.split(","))
        else:
            out[key] = _parse_scalar(value, default, key)
    return out


class Baseline(abc.ABC):
    """A roadmap learner that clusters images per role; subclasses implement :meth:`_sweep`.

    :meth:`fit` never sees ground truth: it drops the trace's ``states`` first. A subclass
    names its frozen options dataclass in ``config_class`` (see :func:`parse_params`).
    """

    name: str = "baseline"
    config_class: type = type(None)

    def fit(self, trace: Trace, *, progress: bool = False) -> SolveResult:
        """Sweep the hyperparameters on ``trace`` and return the selected graph.

        Parameters
        ----------
        trace : Trace
        progress : bool
            Show a tqdm bar on stderr over the sweep's work (:meth:`_work`).

        Returns
        -------
        SolveResult
            ``status`` ``"feasible"`` (a graph is always produced; it may violate
            Exactly-One), ``k_pick``/``k_place`` the numbers of nodes per role, ``J`` on the
            baseline's own feature distances, and ``stats`` holding ``params`` (the selected
            hyperparameters), ``violations`` (:class:`GraphStats` of the selection),
            ``grid`` (one row per sweep point) and ``selection`` (the rule).
        """
        from tqdm.auto import tqdm

        t0 = time.perf_counter()
        total, unit = self._work()
        with tqdm(total=total, desc=self.name, unit=unit, disable=not progress,
                  leave=False) as bar:
            candidates = self._sweep(trace.without_states(), bar.update)
        best = select(candidates)
        seconds = time.perf_counter() - t0
        stats = {
            "params": best.params,
            "violations": best.stats.as_dict(),
            "grid": [c.grid_row() for c in candidates],
            "selection": "fewest transitions in Exactly-One violations, then fewest nodes",
            "constraints": NO_CONSTRAINTS,
        }
        return SolveResult(best.labels, best.stats.pick_nodes, best.stats.place_nodes, best.J,
                           FEASIBLE, self.name, seconds, None, stats)

    @abc.abstractmethod
    def _work(self) -> tuple[int, str]:
        """The sweep's work in all, and its unit (a progress bar's total and unit)."""

    @abc.abstractmethod
    def _sweep(self, trace: Trace, advance: Callable[[int], object]) -> list[Candidate]:
        """Every sweep point, in grid order (at least one); ``advance(n)`` reports ``n`` units
        of :meth:`_work` done."""


def baseline_solution(trace: Trace, result: SolveResult) -> dict:
    """The solution JSON object of a baseline result (``FORMATS.md`` plus ``grid``,
    ``constraints``, ``params``, ``violations``, ``seconds``)."""
    return labels_solution(trace, result.labels, solver=result.solver, status=result.status,
                           J=result.J, grid=result.stats["grid"],
                           constraints=result.stats["constraints"],
                           params=result.stats["params"], violations=result.stats["violations"],
                           selection=result.stats["selection"], seconds=round(result.seconds, 3))


BASELINES: dict[str, type[Baseline]] = {}


def register_baseline(cls: type[Baseline]) -> type[Baseline]:
    """Class decorator: add a baseline to :data:`BASELINES` under ``cls.name``."""
    BASELINES[cls.name] = cls
    return cls


def get_baseline(name: str, **options) -> Baseline:
    """Instantiate a registered baseline by name (unknown names list the known ones)."""
    return lookup(BASELINES, name, "baseline")(**options)
