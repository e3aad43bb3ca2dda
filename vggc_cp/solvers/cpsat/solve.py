"""The CP-SAT solver of one cell: enumeration first, then the hinted objective model.

Warm start
----------
The greedy (DSATUR) colouring of the same cell, renamed to satisfy value precedence, is given
as a complete hint (every variable, auxiliary ones included). The result is never worse than
the hint: when CP-SAT returns a colouring with a larger float J than its hint (or none), the
hint is returned instead and ``stats['fell_back_to_hint']`` says so.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.solvers.base import (
    FEASIBLE,
    INFEASIBLE,
    OPTIMAL,
    UNKNOWN,
    Problem,
    Solver,
    SolveResult,
    register_solver,
)
from vggc_cp.solvers.brute import fit_colouring, split_colours, violations
from vggc_cp.solvers.cpsat.cell import CellModel
from vggc_cp.solvers.cpsat.enumeration import Enumeration, enumerate_colourings
from vggc_cp.solvers.cpsat.model import build_cell_model
from vggc_cp.solvers.cpsat.parameters import CpSatConfig
from vggc_cp.solvers.greedy import GreedySolver

#: A colouring offered as a repair hint is used only this many colour merges from the cell:
#: each merge tries every pair of colours (quadratic), and a far-away colouring is a poor start.
REPAIR_MAX_MERGES = 6


def greedy_result(problem: Problem, k_pick: int, k_place: int,
                  options: dict | None = None) -> SolveResult:
    """The greedy solver's result on the cell (the warm start), with ``options`` as keywords."""
    return GreedySolver(**(options or {})).solve(problem, k_pick, k_place)


def _cp_status(code) -> str:
    """Our status of a CP-SAT status code."""
    from ortools.sat.python import cp_model

    return {cp_model.OPTIMAL: OPTIMAL, cp_model.FEASIBLE: FEASIBLE,
            cp_model.INFEASIBLE: INFEASIBLE, cp_model.UNKNOWN: UNKNOWN}[code]


@register_solver
class CpSatSolver(Solver):
    """Exact colouring of one cell with OR-Tools CP-SAT (model: :mod:`vggc_cp.solvers.cpsat.model`).

    Parameters
    ----------
    objective, deterministic, max_actions, params, max_pair_terms, hint, symmetry,
    enumerate_limit, codeterministic, cannot_link :
        See :class:`CpSatConfig`. ``params`` errors raise :class:`VggcError` here.
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
                 max_actions: int | None = None, params: str = "",
                 max_pair_terms: int = 300_000, hint: str = "greedy", symmetry: bool = True,
                 enumerate_limit: int = 20_000,
                 greedy_options: dict | None = None, codeterministic: bool = False,
                 cannot_link: float | None = None,
                 hints: Sequence[tuple[str, np.ndarray]] = ()):
        self.options = CpSatConfig(objective, deterministic, max_actions, params,
                                    max_pair_terms, hint, symmetry, enumerate_limit,
                                    codeterministic, cannot_link)
        self.params_text = self.options.sat_parameters_text()
        self.greedy_options = dict(greedy_options or {})
        self.hints = [(str(src), np.asarray(lab, dtype=np.int64)) for src, lab in hints]

    def _solve(self, problem: Problem, k_pick: int, k_place: int) -> SolveResult:
        hints: list[tuple[str, np.ndarray]] = []
        if self.options.hint == "greedy":
            g = greedy_result(problem, k_pick, k_place, self.greedy_options)
            if g.found:
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
        from google.protobuf import text_format
        from ortools.sat import sat_parameters_pb2
        from ortools.sat.python import cp_model

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
        status = _cp_status(code)
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
