"""The paper's solver: three-stage vision-guided DSATUR for one ``(k_pick, k_place)`` cell.

Colour the pick observations with at most ``k_pick`` colours and the place observations with
at most ``k_place`` so that the induced task graph is bipartite (by construction: colours never
cross roles) and satisfies **Exactly-One** in both directions — pick edges (pick node -> place
node, labelled by pick actions) and place edges (place node -> pick node, labelled by place
actions) — while keeping visually similar observations together.

Visual affinity (paper, Eq. K_vis) on the within-role distances ``d``:

.. math::  K_{vis}(o_i, o_j) = \\exp(-d(o_i, o_j) / \\tau)

``tau`` defaults, per role, to the median off-diagonal within-role distance, so an affinity of
``exp(-1)`` means "as far apart as a typical pair of this role".

In stages 2-3 "visually close" is decided *relatively*, without a threshold: an observation is
close to a colour when its mean K_vis to the colour's members exceeds its mean K_vis to the
observations not yet coloured (the pool from which a new colour would be drawn). A fixed
threshold fails as soon as a role has three or more states: most pairs are then between-state
pairs, so any quantile-based threshold merges the nearest states.

Stages
------
1. **Pick seeding, vision only** (:func:`seed_colours`). The pick observation with the highest
   mean affinity to the rest seeds a colour, further seeds (up to ``k_pick``) are taken
   farthest-first, and the clusters grow greedily by the observation of highest mean affinity
   to a cluster, keeping each cluster's mean distance low.
2. **Place side, picks fixed.** Two place observations *conflict* when sharing a colour would
   give one ordered pair of colours two action labels: both entered from the same pick colour by
   different pick actions, or both leaving to the same pick colour by different place actions.
   Feasibility is kept through the pair-action tables Lambda (for each ordered pair of colours,
   in each direction, the one action label already fixed, with reference counts so decisions
   can be undone). DSATUR order: the uncoloured observation with the most used colours already
   infeasible for it (saturation), ties by conflict degree, then by visual centrality. Among the
   feasible colours the one with highest mean K_vis to its members is tried first; a new colour
   (while fewer than ``k_place`` are used) is tried before the existing colours the observation
   is not close to (``open_when="dissimilar"``) or only after all of them (``open_when="stuck"``,
   plain DSATUR). With no candidate left, the search backtracks chronologically: the most
   recent decision is undone and its next candidate tried, within a node limit and a time
   limit (reported in the statistics when hit). The unused colours are interchangeable, so one
   new colour per decision suffices and the search is complete for the fixed other side: an
   ``exhausted`` search proves that no colouring fits *these* pick colours. Before searching, a
   greedy clique of the conflict graph larger than ``k_place`` ends the stage at once.
3. **Pick side, places frozen.** The seeds are discarded and the pick side is recoloured the
   same way against the place colours. Should that search fail (limit), the stage-1 pick
   colours (which the place colours were built to fit) are kept, so a stage-2 success is never
   lost.

A greedy solver never proves infeasibility: without a colouring the status is ``unknown``.

References
----------
A. Ajith, C. Chamzas. *Learning Discrete Abstractions for Visual Rearrangement Tasks Using
Vision-Guided Graph Coloring*, arXiv:2509.14460, 2025.
D. Brelaz. *New methods to color the vertices of a graph*, CACM 22(4), 1979 (DSATUR).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import VggcError, lookup
from vggc_cp.score import affinity
from vggc_cp.solvers.base import FEASIBLE, UNKNOWN, Problem, Solver, SolveResult, register_solver
from vggc_cp.trace import PICK, PLACE

OPEN_WHEN = ("dissimilar", "stuck")
DEFAULT_NODE_LIMIT = 5_000
DEFAULT_TIME_LIMIT = 30.0


def default_tau(dist: np.ndarray) -> float:
    """The data-derived temperature of K_vis for one role.

    Parameters
    ----------
    dist : ndarray, shape (n, n)
        Symmetric within-role distances.

    Returns
    -------
    float
        The median off-diagonal distance; if that is 0 (mostly identical images), the mean of the
        positive distances; 1.0 when there is no positive distance at all.
    """
    n = len(dist)
    if n < 2:
        return 1.0
    off = np.asarray(dist, dtype=np.float64)[np.triu_indices(n, 1)]
    med = float(np.median(off))
    if med > 0:
        return med
    pos = off[off > 0]
    return float(pos.mean()) if pos.size else 1.0


@dataclass(frozen=True, eq=False)
class SideLinks:
    """The transitions seen from one role's observations (local indices).

    Every observation of a trace has at most one incoming and one outgoing transition, both to
    observations of the other role.

    Attributes
    ----------
    in_obs, out_obs : ndarray of int64, shape (n_side,)
        Local index (in the other role) of the predecessor / successor; -1 if none.
    in_act, out_act : ndarray of int64, shape (n_side,)
        Action of that transition; -1 if none.
    """

    in_obs: np.ndarray
    in_act: np.ndarray
    out_obs: np.ndarray
    out_act: np.ndarray

    @classmethod
    def of(cls, problem: Problem, role: int) -> SideLinks:
        """Incoming/outgoing transitions of every observation of ``role`` (PICK or PLACE)."""
        n = problem.n_pick if role == PICK else problem.n_place
        in_obs = np.full(n, -1, dtype=np.int64)
        in_act = np.full(n, -1, dtype=np.int64)
        out_obs = np.full(n, -1, dtype=np.int64)
        out_act = np.full(n, -1, dtype=np.int64)
        roles, local = problem.roles, problem.local
        src, act, dst = (np.asarray(x, dtype=np.int64) for x in (problem.src, problem.act,
                                                                 problem.dst))
        if np.any(roles[src] == roles[dst]):
            raise ValueError("a transition joins two observations of one role")
        into = roles[dst] == role
        for arr_obs, arr_act, mine, other, sel in ((in_obs, in_act, dst, src, into),
                                                   (out_obs, out_act, src, dst, ~into)):
            where = local[mine[sel]]
            if len(np.unique(where)) != len(where):
                raise ValueError("an observation has two incoming or two outgoing transitions")
            arr_obs[where] = local[other[sel]]
            arr_act[where] = act[sel]
        return cls(in_obs, in_act, out_obs, out_act)

    def signatures(self, other_colour: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Colour of the other-role neighbour of each incidence under ``other_colour``.

        Returns
        -------
        in_col, out_col : ndarray of int64, shape (n_side,)
            -1 where there is no transition.
        """
        oc = np.asarray(other_colour, dtype=np.int64)
        in_col = np.where(self.in_obs >= 0, oc[np.maximum(self.in_obs, 0)], -1) if len(oc) else \
            np.full(len(self.in_obs), -1, dtype=np.int64)
        out_col = np.where(self.out_obs >= 0, oc[np.maximum(self.out_obs, 0)], -1) if len(oc) else \
            np.full(len(self.out_obs), -1, dtype=np.int64)
        return in_col, out_col


