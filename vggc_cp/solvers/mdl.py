"""Model selection by description length: the graph that explains the trace's actions best.

A task graph is a model of what the robot did: from node ``u`` it took action ``a`` with some
frequency, and (deterministically) went to the node the edge ``(u, a, v)`` names. Its
description length is the code length of the trace's actions under the graph plus the cost
of the graph's own parameters (BIC / two-part MDL), in nats::

    DL(G) = - sum_{(u, a)} n(u, a) log(n(u, a) / n(u))  +  1/2 log|D| * |E|

with ``n(u, a)`` the transitions taking ``a`` from an observation of node ``u``, ``n(u)`` their
sum and ``|E|`` the number of edges. Merging two states that afford different actions
raises the first term (the merged node's actions are less predictable); keeping near
duplicates apart raises the second (every copy repeats its edges). The true graph balances
them once the trace visits its states a few times each. Lower is better.

References
----------
J. Rissanen, *Modeling by shortest data description*, Automatica 14, 1978.
G. Schwarz, *Estimating the dimension of a model*, Annals of Statistics 6, 1978.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vggc_cp.solvers.base import Problem, SolveResult
from vggc_cp.solvers.selection import PATH, register_selection


def description_length(problem: Problem, labels: np.ndarray) -> float:
    """``DL`` of the graph ``labels`` induces on ``problem``'s transitions (nats; lower is
    better). Returns ``inf`` for ``labels`` None.

    Parameters
    ----------
    problem : Problem
    labels : ndarray of int, shape (N,)
    """
    if labels is None:
        return float("inf")
    n_trans = len(problem.act)
    if n_trans == 0:
        return 0.0
    src = np.asarray(labels, dtype=np.int64)[problem.src]
    n_act = max(problem.n_actions, 1)
    pair = src * n_act + problem.act
    keys, counts = np.unique(pair, return_counts=True)
    node = keys // n_act
    per_node = np.bincount(np.searchsorted(np.unique(node), node), weights=counts)
    totals = per_node[np.searchsorted(np.unique(node), node)]
    loglik = float(np.sum(counts * np.log(counts / totals)))
    return -loglik + 0.5 * np.log(n_trans) * len(keys)


@register_selection("mdl", PATH)
def select_mdl(results: Sequence[SolveResult], problem: Problem | None = None) -> int | None:
    """The result of least description length (:func:`description_length`). Of graphs whose
    code lengths are equal (to 1e-9 nats), the one with fewer nodes: observations from which
    the trace takes no action (an episode's last) cost nothing wherever they go, and an equal
    code length does not pay for a node. Of equal graphs, the first (the lowest threshold)."""
    if not results:
        return None
    if problem is None:
        raise ValueError("the mdl rule needs the problem")
    keys = [(round(description_length(problem, r.labels), 9),
             r.n_nodes if r.labels is not None else np.inf, i) for i, r in enumerate(results)]
    return int(min(keys)[2])
