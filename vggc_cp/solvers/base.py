"""The values every solver shares: one :class:`Problem` in, one :class:`SolveResult` out.

A *cell* is a pair ``(k_pick, k_place)``: at most ``k_pick`` pick colours and ``k_place``
place colours. A solver colours the pick observations and the place observations of a
:class:`Problem` so that the induced task graph is bipartite and satisfies Exactly-One
(:func:`vggc_cp.graph.check`), and among such colourings prefers a low visual score J.
"""

from __future__ import annotations

import abc
import time
from dataclasses import dataclass, field

import numpy as np

from vggc_cp.errors import lookup
from vggc_cp.graph import TaskGraph
from vggc_cp.recorded import recorded_facts
from vggc_cp.score import visual_score
from vggc_cp.solvers.selection import GRID
from vggc_cp.trace import PICK, PLACE, Trace, hand_colours_along

OPTIMAL = "optimal"
FEASIBLE = "feasible"
INFEASIBLE = "infeasible"
UNKNOWN = "unknown"
STATUSES = (OPTIMAL, FEASIBLE, INFEASIBLE, UNKNOWN)


def set_role_index(problem) -> tuple[np.ndarray, np.ndarray]:
    """Give a frozen problem its ``roles`` (int8), ``pick_obs``, ``place_obs`` and ``local``
    (each observation's row in its role's distances); returns ``(pick_obs, place_obs)``."""
    roles = np.asarray(problem.roles, dtype=np.int8)
    pick, place = np.flatnonzero(roles == PICK), np.flatnonzero(roles == PLACE)
    local = np.empty(len(roles), dtype=np.int64)
    local[pick] = np.arange(len(pick))
    local[place] = np.arange(len(place))
    for name, value in (("roles", roles), ("pick_obs", pick), ("place_obs", place),
                        ("local", local)):
        object.__setattr__(problem, name, value)
    return pick, place


@dataclass(frozen=True, eq=False)
class SiteReads:
    """What every site holds in every observation, stated by the actions or read from the
    images, and how far each site's reading can be trusted.

    Attributes
    ----------
    held : ndarray of int64, shape (N, S)
        0 empty, ``1 + c`` an object of colour ``c``.
    stated : ndarray of bool, shape (N, S)
        Where the actions state it (a fact); elsewhere the images read it.
    kappa : ndarray of float64, shape (S,)
        The reading's agreement with the stated observations beyond chance (1 always right,
        0 no better than saying what most of them hold; NaN: nothing read).
    action : ndarray of int64, shape (S,)
        The action whose footprint is the site (it names the site).
    trust : ndarray of float64, shape (N, S), or None
        How far the reading that set each observation's value can be trusted: 1 where
        stated, else the kappa of the reading its run took, which is less than the site's
        ``kappa`` where that run fell back to a weaker reading (an arm hid the site in
        every pose of the run). None: the site's ``kappa`` for every observation.
    trust_low : ndarray of float64, shape (N, S), or None
        Where the evidence can say it, how far each observation's reading can be trusted
        for sure (a lower confidence bound, e.g. from the few stated frames of the poses
        that read it); NaN or None elsewhere.
    stacked : ndarray of bool, shape (S,), or None
        Sites of slots the actions stack, above another or under one: what the actions
        state there depends on which level they are read at. None: not known.
    """

    held: np.ndarray
    stated: np.ndarray
    kappa: np.ndarray
    action: np.ndarray
    trust: np.ndarray | None = None
    trust_low: np.ndarray | None = None
    stacked: np.ndarray | None = None

    def restricted(self, idx: np.ndarray) -> SiteReads:
        """The rows of the observations ``idx``."""
        return SiteReads(self.held[idx], self.stated[idx], self.kappa, self.action,
                         None if self.trust is None else self.trust[idx],
                         None if self.trust_low is None else self.trust_low[idx],
                         self.stacked)