def seed_colours(aff: np.ndarray, k: int) -> np.ndarray:
    """Stage 1: vision-only clustering of one role into at most ``k`` colours.

    The observation with the highest mean affinity to the rest seeds the first colour; each
    further colour (up to ``k``) is seeded by the observation least similar to every seed so far
    (farthest-first, so seeds land in different visual modes). Then the clusters grow greedily:
    at every step the uncoloured observation with the highest mean K_vis to some cluster joins
    that cluster, which keeps each cluster's mean distance low.

    Parameters
    ----------
    aff : ndarray, shape (n, n)
        K_vis within the role.
    k : int
        Most colours.

    Returns
    -------
    ndarray of int64, shape (n,)
        Colour of every observation, ``0 .. min(k, n)-1``.
    """
    n = len(aff)
    colour = np.full(n, -1, dtype=np.int64)
    if n == 0:
        return colour
    k = min(int(k), n)
    centrality = (aff.sum(axis=1) - np.diag(aff)) / max(n - 1, 1)
    seeds = [int(np.argmax(centrality))]
    closest = aff[:, seeds[0]].copy()  # highest affinity of each observation to any seed
    while len(seeds) < k:
        masked = closest.copy()
        masked[seeds] = np.inf
        s = int(np.argmin(masked))
        seeds.append(s)
        np.maximum(closest, aff[:, s], out=closest)
    colour[seeds] = np.arange(k)
    total = aff[:, seeds].copy()  # (n, k) sum of K_vis to each cluster's members
    size = np.ones(k)
    free = colour < 0
    while free.any():
        idx = np.flatnonzero(free)
        mean = total[idx] / size
        j, c = np.unravel_index(int(np.argmax(mean)), mean.shape)
        o = int(idx[j])
        colour[o] = c
        free[o] = False
        total[:, c] += aff[:, o]
        size[c] += 1
    return colour


