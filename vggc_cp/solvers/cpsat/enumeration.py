r"""Exact optimum of a cell by enumerating its valid colourings with CP-SAT.

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
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.cpsat.cell import CellModel
from vggc_cp.solvers.cpsat.model import build_cell_model
from vggc_cp.solvers.cpsat.parameters import CpSatConfig


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
                         options: CpSatConfig | None = None, limit: int = 20_000,
                         max_seconds: float = 10.0) -> Enumeration:
    """Visit every valid colouring of a cell (up to renaming) with CP-SAT; keep the lowest J.

    The feasibility model of the cell (objective none, symmetry breaking on, which leaves one
    representative per partition) with :func:`_exact_auxiliaries` has exactly one solution
    per valid colouring, so ``enumerate_all_solutions`` lists them without repetition. Stops
    (``complete=False``) after ``limit`` colourings or ``max_seconds``.
    """
    t0 = time.perf_counter()
    options = CpSatConfig() if options is None else options
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

    from ortools.sat.python import cp_model

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
