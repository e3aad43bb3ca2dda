"""The CP-SAT grid: decide every cell by monotonicity (the feasibility frontier), minimize J
where the selection looks, and say whether the fewest nodes are proved minimal."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.parallel import Executor
from vggc_cp.solvers.base import FEASIBLE, INFEASIBLE, UNKNOWN, Problem, SolveResult
from vggc_cp.solvers.brute import split_colours, violations
from vggc_cp.solvers.cpsat.solve import CpSatSolver
from vggc_cp.solvers.selection import get_selection

OPTIMIZE = ("minimal", "all")


def exact_sweep(problem: Problem, k_pick: Sequence[int], k_place: Sequence[int],
                solver: CpSatSolver, greedy: Sequence[SolveResult] = (), *,
                optimize: str = "minimal", select: str = "fewest", progress: bool = False,
                executor: Executor | None = None):
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
        A ``"grid"`` rule of :mod:`vggc_cp.solvers.selection`.
    executor : vggc_cp.parallel.Executor, optional
        Where the J cells of one ``k_pick + k_place`` run (default: here, in order); the
        feasibility frontier is a walk and runs here. Same results on every executor.

    Returns
    -------
    vggc_cp.solvers.sweep.Sweep
    """
    from vggc_cp.solvers.sweep import Sweep

    if optimize not in OPTIMIZE:
        raise VggcError(f"unknown optimize mode {optimize!r}; known: {', '.join(OPTIMIZE)}")
    rule = get_selection(select)
    executor = executor or Executor()
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

    def hints_for(cell):
        return [(f"{src}@{c[0]},{c[1]}", lab) for src, lab, _, c in below(cell)]

    def run(s, cell):
        return record(cell, s.solve_hinted(problem, cell[0], cell[1], hints_for(cell)))

    def record(cell, res):
        spent[cell] = spent.get(cell, 0.0) + res.seconds
        solved[cell] = res
        if res.status == INFEASIBLE:
            proved[cell] = res
        elif res.found:
            add_witness(cell, "cpsat", res.labels)
        return res

    def new_bar(desc: str, total: int, unit: str):
        if not progress:
            return None
        from tqdm import tqdm
        return tqdm(total=total, desc=desc, unit=unit, leave=False)

    def solved_once():
        if bar is not None:
            bar.set_postfix_str(f"{len(solved)} cells solved", refresh=False)

    # the frontier's solves per row are not known in advance: the bar counts rows
    bar = new_bar("cpsat frontier", len(kp), "row")
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
                solved_once()
                if res.found:
                    break
                if res.status != INFEASIBLE:
                    undecided_at = j
                    break
            if undecided_at is not None:
                # past an undecided cell, bisect for the row's lowest feasible cell
                lo = undecided_at
                hi = next((j for j in range(lo + 1, len(kq)) if below((a, kq[j]))), len(kq))
                while hi - lo > 1:
                    mid = (lo + hi) // 2
                    res = run(feas_solver, (a, kq[mid]))
                    solved_once()
                    if res.found:
                        hi = mid
                    else:
                        lo = mid
            if bar is not None:
                bar.update(1)
        todo = []
        if opts.objective == "J":
            feasible = [(a, b) for a in kp for b in kq if below((a, b))]
            if feasible:
                low = min(a + b for a, b in feasible)
                todo = sorted((c for c in feasible if optimize == "all" or sum(c) == low),
                              key=lambda c: (c[0] + c[1], c))
        if bar is not None:
            bar.close()
        bar = new_bar("cpsat J", len(todo), "cell") if todo else None
        # cells of one k_pick + k_place never lie below each other: each wave's cells are
        # independent (the same hints in any order), so a wave runs on the executor
        task = partial(_solve_hinted, solver, problem)
        for total in sorted({sum(c) for c in todo}):
            wave = [c for c in todo if sum(c) == total]
            results = executor.map(task, [(c, hints_for(c)) for c in wave],
                                   None if bar is None else lambda i, r: bar.update(1))
            for cell, res in zip(wave, results):
                record(cell, res)
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


def _solve_hinted(solver: CpSatSolver, problem: Problem, item: tuple) -> SolveResult:
    (k_pick, k_place), hints = item
    return solver.solve_hinted(problem, k_pick, k_place, hints)


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
