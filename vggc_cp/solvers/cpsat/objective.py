r"""The objective of the CP-SAT model of a cell: the quantized visual score.

Distances are symmetrized, :math:`\bar d_{ij} = (d_{ij} + d_{ji}) / 2`, and scaled to integers
:math:`\hat d_{ij} = \mathrm{round}(s\,\bar d_{ij})` with :math:`s = R / \max \bar d` (one
:math:`s` for both roles; :math:`R` = :data:`RESOLUTION` = 1000: the largest distance
becomes :math:`R`). For each colour :math:`c`: :math:`w_{ijc} \ge x_{ic} \wedge x_{jc}` (only
pairs with :math:`\hat d_{ij} > 0`), :math:`S_c = \sum_{i<j} \hat d_{ij} w_{ijc}`, size
:math:`n_c = \sum_i x_{ic}`, :math:`q_c = n_c (n_c - 1)` and an integer mean :math:`m_c` with
:math:`m_c \cdot q_c \ge 2 S_c` (``add_multiplication_equality``). Minimizing
:math:`\sum_c m_c` makes :math:`m_c = \lceil 2 S_c / q_c \rceil` (0 for clusters of at most
one observation), so **the integer objective equals**

.. math:: \hat J = \sum_c \left\lceil \frac{\sum_{i<j \in c} \hat d_{ij}}{|c|(|c|-1)/2}
          \right\rceil ,

the visual score J of the paper on the quantized distances with each cluster's mean rounded
up. For any colouring, :math:`s J - K/2 \le \hat J < s J + 3K/2` with :math:`K` the number
of clusters of two or more observations; the solution's true float J is recomputed from its
labels and reported beside :math:`\hat J`. *Optimal* means optimal for :math:`\hat J`, hence
within ``quantization_margin`` :math:`= 2 (K_P + K_Q) / s` of the true optimum of J.
``bound`` is the proved lower bound on :math:`\hat J / s`.

*Size-aware lower bound* (exact reformulation plus an implied cut). Cluster
sizes are one-hot, :math:`\beta_{c,t} \Leftrightarrow n_c = t`, with
:math:`\sum_t t\,\beta_{c,t} = n_c` and :math:`q_c = \sum_t t(t-1)\,\beta_{c,t}` (linear, no
product); :math:`z_{i,c,t} = x_{ic} \wedge \beta_{c,t}` is linked by
:math:`\sum_t z_{ict} = x_{ic}` and :math:`\sum_i z_{ict} = t\,\beta_{c,t}` (a cluster of size
:math:`t` has :math:`t` members). The mean of a cluster is the average over its members of
their mean distance to the other members, and a member's mean distance to :math:`t-1` others is
at least the mean of its :math:`t-1` smallest distances :math:`H_i(t)/(t-1)`. Hence the valid cut

.. math:: m_c \ge \sum_i \sum_{t \ge 2} \frac{H_i(t)}{t(t-1)} z_{ict}

(coefficients rounded down at scale 1/64). Unlike the product constraint, whose LP relaxation
is 0, this bound is tight when clusters are visually tight, and it sees the cost of a cluster
that outgrows a visual group. On fruit-2x3 (|D| = 50) the best bound stayed at 0 for 60 s
without it; with it the minimal cell (3, 2) is proved optimal in about 27 s on an unloaded
machine (2 workers). Cells of about 50 observations per role (|D| = 95) keep a gap after
two minutes.

The pair variables grow as :math:`O(n^2 K)`. When their number exceeds ``max_pair_terms``
the model drops the objective (a documented relaxation: feasibility only, the colouring with
the lower J of the CP-SAT solution and its hint is kept), and the status is at most
*feasible* with no bound.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.cpsat.parameters import CpSatConfig
from vggc_cp.trace import PICK, PLACE

if TYPE_CHECKING:  # OR-Tools is imported where a model is built or solved
    from ortools.sat.python import cp_model

#: The largest symmetrized distance becomes this integer.
RESOLUTION = 1000
SIZE_CUT_SCALE = 64


def quantize(problem: Problem, resolution: int = RESOLUTION) -> tuple[float, tuple[np.ndarray, np.ndarray]]:
    """``(s, (dhat_pick, dhat_place))``: the scale and the symmetrized integer distances.

    ``dhat = round(s (d + d.T) / 2)`` with ``s = resolution / max d`` (one scale for both
    roles), zero diagonal; shapes ``(n_pick, n_pick)`` and ``(n_place, n_place)``.
    """
    dmax = max(float(np.max(problem.dist_pick, initial=0.0)),
               float(np.max(problem.dist_place, initial=0.0)))
    scale = resolution / dmax if dmax > 0 else 1.0
    dhat = tuple(np.rint((d + d.T) / 2.0 * scale).astype(np.int64)
                 for d in (problem.dist_pick, problem.dist_place))
    for d in dhat:
        np.fill_diagonal(d, 0)
    return scale, dhat


def add_objective(model: cp_model.CpModel, roles: list, dhat: tuple, options: CpSatConfig,
                  notes: list[str]) -> tuple[str, dict, dict, dict]:
    """Add the quantized J (or nothing) to ``model``; see the module docstring.

    Parameters
    ----------
    model : cp_model.CpModel
        The cell's model, colour variables already in ``roles``.
    roles : list of RoleVars
        Pick then place.
    dhat : tuple of ndarray
        Integer distances of :func:`quantize`.
    options : CpSatConfig
    notes : list of str
        Appended to when the objective is dropped.

    Returns
    -------
    objective_mode : {'J', 'none'}
    pairs, means, sizes : dict
        The objective's variables (see :class:`~vggc_cp.solvers.cpsat.cell.CellModel`).
    """
    pairs: dict = {}
    means: dict = {}
    sizes: dict = {}
    objective_mode = options.objective
    if objective_mode == "J":
        n_terms = sum(int(np.count_nonzero(np.triu(dhat[r], 1))) * roles[r].k for r in (PICK, PLACE))
        if n_terms > options.max_pair_terms:
            objective_mode = "none"
            notes.append(f"objective dropped: {n_terms} pair terms > max_pair_terms "
                         f"{options.max_pair_terms} (feasibility only)")
    if objective_mode == "J":
        terms = []
        for r in (PICK, PLACE):
            n, k, x, dq = len(roles[r].obs), roles[r].k, roles[r].x, dhat[r]
            dmax_i = int(dq.max(initial=0))
            iu, ju = np.nonzero(np.triu(dq, 1))
            for c in range(k):
                members = [x[i][c] for i in range(n) if x[i][c] is not None]
                if len(members) < 2:
                    continue
                s_terms = []
                for i, j in zip(iu.tolist(), ju.tolist()):
                    xi, xj = x[i][c], x[j][c]
                    if xi is None or xj is None:
                        continue
                    w = model.new_bool_var(f"w{r}_{i}_{j}_{c}")
                    model.add_bool_or([~xi, ~xj, w])
                    pairs[(r, i, j, c)] = (w, int(dq[i, j]))
                    s_terms.append(int(dq[i, j]) * w)
                nm = len(members)
                size = sum(members)
                q = model.new_int_var(0, nm * (nm - 1), f"q{r}_{c}")
                beta, z, cut = _size_indicators(model, [x[i][c] for i in range(n)], dq, size, q,
                                                f"{r}_{c}")
                sizes[(r, c)] = (beta, z)
                m = model.new_int_var(0, dmax_i, f"m{r}_{c}")
                prod = model.new_int_var(0, dmax_i * nm * (nm - 1), f"mq{r}_{c}")
                model.add_multiplication_equality(prod, [m, q])
                if s_terms:
                    model.add(prod >= 2 * sum(s_terms))
                if cut:
                    model.add(SIZE_CUT_SCALE * m >= sum(cut))
                means[(r, c)] = (q, prod, m, nm)
                terms.append(m)
        model.minimize(sum(terms))
    return objective_mode, pairs, means, sizes


def _size_indicators(model: cp_model.CpModel, xc: list, dq: np.ndarray, size, q, tag: str
                     ) -> tuple[list, dict, list]:
    """One-hot size of one cluster and the nearest-neighbour cut on its mean (module docstring).

    ``xc[i]`` is observation ``i``'s literal for the colour (None: excluded by symmetry
    breaking); ``size`` and ``q`` are the cluster's size expression and :math:`q_c` variable.
    Returns ``(beta, z, cut)``: ``beta[t]`` (size is t), ``z[(i, t)]`` (member of a cluster of
    size t) and the terms of ``SIZE_CUT_SCALE * m_c >= sum(cut)``.
    """
    cand = [i for i, v in enumerate(xc) if v is not None]
    nm = len(cand)
    beta = [model.new_bool_var(f"b{tag}_{t}") for t in range(nm + 1)]
    model.add_exactly_one(beta)
    model.add(sum(t * b for t, b in enumerate(beta)) == size)
    model.add(sum(t * (t - 1) * b for t, b in enumerate(beta)) == q)
    z: dict = {}
    cut = []
    for i in cand:
        near = np.cumsum(np.sort(np.delete(dq[i], i)))  # H_i(t) = near[t-2]
        for t in range(1, nm + 1):
            v = model.new_bool_var(f"z{tag}_{i}_{t}")
            model.add_implication(v, xc[i])
            model.add_implication(v, beta[t])
            z[(i, t)] = v
            if t >= 2:
                coef = int(SIZE_CUT_SCALE * int(near[t - 2]) // (t * (t - 1)))
                if coef > 0:
                    cut.append(coef * v)
        model.add(sum(z[(i, t)] for t in range(1, nm + 1)) == xc[i])
    for t in range(1, nm + 1):
        model.add(sum(z[(i, t)] for i in cand) == t * beta[t])
    return beta, z, cut