@dataclass(frozen=True, eq=False)
class Readings:
    """What the evidence says every site of every observation holds, as symbols.

    The observations' rows are coded: ``symbols[codes[o]]`` is the row of observation ``o``,
    one small non-negative integer per site (the footprints: 0 where nothing is stated, 1
    empty, ``2 + c`` an object of colour ``c``). The description length codes the non-zero
    symbols given the nodes (:func:`vggc_cp.solvers.mdl.reading_length`).

    Attributes
    ----------
    codes : ndarray of int64, shape (N,)
    symbols : ndarray of int64, shape (G, S)
    kinds : ndarray of float64, shape (S,)
        How many non-zero symbols each site takes anywhere (at least 1): what stating a
        node's symbol there chooses from (derived from ``symbols``, once).
    sites : SiteReads or None
        Every site's value, read where not stated, and its reading's trust: not coded, but
        what tells doubtful nodes apart (:func:`vggc_cp.solvers.read_doubts.read_doubts`).
    """

    codes: np.ndarray
    symbols: np.ndarray
    kinds: np.ndarray = field(init=False)
    sites: SiteReads | None = None

    def __post_init__(self):
        kinds = [max(len(np.unique(col[col > 0])), 1) for col in np.asarray(self.symbols).T]
        object.__setattr__(self, "kinds", np.array(kinds, dtype=np.float64))

    @classmethod
    def from_rows(cls, rows: np.ndarray, sites: SiteReads | None = None) -> Readings:
        """From one row of symbols per observation, shape (N, S).

        >>> r = Readings.from_rows(np.array([[0, 2], [1, 2], [0, 2]]))
        >>> r.codes.tolist(), r.symbols.tolist()
        ([0, 1, 0], [[0, 2], [1, 2]])
        """
        rows = np.asarray(rows, dtype=np.int64)
        symbols, codes = np.unique(rows, axis=0, return_inverse=True)
        return cls(np.asarray(codes, dtype=np.int64).ravel(), symbols, sites)

    def restricted(self, idx: np.ndarray) -> Readings:
        """The readings of the observations ``idx`` (their codes; the same symbols)."""
        return Readings(self.codes[idx], self.symbols,
                        None if self.sites is None else self.sites.restricted(idx))


def kept_refusals(refused, new: np.ndarray) -> tuple[tuple[int, int], ...]:
    """``refused`` on the observations a restriction keeps (``new``: the new index of every
    observation, -1 where dropped).

    >>> kept_refusals(((0, 1), (2, 0)), np.array([-1, 0, 1]))
    ((1, 0),)
    """
    return tuple((int(new[o]), int(k)) for o, k in refused if new[o] >= 0)


def kept_resets(resets, new: np.ndarray) -> tuple[tuple[int, int], ...]:
    """``resets`` on the observations a restriction keeps, both ends kept (``new``: the new
    index of every observation, -1 where dropped).

    >>> kept_resets(((0, 2), (1, 2)), np.array([-1, 0, 1]))
    ((0, 1),)
    """
    return tuple((int(new[a]), int(new[b])) for a, b in resets if new[a] >= 0 and new[b] >= 0)


def hand_colours(problem) -> np.ndarray:
    """Colour of what the hand holds in every observation, int64 shape (N,), from the
    problem's ``action_colour``: a pick lifts an object of its colour and the next place puts
    it down, so a place-role observation holds the colour of the pick into it or of the place
    out of it. -1 for a pick-role observation, one no transition touches, or a problem
    without colours.

    Two place observations whose hands hold different colours are different states whatever
    the images say (the held object may be out of view, or look alike under an arm).

    >>> import numpy as np
    >>> p = Problem(np.array([0, 1, 0, 1]), np.array([0, 1, 2]), np.array([0, 1, 2]),
    ...             np.array([1, 2, 3]), ("pick_a", "place_a", "pick_b"),
    ...             np.zeros((2, 2)), np.zeros((2, 2)), action_colour=np.array([0, 0, 1]))
    >>> hand_colours(p).tolist()
    [-1, 0, -1, 1]
    """
    colour = problem.action_colour
    if colour is None or len(problem.act) == 0:
        return np.full(len(problem.roles), -1, dtype=np.int64)
    return hand_colours_along(len(problem.roles), problem.src, problem.act, problem.dst,
                              problem.roles[problem.dst] == PLACE,   # a pick: it holds it now
                              problem.roles[problem.src] == PLACE,   # a place: it held it
                              colour)


