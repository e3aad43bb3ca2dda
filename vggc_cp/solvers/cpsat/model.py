r"""The constraints of the exact CP-SAT model of one ``(k_pick, k_place)`` cell.

The model
---------
Let :math:`P` be the pick observations, :math:`Q` the place observations, and
:math:`K_P = \min(k_{pick}, |P|)`, :math:`K_Q = \min(k_{place}, |Q|)` the colours each role may
use (more colours than observations are never needed). Transitions are split by direction:
pick transitions :math:`(o, a, o') \in P \times A_{pick} \times Q` and place transitions
:math:`(o, a, o') \in Q \times A_{place} \times P`.

*Colours.* One Boolean :math:`x_{o,c}` per observation and colour of its role, with
``add_exactly_one`` over :math:`c`. A node of the task graph is a (role, colour) pair, so the
graph is bipartite by construction.

*Pair-action table.* For every direction, ordered colour pair :math:`(c, c')` and action
:math:`a` of that direction that occurs in the trace, a Boolean :math:`y_{c,c',a}` ("the
edge :math:`c \xrightarrow{a} c'` exists"), with **Exactly-One**
:math:`\sum_a y_{c,c',a} \le 1` and, for every transition :math:`(o, a, o')`, the clauses
:math:`x_{o,c} \wedge x_{o',c'} \Rightarrow y_{c,c',a}` for all :math:`c, c'`. Only the lower
bound of :math:`y` is forced; since every constraint on :math:`y` is downward closed, a
colouring is feasible in the model iff its *induced* edges satisfy the constraints — the
model is exact.

*Deterministic* (option): :math:`\sum_{c'} y_{c,c',a} \le 1` for every source colour and
action (one node and one action lead to one node).

*Action variety.* :math:`u_{c,a}` ("colour :math:`c` has an outgoing :math:`a`-edge") with
:math:`x_{o,c} \Rightarrow u_{c,a}` for each observation :math:`o` whose outgoing action is
:math:`a`, and symmetrically :math:`v_{c',a}` for incoming actions. Distinct outgoing actions of
one node must reach distinct nodes (Exactly-One), so :math:`\sum_a u_{c,a} \le K_{other}` and
:math:`\sum_a v_{c',a} \le K_{other}`; every action occurs, so :math:`\sum_c u_{c,a} \ge 1`.
These are *implied* cuts (valid for every valid colouring) that give the LP relaxation the
pigeonhole bound :math:`|A_{dir}| \le K_P K_Q`. Where the pair table exists they are linked
to it: :math:`u_{c,a} \Rightarrow \bigvee_{c'} y_{c,c',a}` and
:math:`v_{c',a} \Rightarrow \bigvee_{c} y_{c,c',a}` (an action that leaves or enters a node
labels one of its pairs); on fruit-4x6, |D| = 70, this cuts the time CP-SAT takes to prove
the cells just below the frontier infeasible by a factor of 2 to 5 (one worker). The option
``max_actions = K`` tightens :math:`\sum_a u_{c,a} \le K`: at most ``K`` distinct action
labels leave a node.

*Symmetry breaking* (value precedence, Law & Lee 2004). Colours of one role are
interchangeable. Order the observations of a role :math:`\pi_0, \pi_1, \dots` and require that
colour :math:`c \ge 1` is used by :math:`\pi_r` only if colour :math:`c-1` is used by some
:math:`\pi_s`, :math:`s < r`; encoded with prefix Booleans
:math:`p_{r,c} \Leftrightarrow p_{r-1,c} \vee x_{\pi_r,c}` and
:math:`x_{\pi_r,c} \Rightarrow p_{r-1,c-1}` (so :math:`x_{\pi_r,c}` does not exist for
:math:`c > r`). Every colouring has exactly one representative (rename colours by first
appearance along :math:`\pi`), so this removes all :math:`K!` symmetric copies and keeps
exactness. When the *other* role has a single colour, two observations whose outgoing (or
incoming) actions differ can never share a colour — sound because every transition then ends
in the same node; a greedy clique of that conflict graph is put first in :math:`\pi` and fixed
to colours ``0, 1, ...`` (the Heule–Verwer clique of exact DFA identification) and a clique
larger than :math:`K` proves infeasibility. With two or more colours on the other side no pair
of observations is conflicting or forced equal in every valid colouring: each observation has
at most one predecessor and one successor, and the all-singletons colouring is always valid.

*Presolve* (exact): cap :math:`K` at the number of observations; drop actions absent from the
trace; skip the pair table of a direction with one action and no ``deterministic`` /
``max_actions``; prove infeasibility without search when :math:`|A_{dir}| > K_P K_Q`
(each ordered colour pair carries one action) or, with ``max_actions = K``, when
:math:`|A_{dir}| > K_{src} K`; or when the conflict clique above exceeds :math:`K`.

References
----------
M. Heule, S. Verwer. *Exact DFA identification using SAT solvers*, ICGI 2010.
Y. C. Law, J. H. M. Lee. *Global constraints for integer and set value precedence*, CP 2004.
"""


