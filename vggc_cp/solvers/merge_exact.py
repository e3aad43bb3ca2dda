r"""The exact counterpart of the merge rule: fewest nodes under the merge's own constraints.

Congruence-closure merging (:mod:`vggc_cp.solvers.merge`) is greedy: it returns a graph that
is bipartite, Exactly-One, deterministic and co-deterministic, whose clusters hold no two
observations farther apart than some distance, but it does not know whether a graph with fewer
nodes satisfies the same constraints. This module asks CP-SAT.

Given a merge result with ``(K_pick, K_place)`` nodes, let ``tau`` be the largest visual
distance between two observations of one of its clusters (the *visual evidence* it used: no
pair farther apart than ``tau`` shares a node). The counterpart is

.. math::

    \min\ |V_{pick}| + |V_{place}| \quad \text{s.t. bipartite, Exactly-One, deterministic,
    co-deterministic, and } d(o, o') > \tau \Rightarrow c(o) \ne c(o'),

decided by :func:`vggc_cp.solvers.cpsat.exact_sweep` (objective ``none``: feasibility per cell,
the staircase frontier) over the window ``[K_pick - w, K_pick] x [K_place - w, K_place]``, with
the merge colouring as the witness of the top cell. Feasibility is monotone in each ``k``, so
when every cell just below the frontier is proved infeasible and the window's lowest row and
column are infeasible too, the minimum is proved; a frontier cell below the merge's counts is a
graph with fewer nodes than the greedy rule found (its colouring is returned). The selected cell
(fewest nodes, then lowest J) is what the benchmark evaluates as ``cpsat-merge``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from vggc_cp.solvers.base import Problem, SolveResult

#: Colours below the merge's count examined per role.
DEFAULT_WINDOW = 6
#: CP-SAT parameters per cell of the counterpart.
DEFAULT_PARAMS = "max_time_in_seconds:5,num_workers:2"
#: Largest number of cannot-link clauses (far pairs x colours) a counterpart model may hold.
MAX_CLAUSES = 3_000_000


def widest_pair(problem: Problem, labels: np.ndarray) -> float:
    """Largest visual distance between two observations of one cluster of ``labels``."""
    labels = np.asarray(labels)
    widest = 0.0
    for obs, dist in ((problem.pick_obs, problem.dist_pick),
                      (problem.place_obs, problem.dist_place)):
        lab = labels[obs]
        same = lab[:, None] == lab[None, :]
        if same.any():
            widest = max(widest, float(np.max(np.where(same, (dist + dist.T) / 2.0, 0.0))))
    return widest


@dataclass(frozen=True, eq=False)
class MergeCounterpart:
    """What :func:`exact_counterpart` found.

    Attributes
    ----------
    sweep : vggc_cp.solvers.sweep.Sweep
        The window's cells (CP-SAT statuses, witnesses) and the selected one.
    merge_nodes : int
        Nodes of the merge result.
    minimal_nodes : int or None
        Fewest nodes of a feasible cell of the window.
    proved : bool
        Every cell with fewer nodes than ``minimal_nodes`` in the window is proved infeasible
        and the window's lowest row and column are infeasible (so no smaller cell exists).
    cannot_link : float
        ``tau``.
    seconds : float
    skipped : str or None
        Why CP-SAT was not run (the model would exceed ``max_clauses``); the sweep then holds
        the merge colouring alone.
    """

    sweep: object
    merge_nodes: int
    minimal_nodes: int | None
    proved: bool
    cannot_link: float
    seconds: float
    skipped: str | None = None

    @property
    def best(self) -> SolveResult | None:
        return self.sweep.best

    def summary(self) -> str:
        def _nodes(n: int) -> str:
            return f"{n} node{'' if n == 1 else 's'}"

        if self.skipped:
            return f"not decided: {self.skipped}"
        if self.minimal_nodes is None:
            return "no colouring in the window"
        verdict = ("merge is node-minimal" if self.minimal_nodes == self.merge_nodes
                   else f"{_nodes(self.merge_nodes - self.minimal_nodes)} fewer than merge")
        return (f"{_nodes(self.minimal_nodes)} ({verdict}; "
                f"{'proved' if self.proved else 'not proved'}), cannot-link {self.cannot_link:.4f}")


def exact_counterpart(problem: Problem, merge: SolveResult, *, window: int = DEFAULT_WINDOW,
                      params: str = DEFAULT_PARAMS, max_clauses: int = MAX_CLAUSES,
                      progress: bool = False) -> MergeCounterpart:
    """Fewest nodes under the merge's constraints near the merge result (module docstring).

    When the cannot-link clauses of the top cell would exceed ``max_clauses``, CP-SAT is not
    run and the result says so (``skipped``).
    """
    from vggc_cp.solvers.base import INFEASIBLE
    from vggc_cp.solvers.cpsat import CpSatSolver, exact_sweep
    from vggc_cp.solvers.sweep import Sweep

    t0 = time.perf_counter()
    tau = widest_pair(problem, merge.labels)
    kp_top = len(np.unique(merge.labels[problem.pick_obs])) if problem.n_pick else 0
    kq_top = len(np.unique(merge.labels[problem.place_obs])) if problem.n_place else 0
    clauses = sum(int(np.count_nonzero(np.triu((d + d.T) / 2.0 > tau, 1))) * k
                  for d, k in ((problem.dist_pick, kp_top), (problem.dist_place, kq_top)))
    if clauses > max_clauses:
        kept = replace(merge, k_pick=kp_top, k_place=kq_top)
        sweep = Sweep((kept,), 0, "fewest", "merge", 0.0, 1)
        return MergeCounterpart(sweep, merge.n_nodes, None, False, tau,
                                time.perf_counter() - t0,
                                f"{clauses} cannot-link clauses > max_clauses {max_clauses}")
    kp = range(max(1, kp_top - window), max(1, kp_top) + 1)
    kq = range(max(1, kq_top - window), max(1, kq_top) + 1)
    solver = CpSatSolver(objective="none", deterministic=True, codeterministic=True,
                         cannot_link=tau, params=params, hint="none")
    witness = replace(merge, k_pick=kp_top, k_place=kq_top)
    sweep = exact_sweep(problem, list(kp), list(kq), solver, greedy=[witness],
                        select="fewest", progress=progress)
    found = [r for r in sweep.results if r.found]
    minimal = min((r.n_nodes for r in found), default=None)
    proved = False
    if minimal is not None:
        below = [r for r in sweep.results if r.k_pick + r.k_place < minimal]
        edge = [r for r in sweep.results if r.k_pick == kp.start or r.k_place == kq.start]
        floor_open = any(r.status != INFEASIBLE for r in edge) and (kp.start > 1 or kq.start > 1)
        proved = all(r.status == INFEASIBLE for r in below) and not floor_open
    return MergeCounterpart(sweep, merge.n_nodes, minimal, proved, tau,
                            time.perf_counter() - t0)


__all__ = ["DEFAULT_PARAMS", "DEFAULT_WINDOW", "MAX_CLAUSES", "MergeCounterpart", "exact_counterpart",
           "widest_pair"]
