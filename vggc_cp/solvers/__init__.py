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

# register the built-in solvers ("greedy", "merge", "cpsat") on import of the package
from vggc_cp.solvers import cpsat as _cpsat  # noqa: E402,F401
from vggc_cp.solvers import greedy as _greedy  # noqa: E402,F401
from vggc_cp.solvers import mdl as _mdl  # noqa: E402,F401  (registers the "mdl" path rule)
from vggc_cp.solvers import merge as _merge  # noqa: E402,F401
