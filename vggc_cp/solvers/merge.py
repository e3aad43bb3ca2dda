"""Agglomerative merging by visual distance with congruence closure (beyond the paper).

Within each role, candidate pairs of observations are visited in order of increasing visual
distance. Merging the clusters of a pair *forces* further merges: the clusters that one action
reaches from the merged cluster must become one (determinism: one node and one action lead to
one node) and the clusters from which one action reaches it must become one (co-determinism, which holds for pick/place rearrangement: the state before placing
into region r is the state after, with that object removed). Forced merges are closed
transitively (congruence closure, as in DFA state merging). The whole merge is refused when
any forced merge joins two clusters whose average-linkage distance exceeds ``threshold``,
or when the result breaks Exactly-One (two labels between one ordered pair of nodes).

The result satisfies bipartiteness, Exactly-One and determinism by construction.

Cost. Most attempts are refused, so refusals are made cheap without changing any partition:
each cluster keeps a compressed signature of its transitions, a forced merge rescans only the
transitions that can still disagree, a closure stops as soon as it breaks Exactly-One (merges
never split, so it could not succeed; the veto then counts as ``exactly_one`` even where the
plain closure would have hit the distance or work limit first), and an attempt vetoed before is
replayed, not recomputed, while none of the clusters its closure read has changed.
:func:`threshold_path` sorts the candidate pairs once for all thresholds.

References
----------
K. J. Lang, B. A. Pearlmutter, R. A. Price. *Results of the Abbadingo One DFA Learning
Competition and a New Evidence-Driven State Merging Algorithm*, ICGI 1998 (state merging with
determinisation).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from itertools import chain

import numpy as np

from vggc_cp.solvers.base import (
    FEASIBLE,
    Problem,
    Solver,
    SolveResult,
    hand_colours,
    register_solver,
)
from vggc_cp.solvers.episodes import move_lone_episodes
from vggc_cp.solvers.parts import move_lone_parts
from vggc_cp.solvers.read_splits import combined_readings, split_by_readings
from vggc_cp.solvers.selection import (  # noqa: F401  (re-exported)
    PATH,
    RULES,
    get_selection,
    select_cascade,
    select_path_fewest,
)


@dataclass(frozen=True)
class MergeStats:
    """Counters of one merge run.

    ``attempts`` and the veto counters count every candidate pair between two clusters that
    was examined; ``vetoes_replayed`` says how many of the vetoes were not recomputed because
    nothing their closure read had changed since the same attempt was vetoed;
    ``vetoed_hand`` counts closures that would have put two place observations whose hands
    hold different colours in one node (:func:`~vggc_cp.solvers.base.hand_colours`);
    ``read_splits`` the nodes cut afterwards where the sites' readings show two states
    (:func:`with_read_splits`), ``lone_moves`` the lone episodes moved then onto the path
    their actions walk (:func:`~vggc_cp.solvers.episodes.move_lone_episodes`) and the parts
    moved onto the rest of the graph (:func:`~vggc_cp.solvers.parts.move_lone_parts`).
    """

    attempts: int
    accepted: int
    vetoed_distance: int
    vetoed_exactly_one: int
    vetoed_work: int
    vetoes_replayed: int = 0
    vetoed_hand: int = 0
    vetoed_refused: int = 0
    read_splits: int = 0
    lone_moves: int = 0


class _Clusters:
    """Union-find over all observations with per-role cluster distance sums.

    Every root keeps, per direction (outgoing, incoming), the *signature* of its members'
    transitions: the distinct ``(action, other end)`` pairs in the order of their last
    occurrence in the members' transitions (members in cluster order), and the other end of the
    first transition of each action. Two transitions whose other ends lie in one cluster are
    one pair (they lead to one node now and after any later merge), so scanning a signature
    instead of all transitions gives the closure exactly the same forced merges in the same
    order (see :func:`_try_merge`) while skipping repeats. Plain Python lists hold the
    per-observation state: the closure touches single elements millions of times.
    """

    def __init__(self, problem: Problem):
        self.p = problem
        n = problem.n_obs
        self.roles: list[int] = problem.roles.tolist()
        self.local: list[int] = problem.local.tolist()
        self.parent: list[int] = list(range(n))
        self.size: list[int] = [1] * n
        # sig[d][r]: (action, observation) pairs; first[d][r]: action -> observation
        self.sig: tuple[list[list[tuple[int, int]]], ...] = ([[] for _ in range(n)],
                                                             [[] for _ in range(n)])
        self.first: tuple[list[dict[int, int]], ...] = ([{} for _ in range(n)],
                                                        [{} for _ in range(n)])
        for s, a, d in zip(problem.src.tolist(), problem.act.tolist(), problem.dst.tolist()):
            for k, (x, y) in enumerate(((s, d), (d, s))):
                self.sig[k][x].append((a, y))
                self.first[k][x].setdefault(a, y)
        for k in (0, 1):
            self.sig[k][:] = [self._compress(lst) for lst in self.sig[k]]
        self.members: dict[int, list[int]] = {i: [i] for i in range(n)}
        # colour the hand holds in each root's observations (-1: none known)
        self.hand: list[int] = hand_colours(problem).tolist()
        # actions refused in each root's observations (Problem.refused; None: none)
        self.refused: list[set[int] | None] = [None] * n
        for o, k in getattr(problem, "refused", ()):
            if self.refused[o] is None:
                self.refused[o] = set()
            self.refused[o].add(int(k))
        self.any_refused = any(r is not None for r in self.refused)
        self.sums = self._distance_sums(problem)

    def _distance_sums(self, problem: Problem):
        """Distance sums between clusters, per role, indexed by the local index of the root
        (here the dense ``(n, n)`` matrices; :mod:`vggc_cp.solvers.pairs` keeps them per
        descriptor code instead)."""
        return (problem.dist_pick.copy(), problem.dist_place.copy())

    def _absorb_sums(self, head: int, r: int) -> None:
        """Add root ``r``'s distance sums to root ``head``'s."""
        s = self.sums[self.roles[head]]
        h, lr = self.local[head], self.local[r]
        s[h, :] += s[lr, :]
        s[:, h] += s[:, lr]

    def find(self, x: int) -> int:
        parent = self.parent
        root = x
        while parent[root] != root:
            root = parent[root]
        while parent[x] != root:
            parent[x], x = root, parent[x]
        return root

    def _compress(self, pairs: list[tuple[int, int]]) -> list[tuple[int, int]]:
        """Distinct (action, root of the other end), ordered by last occurrence."""
        last: dict[tuple[int, int], None] = {}
        for a, y in pairs:
            key = (a, self.find(y))
            last.pop(key, None)
            last[key] = None
        return list(last)

    def link_sum(self, roots_a: list[int], roots_b: list[int]) -> float:
        s = self.sums[self.roles[roots_a[0]]]
        if len(roots_a) == 1 and len(roots_b) == 1:
            return float(s[self.local[roots_a[0]], self.local[roots_b[0]]])
        la = [self.local[r] for r in roots_a]
        lb = [self.local[r] for r in roots_b]
        return float(s[np.ix_(la, lb)].sum())

    def commit(self, groups: dict[int, list[int]]) -> None:
        """Make each tentative group (head root -> absorbed roots) one cluster."""
        for head, absorbed in groups.items():
            for r in absorbed:
                self._absorb_sums(head, r)
                self.parent[r] = head
                self.size[head] += self.size[r]
                self.members[head].extend(self.members.pop(r))
                if self.hand[head] < 0:
                    self.hand[head] = self.hand[r]
                if self.refused[r] is not None:
                    if self.refused[head] is None:
                        self.refused[head] = set()
                    self.refused[head] |= self.refused[r]
        for head, absorbed in groups.items():
            for k in (0, 1):
                sig, first = self.sig[k], self.first[k]
                pairs = list(sig[head])
                fh = first[head]
                for r in absorbed:
                    pairs.extend(sig[r])
                    for a, y in first[r].items():
                        fh.setdefault(a, y)
                    sig[r] = []
                    first[r] = {}
                sig[head] = self._compress(pairs)


#: Relative tolerance of the average-linkage test: sums of the same distances taken in another
#: order (per code on the candidate-pair path, per observation on the dense one) differ in the
#: last bits, and where sites are settled an average equal to the threshold is common.
LINK_RTOL = 1e-9


def within(average: float, threshold: float) -> bool:
    """Whether an average linkage is within ``threshold`` (up to :data:`LINK_RTOL`)."""
    return average <= threshold * (1.0 + LINK_RTOL)


def _refused_taken(cl: _Clusters, roots: list[int]) -> bool:
    """Whether the cluster of ``roots`` (committed roots) would both take and refuse an
    action."""
    refused = [cl.refused[r] for r in roots if cl.refused[r] is not None]
    if not refused:
        return False
    out = cl.first[0]
    return any(k in out[r] for ref in refused for k in ref for r in roots)


def _try_merge(cl: _Clusters, i: int, j: int, threshold: float, max_work: int,
               read: set[int] | None = None, linkage: list[float] | None = None
               ) -> tuple[dict[int, list[int]] | None, str]:
    """Close the merge of the clusters of ``i`` and ``j`` under congruence; return the groups
    to commit (head root -> absorbed roots) or None with the reason of the veto.

    After each forced merge the transitions of the merged group are scanned in member order;
    per direction and action, the first one fixes the target and each later one with another
    target pushes that pair on a stack (last in, first out). A pair pushed twice is a no-op the
    second time it is popped, so only the last push of each pair matters, and the signatures
    (:class:`_Clusters`) yield exactly those.

    ``read``, when given, collects every committed root the closure looked at: the outcome
    depends on nothing else, so it repeats exactly while none of them changes. ``linkage``,
    when given, receives the average linkage that a ``distance`` veto exceeded (``inf`` for
    two roles): the only place where ``threshold`` enters, so the same attempt under a
    larger threshold goes the same way unless that value is within it.

    A closure that would put place observations whose hands hold different colours in one
    cluster is refused (``hand``): the hand holds one object, whatever the images say. So is
    one that would put an observation where an action was refused (:attr:`Problem.refused`)
    with one that took it (``refused``): the two are different states.
    """
    over: dict[int, int] = {}  # committed root -> tentative head
    groups: dict[int, list[int]] = {}  # tentative head -> committed roots in it (head first)
    parent = cl.parent
    find = cl.find
    size = cl.size
    roles = cl.roles
    hand = cl.hand
    read = read if read is not None else set()
    add_root = read.add

    def head(x: int) -> int:
        r = x if parent[x] == x else find(x)
        add_root(r)
        return over.get(r, r)

    queue = [(i, j)]
    push = queue.append
    touched: set[int] = set()
    work = 0
    directions = ((cl.sig[0], cl.first[0], {}, {}), (cl.sig[1], cl.first[1], {}, {}))
    while queue:
        a, b = queue.pop()
        ha, hb = head(a), head(b)
        if ha == hb:
            continue
        work += 1
        if work > max_work:
            return None, "work"
        if roles[ha] != roles[hb]:
            if linkage is not None:
                linkage.append(float("inf"))
            return None, "distance"
        ra = groups.get(ha) or [ha]
        rb = groups.get(hb) or [hb]
        held_a = next((hand[r] for r in ra if hand[r] >= 0), -1)
        held_b = next((hand[r] for r in rb if hand[r] >= 0), -1)
        if held_a >= 0 and held_b >= 0 and held_a != held_b:
            return None, "hand"
        if cl.any_refused and _refused_taken(cl, ra + rb):
            return None, "refused"
        na = sum(size[r] for r in ra)
        nb = sum(size[r] for r in rb)
        average = cl.link_sum(ra, rb) / (na * nb)
        if not within(average, threshold):  # average linkage
            if linkage is not None:
                linkage.append(average)
            return None, "distance"
        groups[ha] = ra + rb
        groups.pop(hb, None)
        for r in rb:
            over[r] = ha
        over.pop(ha, None)
        touched.discard(hb)
        touched.add(ha)
        # congruence: one action from the merged cluster leads to one cluster. The scan of
        # the merged group's signatures (ra's roots, then rb's) pushes, per action, every
        # entry whose target differs from that of the action's first entry. Committed
        # clusters are closed, and targets only ever merge, so in the ra part exactly the
        # entries that mismatched at ra's last scan (``mism``) can still mismatch: only those
        # and the rb part are looked at, in the same order.
        for sig, first, gfirst, mism in directions:
            fa = gfirst.get(ha)
            if fa is None:
                fa = gfirst[ha] = dict(first[ha])
            fb = gfirst.pop(hb, None) or first[hb]
            for act, y in fb.items():
                fa.setdefault(act, y)
            seen: dict[int, int] = {}
            still: list[tuple[int, int]] = []
            keep = still.append
            entries = chain(mism.pop(ha, ()), *(sig[r] for r in rb))
            mism.pop(hb, None)
            for act, y in entries:
                h2 = head(y)
                f = seen.get(act)
                if f is None:
                    f = seen[act] = head(fa[act])
                if f != h2:
                    push((f, h2))
                    keep((act, y))
            # Exactly-One, early: merges never split, so two actions from (or into) the
            # merged group that already meet one group make the closure fail whatever follows;
            # refuse it now (the final check below would refuse it anyway, at most later and
            # perhaps under another reason). Checked: the first target of each action, and
            # the targets that must still merge into it.
            by_head: dict[int, int] = {}
            for act, y in fa.items():
                f = seen.get(act)
                if f is None:
                    f = head(y)
                if by_head.setdefault(f, act) != act:
                    return None, "exactly_one"
            for act, y in still:
                if by_head.get(head(y), act) != act:
                    return None, "exactly_one"
            if still:
                mism[ha] = still
    # Exactly-One around every touched cluster, in both directions
    for h in touched:
        if head(h) != h:
            continue
        for sig in cl.sig:
            labels_to: dict[int, int] = {}
            for r in groups.get(h) or [h]:
                for act, y in sig[r]:
                    if labels_to.setdefault(head(y), act) != act:
                        return None, "exactly_one"
    result: dict[int, list[int]] = {}
    for h, rs in groups.items():
        if head(h) == h:
            result[h] = [r for r in rs if r != h]
    return result, ""


def _candidates(problem: Problem, threshold: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Within-role pairs ``(i, j)`` (observation ids, ``i < j``) at distance <= ``threshold``,
    sorted by distance, then ``i``, then ``j``; returns ``(d, i, j)``."""
    ds, iis, jjs = [], [], []
    for obs, dist in ((problem.pick_obs, problem.dist_pick),
                      (problem.place_obs, problem.dist_place)):
        iu, ju = np.triu_indices(len(obs), k=1)
        d = dist[iu, ju]
        keep = d <= threshold
        ds.append(d[keep])
        iis.append(obs[iu[keep]])
        jjs.append(obs[ju[keep]])
    d = np.concatenate(ds).astype(np.float64)
    i = np.concatenate(iis).astype(np.int64)
    j = np.concatenate(jjs).astype(np.int64)
    order = np.lexsort((j, i, d))
    return d[order], i[order], j[order]