from __future__ import annotations

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.cpsat.cell import CellModel, RoleVars
from vggc_cp.solvers.cpsat.objective import add_objective, quantize
from vggc_cp.solvers.cpsat.parameters import CpSatConfig
from vggc_cp.trace import PICK, PLACE


def _greedy_clique(adj: list[set[int]]) -> list[int]:
    """A clique of the graph ``adj`` (vertex -> neighbours), grown by largest degree."""
    cand = set(range(len(adj)))
    clique: list[int] = []
    while cand:
        v = max(sorted(cand), key=lambda u: len(adj[u] & cand))
        clique.append(v)
        cand &= adj[v]
    return clique


def _conflict_graph(problem: Problem, role: int) -> list[set[int]]:
    """Observations of ``role`` that cannot share a colour when the other role has one colour.

    Two observations conflict when both have an outgoing transition with different actions,
    or both an incoming one with different actions (both would put two labels on the pair
    (c, the other role's only node)).
    """
    obs = problem.pick_obs if role == PICK else problem.place_obs
    out_a = {int(s): int(a) for s, a in zip(problem.src, problem.act)}
    in_a = {int(d): int(a) for d, a in zip(problem.dst, problem.act)}
    n = len(obs)
    adj: list[set[int]] = [set() for _ in range(n)]
    for key in (out_a, in_a):
        groups: dict[int, list[int]] = {}
        for i, o in enumerate(obs.tolist()):
            if o in key:
                groups.setdefault(key[o], []).append(i)
        members = list(groups.values())
        for gi, g in enumerate(members):
            other = [j for h in members[gi + 1:] for j in h]
            for i in g:
                for j in other:
                    adj[i].add(j)
                    adj[j].add(i)
    return adj


