"""The ``(k_pick, k_place)`` grid sweep around any solver, and the registry of selection rules.

A sweep solves every cell of a grid (in parallel processes when ``jobs > 1``), keeps each
cell's :class:`~vggc_cp.solvers.base.SolveResult`, and lets a *selection rule* pick one
(:mod:`vggc_cp.solvers.selection`, axis ``"grid"``).
The paper's rule is ``"fewest"``: the fewest abstract nodes actually used, then the lowest
visual score J.

Default grid (:func:`default_grid`), from the actions alone. Let ``A_pick`` / ``A_place`` be the
numbers of distinct pick / place actions in the transitions.

* **Always feasible:** colour every place observation by the pick action that entered it and
  every pick observation by the place action that entered it (observations that start an
  episode join any colour). Every edge's label is then fixed by its target node, so
  Exactly-One holds in both directions: the cell ``(A_place, A_pick)`` has a solution.
* **Monotone:** splitting a node never breaks Exactly-One (a pair of parts carries a subset of
  the labels of the pair of wholes), so a feasible cell stays feasible when either k grows
  (up to the role's number of observations). A greedy failure in a larger cell is the
  heuristic's, not the problem's.
* **Lower bound:** a pick node's distinct outgoing labels need distinct place nodes (and a
  place node's distinct outgoing labels distinct pick nodes), so
  ``k_pick * k_place >= max(A_pick, A_place)`` in every feasible cell.

The default grid runs each role from the smallest value the lower bound allows up to
``max(2 * always-feasible value, 20)`` (at most the role's number of observations): the
vision-first greedy seeds its pick colours from distances alone, and with noisy distances it
needs more colours than the minimum before the seeds fit the transitions, so the grid leaves
it room well beyond the always-feasible corner.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.parallel import Executor, ProcessExecutor
from vggc_cp.solvers.base import Problem, Solver, SolveResult
from vggc_cp.solvers.selection import (  # noqa: F401  (re-exported)
    GRID,
    RULES,
    SelectionRule,
    get_selection,
    register_selection,
    select_fewest,
)
from vggc_cp.trace import PICK, PLACE, action_kind

if TYPE_CHECKING:
    import pandas as pd

GRID_MIN_TOP = 20
#: The grid's selection rules (the ``"grid"`` axis of :data:`vggc_cp.solvers.selection.RULES`).
SELECTIONS = RULES[GRID]


# ---------------------------------------------------------------- grid


def action_counts(problem: Problem) -> tuple[int, int]:
    """``(A_pick, A_place)``: distinct pick and place actions among the transitions."""
    acts = np.unique(np.asarray(problem.act))
    kinds = [action_kind(problem.action_names[a]) for a in acts]
    return sum(k == PICK for k in kinds), sum(k == PLACE for k in kinds)


def default_grid(problem: Problem) -> tuple[range, range]:
    """The default ``(k_pick values, k_place values)``; see the module docstring."""
    a_pick, a_place = action_counts(problem)
    hi_pick = max(1, min(problem.n_pick, max(2 * a_place, GRID_MIN_TOP)))
    hi_place = max(1, min(problem.n_place, max(2 * a_pick, GRID_MIN_TOP)))
    need = max(a_pick, a_place, 1)
    lo_pick = min(hi_pick, max(1, math.ceil(need / hi_place)))
    lo_place = min(hi_place, max(1, math.ceil(need / hi_pick)))
    return range(lo_pick, hi_pick + 1), range(lo_place, hi_place + 1)


#: largest k of a --k-pick / --k-place range (each k is a row or column of the grid)
MAX_K = 1000


def parse_range(text: str, what: str = "range") -> range:
    """``"A:B"`` (inclusive) or ``"A"`` as a range of positive integers.

    Raises
    ------
    VggcError
        Naming ``what`` and the offending text.
    """
    parts = text.split(":")
    try:
        if len(parts) == 1:
            lo = hi = int(parts[0])
        elif len(parts) == 2:
            lo, hi = int(parts[0]), int(parts[1])
        else:
            raise ValueError
    except ValueError:
        raise VggcError(f"{what} {text!r} is not A:B or A (integers)") from None
    if lo < 1 or hi < lo:
        raise VggcError(f"{what} {text!r} must satisfy 1 <= A <= B")
    if hi > MAX_K:
        raise VggcError(f"{what} {text!r}: B = {hi:,} is above the cap of {MAX_K:,} "
                        f"(solvers.sweep.MAX_K)")
    return range(lo, hi + 1)


# ---------------------------------------------------------------- sweep


@dataclass(frozen=True, eq=False)
class Sweep:
    """Every cell's result of a grid sweep and the selected one.

    Attributes
    ----------
    results : tuple of SolveResult
        One per cell, ``k_pick``-major then ``k_place``.
    selected : int or None
        Index into ``results`` chosen by ``rule``; None when no cell has a colouring.
    rule : str
        Selection rule name.
    solver : str
    seconds : float
        Wall time of the whole sweep.
    jobs : int
    """

    results: tuple[SolveResult, ...]
    selected: int | None
    rule: str
    solver: str
    seconds: float
    jobs: int

    @property
    def best(self) -> SolveResult | None:
        return None if self.selected is None else self.results[self.selected]

    @property
    def k_pick_values(self) -> list[int]:
        return sorted({r.k_pick for r in self.results})

    @property
    def k_place_values(self) -> list[int]:
        return sorted({r.k_place for r in self.results})

    def cell(self, k_pick: int, k_place: int) -> SolveResult:
        """The result of one cell (KeyError if the cell was not in the grid)."""
        for r in self.results:
            if r.k_pick == k_pick and r.k_place == k_place:
                return r
        raise KeyError((k_pick, k_place))

    def records(self) -> list[dict]:
        """Per cell: ``k_pick, k_place, status, J, seconds, nodes`` (+ search statistics).

        ``J`` is None without a colouring; ``nodes`` counts the abstract nodes used (0 without
        a colouring). This is the solution JSON's ``grid``.
        """
        out = []
        for r in self.results:
            out.append({
                "k_pick": int(r.k_pick), "k_place": int(r.k_place), "status": r.status,
                "J": None if not r.found or math.isnan(r.J) else float(r.J),
                "seconds": round(float(r.seconds), 4), "nodes": r.n_nodes,
                "search_nodes": r.stats.get("nodes"), "backtracks": r.stats.get("backtracks"),
                "limit_hit": r.stats.get("limit_hit"),
            })
        return out

    def table(self) -> pd.DataFrame:
        """The grid as a DataFrame, one row per cell, with a ``selected`` column."""
        import pandas as pd

        df = pd.DataFrame.from_records(self.records())
        df.insert(2, "feasible", [r.found for r in self.results])
        df["selected"] = [i == self.selected for i in range(len(self.results))]
        return df

    def pivot(self, digits: int = 3) -> pd.DataFrame:
        """The grid as text: rows ``k_pick``, columns ``k_place``, J per cell (``-`` without a
        colouring, ``*`` after the selected cell)."""
        import pandas as pd

        kp, kq, mat = self.j_matrix()
        best = self.best
        cells = [[("-" if np.isnan(mat[i, j]) else f"{mat[i, j]:.{digits}f}")
                  + ("*" if best is not None and (a, b) == (best.k_pick, best.k_place) else "")
                  for j, b in enumerate(kq)] for i, a in enumerate(kp)]
        df = pd.DataFrame(cells, index=pd.Index(kp, name="k_pick \\ k_place"), columns=kq)
        return df

    def pivot_text(self, width: int = 120, digits: int = 3) -> str:
        """:meth:`pivot` as markdown no wider than ``width`` characters: the ``k_place``
        columns are cut into consecutive blocks, each printed with the ``k_pick`` column and
        separated by a blank line (one block when the whole grid fits)."""
        df = self.pivot(digits)
        blocks: list[str] = []
        start = 0
        while start < df.shape[1]:
            stop = start + 1
            text = _markdown(df.iloc[:, start:stop])
            while stop < df.shape[1]:
                wider = _markdown(df.iloc[:, start:stop + 1])
                if max(map(len, wider.splitlines())) > width:
                    break
                stop, text = stop + 1, wider
            blocks.append(text)
            start = stop
        return "\n\n".join(blocks)

    def j_matrix(self) -> tuple[list[int], list[int], np.ndarray]:
        """``(k_pick values, k_place values, J)`` with J of shape (len(kp), len(kq)), NaN blank."""
        kp, kq = self.k_pick_values, self.k_place_values
        mat = np.full((len(kp), len(kq)), np.nan)
        for r in self.results:
            if r.found:
                mat[kp.index(r.k_pick), kq.index(r.k_place)] = r.J
        return kp, kq, mat


def _markdown(df) -> str:
    return df.to_markdown(stralign="right", disable_numparse=True)


def _solve_cell(solver: Solver, problem: Problem, cell: tuple[int, int]) -> SolveResult:
    return solver.solve(problem, cell[0], cell[1])


def run_sweep(problem: Problem, solver: Solver, k_pick: Sequence[int], k_place: Sequence[int],
              *, jobs: int = 1, select: str = "fewest", progress: bool = False,
              executor: Executor | None = None) -> Sweep:
    """Solve every cell of ``k_pick x k_place`` and select one.

    Parameters
    ----------
    problem : Problem
    solver : Solver
        Any solver instance; it is pickled into the worker processes.
    k_pick, k_place : sequences of int
        Grid values.
    jobs : int
        Worker processes when no ``executor`` is given; 1 solves inline. Workers are forked
        where the platform can (no ``if __name__ == "__main__"`` guard needed in scripts or
        notebooks; workers only run numpy), else spawned.
    select : str
        A name in :data:`SELECTIONS`.
    progress : bool
        Show a tqdm bar on stderr.
    executor : vggc_cp.parallel.Executor, optional
        Where the cells run (e.g. a dask cluster, :func:`vggc_cp.parallel.open_executor`);
        the results, their order and the selection are the same on every executor.
    """
    rule = get_selection(select)
    cells = [(int(a), int(b)) for a in k_pick for b in k_place]
    if not cells:
        raise VggcError("the (k_pick, k_place) grid is empty")
    if jobs < 1:
        raise VggcError(f"--jobs must be at least 1, got {jobs}")
    if executor is None:
        executor = Executor() if jobs == 1 else ProcessExecutor(jobs)
    t0 = time.perf_counter()
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(cells), desc=f"{solver.name} sweep", unit="cell", leave=False)
    try:
        results = executor.map(partial(_solve_cell, solver, problem), cells,
                               None if bar is None else lambda i, r: bar.update(1))
    finally:
        if bar is not None:
            bar.close()
    done = tuple(results)
    selected = rule(done, problem)
    return Sweep(done, selected, select, solver.name, time.perf_counter() - t0, jobs)