def _merge_sorted(problem: Problem, cand_i: Sequence[int], cand_j: Sequence[int],
                  threshold: float, max_work: int) -> tuple[np.ndarray, MergeStats]:
    """:func:`congruence_merge` on candidate pairs already filtered and sorted."""
    cl = _Clusters(problem)
    find = cl.find
    attempts = accepted = replayed = 0
    vetoes = {"distance": 0, "exactly_one": 0, "work": 0, "hand": 0, "refused": 0}
    # A veto depends only on the clusters its closure read. Two memories, both exact:
    # * ``vetoed`` (as before): until the next commit, any candidate pair between the same two
    #   clusters (either way round) is skipped and not counted;
    # * ``replay``: an attempt (ri, rj) vetoed earlier is vetoed again, for the same reason,
    #   while none of the roots its closure read has been merged since; it is counted as an
    #   attempt but not recomputed. ``depends[r]`` lists the memories that root r invalidates.
    epoch = 0
    vetoed: dict[tuple[int, int], int] = {}
    replay: dict[tuple[int, int], tuple[int, str]] = {}
    depends: dict[int, list[tuple[tuple[int, int], int]]] = {}
    token = 0
    for i, j in zip(cand_i, cand_j):
        ri, rj = find(i), find(j)
        if ri == rj:
            continue
        key = (ri, rj) if ri < rj else (rj, ri)
        if vetoed.get(key) == epoch:
            continue
        attempts += 1
        memo = replay.get((ri, rj))
        if memo is not None:
            vetoed[key] = epoch
            vetoes[memo[1]] += 1
            replayed += 1
            continue
        read: set[int] = set()
        groups, why = _try_merge(cl, i, j, threshold, max_work, read)
        if groups is None:
            vetoed[key] = epoch
            vetoes[why] += 1
            token += 1
            replay[(ri, rj)] = (token, why)
            for r in read:
                depends.setdefault(r, []).append(((ri, rj), token))
            continue
        for h, absorbed in groups.items():
            for r in (h, *absorbed):
                for k, t in depends.pop(r, ()):
                    m = replay.get(k)
                    if m is not None and m[0] == t:
                        del replay[k]
        cl.commit(groups)
        epoch += 1
        accepted += 1
    roots = np.array([find(x) for x in range(problem.n_obs)], dtype=np.int64)
    labels = problem.labels_from_colours(roots[problem.pick_obs], roots[problem.place_obs])
    return labels, MergeStats(attempts, accepted, vetoes["distance"], vetoes["exactly_one"],
                              vetoes["work"], replayed, vetoes["hand"],
                              vetoes["refused"])


