r"""Exact CP-SAT model of one ``(k_pick, k_place)`` cell, warm-started by the greedy solver.

The model
---------
Let :math:`P` be the pick observations, :math:`Q` the place observations, and
:math:`K_P = \min(k_{pick}, |P|)`, :math:`K_Q = \min(k_{place}, |Q|)` the colours each role may
use (more colours than observations are never needed). Transitions are split by direction:
pick transitions :math:`(o, a, o') \in P \times A_{pick} \times Q` and place transitions
:math:`(o, a, o') \in Q \times A_{place} \times P`.

*Colours.* One Boolean :math:`x_{o,c}` per observation and colour of its role, with
``add_exactly_one`` over :math:`c`. A node of the task graph is a (role, colour) pair, so the
graph is bipartite by construction.

*Pair-action table.* For every direction, ordered colour pair :math:`(c, c')` and action
:math:`a` of that direction that occurs in the trace, a Boolean :math:`y_{c,c',a}` ("the
edge :math:`c \xrightarrow{a} c'` exists"), with **Exactly-One**
:math:`\sum_a y_{c,c',a} \le 1` and, for every transition :math:`(o, a, o')`, the clauses
:math:`x_{o,c} \wedge x_{o',c'} \Rightarrow y_{c,c',a}` for all :math:`c, c'`. Only the lower
bound of :math:`y` is forced; since every constraint on :math:`y` is downward closed, a
colouring is feasible in the model iff its *induced* edges satisfy the constraints — the
model is exact.

*Deterministic* (option): :math:`\sum_{c'} y_{c,c',a} \le 1` for every source colour and
action (one node and one action lead to one node).

*Action variety.* :math:`u_{c,a}` ("colour :math:`c` has an outgoing :math:`a`-edge") with
:math:`x_{o,c} \Rightarrow u_{c,a}` for each observation :math:`o` whose outgoing action is
:math:`a`, and symmetrically :math:`v_{c',a}` for incoming actions. Distinct outgoing actions of
one node must reach distinct nodes (Exactly-One), so :math:`\sum_a u_{c,a} \le K_{other}` and
:math:`\sum_a v_{c',a} \le K_{other}`; every action occurs, so :math:`\sum_c u_{c,a} \ge 1`.
These are *implied* cuts (valid for every valid colouring) that give the LP relaxation the
pigeonhole bound :math:`|A_{dir}| \le K_P K_Q`. Where the pair table exists they are linked
to it: :math:`u_{c,a} \Rightarrow \bigvee_{c'} y_{c,c',a}` and
:math:`v_{c',a} \Rightarrow \bigvee_{c} y_{c,c',a}` (an action that leaves or enters a node
labels one of its pairs); on fruit-4x6, |D| = 70, this cuts the time CP-SAT takes to prove
the cells just below the frontier infeasible by a factor of 2 to 5 (one worker). The option
``max_actions = K`` tightens :math:`\sum_a u_{c,a} \le K`: at most ``K`` distinct action
labels leave a node.

*Symmetry breaking* (value precedence, Law & Lee 2004). Colours of one role are
interchangeable. Order the observations of a role :math:`\pi_0, \pi_1, \dots` and require that
colour :math:`c \ge 1` is used by :math:`\pi_r` only if colour :math:`c-1` is used by some
:math:`\pi_s`, :math:`s < r`; encoded with prefix Booleans
:math:`p_{r,c} \Leftrightarrow p_{r-1,c} \vee x_{\pi_r,c}` and
:math:`x_{\pi_r,c} \Rightarrow p_{r-1,c-1}` (so :math:`x_{\pi_r,c}` does not exist for
:math:`c > r`). Every colouring has exactly one representative (rename colours by first
appearance along :math:`\pi`), so this removes all :math:`K!` symmetric copies and keeps
exactness. When the *other* role has a single colour, two observations whose outgoing (or
incoming) actions differ can never share a colour — sound because every transition then ends
in the same node; a greedy clique of that conflict graph is put first in :math:`\pi` and fixed
to colours ``0, 1, ...`` (the Heule–Verwer clique of exact DFA identification) and a clique
larger than :math:`K` proves infeasibility. With two or more colours on the other side no pair
of observations is conflicting or forced equal in every valid colouring: each observation has
at most one predecessor and one successor, and the all-singletons colouring is always valid.

*Presolve* (exact): cap :math:`K` at the number of observations; drop actions absent from the
trace; skip the pair table of a direction with one action and no ``deterministic`` /
``max_actions``; prove infeasibility without search when :math:`|A_{dir}| > K_P K_Q`
(each ordered colour pair carries one action) or, with ``max_actions = K``, when
:math:`|A_{dir}| > K_{src} K`; or when the conflict clique above exceeds :math:`K`.

Objective (quantized visual score)
----------------------------------
Distances are symmetrized, :math:`\bar d_{ij} = (d_{ij} + d_{ji}) / 2`, and scaled to integers
:math:`\hat d_{ij} = \mathrm{round}(s\,\bar d_{ij})` with :math:`s = R / \max \bar d` (one
:math:`s` for both roles; ``resolution`` :math:`R`, default 1000: the largest distance
becomes :math:`R`). For each colour :math:`c`: :math:`w_{ijc} \ge x_{ic} \wedge x_{jc}` (only
pairs with :math:`\hat d_{ij} > 0`), :math:`S_c = \sum_{i<j} \hat d_{ij} w_{ijc}`, size
:math:`n_c = \sum_i x_{ic}`, :math:`q_c = n_c (n_c - 1)` and an integer mean :math:`m_c` with
:math:`m_c \cdot q_c \ge 2 S_c` (``add_multiplication_equality``). Minimizing
:math:`\sum_c m_c` makes :math:`m_c = \lceil 2 S_c / q_c \rceil` (0 for clusters of at most
one observation), so **the integer objective equals**

.. math:: \hat J = \sum_c \left\lceil \frac{\sum_{i<j \in c} \hat d_{ij}}{|c|(|c|-1)/2}
          \right\rceil ,

the visual score J of the paper on the quantized distances with each cluster's mean rounded
up. For any colouring, :math:`s J - K/2 \le \hat J < s J + 3K/2` with :math:`K` the number
of clusters of two or more observations; the solution's true float J is recomputed from its
labels and reported beside :math:`\hat J`. *Optimal* means optimal for :math:`\hat J`, hence
within ``quantization_margin`` :math:`= 2 (K_P + K_Q) / s` of the true optimum of J.
``bound`` is the proved lower bound on :math:`\hat J / s`.

*Size-aware lower bound* (``size_cuts``, exact reformulation plus an implied cut). Cluster
sizes are one-hot, :math:`\beta_{c,t} \Leftrightarrow n_c = t`, with
:math:`\sum_t t\,\beta_{c,t} = n_c` and :math:`q_c = \sum_t t(t-1)\,\beta_{c,t}` (linear, no
product); :math:`z_{i,c,t} = x_{ic} \wedge \beta_{c,t}` is linked by
:math:`\sum_t z_{ict} = x_{ic}` and :math:`\sum_i z_{ict} = t\,\beta_{c,t}` (a cluster of size
:math:`t` has :math:`t` members). The mean of a cluster is the average over its members of
their mean distance to the other members, and a member's mean distance to :math:`t-1` others is
at least the mean of its :math:`t-1` smallest distances :math:`H_i(t)/(t-1)`. Hence the valid cut

.. math:: m_c \ge \sum_i \sum_{t \ge 2} \frac{H_i(t)}{t(t-1)} z_{ict}

(coefficients rounded down at scale 1/64). Unlike the product constraint, whose LP relaxation
is 0, this bound is tight when clusters are visually tight, and it sees the cost of a cluster
that outgrows a visual group. On fruit-2x3 (|D| = 50) the best bound stayed at 0 for 60 s
without it; with it the minimal cell (3, 2) is proved optimal in about 27 s on an unloaded
machine (2 workers). Cells of about 50 observations per role (|D| = 95) keep a gap after
two minutes.

The pair variables grow as :math:`O(n^2 K)`. When their number exceeds ``max_pair_terms``
the model drops the objective (a documented relaxation: feasibility only, the colouring with
the lower J of the CP-SAT solution and its hint is kept), and the status is at most
*feasible* with no bound.

Exact optimum by enumeration
----------------------------
With objective ``J`` (and ``symmetry`` on) a cell is first solved by enumeration: the
feasibility model (no objective) with every auxiliary Boolean tied to the colours in both
directions (:func:`_exact_auxiliaries`: :math:`y_{c,c',a}` implies some :math:`a`-transition
from a :math:`c`- to a :math:`c'`-observation, :math:`u`, :math:`v` imply a member with that
action) has exactly one solution per valid colouring up to renaming (value precedence keeps one
representative per partition), and CP-SAT's ``enumerate_all_solutions`` lists them; the float
J of each is computed from the colours. When the enumeration ends within
``enumerate_limit`` colourings and half the cell's time limit, its best colouring is the
**exact optimum of the float J** (no quantization), the status is *optimal*, ``bound``
equals J and ``stats['method']`` is ``'enumeration'``; no colouring at all proves the cell
infeasible. Minimal cells are tightly constrained: the selected cells of fruit-2x3 (3, 2),
multifruit-2x3 (3, 3) and blocks-2 (3, 3) have 16, 2 and 1 valid colourings, which the
objective model below could not prove optimal in minutes (its LP bound stays far below the
optimum) but enumeration decides in a fraction of a second. Otherwise the best enumerated
colouring joins the hints and the objective model gets the rest of the time limit.

Warm start
----------
The greedy (DSATUR) colouring of the same cell, renamed to satisfy value precedence, is given
as a complete hint (every variable, auxiliary ones included). The result is never worse than
the hint: when CP-SAT returns a colouring with a larger float J than its hint (or none), the
hint is returned instead and ``stats['fell_back_to_hint']`` says so.

References
----------
M. Heule, S. Verwer. *Exact DFA identification using SAT solvers*, ICGI 2010.
Y. C. Law, J. H. M. Lee. *Global constraints for integer and set value precedence*, CP 2004.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from google.protobuf import text_format
from ortools.sat import sat_parameters_pb2
from ortools.sat.python import cp_model

from vggc_cp.errors import VggcError
from vggc_cp.solvers.base import (
    FEASIBLE,
    INFEASIBLE,
    OPTIMAL,
    SOLVERS,
    UNKNOWN,
    Problem,
    Solver,
    SolveResult,
    register_solver,
)
from vggc_cp.solvers.brute import CellConstraints, fit_colouring, split_colours, violations
from vggc_cp.trace import PICK, PLACE

OBJECTIVES = ("J", "none")
HINTS = ("greedy", "none")
DEFAULT_PARAMS = "max_time_in_seconds:10,num_workers:2"

#: A colouring offered as a repair hint is used only this many colour merges from the cell:
#: each merge tries every pair of colours (quadratic), and a far-away colouring is a poor start.
REPAIR_MAX_MERGES = 6
SIZE_CUT_SCALE = 64


# ---------------------------------------------------------------- parameters


def parse_cpsat_params(text: str | None) -> str:
    """Validate a ``--cpsat-params`` string and return it as protobuf text format.

    Parameters
    ----------
    text : str or None
        Comma- or newline-separated ``field:value`` items of OR-Tools' ``SatParameters``,
        e.g. ``"max_time_in_seconds:30,num_workers:2"``.

    Raises
    ------
    VggcError
        Naming the offending item (unknown field, bad value).
    """
    if not text or not text.strip():
        return ""
    msg = sat_parameters_pb2.SatParameters()
    items = [s.strip() for chunk in text.split("\n") for s in chunk.split(",")]
    for item in items:
        if not item:
            continue
        try:
            text_format.Merge(item, msg)
        except text_format.ParseError as exc:
            raise VggcError(f"--cpsat-params: cannot parse {item!r}: {exc}") from None
    return text_format.MessageToString(msg)


@dataclass(frozen=True)
class CpSatOptions:
    r"""Everything that shapes the CP-SAT model of a cell and its solve.

    Attributes
    ----------
    objective : {'J', 'none'}
        Minimize the quantized visual score, or decide feasibility only.
    deterministic : bool
    max_actions : int or None
    params : str
        CP-SAT parameters (``--cpsat-params`` syntax), merged over :data:`DEFAULT_PARAMS`.
    resolution : int
        The largest distance is scaled to this integer (see the module docstring).
    max_pair_terms : int
        Above this many pair variables the objective is dropped (feasibility only).
    hint : {'greedy', 'none'}
        Warm start from the greedy solver of the same cell.
    symmetry : bool
        Value-precedence symmetry breaking (and the conflict clique).
    size_cuts : bool
        Cluster-size indicators and the nearest-neighbour lower bound on each cluster's mean
        (see the module docstring); off: ``q_c = n_c (n_c - 1)`` by a product constraint.
    codeterministic : bool
        One action into a node comes from one node: :math:`\sum_{c} y_{c,c',a} \le 1`.
    cannot_link : float or None
        Two observations of one role farther apart than this (visual distance) never share a
        colour: :math:`x_{o,c} + x_{o',c} \le 1`.
    enumerate_limit : int
        With objective ``J``, first enumerate the cell's valid colourings (up to renaming) and
        keep the lowest float J when there are at most this many; 0 disables, and so does
        ``symmetry=False`` (see the module docstring, *Exact optimum by enumeration*).
    """

    objective: str = "J"
    deterministic: bool = False
    max_actions: int | None = None
    params: str = ""
    resolution: int = 1000
    max_pair_terms: int = 300_000
    hint: str = "greedy"
    symmetry: bool = True
    size_cuts: bool = True
    enumerate_limit: int = 20_000
    codeterministic: bool = False
    cannot_link: float | None = None

    def __post_init__(self):
        if self.objective not in OBJECTIVES:
            raise VggcError(f"unknown objective {self.objective!r}; known: {', '.join(OBJECTIVES)}")
        if self.hint not in HINTS:
            raise VggcError(f"unknown hint {self.hint!r}; known: {', '.join(HINTS)}")
        if self.resolution < 1:
            raise VggcError(f"resolution must be a positive integer, got {self.resolution}")
        if self.enumerate_limit < 0:
            raise VggcError(f"enumerate_limit must be >= 0, got {self.enumerate_limit}")
        self.constraints  # noqa: B018  (validates max_actions and cannot_link)

    @property
    def constraints(self) -> CellConstraints:
        return CellConstraints(self.deterministic, self.max_actions, self.codeterministic,
                               self.cannot_link)

    def sat_parameters_text(self) -> str:
        """Default parameters with the user's merged over them, as protobuf text."""
        msg = sat_parameters_pb2.SatParameters()
        text_format.Merge(parse_cpsat_params(DEFAULT_PARAMS), msg)
        text_format.Merge(parse_cpsat_params(self.params), msg)
        return text_format.MessageToString(msg)