@dataclass(frozen=True, eq=False)
class Problem:
    """What a solver may see: roles, transitions, action names and within-role distances.

    Never holds ground-truth states.

    Attributes
    ----------
    roles : ndarray of int8, shape (N,)
    src, act, dst : ndarray of int64, shape (|D|,)
        Transition ``t`` goes from observation ``src[t]`` by action ``act[t]`` to ``dst[t]``.
    action_names : tuple of str, length A
    dist_pick : ndarray of float64, shape (n_pick, n_pick)
        Visual distance between pick observations, in the order of ``pick_obs``.
    dist_place : ndarray of float64, shape (n_place, n_place)
    action_colour : ndarray of int64, shape (A,), or None
        Colour of the objects every action moves, where the evidence tells colours apart
        (the footprints' :attr:`~vggc_cp.vision.footprints.Footprints.colour`): the hand
        holds one object, so a place node's actions all move one colour
        (:func:`hand_colours`; the congruence merge keeps to it). None: no such constraint.
    readings : Readings or None
        What the evidence reads at every site (:class:`Readings`); the description length
        then codes them too (:func:`vggc_cp.solvers.mdl.description_length`). None: only the
        actions are coded.
    refused : tuple of (int, int)
        ``(o, k)``: action ``k`` was refused in the state of observation ``o``
        (:func:`vggc_cp.recorded.recorded_facts`); the congruence merge never puts ``o`` in
        one node with an observation that took ``k``.
    resets : tuple of (int, int)
        ``(a, b)``: observation ``b``, an episode's first, shows the state of observation
        ``a`` (:func:`vggc_cp.recorded.recorded_facts`); such an episode cannot run on nodes
        of its own (:func:`vggc_cp.solvers.episodes.lone_episodes`).
    """

    roles: np.ndarray
    src: np.ndarray
    act: np.ndarray
    dst: np.ndarray
    action_names: tuple[str, ...]
    dist_pick: np.ndarray
    dist_place: np.ndarray
    #: what the evidence says about how it ran (e.g. the footprints' working resolution)
    notes: tuple[str, ...] = ()
    action_colour: np.ndarray | None = None
    readings: Readings | None = None
    refused: tuple[tuple[int, int], ...] = ()
    resets: tuple[tuple[int, int], ...] = ()
    pick_obs: np.ndarray = field(init=False)
    place_obs: np.ndarray = field(init=False)
    local: np.ndarray = field(init=False)

    def __post_init__(self):
        pick, place = set_role_index(self)
        for name, d, n in (("dist_pick", self.dist_pick, len(pick)),
                           ("dist_place", self.dist_place, len(place))):
            if np.shape(d) != (n, n):
                raise ValueError(f"{name} has shape {np.shape(d)}, expected ({n}, {n})")

    @classmethod
    def from_trace(cls, trace: Trace, dist_pick: np.ndarray, dist_place: np.ndarray,
                   action_colour: np.ndarray | None = None, readings: Readings | None = None
                   ) -> Problem:
        """Build a problem from a trace (its ``states`` are not copied) and distances."""
        src, act, dst = trace.transitions()
        facts = recorded_facts(trace)
        return cls(trace.roles(), src, act, dst, trace.action_names,
                   np.asarray(dist_pick, dtype=np.float64), np.asarray(dist_place, dtype=np.float64),
                   action_colour=action_colour, readings=readings,
                   refused=facts.refusals, resets=facts.resets)

    @property
    def n_obs(self) -> int:
        return len(self.roles)

    @property
    def n_pick(self) -> int:
        return len(self.pick_obs)

    @property
    def n_place(self) -> int:
        return len(self.place_obs)

    @property
    def n_actions(self) -> int:
        return len(self.action_names)

    def labels_from_colours(self, pick_colour: np.ndarray, place_colour: np.ndarray) -> np.ndarray:
        """Global node labels from per-role colours (shapes (n_pick,), (n_place,)).

        Pick colours become nodes ``0..`` and place colours follow, both renumbered compactly
        in order of first appearance, so node ids are unique across roles.
        """
        labels = np.empty(self.n_obs, dtype=np.int64)
        pick_ids = _compact(np.asarray(pick_colour))
        place_ids = _compact(np.asarray(place_colour))
        labels[self.pick_obs] = pick_ids
        labels[self.place_obs] = place_ids + (pick_ids.max() + 1 if len(pick_ids) else 0)
        return labels

    def visual_score(self, labels: np.ndarray) -> float:
        """The paper's J of a labelling on this problem's distances."""
        return visual_score(labels, self.roles, self.dist_pick, self.dist_place)

    def graph(self, labels: np.ndarray) -> TaskGraph:
        """The task graph that ``labels`` induces on this problem's transitions."""
        return TaskGraph.from_labels(labels, self.roles, self.src, self.act, self.dst,
                                     self.action_names)