def congruence_merge(problem: Problem, threshold: float, max_work: int = 2_000
                     ) -> tuple[np.ndarray, MergeStats]:
    """Labels of the merged clustering and counters.

    Parameters
    ----------
    problem : Problem
    threshold : float
        Largest average-linkage visual distance allowed inside any forced merge.
    max_work : int
        Cap on forced merges examined per attempt (a larger closure is vetoed).

    Returns
    -------
    labels : ndarray of int64, shape (N,)
    stats : MergeStats
    """
    _, ci, cj = _candidates(problem, threshold)
    return with_read_splits(problem, *_merge_sorted(problem, ci.tolist(), cj.tolist(),
                                                    threshold, max_work))


def with_read_splits(problem: Problem, labels: np.ndarray, stats: MergeStats
                     ) -> tuple[np.ndarray, MergeStats]:
    """The merge's partition with the nodes cut that the sites' readings show to hold two
    states (:func:`vggc_cp.solvers.read_splits.split_by_readings`), and its counters with
    ``read_splits`` set: :func:`congruence_merge` and the coded merge (the merge solver and
    the confidence's re-runs) end here, and :func:`cut_path` cuts the path's graphs the same
    way, so the re-runs and the path compare one kind of graph."""
    labels, cuts, moved = _cut(problem, labels)
    return labels, replace(stats, read_splits=cuts, lone_moves=moved)