# ---------------------------------------------------------------- model


@dataclass(frozen=True)
class _Role:
    """One role's side of the model: its observations, order and colour variables."""

    role: int
    obs: np.ndarray                 # global observation ids, local order
    k: int                          # colours available (capped at len(obs))
    order: np.ndarray               # precedence order, local ids
    x: list                         # x[i][c]: BoolVar or None (fixed false)
    prefix: dict                    # (rank, c) -> literal: colour c used among order[:rank+1]


@dataclass(frozen=True, eq=False)
class CellModel:
    """A built CP-SAT model of one cell plus what is needed to hint and decode it.

    Attributes
    ----------
    model : cp_model.CpModel or None
        None when presolve already proved the cell infeasible.
    infeasible_reason : str or None
    objective_mode : {'J', 'none'}
        The objective actually in the model.
    scale : float
        :math:`s`, integer units per unit of distance.
    notes : tuple of str
        Presolve and relaxation decisions.
    """

    problem: Problem
    k_pick: int
    k_place: int
    options: CpSatOptions
    model: cp_model.CpModel | None
    infeasible_reason: str | None
    objective_mode: str
    scale: float
    roles: tuple = ()
    y: dict = field(default_factory=dict)
    out_used: dict = field(default_factory=dict)
    in_used: dict = field(default_factory=dict)
    pairs: dict = field(default_factory=dict)       # (role, i, j, c) -> (BoolVar, dhat)
    means: dict = field(default_factory=dict)       # (role, c) -> (q, prod, m, members)
    sizes: dict = field(default_factory=dict)       # (role, c) -> (beta[t], z[(i, t)])
    dhat: tuple = ()
    notes: tuple = ()

    @property
    def n_variables(self) -> int:
        return 0 if self.model is None else len(self.model.proto.variables)

    @property
    def n_constraints(self) -> int:
        return 0 if self.model is None else len(self.model.proto.constraints)

    @property
    def quantization_margin(self) -> float:
        """Upper bound on ``|J_true - J_hat / s|`` differences that optimality allows."""
        return 2.0 * (self.k_pick + self.k_place) / self.scale

    # ------------------------------------------------------------ decode / hint

    def colours_of(self, solver: cp_model.CpSolver) -> tuple[np.ndarray, np.ndarray]:
        """Per-role colours of the solver's solution: shapes (n_pick,), (n_place,)."""
        out = []
        for r in self.roles:
            col = np.empty(len(r.obs), dtype=np.int64)
            for i, row in enumerate(r.x):
                col[i] = next(c for c, v in enumerate(row) if v is not None and solver.boolean_value(v))
            out.append(col)
        return out[0], out[1]

    def canonical(self, pick_colour: np.ndarray, place_colour: np.ndarray) -> tuple:
        """Rename colours by first appearance along each role's precedence order."""
        out = []
        for r, col in zip(self.roles, (pick_colour, place_colour)):
            col = np.asarray(col, dtype=np.int64)
            rename: dict[int, int] = {}
            for i in r.order.tolist():
                rename.setdefault(int(col[i]), len(rename))
            out.append(np.array([rename[int(c)] for c in col], dtype=np.int64))
        return out[0], out[1]

    def integer_objective(self, pick_colour: np.ndarray, place_colour: np.ndarray) -> int:
        """:math:`\\hat J` of a colouring (the model's objective, see the module docstring)."""
        total = 0
        for dq, col in zip(self.dhat, (pick_colour, place_colour)):
            for c in np.unique(col):
                mem = np.flatnonzero(col == c)
                n = len(mem)
                if n < 2:
                    continue
                s2 = int(dq[np.ix_(mem, mem)].sum())  # = 2 * S_c
                total += -(-s2 // (n * (n - 1)))
        return total

    def hint_assignment(self, pick_colour: np.ndarray, place_colour: np.ndarray) -> dict:
        """Values of every model variable for a colouring: ``{index: (var, value)}`` (for an
        invalid one, a hint that CP-SAT has to repair).

        The colouring is first renamed by :meth:`canonical` so that it satisfies the
        symmetry breaking; returns ``{}`` when it uses more colours than the cell allows.
        """
        cols = self.canonical(pick_colour, place_colour)
        vals: dict[int, tuple] = {}

        def put(var, value):
            if var is None or isinstance(var, (int, bool)):
                return
            vals[var.index] = (var, int(value))

        for r, col in zip(self.roles, cols):
            if len(col) and col.max() >= r.k:
                return {}
            for i, row in enumerate(r.x):
                for c, v in enumerate(row):
                    put(v, col[i] == c)
            seen: set[int] = set()
            for rank, i in enumerate(r.order.tolist()):
                seen.add(int(col[i]))
                for c in range(r.k):
                    lit = r.prefix.get((rank, c))
                    if lit is not None:
                        put(lit, c in seen)
        colour = np.empty(self.problem.n_obs, dtype=np.int64)
        colour[self.problem.pick_obs] = cols[0]
        colour[self.problem.place_obs] = cols[1]
        roles = self.problem.roles
        edges, outs, ins = set(), set(), set()
        for s, a, d in zip(self.problem.src.tolist(), self.problem.act.tolist(),
                           self.problem.dst.tolist()):
            r = int(roles[s])
            edges.add((r, int(colour[s]), int(colour[d]), a))
            outs.add((r, int(colour[s]), a))
            ins.add((1 - r, int(colour[d]), a))
        for key, v in self.y.items():
            put(v, key in edges)
        for key, v in self.out_used.items():
            put(v, key in outs)
        for key, v in self.in_used.items():
            put(v, key in ins)
        for (role, i, j, c), (w, _) in self.pairs.items():
            col = cols[role]
            put(w, col[i] == c and col[j] == c)
        for (role, c), (q, prod, m, _) in self.means.items():
            col = cols[role]
            mem = np.flatnonzero(col == c)
            n = len(mem)
            mval = 0
            if n >= 2:
                s2 = int(self.dhat[role][np.ix_(mem, mem)].sum())
                mval = -(-s2 // (n * (n - 1)))
            put(q, n * (n - 1))
            put(m, mval)
            put(prod, mval * n * (n - 1))
            if (role, c) in self.sizes:
                beta, z = self.sizes[(role, c)]
                for t, b in enumerate(beta):
                    put(b, t == n)
                for (i, t), v in z.items():
                    put(v, col[i] == c and t == n)
        return vals


def _greedy_clique(adj: list[set[int]]) -> list[int]:
    """A clique of the graph ``adj`` (vertex -> neighbours), grown by largest degree."""
    cand = set(range(len(adj)))
    clique: list[int] = []
    while cand:
        v = max(sorted(cand), key=lambda u: len(adj[u] & cand))
        clique.append(v)
        cand &= adj[v]
    return clique


def _conflict_graph(problem: Problem, role: int) -> list[set[int]]:
    """Observations of ``role`` that cannot share a colour when the other role has one colour.

    Two observations conflict when both have an outgoing transition with different actions,
    or both an incoming one with different actions (both would put two labels on the pair
    (c, the other role's only node)).
    """
    obs = problem.pick_obs if role == PICK else problem.place_obs
    out_a = {int(s): int(a) for s, a in zip(problem.src, problem.act)}
    in_a = {int(d): int(a) for d, a in zip(problem.dst, problem.act)}
    n = len(obs)
    adj: list[set[int]] = [set() for _ in range(n)]
    for key in (out_a, in_a):
        groups: dict[int, list[int]] = {}
        for i, o in enumerate(obs.tolist()):
            if o in key:
                groups.setdefault(key[o], []).append(i)
        members = list(groups.values())
        for gi, g in enumerate(members):
            other = [j for h in members[gi + 1:] for j in h]
            for i in g:
                for j in other:
                    adj[i].add(j)
                    adj[j].add(i)
    return adj


def build_cell_model(problem: Problem, k_pick: int, k_place: int,
                     options: CpSatOptions = CpSatOptions()) -> CellModel:
    """Build the CP-SAT model of one cell (see the module docstring for the mathematics)."""
    notes: list[str] = []
    n_role = (problem.n_pick, problem.n_place)
    kk = (min(k_pick, n_role[0]), min(k_place, n_role[1]))
    if kk != (k_pick, k_place):
        notes.append(f"colours capped at the observation counts: {kk[0]} pick, {kk[1]} place")
    dmax = max(float(np.max(problem.dist_pick, initial=0.0)),
               float(np.max(problem.dist_place, initial=0.0)))
    scale = options.resolution / dmax if dmax > 0 else 1.0
    dhat = tuple(np.rint((d + d.T) / 2.0 * scale).astype(np.int64)
                 for d in (problem.dist_pick, problem.dist_place))
    for d in dhat:
        np.fill_diagonal(d, 0)

    def infeasible(reason: str) -> CellModel:
        return CellModel(problem, k_pick, k_place, options, None, reason, "none", scale,
                         dhat=dhat, notes=tuple(notes + [reason]))

    roles_arr = problem.roles
    src, act, dst = problem.src, problem.act, problem.dst
    for r in (PICK, PLACE):
        if n_role[r] > 0 and kk[r] < 1:
            return infeasible(f"{('pick', 'place')[r]} side has observations but no colour")
    dir_actions = [sorted({int(a) for s, a in zip(src, act) if roles_arr[s] == r})
                   for r in (PICK, PLACE)]
    for r in (PICK, PLACE):
        n_a = len(dir_actions[r])
        if n_a > kk[0] * kk[1]:
            return infeasible(f"{n_a} distinct {('pick', 'place')[r]} actions > "
                              f"k_pick*k_place = {kk[0] * kk[1]} ordered colour pairs")
        if options.max_actions is not None and n_a > kk[r] * options.max_actions:
            return infeasible(f"{n_a} distinct {('pick', 'place')[r]} actions > "
                              f"{kk[r]} nodes x max_actions {options.max_actions}")

    # ---- orders and fixed clique
    orders, fixed = [], []
    for r in (PICK, PLACE):
        order = np.arange(n_role[r], dtype=np.int64)  # time order within the role
        clique: list[int] = []
        if options.symmetry and kk[1 - r] == 1:
            clique = _greedy_clique(_conflict_graph(problem, r))
            if len(clique) > kk[r]:
                return infeasible(f"{len(clique)} {('pick', 'place')[r]} observations pairwise "
                                  f"conflict (other side has one colour) > {kk[r]} colours")
            if len(clique) > 1:
                notes.append(f"{('pick', 'place')[r]}: clique of {len(clique)} conflicting "
                             f"observations fixed to distinct colours")
                rest = np.setdiff1d(order, clique, assume_unique=True)
                order = np.concatenate([np.array(clique, dtype=np.int64), rest])
        orders.append(order)
        fixed.append(clique if len(clique) > 1 else [])

    model = cp_model.CpModel()
    roles: list[_Role] = []
    for r in (PICK, PLACE):
        n, k, order = n_role[r], kk[r], orders[r]
        rank = np.empty(n, dtype=np.int64)
        rank[order] = np.arange(n)
        x: list[list] = []
        for i in range(n):
            top = min(int(rank[i]), k - 1) if options.symmetry else k - 1
            row = [model.new_bool_var(f"x{r}_{i}_{c}") for c in range(top + 1)]
            row += [None] * (k - 1 - top)
            model.add_exactly_one([v for v in row if v is not None])
            x.append(row)
        for pos, i in enumerate(fixed[r]):
            model.add(x[i][pos] == 1)
        prefix: dict = {}
        if options.symmetry:
            for pos, i in enumerate(order.tolist()):
                for c in range(k - 1):  # colour k-1 is never a predecessor colour
                    prev = prefix.get((pos - 1, c))
                    cur = x[i][c]
                    if prev is None and cur is None:
                        continue
                    if prev is None or cur is None:
                        prefix[(pos, c)] = cur if prev is None else prev
                        continue
                    p = model.new_bool_var(f"p{r}_{pos}_{c}")
                    model.add_implication(prev, p)
                    model.add_implication(cur, p)
                    model.add_bool_or([~p, prev, cur])
                    prefix[(pos, c)] = p
                for c in range(1, k):
                    cur = x[i][c]
                    if cur is None:
                        continue
                    prev = prefix.get((pos - 1, c - 1))
                    if prev is None:
                        model.add(cur == 0)
                    else:
                        model.add_implication(cur, prev)
        roles.append(_Role(r, problem.pick_obs if r == PICK else problem.place_obs, k, order,
                           x, prefix))

    local = problem.local
    trans = [(int(s), int(a), int(d)) for s, a, d in zip(src, act, dst)]

    # ---- pair-action table (Exactly-One), determinism
    y: dict = {}
    for r in (PICK, PLACE):
        needs_table = (len(dir_actions[r]) > 1 or options.deterministic
                       or options.codeterministic)
        if not needs_table:
            notes.append(f"{('pick', 'place')[r]} direction has one action: no pair table")
            continue
        xs, xd = roles[r].x, roles[1 - r].x
        for s, a, d in trans:
            if roles_arr[s] != r:
                continue
            for c, vs in enumerate(xs[local[s]]):
                if vs is None:
                    continue
                for c2, vd in enumerate(xd[local[d]]):
                    if vd is None:
                        continue
                    key = (r, c, c2, a)
                    if key not in y:
                        y[key] = model.new_bool_var(f"y{r}_{c}_{c2}_{a}")
                    model.add_bool_or([~vs, ~vd, y[key]])
    by_pair: dict = {}
    by_succ: dict = {}
    by_pred: dict = {}
    for (r, c, c2, a), v in y.items():
        by_pair.setdefault((r, c, c2), []).append(v)
        by_succ.setdefault((r, c, a), []).append(v)
        by_pred.setdefault((r, c2, a), []).append(v)
    for vs in by_pair.values():
        if len(vs) > 1:
            model.add_at_most_one(vs)
    if options.deterministic:
        for vs in by_succ.values():
            if len(vs) > 1:
                model.add_at_most_one(vs)
    if options.codeterministic:
        for vs in by_pred.values():
            if len(vs) > 1:
                model.add_at_most_one(vs)

    # ---- visual cannot-link: observations farther apart than the bound never share a colour
    if options.cannot_link is not None:
        n_links = 0
        for r, dist in ((PICK, problem.dist_pick), (PLACE, problem.dist_place)):
            x = roles[r].x
            ii, jj = np.nonzero(np.triu((dist + dist.T) / 2.0 > options.cannot_link, 1))
            for i, j in zip(ii.tolist(), jj.tolist()):
                for vi, vj in zip(x[i], x[j]):
                    if vi is not None and vj is not None:
                        model.add_bool_or([~vi, ~vj])
            n_links += len(ii)
        notes.append(f"cannot-link: {n_links} pairs farther apart than {options.cannot_link:g}")

    # ---- action variety: implied cuts, max_actions
    has_table = [any(key[0] == r for key in y) for r in (PICK, PLACE)]
    out_used: dict = {}
    in_used: dict = {}
    for r in (PICK, PLACE):
        n_a = len(dir_actions[r])
        cap_out = kk[1 - r] if options.max_actions is None else min(kk[1 - r], options.max_actions)
        cap_in = kk[r]
        for table, side, cap, end in ((out_used, r, cap_out, 0), (in_used, 1 - r, cap_in, 2)):
            if n_a <= cap:
                continue  # the cut cannot bind
            xsd = roles[side].x
            for tr in trans:
                if roles_arr[tr[0]] != r:
                    continue
                o, a = tr[end], tr[1]
                for c, v in enumerate(xsd[local[o]]):
                    if v is None:
                        continue
                    key = (side, c, a)
                    if key not in table:
                        table[key] = model.new_bool_var(f"{'uv'[end // 2]}{side}_{c}_{a}")
                    model.add_implication(v, table[key])
            per_c: dict = {}
            per_a: dict = {}
            for (sd, c, a), v in table.items():
                if sd == side and a in dir_actions[r]:
                    per_c.setdefault(c, []).append(v)
                    per_a.setdefault(a, []).append(v)
            for vs in per_c.values():
                if len(vs) > cap:
                    model.add(sum(vs) <= cap)
            for vs in per_a.values():
                model.add_bool_or(vs)
            if has_table[r]:  # a used action needs a labelled pair (both ends)
                for (sd, c, a), v in table.items():
                    if sd != side or a not in dir_actions[r]:
                        continue
                    ys = [y[key] for c2 in range(kk[1 - side])
                          if (key := ((r, c, c2, a) if end == 0 else (r, c2, c, a))) in y]
                    model.add_bool_or([~v] + ys)

    # ---- objective
    pairs: dict = {}
    means: dict = {}
    sizes: dict = {}
    objective_mode = options.objective
    if objective_mode == "J":
        n_terms = sum(int(np.count_nonzero(np.triu(dhat[r], 1))) * kk[r] for r in (PICK, PLACE))
        if n_terms > options.max_pair_terms:
            objective_mode = "none"
            notes.append(f"objective dropped: {n_terms} pair terms > max_pair_terms "
                         f"{options.max_pair_terms} (feasibility only)")
    if objective_mode == "J":
        terms = []
        for r in (PICK, PLACE):
            n, k, x, dq = n_role[r], kk[r], roles[r].x, dhat[r]
            dmax_i = int(dq.max(initial=0))
            iu, ju = np.nonzero(np.triu(dq, 1))
            for c in range(k):
                members = [x[i][c] for i in range(n) if x[i][c] is not None]
                if len(members) < 2:
                    continue
                s_terms = []
                for i, j in zip(iu.tolist(), ju.tolist()):
                    xi, xj = x[i][c], x[j][c]
                    if xi is None or xj is None:
                        continue
                    w = model.new_bool_var(f"w{r}_{i}_{j}_{c}")
                    model.add_bool_or([~xi, ~xj, w])
                    pairs[(r, i, j, c)] = (w, int(dq[i, j]))
                    s_terms.append(int(dq[i, j]) * w)
                nm = len(members)
                size = sum(members)
                q = model.new_int_var(0, nm * (nm - 1), f"q{r}_{c}")
                if options.size_cuts:
                    cand = [i for i in range(n) if x[i][c] is not None]
                    beta = [model.new_bool_var(f"b{r}_{c}_{t}") for t in range(nm + 1)]
                    model.add_exactly_one(beta)
                    model.add(sum(t * b for t, b in enumerate(beta)) == size)
                    model.add(sum(t * (t - 1) * b for t, b in enumerate(beta)) == q)
                    z: dict = {}
                    cut = []
                    for i in cand:
                        near = np.cumsum(np.sort(np.delete(dq[i], i)))  # H_i(t) = near[t-2]
                        for t in range(1, nm + 1):
                            v = model.new_bool_var(f"z{r}_{c}_{i}_{t}")
                            model.add_implication(v, x[i][c])
                            model.add_implication(v, beta[t])
                            z[(i, t)] = v
                            if t >= 2:
                                coef = int(SIZE_CUT_SCALE * int(near[t - 2]) // (t * (t - 1)))
                                if coef > 0:
                                    cut.append(coef * v)
                        model.add(sum(z[(i, t)] for t in range(1, nm + 1)) == x[i][c])
                    for t in range(1, nm + 1):
                        model.add(sum(z[(i, t)] for i in cand) == t * beta[t])
                    sizes[(r, c)] = (beta, z)
                else:
                    model.add_multiplication_equality(q, [size, size - 1])
                m = model.new_int_var(0, dmax_i, f"m{r}_{c}")
                prod = model.new_int_var(0, dmax_i * nm * (nm - 1), f"mq{r}_{c}")
                model.add_multiplication_equality(prod, [m, q])
                if s_terms:
                    model.add(prod >= 2 * sum(s_terms))
                if options.size_cuts and cut:
                    model.add(SIZE_CUT_SCALE * m >= sum(cut))
                means[(r, c)] = (q, prod, m, nm)
                terms.append(m)
        model.minimize(sum(terms))
    return CellModel(problem, k_pick, k_place, options, model, None, objective_mode, scale,
                     tuple(roles), y, out_used, in_used, pairs, means, sizes, dhat, tuple(notes))


# ---------------------------------------------------------------- enumeration


@dataclass(frozen=True)
class Enumeration:
    """Outcome of :func:`enumerate_colourings`.

    Attributes
    ----------
    complete : bool
        Every valid colouring of the cell was visited (then ``J`` is the exact optimum).
    count : int
        Valid colourings visited (up to renaming of colours within a role).
    pick_colour, place_colour : ndarray or None
        The visited colouring with the lowest float J.
    J : float
        Its float J (``nan`` when none was visited).
    seconds : float
    variables, constraints : int
        Size of the enumeration model (0 when presolve proved the cell infeasible).
    """

    complete: bool
    count: int
    pick_colour: np.ndarray | None
    place_colour: np.ndarray | None
    J: float
    seconds: float
    variables: int = 0
    constraints: int = 0
    notes: tuple = ()


def _exact_auxiliaries(cm: CellModel) -> None:
    r"""Tie every auxiliary Boolean of a feasibility model to the colours (both directions).

    The model forces only ``y``, ``u`` and ``v`` *up*; for enumeration each valid colouring
    must have exactly one model solution, so ``y_{c,c',a}`` also implies that some
    ``a``-transition runs from a ``c``- to a ``c'``-observation (``e_{t,c,c'} = x_{s,c} \wedge
    x_{d,c'}``, defined both ways), and ``u_{c,a}`` / ``v_{c,a}`` imply some member with that
    outgoing / incoming action. Prefix literals are already defined by equivalences.
    """
    p, model = cm.problem, cm.model
    roles, local = p.roles, p.local
    trans = [(int(s), int(a), int(d)) for s, a, d in zip(p.src, p.act, p.dst)]
    support: dict = {}
    e_vars: dict = {}
    for t, (s, a, d) in enumerate(trans):
        r = int(roles[s])
        xs, xd = cm.roles[r].x[local[s]], cm.roles[1 - r].x[local[d]]
        for c, vs in enumerate(xs):
            for c2, vd in enumerate(xd):
                key = (r, c, c2, a)
                if vs is None or vd is None or key not in cm.y:
                    continue
                e = model.new_bool_var(f"e{t}_{c}_{c2}")
                model.add_implication(e, vs)
                model.add_implication(e, vd)
                model.add_bool_or([~vs, ~vd, e])
                e_vars[(t, c, c2)] = e
                support.setdefault(key, []).append(e)
    for key, yv in cm.y.items():
        model.add_bool_or([~yv] + support.get(key, []))
    out_obs: dict = {}
    in_obs: dict = {}
    for s, a, d in trans:
        out_obs.setdefault((int(roles[s]), a), []).append(s)
        in_obs.setdefault((int(roles[d]), a), []).append(d)
    for table, obs_of in ((cm.out_used, out_obs), (cm.in_used, in_obs)):
        for (side, c, a), uv in table.items():
            lits = [cm.roles[side].x[local[o]][c] for o in obs_of.get((side, a), [])]
            model.add_bool_or([~uv] + [v for v in lits if v is not None])


def _role_scorer(dist: np.ndarray, k: int):
    """``colours (n,) -> J of the role`` (the paper's J), memoized on the colouring."""
    d = np.asarray(dist, dtype=np.float64).copy()
    np.fill_diagonal(d, 0.0)
    eye = np.eye(max(k, 1))
    memo: dict[bytes, float] = {}

    def score(col: np.ndarray) -> float:
        key = col.tobytes()
        got = memo.get(key)
        if got is not None:
            return got
        value = 0.0
        if len(col):
            x = eye[col]
            n = x.sum(axis=0)
            s = ((d @ x) * x).sum(axis=0)
            q = n * (n - 1)
            value = float(np.sum(s[q > 0] / q[q > 0]))
        if len(memo) < 1_000_000:
            memo[key] = value
        return value

    return score


def enumerate_colourings(problem: Problem, k_pick: int, k_place: int,
                         options: CpSatOptions = CpSatOptions(), limit: int = 20_000,
                         max_seconds: float = 10.0) -> Enumeration:
    """Visit every valid colouring of a cell (up to renaming) with CP-SAT; keep the lowest J.

    The feasibility model of the cell (objective none, symmetry breaking on, which leaves one
    representative per partition) with :func:`_exact_auxiliaries` has exactly one solution
    per valid colouring, so ``enumerate_all_solutions`` lists them without repetition. Stops
    (``complete=False``) after ``limit`` colourings or ``max_seconds``.
    """
    t0 = time.perf_counter()
    opts = dataclasses.replace(options, objective="none", symmetry=True)  # one per partition
    cm = build_cell_model(problem, k_pick, k_place, opts)
    if cm.model is None:
        return Enumeration(True, 0, None, None, math.nan, time.perf_counter() - t0,
                           notes=cm.notes)
    _exact_auxiliaries(cm)
    # one integer colour per observation (defined by its x row) is read back per solution
    index = []
    for r in cm.roles:
        ids = []
        for i, row in enumerate(r.x):
            col = cm.model.new_int_var(0, max(r.k - 1, 0), f"col{r.role}_{i}")
            cm.model.add(col == sum(c * v for c, v in enumerate(row) if v is not None))
            ids.append(col.index)
        index.append(ids)
    scorers = [_role_scorer(problem.dist_pick, cm.roles[0].k),
               _role_scorer(problem.dist_place, cm.roles[1].k)]

    class _Visit(cp_model.CpSolverSolutionCallback):
        def __init__(self):
            super().__init__()
            self.count = 0
            self.best = (math.inf, None, None)
            self.overflow = False

        def on_solution_callback(self):
            if self.count >= limit:
                self.overflow = True
                self.stop_search()
                return
            self.count += 1
            value = self.SolutionIntegerValue
            cols = [np.array([value(i) for i in ids], dtype=np.int64) for ids in index]
            J = scorers[0](cols[0]) + scorers[1](cols[1])
            if J < self.best[0]:
                self.best = (J, cols[0], cols[1])

    solver = cp_model.CpSolver()
    solver.parameters.enumerate_all_solutions = True
    solver.parameters.num_workers = 1
    solver.parameters.max_time_in_seconds = max(float(max_seconds), 0.01)
    visit = _Visit()
    code = solver.solve(cm.model, visit)
    if code == cp_model.MODEL_INVALID:
        raise RuntimeError(f"CP-SAT model invalid: {cm.model.validate()}")
    complete = (not visit.overflow) and code in (cp_model.OPTIMAL, cp_model.INFEASIBLE)
    J, pc, qc = visit.best
    return Enumeration(complete, visit.count, pc, qc, J if pc is not None else math.nan,
                       time.perf_counter() - t0, cm.n_variables, cm.n_constraints, cm.notes)


# ---------------------------------------------------------------- solver


def greedy_result(problem: Problem, k_pick: int, k_place: int,
                  options: dict | None = None) -> SolveResult | None:
    """The registered greedy solver's result on the cell, or None when it is not installed."""
    if "greedy" not in SOLVERS:
        try:
            importlib.import_module("vggc_cp.solvers.greedy")
        except ImportError:
            return None
    if "greedy" not in SOLVERS:
        return None
    return SOLVERS["greedy"](**(options or {})).solve(problem, k_pick, k_place)


_CP_STATUS = {cp_model.OPTIMAL: OPTIMAL, cp_model.FEASIBLE: FEASIBLE,
              cp_model.INFEASIBLE: INFEASIBLE, cp_model.UNKNOWN: UNKNOWN}


@register_solver
class CpSatSolver(Solver):
    """Exact colouring of one cell with OR-Tools CP-SAT (model: see the module docstring).

    Parameters
    ----------
    objective, deterministic, max_actions, params, resolution, max_pair_terms, hint, symmetry,
    size_cuts, enumerate_limit, codeterministic, cannot_link :
        See :class:`CpSatOptions`. ``params`` errors raise :class:`VggcError` here.
    greedy_options : dict, optional
        Keyword arguments of the greedy solver that computes the hint.
    hints : sequence of (str, ndarray), optional
        Extra colourings ``(source, labels (N,))`` offered to every cell, e.g. a solution of a
        larger cell. A valid one is a hint like the greedy colouring (and the floor of the
        result). When no offered colouring is valid in the cell, the one that
        :func:`~vggc_cp.solvers.brute.fit_colouring` squeezes into it with the fewest
        violations (at most :data:`REPAIR_MAX_MERGES` merges away) is given to CP-SAT as a
        *repair* hint (``repair_hint``): a start for the search, never part of a proof;
        ``stats["repair_hint"]`` says which and how far off.
    """

    name = "cpsat"

    def __init__(self, objective: str = "J", deterministic: bool = False,
                 max_actions: int | None = None, params: str = "", resolution: int = 1000,
                 max_pair_terms: int = 300_000, hint: str = "greedy", symmetry: bool = True,
                 size_cuts: bool = True, enumerate_limit: int = 20_000,
                 greedy_options: dict | None = None, codeterministic: bool = False,
                 cannot_link: float | None = None,
                 hints: Sequence[tuple[str, np.ndarray]] = ()):
        self.options = CpSatOptions(objective, deterministic, max_actions, params, resolution,
                                    max_pair_terms, hint, symmetry, size_cuts, enumerate_limit,
                                    codeterministic, cannot_link)
        self.params_text = self.options.sat_parameters_text()
        self.greedy_options = dict(greedy_options or {})
        self.hints = [(str(src), np.asarray(lab, dtype=np.int64)) for src, lab in hints]

    def _solve(self, problem: Problem, k_pick: int, k_place: int) -> SolveResult:
        hints: list[tuple[str, np.ndarray]] = []
        if self.options.hint == "greedy":
            g = greedy_result(problem, k_pick, k_place, self.greedy_options)
            if g is not None and g.found:
                hints.append(("greedy", g.labels))
        return self._solve_hinted(problem, k_pick, k_place, hints)

    def solve_hinted(self, problem: Problem, k_pick: int, k_place: int,
                     hints: list[tuple[str, np.ndarray]]) -> SolveResult:
        """Solve with given hint colourings ``[(source, labels (N,)), ...]`` (greedy not run).

        The valid hint with the lowest float J becomes the complete CP-SAT hint and the floor
        of the result.
        """
        t0 = time.perf_counter()
        res = self._solve_hinted(problem, k_pick, k_place, hints)
        return SolveResult(res.labels, res.k_pick, res.k_place, res.J, res.status, res.solver,
                           time.perf_counter() - t0, res.bound, res.stats)

    def _solve_hinted(self, problem: Problem, k_pick: int, k_place: int,
                      hints: list[tuple[str, np.ndarray]]) -> SolveResult:
        t0 = time.perf_counter()
        hints = list(hints) + self.hints
        params = sat_parameters_pb2.SatParameters()
        text_format.Merge(self.params_text, params)
        max_time = params.max_time_in_seconds
        enum = None
        if (self.options.objective == "J" and self.options.enumerate_limit > 0
                and self.options.symmetry):
            enum = enumerate_colourings(problem, k_pick, k_place, self.options,
                                        self.options.enumerate_limit, max_time / 2)
            if enum.complete:
                return self._enumerated(problem, k_pick, k_place, hints, enum)
        cm = build_cell_model(problem, k_pick, k_place, self.options)
        stats: dict = {"objective_mode": cm.objective_mode, "scale": cm.scale,
                       "quantization_margin": cm.quantization_margin, "notes": list(cm.notes),
                       "fell_back_to_hint": False, "hint_source": None, "hint_J": None,
                       "method": "cpsat"}
        if enum is not None:
            stats["enumerated"] = enum.count
            stats["notes"].append(f"enumeration stopped after {enum.count} colourings "
                                  f"({enum.seconds:.1f} s)")
        best_hint = self._pick_hint(problem, k_pick, k_place, hints, stats)
        if enum is not None and enum.pick_colour is not None:
            lab = problem.labels_from_colours(enum.pick_colour, enum.place_colour)
            if best_hint is None or enum.J < best_hint[2]:
                best_hint = ("enumeration", lab, problem.visual_score(lab))
                stats["hint_source"], stats["hint_J"] = best_hint[0], best_hint[2]
        if cm.model is None:
            stats.update(status_name="PRESOLVE_INFEASIBLE", variables=0, constraints=0,
                         wall_time=0.0, conflicts=0, branches=0)
            if best_hint is not None:  # a valid colouring contradicts the proof: keep it
                stats["contradiction"] = cm.infeasible_reason
                return self._result(problem, k_pick, k_place, best_hint[1], FEASIBLE, None, stats)
            return SolveResult(None, k_pick, k_place, math.nan, INFEASIBLE, self.name,
                               stats=stats)
        stats.update(variables=cm.n_variables, constraints=cm.n_constraints)
        repair = False
        if best_hint is not None:
            pc, qc = split_colours(problem, best_hint[1])
            values = cm.hint_assignment(pc, qc)
            for var, value in values.values():
                cm.model.add_hint(var, value)
            stats["hint_objective"] = cm.integer_objective(*cm.canonical(pc, qc)) \
                if cm.objective_mode == "J" else None
        elif self.hints:
            repair = self._add_repair_hint(problem, k_pick, k_place, cm, stats)
        solver = cp_model.CpSolver()
        if not solver.parameters.merge_text_format(self.params_text):
            raise VggcError(f"--cpsat-params rejected by OR-Tools: {self.params_text!r}")
        if repair:
            solver.parameters.repair_hint = True
        if enum is not None and math.isfinite(max_time):  # the limit covers the whole cell
            solver.parameters.max_time_in_seconds = max(max_time - (time.perf_counter() - t0),
                                                        0.01)
        code = solver.solve(cm.model)
        if code == cp_model.MODEL_INVALID:
            raise RuntimeError(f"CP-SAT model invalid: {cm.model.validate()}")
        status = _CP_STATUS[code]
        stats.update(status_name=solver.status_name(code), wall_time=solver.wall_time,
                     conflicts=int(solver.num_conflicts), branches=int(solver.num_branches))
        labels = None
        bound_int = None
        if status in (OPTIMAL, FEASIBLE):
            pc, qc = cm.colours_of(solver)
            labels = problem.labels_from_colours(pc, qc)
            if cm.objective_mode == "J":
                stats["objective"] = int(round(solver.objective_value))
                bound_int = int(math.ceil(solver.best_objective_bound - 1e-9))
                stats["objective_bound"] = bound_int
                obj = stats["objective"]
                stats["gap"] = 0.0 if obj <= 0 else max(0.0, (obj - bound_int) / obj)
            else:
                status = FEASIBLE  # decided, but J was not optimized
        if status == INFEASIBLE and best_hint is not None:
            stats["contradiction"] = "CP-SAT proved infeasible but the hint is valid"
        if best_hint is not None:
            J_cp = problem.visual_score(labels) if labels is not None else math.inf
            if best_hint[2] < J_cp - 1e-12:
                stats["fell_back_to_hint"] = True
                labels = best_hint[1]
                if status in (INFEASIBLE, UNKNOWN):
                    status = FEASIBLE
        bound = None
        if labels is not None and bound_int is not None:
            bound = bound_int / cm.scale
        return self._result(problem, k_pick, k_place, labels, status, bound, stats)

    def _enumerated(self, problem, k_pick, k_place, hints, enum: Enumeration) -> SolveResult:
        """The result of a complete enumeration: exact float optimum, or proved infeasible."""
        stats: dict = {"objective_mode": "J", "method": "enumeration",
                       "enumerated": enum.count, "variables": enum.variables,
                       "constraints": enum.constraints,
                       "status_name": "ENUMERATED" if enum.variables else "PRESOLVE_INFEASIBLE",
                       "wall_time": enum.seconds, "conflicts": 0, "branches": 0,
                       "quantization_margin": 0.0, "notes": list(enum.notes),
                       "fell_back_to_hint": False, "hint_source": None, "hint_J": None}
        best_hint = self._pick_hint(problem, k_pick, k_place, hints, stats)
        if enum.pick_colour is None:
            if best_hint is not None:  # a valid colouring contradicts the enumeration: keep it
                stats["contradiction"] = "enumeration found no colouring but the hint is valid"
                return self._result(problem, k_pick, k_place, best_hint[1], FEASIBLE, None, stats)
            return SolveResult(None, k_pick, k_place, math.nan, INFEASIBLE, self.name,
                               stats=stats)
        labels = problem.labels_from_colours(enum.pick_colour, enum.place_colour)
        J = problem.visual_score(labels)
        status, bound = OPTIMAL, J
        if best_hint is not None and best_hint[2] < J - 1e-12:  # cannot happen if exact
            stats["fell_back_to_hint"] = True
            stats["contradiction"] = "a hint beats the enumerated optimum"
            labels, status, bound = best_hint[1], FEASIBLE, None
        stats["gap"] = 0.0 if status == OPTIMAL else None
        return self._result(problem, k_pick, k_place, labels, status, bound, stats)

    def _add_repair_hint(self, problem, k_pick, k_place, cm: CellModel, stats) -> bool:
        """Hint the offered colouring that fits the cell with the fewest violations (only
        colourings at most :data:`REPAIR_MAX_MERGES` merges away from the cell)."""
        best = None
        for source, labels in self.hints:
            if len(labels) != problem.n_obs:
                continue
            pc, qc = split_colours(problem, labels)
            merges = max(len(np.unique(pc)) - k_pick, 0) + max(len(np.unique(qc)) - k_place, 0)
            if merges > REPAIR_MAX_MERGES:
                stats.setdefault("hints_rejected", []).append(
                    f"{source}: {merges} merges from the cell (> {REPAIR_MAX_MERGES})")
                continue
            pc, qc, bad = fit_colouring(problem, labels, k_pick, k_place,
                                        self.options.constraints)
            if best is None or bad < best[0]:
                best = (bad, source, pc, qc)
        if best is None:
            return False
        values = cm.hint_assignment(best[2], best[3])
        for var, value in values.values():
            cm.model.add_hint(var, value)
        stats["repair_hint"] = (f"{best[1]}: merged into the cell's colours, "
                                f"{best[0]} violated constraints")
        return bool(values)

    def _pick_hint(self, problem, k_pick, k_place, hints, stats):
        """The valid hint with the lowest float J: ``(source, labels, J)`` or None."""
        best = None
        rejected = []
        for source, labels in hints:
            pc, qc = split_colours(problem, labels)
            if pc.max(initial=-1) >= k_pick or qc.max(initial=-1) >= k_place:
                rejected.append(f"{source}: more colours than the cell allows")
                continue
            bad = violations(problem, pc, qc, self.options.constraints)
            if bad:
                rejected.append(f"{source}: {bad[0]}")
                continue
            J = problem.visual_score(labels)
            if best is None or J < best[2]:
                best = (source, np.asarray(labels, dtype=np.int64), J)
        if rejected:
            stats["hints_rejected"] = rejected
        if best is not None:
            stats["hint_source"], stats["hint_J"] = best[0], best[2]
        return best

    def _result(self, problem, k_pick, k_place, labels, status, bound, stats) -> SolveResult:
        if labels is None:
            return SolveResult(None, k_pick, k_place, math.nan, status, self.name, bound=None,
                               stats=stats)
        labels = np.asarray(labels, dtype=np.int64)
        return SolveResult(labels, k_pick, k_place, problem.visual_score(labels), status,
                           self.name, bound=bound, stats=stats)


# ---------------------------------------------------------------- grid


OPTIMIZE = ("minimal", "all")


def exact_sweep(problem: Problem, k_pick: Sequence[int], k_place: Sequence[int],
                solver: CpSatSolver, greedy: Sequence[SolveResult] = (), *,
                optimize: str = "minimal", select: str = "fewest", progress: bool = False):
    """Decide every cell of a grid with CP-SAT, then minimize J where it matters.

    Feasibility is monotone: a colouring of ``(a, b)`` is a colouring of every
    ``(a', b') >= (a, b)``, and a cell proved infeasible proves every ``(a', b') <= (a, b)``
    infeasible. Hence

    1. **Frontier** (objective none): rows ``k_pick = a`` are walked from the largest ``a`` down,
       ``k_place`` upwards, skipping cells already decided by dominance (a greedy colouring of a
       smaller cell, or a proof for a larger one), until the row's first feasible cell: a
       staircase of ``O(|k_pick| + |k_place|)`` solves decides the whole grid. When a cell of
       the row ends undecided (time limit), the rest of the row is bisected for its lowest
       feasible cell instead (``O(log |k_place|)`` solves, each of which may also prove the
       cells below it infeasible); cells between stay undecided unless a proof covers them.
    2. **J** (objective ``J``): cells of the minimal feasible ``k_pick + k_place``
       (``optimize="minimal"``, the candidates of the fewest-nodes rule) or every feasible cell
       (``"all"``) are optimized in increasing order, hinted by the greedy colouring and the
       colourings found for smaller cells.

    Cells that are not optimized keep the best (lowest J) colouring known for a smaller or
    equal cell, status ``feasible`` without bound; ``stats['decided_by']`` says whether a cell
    was solved or inferred (and from which cell).

    Parameters
    ----------
    greedy : sequence of SolveResult
        Greedy results of (some of) the cells; used as witnesses and hints.
    optimize : {'minimal', 'all'}
    select : str
        Selection rule (:data:`vggc_cp.solvers.sweep.SELECTIONS`).

    Returns
    -------
    vggc_cp.solvers.sweep.Sweep
    """
    from vggc_cp.solvers.sweep import Sweep, get_selection

    if optimize not in OPTIMIZE:
        raise VggcError(f"unknown optimize mode {optimize!r}; known: {', '.join(OPTIMIZE)}")
    rule = get_selection(select)
    kp, kq = sorted({int(a) for a in k_pick}), sorted({int(b) for b in k_place})
    if not kp or not kq:
        raise VggcError("the (k_pick, k_place) grid is empty")
    t_start = time.perf_counter()
    opts = solver.options
    # the same model without objective; offered colourings also start its solves
    feas_solver = CpSatSolver(**{**dataclasses.asdict(opts), "objective": "none", "hint": "none"},
                              greedy_options=solver.greedy_options, hints=solver.hints)
    cons = opts.constraints
    witness: dict = {}        # cell -> (source, labels, J): valid colourings found in the cell
    proved: dict = {}         # cell -> SolveResult proving infeasibility
    solved: dict = {}         # cell -> last SolveResult of CP-SAT in the cell
    spent: dict = {}

    def add_witness(cell, source, labels):
        pc, qc = split_colours(problem, labels)
        if pc.max(initial=-1) >= cell[0] or qc.max(initial=-1) >= cell[1]:
            return
        if violations(problem, pc, qc, cons):
            return
        J = problem.visual_score(labels)
        if cell not in witness or J < witness[cell][2]:
            witness[cell] = (source, np.asarray(labels, dtype=np.int64), J)

    for g in greedy:
        if g.found:
            add_witness((g.k_pick, g.k_place), "greedy", g.labels)

    def below(cell):
        return [w + (c,) for c, w in witness.items() if c[0] <= cell[0] and c[1] <= cell[1]]

    def infeasible_by(cell):
        return next((c for c in proved if c[0] >= cell[0] and c[1] >= cell[1]), None)

    def run(s, cell):
        hints = [(f"{src}@{c[0]},{c[1]}", lab) for src, lab, _, c in below(cell)]
        res = s.solve_hinted(problem, cell[0], cell[1], hints)
        spent[cell] = spent.get(cell, 0.0) + res.seconds
        solved[cell] = res
        if res.status == INFEASIBLE:
            proved[cell] = res
        elif res.found:
            add_witness(cell, "cpsat", res.labels)
        return res

    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(desc="cpsat frontier", unit="cell", leave=False)
    try:
        for a in reversed(kp):
            undecided_at = None
            for j, b in enumerate(kq):
                cell = (a, b)
                if infeasible_by(cell) is not None:
                    continue
                if below(cell):
                    break
                res = run(feas_solver, cell)
                if bar is not None:
                    bar.update(1)
                if res.found:
                    break
                if res.status != INFEASIBLE:
                    undecided_at = j
                    break
            if undecided_at is None:
                continue
            # past an undecided cell, bisect for the row's lowest feasible cell
            lo = undecided_at
            hi = next((j for j in range(lo + 1, len(kq)) if below((a, kq[j]))), len(kq))
            while hi - lo > 1:
                mid = (lo + hi) // 2
                res = run(feas_solver, (a, kq[mid]))
                if bar is not None:
                    bar.update(1)
                if res.found:
                    hi = mid
                else:
                    lo = mid
        todo = []
        if opts.objective == "J":
            feasible = [(a, b) for a in kp for b in kq if below((a, b))]
            if feasible:
                low = min(a + b for a, b in feasible)
                todo = sorted((c for c in feasible if optimize == "all" or sum(c) == low),
                              key=lambda c: (c[0] + c[1], c))
        if bar is not None:
            bar.reset(total=len(todo))
            bar.set_description("cpsat J")
        for cell in todo:
            run(solver, cell)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()

    results = []
    optimized = set(todo)
    for a in kp:
        for b in kq:
            cell = (a, b)
            last = solved.get(cell)
            stats = dict(last.stats) if last is not None else {"variables": 0, "constraints": 0}
            if cell in optimized and last.found:
                stats["decided_by"] = "solved"
                results.append(_with(last, spent[cell], stats))
                continue
            by = infeasible_by(cell)
            if by is not None:
                stats["decided_by"] = "solved" if by == cell else f"inferred from {by}"
                results.append(SolveResult(None, a, b, math.nan, INFEASIBLE, solver.name,
                                           spent.get(cell, 0.0), None, stats))
                continue
            wits = below(cell)
            if wits:
                src, labels, J, c = min(wits, key=lambda w: w[2])
                stats["decided_by"] = ("solved" if cell in solved else
                                       f"{src} colouring" if c == cell else f"inferred from {c}")
                stats["colouring_from"] = f"{src}@{c[0]},{c[1]}"
                results.append(SolveResult(labels, a, b, J, FEASIBLE, solver.name,
                                           spent.get(cell, 0.0), None, stats))
                continue
            stats["decided_by"] = "undecided"
            results.append(SolveResult(None, a, b, math.nan, UNKNOWN, solver.name,
                                       spent.get(cell, 0.0), None, stats))
    selected = rule(results, problem)
    return Sweep(tuple(results), selected, select, solver.name, time.perf_counter() - t_start, 1)


def compare_records(greedy, exact) -> list[dict]:
    """One row per cell of two sweeps over the same grid (greedy, CP-SAT exact sweep).

    Columns: ``k_pick, k_place, greedy_feasible, greedy_J, greedy_seconds, cpsat_status,
    cpsat_J, bound, gap, cpsat_seconds, variables, constraints, decided_by``. ``gap`` is the
    relative gap of the integer objective (0 when proved optimal, empty without a bound).
    """
    by_cell = {(r.k_pick, r.k_place): r for r in greedy.results}
    rows = []
    for r in exact.results:
        g = by_cell.get((r.k_pick, r.k_place))
        rows.append({
            "k_pick": r.k_pick, "k_place": r.k_place,
            "greedy_feasible": bool(g is not None and g.found),
            "greedy_J": None if g is None or not g.found else float(g.J),
            "greedy_seconds": None if g is None else round(float(g.seconds), 4),
            "cpsat_status": r.status,
            "cpsat_J": None if not r.found else float(r.J),
            "bound": r.bound,
            "gap": r.stats.get("gap") if r.bound is not None else None,
            "cpsat_seconds": round(float(r.seconds), 4),
            "variables": int(r.stats.get("variables", 0)),
            "constraints": int(r.stats.get("constraints", 0)),
            "decided_by": r.stats.get("decided_by", ""),
        })
    return rows


@dataclass(frozen=True)
class NodeFrontier:
    """The smallest number of nodes a sweep found, and whether it is proved minimal.

    Attributes
    ----------
    nodes : int or None
        Fewest abstract nodes used by any colouring of the sweep (None: no colouring).
    cells : tuple of (k_pick, k_place)
        The minimal cells (no other such cell below them) whose colouring uses that many nodes.
    proved : bool
        Every cell ``(k_pick, k_place)`` with ``k_pick + k_place < nodes`` (both at least 1) is
        proved infeasible: by the CP-SAT sweep ``proof``, or by counting (fewer colour pairs
        than distinct actions of a role). No colouring of any grid uses fewer nodes.
    untried : int
        Cells with fewer nodes that the run neither tried nor rules out by counting (a
        restricted ``--k-pick``/``--k-place`` range): while any remain, nothing is proved.
    """

    nodes: int | None
    cells: tuple
    proved: bool
    untried: int = 0

    @property
    def verdict(self) -> str:
        """``yes``, ``not proved (smaller cells not tried)`` or ``no``, for reports."""
        if self.proved:
            return "yes"
        if self.untried:
            return "not proved (smaller cells not tried)"
        return "no"


def node_frontier(sweep, proof=None, need: int = 1) -> NodeFrontier:
    """:class:`NodeFrontier` of ``sweep``, with infeasibility proofs from ``proof`` (or itself).

    ``need`` is the larger count of distinct pick and place actions
    (:func:`~vggc_cp.solvers.sweep.action_counts`): Exactly-One gives every action of a role
    its own colour pair, so a cell with ``k_pick * k_place < need`` has no colouring and needs
    no run. With the default 1 every smaller cell must have been decided in the run.
    """
    found = [r for r in sweep.results if r.found]
    if not found:
        return NodeFrontier(None, (), False)
    nodes = min(r.n_nodes for r in found)
    at = {(r.k_pick, r.k_place) for r in found if r.n_nodes == nodes}
    cells = tuple(sorted(c for c in at if not any(o != c and o[0] <= c[0] and o[1] <= c[1]
                                                  for o in at)))
    proof = sweep if proof is None else proof
    status = {(r.k_pick, r.k_place): r.status for r in proof.results}
    smaller = [(a, b) for a in range(1, nodes) for b in range(1, nodes - a)
               if a * b >= need]  # the rest are infeasible by counting
    untried = sum((a, b) not in status for a, b in smaller)
    proved = untried == 0 and all(status[c] == INFEASIBLE for c in smaller)
    return NodeFrontier(nodes, cells, proved, untried)


def _with(res: SolveResult, seconds: float, stats: dict) -> SolveResult:
    return SolveResult(res.labels, res.k_pick, res.k_place, res.J, res.status, res.solver,
                       seconds, res.bound, stats)


__all__ = ["DEFAULT_PARAMS", "OPTIMIZE", "CellModel", "CpSatOptions", "CpSatSolver",
           "NodeFrontier", "build_cell_model", "compare_records", "exact_sweep", "node_frontier", "greedy_result", "parse_cpsat_params"]
