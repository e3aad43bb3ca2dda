"""Exact CP-SAT colouring of ``(k_pick, k_place)`` cells, warm-started by the greedy solver.

One module per job:

* :mod:`~vggc_cp.solvers.cpsat.parameters` -- :class:`CpSatConfig`, the ``--cpsat-params`` string;
* :mod:`~vggc_cp.solvers.cpsat.model` -- the constraints of a cell's model (the mathematics);
* :mod:`~vggc_cp.solvers.cpsat.objective` -- the quantized visual score J it minimizes;
* :mod:`~vggc_cp.solvers.cpsat.cell` -- :class:`CellModel`: decode a solution, hint a colouring;
* :mod:`~vggc_cp.solvers.cpsat.enumeration` -- the exact optimum of small cells by enumeration;
* :mod:`~vggc_cp.solvers.cpsat.solve` -- :class:`CpSatSolver` (the hinted run, its statistics);
* :mod:`~vggc_cp.solvers.cpsat.frontier` -- :func:`exact_sweep` over a grid, "proved minimal".
"""

from vggc_cp.solvers.cpsat.cell import CellModel
from vggc_cp.solvers.cpsat.enumeration import Enumeration, enumerate_colourings
from vggc_cp.solvers.cpsat.frontier import (
    OPTIMIZE,
    NodeFrontier,
    compare_records,
    exact_sweep,
    node_frontier,
)
from vggc_cp.solvers.cpsat.model import build_cell_model
from vggc_cp.solvers.cpsat.parameters import (
    DEFAULT_PARAMS,
    HINTS,
    OBJECTIVES,
    CpSatConfig,
    parse_cpsat_params,
)
from vggc_cp.solvers.cpsat.solve import CpSatSolver, greedy_result

__all__ = ["DEFAULT_PARAMS", "HINTS", "OBJECTIVES", "OPTIMIZE", "CellModel", "CpSatConfig",
           "CpSatSolver", "Enumeration", "NodeFrontier", "build_cell_model", "compare_records",
           "enumerate_colourings", "exact_sweep", "greedy_result", "node_frontier",
           "parse_cpsat_params"]