def _cut(problem: Problem, labels: np.ndarray, rows: np.ndarray | None = None
         ) -> tuple[np.ndarray, int, int]:
    """:func:`~vggc_cp.solvers.read_splits.split_by_readings`, then, where the problem reads
    sites, :func:`~vggc_cp.solvers.episodes.move_lone_episodes` and
    :func:`~vggc_cp.solvers.parts.move_lone_parts` (the moves counted together), nodes
    numbered as the merge numbers them (:meth:`~vggc_cp.solvers.base.Problem.labels_from_colours`), so one
    partition is one array whether cuts, moves or merges made it; with the cuts and the
    moves made."""
    rows = combined_readings(problem) if rows is None else rows
    labels, cuts = split_by_readings(problem, labels, rows)
    moved = 0
    if rows is not None:
        labels, moved = move_lone_episodes(problem, labels)
        labels, parts = move_lone_parts(problem, labels)
        moved += parts
    if cuts or moved:
        labels = problem.labels_from_colours(labels[problem.pick_obs], labels[problem.place_obs])
    return labels, cuts, moved


def _solve_prefix(problem: Problem, threshold: float, d: np.ndarray, ci: list[int],
                  cj: list[int]) -> SolveResult:
    """:meth:`MergeSolver.solve` at ``threshold`` from candidates sorted for a larger one."""
    t0 = time.perf_counter()
    n = int(np.searchsorted(d, threshold, side="right"))
    labels, stats = _merge_sorted(problem, ci[:n], cj[:n], threshold, 2_000)
    res = MergeSolver(threshold)._result(problem, labels, stats)
    return SolveResult(res.labels, res.k_pick, res.k_place, res.J, res.status, res.solver,
                       time.perf_counter() - t0, res.bound, res.stats)