def conflict_clique(in_col, in_act, out_col, out_act) -> int:
    """Size of a clique of the conflict graph, found greedily (a lower bound on colours needed).

    Observations with equal signatures ``(in_col, in_act, out_col, out_act)`` never conflict
    with each other and conflict with the same others, so the clique is searched among the
    signature classes, greedily by class degree.
    """
    sig = np.stack([in_col, in_act, out_col, out_act], axis=1)
    if len(sig) == 0:
        return 0
    cls = np.unique(sig, axis=0)
    ic, ia, oc, oa = cls.T
    adj = ((ic[:, None] == ic[None, :]) & (ic[:, None] >= 0) & (ia[:, None] != ia[None, :])) | \
          ((oc[:, None] == oc[None, :]) & (oc[:, None] >= 0) & (oa[:, None] != oa[None, :]))
    order = np.argsort(-adj.sum(axis=1), kind="stable")
    clique: list[int] = []
    for u in order:
        if all(adj[u, v] for v in clique):
            clique.append(int(u))
    return len(clique)


def conflict_degree(in_col, in_act, out_col, out_act) -> np.ndarray:
    """Degree of every observation in the conflict graph, shape (n,), by counting signatures.

    ``deg(i) = #{j : same in-colour, other in-action} + #{j : same out-colour, other
    out-action} - #{j : both}`` (inclusion-exclusion; an absent side never conflicts).
    """
    def count(*cols):
        key = np.stack(cols, axis=1)
        _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        return cnt[inv.reshape(-1)]

    n = len(in_col)
    if n == 0:
        return np.zeros(0, dtype=np.int64)
    has_in = in_col >= 0
    has_out = out_col >= 0
    d_in = np.where(has_in, count(in_col) - count(in_col, in_act), 0)
    d_out = np.where(has_out, count(out_col) - count(out_col, out_act), 0)
    both = count(in_col, out_col) - count(in_col, in_act, out_col) \
        - count(in_col, out_col, out_act) + count(in_col, in_act, out_col, out_act)
    d_both = np.where(has_in & has_out, both, 0)
    return (d_in + d_out - d_both).astype(np.int64)


@dataclass(frozen=True)
class SideResult:
    """Outcome of colouring one role (stages 2 and 3)."""

    colour: np.ndarray | None
    nodes: int
    backtracks: int
    limit: str | None  # "nodes", "time", or None
    exhausted: bool  # the whole search space was tried (no colouring for these fixed colours)
    clique: int
    seconds: float

    def stats(self) -> dict:
        return {"found": self.colour is not None, "nodes": self.nodes,
                "backtracks": self.backtracks, "limit": self.limit, "exhausted": self.exhausted,
                "clique": self.clique, "seconds": round(self.seconds, 6)}


