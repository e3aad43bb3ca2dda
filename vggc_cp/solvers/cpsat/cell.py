"""The built CP-SAT model of one cell: its variables, and how a colouring maps onto them.

:class:`CellModel` decodes a CP-SAT solution into per-role colours, renames colourings to the
model's symmetry-breaking order and writes a complete hint (every variable) for a colouring.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.cpsat.parameters import CpSatConfig

if TYPE_CHECKING:  # OR-Tools is imported where a model is built or solved
    from ortools.sat.python import cp_model


@dataclass(frozen=True)
class RoleVars:
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
    options: CpSatConfig
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
        """:math:`\\hat J` of a colouring (the model's objective, see :mod:`vggc_cp.solvers.cpsat.objective`)."""
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