@register_solver
class MergeSolver(Solver):
    """Congruence-closure merging at one threshold.

    Its axis is the threshold, not the cell (:attr:`Solver.axis` ``"path"``): ``solve`` does
    not read ``k_pick``/``k_place``, and the result's ``k_pick``/``k_place`` are the pick and
    place nodes the merge used. :func:`threshold_path` runs it along the axis and a ``"path"``
    rule of :mod:`vggc_cp.solvers.selection` picks one threshold.
    """

    name = "merge"
    axis = PATH

    def __init__(self, threshold: float = 0.08):
        self.threshold = float(threshold)

    def _solve(self, problem: Problem, k_pick: int, k_place: int) -> SolveResult:
        labels, stats = congruence_merge(problem, self.threshold)
        return self._result(problem, labels, stats)

    def _result(self, problem: Problem, labels: np.ndarray, stats: MergeStats) -> SolveResult:
        n_pick = len(np.unique(labels[problem.pick_obs]))
        n_place = len(np.unique(labels[problem.place_obs]))
        return SolveResult(labels, n_pick, n_place, problem.visual_score(labels), FEASIBLE,
                           self.name, stats={"threshold": self.threshold, **stats.__dict__})


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


#: The threshold path's selection rules (the ``"path"`` axis of
#: :data:`vggc_cp.solvers.selection.RULES`).
PATH_SELECTIONS = RULES[PATH]