def build_cell_model(problem: Problem, k_pick: int, k_place: int,
                     options: CpSatConfig | None = None) -> CellModel:
    """Build the CP-SAT model of one cell (see the module docstring for the mathematics).

    ``options`` defaults to ``CpSatConfig()``.
    """
    options = CpSatConfig() if options is None else options
    notes: list[str] = []
    n_role = (problem.n_pick, problem.n_place)
    kk = (min(k_pick, n_role[0]), min(k_place, n_role[1]))
    if kk != (k_pick, k_place):
        notes.append(f"colours capped at the observation counts: {kk[0]} pick, {kk[1]} place")
    scale, dhat = quantize(problem)

    def infeasible(reason: str) -> CellModel:
        return CellModel(problem, k_pick, k_place, options, None, reason, "none", scale,
                         dhat=dhat, notes=tuple(notes + [reason]))

    roles_arr = problem.roles
    src, act, dst = problem.src, problem.act, problem.dst
    for r in (PICK, PLACE):
        if n_role[r] > 0 and kk[r] < 1:
            return infeasible(f"{('pick', 'place')[r]} side has observations but no colour")
    dir_actions = [sorted({int(a) for s, a in zip(src, act) if roles_arr[s] == r})
                   for r in (PICK, PLACE)]
    for r in (PICK, PLACE):
        n_a = len(dir_actions[r])
        if n_a > kk[0] * kk[1]:
            return infeasible(f"{n_a} distinct {('pick', 'place')[r]} actions > "
                              f"k_pick*k_place = {kk[0] * kk[1]} ordered colour pairs")
        if options.max_actions is not None and n_a > kk[r] * options.max_actions:
            return infeasible(f"{n_a} distinct {('pick', 'place')[r]} actions > "
                              f"{kk[r]} nodes x max_actions {options.max_actions}")

    # ---- orders and fixed clique
    orders, fixed = [], []
    for r in (PICK, PLACE):
        order = np.arange(n_role[r], dtype=np.int64)  # time order within the role
        clique: list[int] = []
        if options.symmetry and kk[1 - r] == 1:
            clique = _greedy_clique(_conflict_graph(problem, r))
            if len(clique) > kk[r]:
                return infeasible(f"{len(clique)} {('pick', 'place')[r]} observations pairwise "
                                  f"conflict (other side has one colour) > {kk[r]} colours")
            if len(clique) > 1:
                notes.append(f"{('pick', 'place')[r]}: clique of {len(clique)} conflicting "
                             f"observations fixed to distinct colours")
                rest = np.setdiff1d(order, clique, assume_unique=True)
                order = np.concatenate([np.array(clique, dtype=np.int64), rest])
        orders.append(order)
        fixed.append(clique if len(clique) > 1 else [])

    from ortools.sat.python import cp_model

    model = cp_model.CpModel()
    roles: list[RoleVars] = []
    for r in (PICK, PLACE):
        n, k, order = n_role[r], kk[r], orders[r]
        rank = np.empty(n, dtype=np.int64)
        rank[order] = np.arange(n)
        x: list[list] = []
        for i in range(n):
            top = min(int(rank[i]), k - 1) if options.symmetry else k - 1
            row = [model.new_bool_var(f"x{r}_{i}_{c}") for c in range(top + 1)]
            row += [None] * (k - 1 - top)
            model.add_exactly_one([v for v in row if v is not None])
            x.append(row)
        for pos, i in enumerate(fixed[r]):
            model.add(x[i][pos] == 1)
        prefix: dict = {}
        if options.symmetry:
            for pos, i in enumerate(order.tolist()):
                for c in range(k - 1):  # colour k-1 is never a predecessor colour
                    prev = prefix.get((pos - 1, c))
                    cur = x[i][c]
                    if prev is None and cur is None:
                        continue
                    if prev is None or cur is None:
                        prefix[(pos, c)] = cur if prev is None else prev
                        continue
                    p = model.new_bool_var(f"p{r}_{pos}_{c}")
                    model.add_implication(prev, p)
                    model.add_implication(cur, p)
                    model.add_bool_or([~p, prev, cur])
                    prefix[(pos, c)] = p
                for c in range(1, k):
                    cur = x[i][c]
                    if cur is None:
                        continue
                    prev = prefix.get((pos - 1, c - 1))
                    if prev is None:
                        model.add(cur == 0)
                    else:
                        model.add_implication(cur, prev)
        roles.append(RoleVars(r, problem.pick_obs if r == PICK else problem.place_obs, k, order,
                           x, prefix))

    local = problem.local
    trans = [(int(s), int(a), int(d)) for s, a, d in zip(src, act, dst)]

    # ---- pair-action table (Exactly-One), determinism
    y: dict = {}
    for r in (PICK, PLACE):
        needs_table = (len(dir_actions[r]) > 1 or options.deterministic
                       or options.codeterministic)
        if not needs_table:
            notes.append(f"{('pick', 'place')[r]} direction has one action: no pair table")
            continue
        xs, xd = roles[r].x, roles[1 - r].x
        for s, a, d in trans:
            if roles_arr[s] != r:
                continue
            for c, vs in enumerate(xs[local[s]]):
                if vs is None:
                    continue
                for c2, vd in enumerate(xd[local[d]]):
                    if vd is None:
                        continue
                    key = (r, c, c2, a)
                    if key not in y:
                        y[key] = model.new_bool_var(f"y{r}_{c}_{c2}_{a}")
                    model.add_bool_or([~vs, ~vd, y[key]])
    by_pair: dict = {}
    by_succ: dict = {}
    by_pred: dict = {}
    for (r, c, c2, a), v in y.items():
        by_pair.setdefault((r, c, c2), []).append(v)
        by_succ.setdefault((r, c, a), []).append(v)
        by_pred.setdefault((r, c2, a), []).append(v)
    for vs in by_pair.values():
        if len(vs) > 1:
            model.add_at_most_one(vs)
    if options.deterministic:
        for vs in by_succ.values():
            if len(vs) > 1:
                model.add_at_most_one(vs)
    if options.codeterministic:
        for vs in by_pred.values():
            if len(vs) > 1:
                model.add_at_most_one(vs)

    # ---- visual cannot-link: observations farther apart than the bound never share a colour
    if options.cannot_link is not None:
        n_links = 0
        for r, dist in ((PICK, problem.dist_pick), (PLACE, problem.dist_place)):
            x = roles[r].x
            ii, jj = np.nonzero(np.triu((dist + dist.T) / 2.0 > options.cannot_link, 1))
            for i, j in zip(ii.tolist(), jj.tolist()):
                for vi, vj in zip(x[i], x[j]):
                    if vi is not None and vj is not None:
                        model.add_bool_or([~vi, ~vj])
            n_links += len(ii)
        notes.append(f"cannot-link: {n_links} pairs farther apart than {options.cannot_link:g}")

    # ---- action variety: implied cuts, max_actions
    has_table = [any(key[0] == r for key in y) for r in (PICK, PLACE)]
    out_used: dict = {}
    in_used: dict = {}
    for r in (PICK, PLACE):
        n_a = len(dir_actions[r])
        cap_out = kk[1 - r] if options.max_actions is None else min(kk[1 - r], options.max_actions)
        cap_in = kk[r]
        for table, side, cap, end in ((out_used, r, cap_out, 0), (in_used, 1 - r, cap_in, 2)):
            if n_a <= cap:
                continue  # the cut cannot bind
            xsd = roles[side].x
            for tr in trans:
                if roles_arr[tr[0]] != r:
                    continue
                o, a = tr[end], tr[1]
                for c, v in enumerate(xsd[local[o]]):
                    if v is None:
                        continue
                    key = (side, c, a)
                    if key not in table:
                        table[key] = model.new_bool_var(f"{'uv'[end // 2]}{side}_{c}_{a}")
                    model.add_implication(v, table[key])
            per_c: dict = {}
            per_a: dict = {}
            for (sd, c, a), v in table.items():
                if sd == side and a in dir_actions[r]:
                    per_c.setdefault(c, []).append(v)
                    per_a.setdefault(a, []).append(v)
            for vs in per_c.values():
                if len(vs) > cap:
                    model.add(sum(vs) <= cap)
            for vs in per_a.values():
                model.add_bool_or(vs)
            if has_table[r]:  # a used action needs a labelled pair (both ends)
                for (sd, c, a), v in table.items():
                    if sd != side or a not in dir_actions[r]:
                        continue
                    ys = [y[key] for c2 in range(kk[1 - side])
                          if (key := ((r, c, c2, a) if end == 0 else (r, c2, c, a))) in y]
                    model.add_bool_or([~v] + ys)

    objective_mode, pairs, means, sizes = add_objective(model, roles, dhat, options, notes)
    return CellModel(problem, k_pick, k_place, options, model, None, objective_mode, scale,
                     tuple(roles), y, out_used, in_used, pairs, means, sizes, dhat, tuple(notes))
