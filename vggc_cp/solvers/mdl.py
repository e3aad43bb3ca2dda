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

**What the actions state.** Where the evidence says what sites hold as symbols
(:class:`~vggc_cp.solvers.base.Readings`: the footprints give each site of each observation
empty or an object of a colour wherever an episode's actions state it and the site's own
reading does not contradict it, and 0, not coded, elsewhere), the model codes those too:
every node has, per site, a distribution over the symbols its observations hold there::

    DL_read(G) = - sum_{(u, s, x)} n(u, s, x) log(n(u, s, x) / n(u))
                 + sum_{(u, s)} log K_s  +  1/2 log N * k

with ``n(u, s, x)`` the observations of node ``u`` that hold ``x`` at site ``s``, ``K_s`` the
symbols site ``s`` takes anywhere (stating what a node holds there costs ``log K_s``, as an
edge costs in the action code), ``N`` the observations and ``k`` the free parameters,
``sum_{(u, s)} (#symbols - 1)``. Two states that afford alike actions but hold different
things cost their mixed sites' entropy when merged, and a split gains nothing (stated facts
agree within a state); without this term, a coarse graph that predicts the actions as well
as the true one is the shorter code, however different the scenes it merges (a task of
identical objects, random-396: 16 nodes for 126 states). Only stated facts are coded: the
readings of sites no action touches were tried (every site's symbol) and made splits pay
wherever an arm or a covered slot misleads them. Sites alike on every observation (the
actions of one slot) are one site (:func:`vggc_cp.vision.footprints.site_readings`).

References
----------
J. Rissanen, *Modeling by shortest data description*, Automatica 14, 1978.
G. Schwarz, *Estimating the dimension of a model*, Annals of Statistics 6, 1978.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vggc_cp.solvers.base import Problem, Readings, SolveResult
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
    readings = getattr(problem, "readings", None)
    seen = 0.0 if readings is None else reading_length(readings, labels)
    n_trans = len(problem.act)
    if n_trans == 0:
        return seen
    src = np.asarray(labels, dtype=np.int64)[problem.src]
    n_act = max(problem.n_actions, 1)
    pair = src * n_act + problem.act
    keys, counts = np.unique(pair, return_counts=True)
    node = keys // n_act
    per_node = np.bincount(np.searchsorted(np.unique(node), node), weights=counts)
    totals = per_node[np.searchsorted(np.unique(node), node)]
    loglik = float(np.sum(counts * np.log(counts / totals)))
    return -loglik + 0.5 * np.log(n_trans) * len(keys) + seen


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


def reading_length(readings: Readings, labels: np.ndarray) -> float:
    """``DL_read`` (module docstring) of the readings given the nodes ``labels``, in nats.
    Symbol 0 is no reading (not coded).

    Parameters
    ----------
    readings : Readings
        Codes of shape (N,) and symbols of shape (G, S).
    labels : ndarray of int, shape (N,)

    >>> r = Readings.from_rows(np.array([[1], [1], [2], [2], [0]]))
    >>> round(reading_length(r, np.array([0, 0, 1, 1, 1])), 3)   # each node: which of 2
    1.386
    >>> round(reading_length(r, np.array([0, 0, 0, 0, 0])), 3)   # log 2 + 4 log 2 + 1/2 log 5
    4.27
    """
    codes, symbols = readings.codes, readings.symbols
    n, n_sites = len(codes), symbols.shape[1]
    if n == 0 or n_sites == 0 or not symbols.any():
        return 0.0
    node = np.unique(np.asarray(labels, dtype=np.int64), return_inverse=True)[1].ravel()
    n_codes = len(symbols)
    pair, count = np.unique(node * n_codes + codes, return_counts=True)
    pnode, pcode = pair // n_codes, pair % n_codes
    width = int(symbols.max()) + 1
    n_nodes = int(node.max()) + 1
    site = np.repeat(np.arange(n_sites)[None, :], len(pair), axis=0)
    read = symbols[pcode]
    some = read > 0                                        # 0: nothing stated there
    key = ((site * n_nodes + pnode[:, None]) * width + read)[some]
    keys, inv = np.unique(key, return_inverse=True)
    c = np.bincount(inv.ravel(), weights=np.repeat(count, n_sites)[some.ravel()]
                    .astype(np.float64))
    cell = keys // width                                   # (site, node)
    cells, cinv = np.unique(cell, return_inverse=True)
    total = np.bincount(cinv.ravel(), weights=c)
    data = -float(np.sum(c * np.log(c / total[cinv.ravel()]))) + 0.0
    # what each node holds at each site: one of the symbols stated there anywhere
    model = float(np.log(readings.kinds)[cells // n_nodes].sum())
    return data + model + 0.5 * float(np.log(n)) * (len(keys) - len(cells))
