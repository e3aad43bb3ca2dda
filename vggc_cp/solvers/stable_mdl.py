"""Model selection among stable graphs: the least description length of the graphs that the
evidence holds over several thresholds in a row (the default path rule, ``stable-mdl``).

Along a merge path (one graph per threshold, :func:`~vggc_cp.solvers.merge.threshold_path`)
a partition the evidence supports persists while the threshold grows; a *transient* one, that
exists at one or two thresholds only, is a step of a collapse (merges that cascade through
congruence closure once the threshold admits pairs whose descriptors differ). The description
length (:mod:`vggc_cp.solvers.mdl`) codes the trace's actions given the nodes, not the
observations, so it cannot see that a collapsed graph merges observations the evidence tells
apart: on a one-class task of 84 states (random-300 of the suite, clean look) the true graph
held for 13 of the 24 thresholds, and the last threshold collapsed it to 15 nodes with a
shorter description length. So the rule takes the least description length among the graphs
that hold for at least :data:`MIN_PLATEAU` thresholds in a row (the bound the plateau check of
the confidence uses, :data:`vggc_cp.solvers.confidence.FIXED_CHECKS`), and among all graphs
where none does.

A shorter transient graph is still evidence: the confidence's margin reads it
(:func:`runner_up`), so a graph chosen over it is warned rather than silently preferred.

Examples
--------
>>> import numpy as np
>>> from vggc_cp.solvers.base import SolveResult
>>> labs = [np.array(x) for x in ([0, 1, 2], [0, 1, 1], [0, 1, 1], [0, 1, 1], [0, 0, 0])]
>>> [plateau_length(labs, i) for i in range(5)]
[1, 3, 3, 3, 1]
>>> stable_indices(labs)
[1, 2, 3]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vggc_cp.solvers.base import Problem, SolveResult
from vggc_cp.solvers.mdl import description_length
from vggc_cp.solvers.selection import PATH, register_selection

#: Thresholds in a row a graph must hold for to be chosen by ``stable-mdl`` (and below which
#: the confidence's plateau check warns).
MIN_PLATEAU = 3


def plateau_length(labelings: Sequence[np.ndarray | None], index: int) -> int:
    """Thresholds in a row around ``index`` whose labels equal those at ``index``.

    Labels of one partition are identical arrays (:meth:`Problem.labels_from_colours`
    numbers nodes in order of first appearance), so equality is exact comparison.
    """
    ref = labelings[index]
    if ref is None:
        return 0
    same = [lab is not None and np.array_equal(lab, ref) for lab in labelings]
    lo = index
    while lo > 0 and same[lo - 1]:
        lo -= 1
    hi = index
    while hi + 1 < len(same) and same[hi + 1]:
        hi += 1
    return hi - lo + 1


def stable_indices(labelings: Sequence[np.ndarray | None],
                   min_plateau: int = MIN_PLATEAU) -> list[int]:
    """Indices of the graphs that hold for at least ``min_plateau`` thresholds in a row."""
    return [i for i in range(len(labelings)) if plateau_length(labelings, i) >= min_plateau]


def eligible(results: Sequence[SolveResult]) -> list[int]:
    """The results ``stable-mdl`` chooses among: the stable ones, or all where none is."""
    stable = stable_indices([r.labels for r in results])
    return stable or list(range(len(results)))


@register_selection("stable-mdl", PATH)
def select_stable_mdl(results: Sequence[SolveResult], problem: Problem | None = None
                      ) -> int | None:
    """The least description length among the stable graphs (module docstring); of equal
    code lengths (to 1e-9 nats) the one with fewer nodes, then the first."""
    if not results:
        return None
    if problem is None:
        raise ValueError("the stable-mdl rule needs the problem")
    keys = [(round(description_length(problem, results[i].labels), 9),
             results[i].n_nodes if results[i].labels is not None else np.inf, i)
            for i in eligible(results)]
    return int(min(keys)[2])


#: the results the rule chooses among (read by the confidence's margin, :func:`runner_up`)
select_stable_mdl.eligible = eligible


def runner_up(results: Sequence[SolveResult], dls: Sequence[float], selected: int,
              rule=None) -> int | None:
    """The graph the description-length margin of the ``selected`` one is measured to: the
    least description length among the graphs of another size that ``rule`` could have chosen
    (its ``eligible`` attribute; every graph for a rule without one), or any graph of another
    size with a shorter description length than the selected one (a transient graph the rule
    passed over). None when every graph has the selected one's size.

    Of equal description lengths, the one nearest ``selected`` on the path.
    """
    size = results[selected].n_nodes
    pool_of = getattr(rule, "eligible", None)
    pool = set(pool_of(results)) if pool_of is not None else set(range(len(results)))
    if selected not in pool:
        pool = set(range(len(results)))
    others = [j for j, r in enumerate(results) if r.n_nodes != size
              and (j in pool or dls[j] < dls[selected])]
    if not others:
        return None
    return min(others, key=lambda j: (dls[j], abs(j - selected)))
