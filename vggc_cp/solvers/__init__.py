"""Colouring solvers; every one returns :class:`~vggc_cp.solvers.base.SolveResult`."""

from vggc_cp.solvers.base import (
    FEASIBLE,
    INFEASIBLE,
    OPTIMAL,
    SOLVERS,
    STATUSES,
    UNKNOWN,
    Problem,
    Solver,
    SolveResult,
    get_solver,
    register_solver,
)

__all__ = ["FEASIBLE", "INFEASIBLE", "OPTIMAL", "SOLVERS", "STATUSES", "UNKNOWN", "Problem",
           "SolveResult", "Solver", "get_solver", "register_solver"]
