"""Agglomerative merging by visual distance with congruence closure (beyond the paper).

Within each role, candidate pairs of observations are visited in order of increasing visual
distance. Merging the clusters of a pair *forces* further merges: the clusters that one action
reaches from the merged cluster must become one (determinism: one node and one action lead to
one node) and, with ``bidirectional``, the clusters from which one action reaches it must
become one (co-determinism, which holds for pick/place rearrangement: the state before placing
into region r is the state after, with that object removed). Forced merges are closed
transitively (congruence closure, as in DFA state merging). The whole merge is refused when
any forced merge joins two clusters whose average-linkage distance exceeds ``threshold``,
or when the result breaks Exactly-One (two labels between one ordered pair of nodes).

The result satisfies bipartiteness, Exactly-One and determinism by construction.

References
----------
K. J. Lang, B. A. Pearlmutter, R. A. Price. *Results of the Abbadingo One DFA Learning
Competition and a New Evidence-Driven State Merging Algorithm*, ICGI 1998 (state merging with
determinisation).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import lookup
from vggc_cp.solvers.base import FEASIBLE, Problem, Solver, SolveResult, register_solver


@dataclass(frozen=True)
class MergeStats:
    """Counters of one merge run."""

    attempts: int
    accepted: int
    vetoed_distance: int
    vetoed_exactly_one: int
    vetoed_work: int


class _Clusters:
    """Union-find over all observations with per-role cluster distance sums."""

    def __init__(self, problem: Problem):
        self.p = problem
        n = problem.n_obs
        self.parent = np.arange(n)
        self.size = np.ones(n, dtype=np.int64)
        self.out: list[list[tuple[int, int]]] = [[] for _ in range(n)]
        self.inn: list[list[tuple[int, int]]] = [[] for _ in range(n)]
        for s, a, d in zip(problem.src.tolist(), problem.act.tolist(), problem.dst.tolist()):
            self.out[s].append((a, d))
            self.inn[d].append((a, s))
        self.members: dict[int, list[int]] = {i: [i] for i in range(n)}
        # distance sums between clusters, per role, indexed by the local index of the root
        self.sums = (problem.dist_pick.copy(), problem.dist_place.copy())

    def find(self, x: int) -> int:
        root = x
        while self.parent[root] != root:
            root = self.parent[root]
        while self.parent[x] != root:
            self.parent[x], x = root, self.parent[x]
        return root

    def link_sum(self, roots_a: list[int], roots_b: list[int]) -> float:
        role = self.p.roles[roots_a[0]]
        la = self.p.local[roots_a]
        lb = self.p.local[roots_b]
        return float(self.sums[role][np.ix_(la, lb)].sum())

    def commit(self, groups: dict[int, list[int]]) -> None:
        """Make each tentative group (head root -> absorbed roots) one cluster."""
        for head, absorbed in groups.items():
            role = self.p.roles[head]
            s = self.sums[role]
            h = self.p.local[head]
            for r in absorbed:
                lr = self.p.local[r]
                s[h, :] += s[lr, :]
                s[:, h] += s[:, lr]
                self.parent[r] = head
                self.size[head] += self.size[r]
                self.members[head].extend(self.members.pop(r))


def _try_merge(cl: _Clusters, i: int, j: int, threshold: float, bidirectional: bool,
               max_work: int) -> tuple[dict[int, list[int]] | None, str]:
    """Close the merge of the clusters of ``i`` and ``j`` under congruence; return the groups
    to commit (head root -> absorbed roots) or None with the reason of the veto."""
    over: dict[int, int] = {}  # committed root -> tentative head
    groups: dict[int, list[int]] = {}  # tentative head -> committed roots in it (head first)

    def head(x: int) -> int:
        r = cl.find(x)
        return over.get(r, r)

    def roots(h: int) -> list[int]:
        return groups.get(h, [h])

    queue = [(i, j)]
    touched: set[int] = set()
    work = 0
    while queue:
        a, b = queue.pop()
        ha, hb = head(a), head(b)
        if ha == hb:
            continue
        work += 1
        if work > max_work:
            return None, "work"
        if cl.p.roles[ha] != cl.p.roles[hb]:
            return None, "distance"
        ra, rb = roots(ha), roots(hb)
        na = sum(int(cl.size[r]) for r in ra)
        nb = sum(int(cl.size[r]) for r in rb)
        if cl.link_sum(ra, rb) / (na * nb) > threshold:
            return None, "distance"
        merged = ra + rb
        groups[ha] = merged
        groups.pop(hb, None)
        for r in rb:
            over[r] = ha
        over.pop(ha, None)
        touched.discard(hb)
        touched.add(ha)
        # congruence: one action from the merged cluster leads to one cluster
        for edges in ((cl.out,) + ((cl.inn,) if bidirectional else ())):
            seen: dict[int, int] = {}
            for r in merged:
                for o in cl.members[r]:
                    for act, o2 in edges[o]:
                        h2 = head(o2)
                        first = seen.setdefault(act, h2)
                        if first != h2:
                            queue.append((first, h2))
    # Exactly-One around every touched cluster, in both directions
    for h in touched:
        if head(h) != h:
            continue
        for edges in (cl.out, cl.inn):
            labels_to: dict[int, int] = {}
            for r in roots(h):
                for o in cl.members[r]:
                    for act, o2 in edges[o]:
                        h2 = head(o2)
                        if labels_to.setdefault(h2, act) != act:
                            return None, "exactly_one"
    result: dict[int, list[int]] = {}
    for h, rs in groups.items():
        if head(h) == h:
            result[h] = [r for r in rs if r != h]
    return result, ""


def congruence_merge(problem: Problem, threshold: float, bidirectional: bool = True,
                     max_work: int = 2_000) -> tuple[np.ndarray, MergeStats]:
    """Labels of the merged clustering and counters.

    Parameters
    ----------
    problem : Problem
    threshold : float
        Largest average-linkage visual distance allowed inside any forced merge.
    bidirectional : bool
        Also close under co-determinism (one action into a cluster comes from one cluster).
    max_work : int
        Cap on forced merges examined per attempt (a larger closure is vetoed).

    Returns
    -------
    labels : ndarray of int64, shape (N,)
    stats : MergeStats
    """
    cl = _Clusters(problem)
    candidates = []
    for obs, dist in ((problem.pick_obs, problem.dist_pick),
                      (problem.place_obs, problem.dist_place)):
        iu, ju = np.triu_indices(len(obs), k=1)
        d = dist[iu, ju]
        keep = d <= threshold
        candidates.append(np.stack([d[keep], obs[iu[keep]], obs[ju[keep]]], axis=1))
    cand = np.concatenate(candidates) if candidates else np.zeros((0, 3))
    order = np.lexsort((cand[:, 2], cand[:, 1], cand[:, 0]))
    attempts = accepted = veto_d = veto_e = veto_w = 0
    # A veto depends only on the current clusters: while nothing is committed, the same pair of
    # clusters is vetoed again, so remember vetoes until the next commit (exact, and most
    # candidate pairs fall between clusters that already failed to merge).
    epoch = 0
    vetoed: dict[tuple[int, int], int] = {}
    for k in order:
        i, j = int(cand[k, 1]), int(cand[k, 2])
        ri, rj = cl.find(i), cl.find(j)
        if ri == rj:
            continue
        key = (ri, rj) if ri < rj else (rj, ri)
        if vetoed.get(key) == epoch:
            continue
        attempts += 1
        groups, why = _try_merge(cl, i, j, threshold, bidirectional, max_work)
        if groups is None:
            vetoed[key] = epoch
            veto_d += why == "distance"
            veto_e += why == "exactly_one"
            veto_w += why == "work"
            continue
        cl.commit(groups)
        epoch += 1
        accepted += 1
    roots = np.array([cl.find(x) for x in range(problem.n_obs)])
    labels = problem.labels_from_colours(roots[problem.pick_obs], roots[problem.place_obs])
    return labels, MergeStats(attempts, accepted, veto_d, veto_e, veto_w)


@register_solver
class MergeSolver(Solver):
    """Congruence-closure merging at one threshold (``k_pick``/``k_place`` are not used)."""

    name = "merge"

    def __init__(self, threshold: float = 0.08, bidirectional: bool = True):
        self.threshold = float(threshold)
        self.bidirectional = bool(bidirectional)

    def _solve(self, problem: Problem, k_pick: int, k_place: int) -> SolveResult:
        labels, stats = congruence_merge(problem, self.threshold, self.bidirectional)
        n_pick = len(np.unique(labels[problem.pick_obs]))
        n_place = len(np.unique(labels[problem.place_obs]))
        return SolveResult(labels, n_pick, n_place, problem.visual_score(labels), FEASIBLE,
                           self.name, stats={"threshold": self.threshold,
                                             "bidirectional": self.bidirectional,
                                             **stats.__dict__})


# ------------------------------------------------------------------ threshold path


def noise_scale(problem: Problem) -> float:
    """Median nearest-neighbour distance over both roles: the scale of rendering noise
    (most observations have a near-duplicate of their own state in the trace)."""
    nn = []
    for d in (problem.dist_pick, problem.dist_place):
        if len(d) > 1:
            masked = d + np.diag(np.full(len(d), np.inf))
            nn.append(masked.min(axis=1))
    return float(np.median(np.concatenate(nn))) if nn else 0.0


def default_thresholds(problem: Problem, factor: float = 1.25, steps: int = 17) -> np.ndarray:
    """Geometric threshold grid from the noise scale: ``s * factor**k`` for ``k < steps``."""
    s = noise_scale(problem)
    if s <= 0:
        s = 1e-3
    return s * factor ** np.arange(steps)


PathRule = Callable[[Sequence[SolveResult]], "int | None"]
PATH_SELECTIONS: dict[str, PathRule] = {}


def register_path_selection(name: str) -> Callable[[PathRule], PathRule]:
    """Decorator: add a rule that picks one result of a threshold path (ascending thresholds)."""
    def deco(fn: PathRule) -> PathRule:
        PATH_SELECTIONS[name] = fn
        return fn
    return deco


@register_path_selection("cascade")
def select_cascade(results: Sequence[SolveResult], stable: float = 0.05) -> int | None:
    """The threshold just after the cascade: where the node count stops collapsing.

    As the threshold grows, noise-level merges first shrink the node count steadily, then
    congruence closure collapses the near-duplicates of each state into one node (the largest
    relative drop of the path), and past the true structure merges slow down until wrong
    merges set in. The rule takes the largest relative drop ``n_k -> n_{k+1}`` and returns the
    first ``j > k`` whose next step loses less than ``stable`` of the nodes (or the last index).
    """
    nodes = [r.n_nodes for r in results]
    if not nodes:
        return None
    if len(nodes) == 1:
        return 0
    drops = [(nodes[k] - nodes[k + 1]) / max(nodes[k], 1) for k in range(len(nodes) - 1)]
    k = int(np.argmax(drops))
    for j in range(k + 1, len(nodes) - 1):
        if nodes[j + 1] >= (1 - stable) * nodes[j]:
            return j
    return len(nodes) - 1


@register_path_selection("fewest")
def select_path_fewest(results: Sequence[SolveResult]) -> int | None:
    """Fewest nodes, then lowest J (the paper's rule applied to the path)."""
    if not results:
        return None
    return min(range(len(results)), key=lambda i: (results[i].n_nodes, results[i].J))


@dataclass(frozen=True, eq=False)
class ThresholdPath:
    """Merges over a grid of thresholds and the one a rule picked."""

    thresholds: tuple[float, ...]
    results: tuple[SolveResult, ...]
    selected: int | None
    rule: str
    seconds: float

    @property
    def best(self) -> SolveResult | None:
        return None if self.selected is None else self.results[self.selected]

    def records(self) -> list[dict]:
        """One JSON-ready row per threshold (the solution file's ``grid``)."""
        return [{"threshold": round(t, 6), "k_pick": r.k_pick, "k_place": r.k_place,
                 "nodes": r.n_nodes, "status": r.status, "J": r.J,
                 "seconds": round(r.seconds, 4), "selected": i == self.selected}
                for i, (t, r) in enumerate(zip(self.thresholds, self.results))]


def threshold_path(problem: Problem, thresholds: Sequence[float] | None = None,
                   rule: str = "cascade", bidirectional: bool = True,
                   progress: bool = False) -> ThresholdPath:
    """Run :class:`MergeSolver` at every threshold (ascending) and select one by ``rule``."""
    fn = lookup(PATH_SELECTIONS, rule, "path selection rule")
    ts = np.sort(np.asarray(default_thresholds(problem) if thresholds is None else thresholds,
                            dtype=np.float64))
    t0 = time.perf_counter()
    iterator = ts
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(ts, desc="merge thresholds", unit="thr")
    results = tuple(MergeSolver(float(t), bidirectional).solve(problem, 0, 0) for t in iterator)
    return ThresholdPath(tuple(float(t) for t in ts), results, fn(results), rule,
                         time.perf_counter() - t0)