def _compact(colours: np.ndarray) -> np.ndarray:
    if len(colours) == 0:
        return colours.astype(np.int64)
    _, first = np.unique(colours, return_index=True)
    order = np.argsort(first)
    mapping = {int(colours[first[i]]): rank for rank, i in enumerate(order)}
    return np.array([mapping[int(c)] for c in colours], dtype=np.int64)


@dataclass(frozen=True, eq=False)
class SolveResult:
    """The one result object every solver and baseline returns (like POT's ``OTResult``).

    Attributes
    ----------
    labels : ndarray of int64, shape (N,), or None
        Node of every observation; None when no colouring was found.
    k_pick, k_place : int
        The cell that was solved (upper bounds on colours per role).
    J : float
        Visual score of ``labels`` (``nan`` without a solution).
    status : str
        One of :data:`STATUSES`.
    bound : float or None
        Best proved lower bound on J (exact solvers).
    seconds : float
        Wall time.
    solver : str
    stats : dict
        Solver-specific statistics (backtracks, conflicts, model size, ...).
    """

    labels: np.ndarray | None
    k_pick: int
    k_place: int
    J: float
    status: str
    solver: str
    seconds: float = 0.0
    bound: float | None = None
    stats: dict = field(default_factory=dict)

    @property
    def found(self) -> bool:
        return self.labels is not None

    @property
    def n_nodes(self) -> int:
        return 0 if self.labels is None else int(len(np.unique(self.labels)))

    @property
    def gap(self) -> float | None:
        if self.bound is None or not self.found:
            return None
        if self.J == 0:
            return 0.0
        return max(0.0, (self.J - self.bound) / abs(self.J))


class Solver(abc.ABC):
    """The one solver protocol: ``solve(problem, k_pick, k_place) -> SolveResult``.

    Every registered solver (:data:`SOLVERS`: brute, cpsat, greedy, merge) takes one
    :class:`Problem`, never mutates it, and returns one :class:`SolveResult` whose ``labels``
    induce a bipartite, Exactly-One task graph (or None), ``J`` their visual score and
    ``status`` one of :data:`STATUSES`. A solver runs along one *axis*, and a selection rule of
    that axis (:mod:`vggc_cp.solvers.selection`) picks one of its results:

    * ``axis = "grid"`` (brute, cpsat, greedy): ``solve`` colours the cell ``(k_pick,
      k_place)`` (upper bounds on colours per role); a sweep runs it over a grid of cells;
    * ``axis = "path"`` (merge): the solver's own parameter (a threshold) is the axis;
      ``solve`` does not read ``k_pick``/``k_place`` and reports the colours it used in the
      result's ``k_pick``/``k_place``; a threshold path runs it along the axis.

    Attributes
    ----------
    name : str
        Registry name.
    axis : {'grid', 'path'}
        What the solver's results run along (the selection rules that apply).
    """

    name: str = "base"
    axis: str = GRID

    def solve(self, problem: Problem, k_pick: int, k_place: int) -> SolveResult:
        """Solve one cell; times the call and fills ``seconds``."""
        t0 = time.perf_counter()
        res = self._solve(problem, k_pick, k_place)
        seconds = time.perf_counter() - t0
        return SolveResult(res.labels, res.k_pick, res.k_place, res.J, res.status, res.solver,
                           seconds, res.bound, res.stats)

    @abc.abstractmethod
    def _solve(self, problem: Problem, k_pick: int, k_place: int) -> SolveResult:
        """Solve one cell (``seconds`` is filled in by :meth:`solve`)."""


SOLVERS: dict[str, type[Solver]] = {}


def register_solver(cls: type[Solver]) -> type[Solver]:
    """Class decorator: add a solver to :data:`SOLVERS` under ``cls.name``."""
    SOLVERS[cls.name] = cls
    return cls


def get_solver(name: str, **options) -> Solver:
    """Instantiate a registered solver by name (unknown names list the known ones)."""
    return lookup(SOLVERS, name, "solver")(**options)
