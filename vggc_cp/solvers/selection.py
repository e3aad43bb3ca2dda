"""Selection: the one registry of rules that pick one result among a solver family's results.

Every rule has one signature, ``rule(results, problem) -> index or None`` (None: nothing to
pick), and is registered under a name for the *axis* its results run along:

* ``"grid"`` -- one :class:`~vggc_cp.solvers.base.SolveResult` per ``(k_pick, k_place)`` cell
  of a sweep (:func:`~vggc_cp.solvers.sweep.run_sweep`,
  :func:`~vggc_cp.solvers.cpsat.exact_sweep`), cells without a colouring included: the solvers
  whose :attr:`~vggc_cp.solvers.base.Solver.axis` is ``"grid"`` (greedy, cpsat, brute);
* ``"path"`` -- one result per threshold, ascending
  (:func:`~vggc_cp.solvers.merge.threshold_path`): the merge solver.

``--select`` names a rule of the chosen solver's axis. Unknown names fail with the known ones.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from vggc_cp.errors import lookup

if TYPE_CHECKING:
    from vggc_cp.solvers.base import Problem, SolveResult

GRID = "grid"
PATH = "path"
AXES = (GRID, PATH)

#: ``rule(results, problem) -> index into results, or None``.
SelectionRule = Callable[[Sequence["SolveResult"], "Problem | None"], "int | None"]
#: axis -> rule name -> rule.
RULES: dict[str, dict[str, SelectionRule]] = {axis: {} for axis in AXES}
_WHAT = {GRID: "selection rule", PATH: "path selection rule"}


def register_selection(name: str, axis: str = GRID) -> Callable[[SelectionRule], SelectionRule]:
    """Decorator: add a rule under ``name`` for results along ``axis`` (``grid`` or ``path``)."""
    rules = lookup(RULES, axis, "selection axis")

    def deco(fn: SelectionRule) -> SelectionRule:
        rules[name] = fn
        return fn
    return deco


def get_selection(name: str, axis: str = GRID) -> SelectionRule:
    """The rule called ``name`` along ``axis`` (unknown names list the known ones)."""
    return lookup(lookup(RULES, axis, "selection axis"), name, _WHAT[axis])


@register_selection("fewest", GRID)
def select_fewest(results: Sequence[SolveResult], problem: Problem | None = None) -> int | None:
    """The paper's rule: fewest nodes used, then lowest J, then the smaller cell.

    Returns the index of the chosen result, or None when no cell has a colouring.
    """
    best, key = None, None
    for i, r in enumerate(results):
        if not r.found:
            continue
        k = (r.n_nodes, r.J, r.k_pick + r.k_place, r.k_pick)
        if key is None or k < key:
            best, key = i, k
    return best


@register_selection("fewest", PATH)
def select_path_fewest(results: Sequence[SolveResult],
                       problem: Problem | None = None) -> int | None:
    """Fewest nodes, then lowest J (the paper's rule applied to the path); the first of equal
    ones (the lowest threshold)."""
    if not results:
        return None
    return min(range(len(results)), key=lambda i: (results[i].n_nodes, results[i].J))


@register_selection("cascade", PATH)
def select_cascade(results: Sequence[SolveResult], problem: Problem | None = None,
                   stable: float = 0.05) -> int | None:
    """The threshold just after the cascade: where the node count stops collapsing.

    As the threshold grows, noise-level merges first shrink the node count steadily, then
    congruence closure collapses the near-duplicates of each state into one node (the largest
    relative drop of the path), and past the true structure merges slow down until wrong
    merges set in. The rule takes the largest relative drop ``n_k -> n_{k+1}`` and, after it,
    the plateaus: runs of thresholds ``j, j+1, ..., j+r`` whose counts stay within ``stable``
    of ``n_j``. It returns the start ``j`` of the longest plateau (the first of equally long
    ones), or the last index when no step after the drop loses less than ``stable``. The
    longest, not the first: a collapse can pause for one threshold on its way down (39, 22, 21,
    12, 12, 12, ... on one multifruit-2x3 trace, whose true graph is the 12-node plateau).
    """
    nodes = [r.n_nodes for r in results]
    if not nodes:
        return None
    if len(nodes) == 1:
        return 0
    drops = [(nodes[k] - nodes[k + 1]) / max(nodes[k], 1) for k in range(len(nodes) - 1)]
    k = int(np.argmax(drops))
    best, best_len = len(nodes) - 1, 0
    j = k + 1
    while j < len(nodes) - 1:
        end = j
        while end < len(nodes) - 1 and nodes[end + 1] >= (1 - stable) * nodes[j]:
            end += 1
        if end - j > best_len:
            best, best_len = j, end - j
        j = max(end, j + 1)
    return best