@dataclass(frozen=True, eq=False)
class ThresholdPath:
    """Merges over a grid of thresholds and the one a rule picked."""

    thresholds: tuple[float, ...]
    results: tuple[SolveResult, ...]
    selected: int | None
    rule: str
    seconds: float
    merged: tuple[np.ndarray, ...] | None = None

    @property
    def best(self) -> SolveResult | None:
        return None if self.selected is None else self.results[self.selected]

    def merged_labels(self, i: int) -> np.ndarray | None:
        """The merge's partition at threshold ``i`` before the read cuts (what the rule
        chose the threshold by, and what the description lengths of the path are of)."""
        return self.results[i].labels if self.merged is None else self.merged[i]

    def records(self) -> list[dict]:
        """One JSON-ready row per threshold (the solution file's ``grid``); where the
        graphs were cut (:func:`cut_path`), ``read_splits``, ``lone_moves`` and the merge's
        own node count ``merged_nodes`` too."""
        rows = [{"threshold": round(t, 6), "k_pick": r.k_pick, "k_place": r.k_place,
                 "nodes": r.n_nodes, "status": r.status, "J": r.J,
                 "seconds": round(r.seconds, 4), "selected": i == self.selected}
                for i, (t, r) in enumerate(zip(self.thresholds, self.results))]
        if self.merged is not None:
            for row, r, m in zip(rows, self.results, self.merged):
                row["read_splits"] = int(r.stats.get("read_splits", 0))
                row["lone_moves"] = int(r.stats.get("lone_moves", 0))
                row["merged_nodes"] = int(len(np.unique(m))) if m is not None else 0
        return rows


def threshold_path(problem: Problem, thresholds: Sequence[float] | None = None,
                   rule: str = "cascade", progress: bool = False) -> ThresholdPath:
    """Run :class:`MergeSolver` at every threshold (ascending) and select one by ``rule``."""
    fn = get_selection(rule, PATH)
    ts = np.sort(np.asarray(default_thresholds(problem) if thresholds is None else thresholds,
                            dtype=np.float64))
    t0 = time.perf_counter()
    iterator = ts
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(ts, desc="merge thresholds", unit="thr")
    # the candidates of a threshold are a prefix of those of the largest one: sort them once
    d, ci, cj = _candidates(problem, float(ts[-1]) if len(ts) else 0.0)
    ci, cj = ci.tolist(), cj.tolist()
    results = tuple(_solve_prefix(problem, float(t), d, ci, cj) for t in iterator)
    return cut_path(problem, ts, results, fn, rule, t0)


def cut_path(problem: Problem, thresholds: np.ndarray, merges: Sequence[SolveResult], fn,
             rule: str, started: float) -> ThresholdPath:
    """The path of the merges ``merges`` (one per threshold): the rule ``fn`` chooses the
    threshold by the merges' graphs, and every graph is then cut where the sites' readings
    show two states (:func:`vggc_cp.solvers.read_splits.split_by_readings`).

    The threshold is a property of the distances, chosen on the graphs they make; the cuts
    are local and may not move it. Chosen on the cut graphs, the description length
    prefers a coarser threshold wherever the cuts repair the merges the stated facts
    object to and leave those nothing states apart (multifruit-4x6 robot s1: 50 nodes for 60
    there, against 58 chosen on the merges and 59 after the cuts)."""
    selected = fn(tuple(merges), problem)
    rows = combined_readings(problem)
    results = []
    for r in merges:
        labels, cuts, moved = ((r.labels, 0, 0) if rows is None or r.labels is None
                               else _cut(problem, r.labels, rows))
        if cuts or moved:
            r = SolveResult(labels, len(np.unique(labels[problem.pick_obs])),
                            len(np.unique(labels[problem.place_obs])),
                            problem.visual_score(labels), r.status, r.solver, r.seconds,
                            r.bound, r.stats)
        results.append(replace(r, stats={**r.stats, "read_splits": cuts, "lone_moves": moved}))
    return ThresholdPath(tuple(float(t) for t in thresholds), tuple(results), selected, rule,
                         time.perf_counter() - started, tuple(r.labels for r in merges))