def colour_side(links: SideLinks, other_colour: np.ndarray, n_other_colours: int,
                aff: np.ndarray, k: int, *, open_when: str,
                node_limit: int, deadline: float) -> SideResult:
    """Stages 2/3: colour one role with at most ``k`` colours, the other role frozen.

    Parameters
    ----------
    links : SideLinks
        Transitions of this role's observations.
    other_colour : ndarray of int64, shape (n_other,)
        Frozen colours of the other role.
    n_other_colours : int
        Upper bound on those colours (size of the Lambda tables).
    aff : ndarray, shape (n, n)
        K_vis within this role.
    k : int
        Most colours for this role.
    open_when : {"dissimilar", "stuck"}
        See the module docstring.
    node_limit : int
        Most colour assignments (search nodes).
    deadline : float
        ``time.perf_counter()`` value after which the search stops.
    """
    t0 = time.perf_counter()
    n = len(aff)
    in_col, out_col = links.signatures(other_colour)
    in_act = np.where(in_col >= 0, links.in_act, -1)
    out_act = np.where(out_col >= 0, links.out_act, -1)
    clique = conflict_clique(in_col, in_act, out_col, out_act)
    if n == 0:
        return SideResult(np.zeros(0, dtype=np.int64), 0, 0, None, False, 0, 0.0)
    if clique > k:
        return SideResult(None, 0, 0, None, True, clique, time.perf_counter() - t0)

    deg = conflict_degree(in_col, in_act, out_col, out_act)
    centrality = (aff.sum(axis=1) - np.diag(aff)) / max(n - 1, 1)
    # static tie-break rank: degree first, then visual centrality, then lower index
    order = np.lexsort((-np.arange(n), centrality, deg))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n)
    m = max(int(n_other_colours), 1)
    # Lambda, one table per direction: label fixed for (this colour, other colour), -1 if none,
    # with the number of members that fix it (so a decision can be undone)
    lam = [np.full((k, m), -1, dtype=np.int64), np.full((k, m), -1, dtype=np.int64)]
    cnt = [np.zeros((k, m), dtype=np.int64), np.zeros((k, m), dtype=np.int64)]
    cols = (in_col, out_col)
    acts = (in_act, out_act)
    # observations of this role grouped by the other-role colour they meet, per direction
    groups = [[np.flatnonzero(col == c) for c in range(m)] for col in cols]
    hits: dict[tuple[int, int, int], np.ndarray] = {}  # (d, oc, a) -> members of the group
    # whose action differs from a, i.e. those a Lambda entry (d, oc) = a forbids
    # blk[c, j]: how many Lambda entries forbid colour c for observation j (0 = feasible);
    # sat[j]: DSATUR saturation, the number of used colours with blk > 0
    blk = np.zeros((k, n), dtype=np.int64)
    sat = np.zeros(n, dtype=np.int64)
    asum = np.zeros((k, n))  # sum of K_vis from each colour's members to each observation
    pool = aff.sum(axis=1) - np.diag(aff)  # ... and to the other uncoloured observations
    size = np.zeros(k, dtype=np.int64)
    colour = np.full(n, -1, dtype=np.int64)
    key = rank.astype(np.float64)  # selection key sat * n + rank; -1 once coloured
    used = 0
    new_first = open_when == "dissimilar"

    def fix(d: int, c: int, oc: int, a: int, step: int) -> None:
        """Lambda[d][c, oc] becomes ``a`` (step +1) or is released (step -1): update blk/sat."""
        hit = hits.get((d, oc, a))
        if hit is None:
            g = groups[d][oc]
            hit = hits[(d, oc, a)] = g[acts[d][g] != a]
        if not len(hit):
            return
        row = blk[c]
        row[hit] += step
        change = hit[row[hit] == (1 if step > 0 else 0)]
        if len(change):
            sat[change] += step
            key[change] += step * n * (colour[change] < 0)

    def assign(i: int, c: int) -> None:
        nonlocal used
        for d in (0, 1):
            oc = cols[d][i]
            if oc >= 0:
                cnt[d][c, oc] += 1
                if cnt[d][c, oc] == 1:
                    lam[d][c, oc] = acts[d][i]
                    fix(d, c, oc, acts[d][i], +1)
        asum[c] += aff[i]
        np.subtract(pool, aff[i], out=pool)
        size[c] += 1
        colour[i] = c
        key[i] = -1.0
        if c == used:
            used += 1

    def unassign(i: int, c: int) -> None:
        nonlocal used
        for d in (0, 1):
            oc = cols[d][i]
            if oc >= 0:
                cnt[d][c, oc] -= 1
                if cnt[d][c, oc] == 0:
                    lam[d][c, oc] = -1
                    fix(d, c, oc, acts[d][i], -1)
        asum[c] -= aff[i]
        np.add(pool, aff[i], out=pool)
        size[c] -= 1
        colour[i] = -1
        key[i] = sat[i] * n + rank[i]
        while used > 0 and size[used - 1] == 0:
            used -= 1

    def candidates(i: int) -> list[int]:
        feas = np.flatnonzero(blk[:used, i] == 0)
        mean = asum[feas, i] / size[feas]
        srt = np.argsort(-mean, kind="stable")
        feas, mean = feas[srt], mean[srt]
        if used >= k:
            return feas.tolist()
        if new_first:
            others = remaining - 1  # uncoloured observations besides i
            rest = pool[i] / others if others > 0 else 0.0
            close = mean > rest
            return feas[close].tolist() + [used] + feas[~close].tolist()
        return feas.tolist() + [used]

    stack: list[tuple[int, list[int], int]] = []
    nodes = backtracks = 0
    limit: str | None = None
    exhausted = False
    remaining = n
    while remaining:
        if nodes >= node_limit:
            limit = "nodes"
            break
        if (nodes & 63) == 0 and time.perf_counter() > deadline:
            limit = "time"
            break
        i = int(np.argmax(key))
        cands = candidates(i)
        if cands:
            stack.append((i, cands, 0))
            assign(i, cands[0])
            nodes += 1
            remaining -= 1
            continue
        # no colour fits: undo the most recent decision that has another candidate
        backtracks += 1
        while stack:
            j, cj, pos = stack.pop()
            unassign(j, cj[pos])
            remaining += 1
            if pos + 1 < len(cj):
                stack.append((j, cj, pos + 1))
                assign(j, cj[pos + 1])
                nodes += 1
                remaining -= 1
                break
        else:
            exhausted = True
            break
    found = remaining == 0 and limit is None and not exhausted
    return SideResult(colour.copy() if found else None, nodes, backtracks, limit, exhausted,
                      clique, time.perf_counter() - t0)


@register_solver
class GreedySolver(Solver):
    """The paper's three-stage vision-guided DSATUR (registered as ``"greedy"``).

    Parameters
    ----------
    tau : float or None
        K_vis temperature for both roles; None: per role, :func:`default_tau`.
    open_when : {"dissimilar", "stuck"}
        When stages 2-3 open a new colour (while fewer than k are used): ``"dissimilar"`` tries
        it before the existing colours the observation is not visually close to; ``"stuck"``
        only after every feasible existing colour (plain DSATUR).
    node_limit : int
        Most search nodes (colour assignments) per stage.
    time_limit : float
        Seconds per cell (stages 2 and 3 together).
    """

    name = "greedy"

    def __init__(self, tau: float | None = None,
                 open_when: str = "dissimilar", node_limit: int = DEFAULT_NODE_LIMIT,
                 time_limit: float = DEFAULT_TIME_LIMIT):
        if tau is not None and not 0 < tau < float("inf"):
            raise VggcError(f"--tau must be positive and finite, got {tau}")
        lookup({w: w for w in OPEN_WHEN}, open_when, "open_when policy")
        self.tau = tau
        self.open_when = open_when
        self.node_limit = int(node_limit)
        self.time_limit = float(time_limit)

    def options(self) -> dict:
        """The constructor arguments (so a sweep can rebuild the solver in a worker)."""
        return {"tau": self.tau, "open_when": self.open_when, "node_limit": self.node_limit,
                "time_limit": self.time_limit}

    def _solve(self, problem: Problem, k_pick: int, k_place: int) -> SolveResult:
        if k_pick < 1 or k_place < 1:
            raise ValueError("k_pick and k_place must be at least 1")
        t_start = time.perf_counter()
        deadline = t_start + self.time_limit
        tau_pick = self.tau or default_tau(problem.dist_pick)
        tau_place = self.tau or default_tau(problem.dist_place)
        aff_pick = affinity((problem.dist_pick + problem.dist_pick.T) / 2, tau_pick)
        aff_place = affinity((problem.dist_place + problem.dist_place.T) / 2, tau_place)
        pick_links = SideLinks.of(problem, PICK)
        place_links = SideLinks.of(problem, PLACE)
        opts = dict(open_when=self.open_when,
                    node_limit=self.node_limit, deadline=deadline)

        t0 = time.perf_counter()
        seeds = seed_colours(aff_pick, k_pick)
        t1 = time.perf_counter()
        place = colour_side(place_links, seeds, k_pick, aff_place, k_place, **opts)
        stats = {"tau_pick": tau_pick, "tau_place": tau_place,
                 "stage1_seconds": round(t1 - t0, 6),
                 "stage1_colours": int(len(np.unique(seeds))), "stage2": place.stats()}
        picks = None
        if place.colour is not None:
            pick = colour_side(pick_links, place.colour, k_place, aff_pick, k_pick, **opts)
            stats["stage3"] = pick.stats()
            picks = pick.colour if pick.colour is not None else seeds
            stats["stage3_fallback"] = pick.colour is None
        stages = [stats["stage2"]] + ([stats["stage3"]] if "stage3" in stats else [])
        stats["nodes"] = sum(s["nodes"] for s in stages)
        stats["backtracks"] = sum(s["backtracks"] for s in stages)
        stats["limit_hit"] = next((s["limit"] for s in stages if s["limit"]), None)
        if picks is None:
            return SolveResult(None, k_pick, k_place, float("nan"), UNKNOWN, self.name,
                               stats=stats)
        labels = problem.labels_from_colours(picks, place.colour)
        stats["colours_pick"] = int(len(np.unique(picks)))
        stats["colours_place"] = int(len(np.unique(place.colour)))
        return SolveResult(labels, k_pick, k_place, problem.visual_score(labels), FEASIBLE,
                           self.name, stats=stats)
