"""The threshold path on candidate pairs of descriptor codes: no N x N matrix (issue 27).

:mod:`vggc_cp.solvers.merge` reads two dense ``(n, n)`` distance matrices and runs one
congruence-closure merge per threshold from scratch over all pairs. Its time grows with the
square of the trace and its memory too. This module gives the same partitions from less.

**Codes.** The footprint evidence describes an observation by per-site presence and colour
values, and renders of one situation share their descriptor to the bit: observations of one
role with identical descriptors get one *code*, and ``d(o, o') = table[code(o), code(o')]``
exactly (:class:`~vggc_cp.solvers.coded.CodedProblem`, :mod:`vggc_cp.solvers.coded`, which
also reads the threshold grid from the tables).

**Candidate pairs.** Pairs are met in the dense path's order (distance, then first, then
second observation id) but generated level by level from pairs of codes
(:class:`_PairStream`): all members of code ``g`` against all of ``h``; the scan drops, with
numpy, pairs inside one cluster (merges never split, so they are no-ops).
Cluster distance sums are kept per code (an ``(n, G)`` row block and the code counts of every
cluster), not per observation.

**One pass for all thresholds.** Within a run, a pair between two clusters is tried only at
its first occurrence since the last accepted merge (the dense loop skips the later ones), so a
window of the sorted pairs is scanned with numpy and only those first occurrences reach the
closure. Across thresholds the closure is kept: the run at the next threshold ``t'`` repeats
the run at ``t`` exactly up to the first attempt whose veto was an average linkage in
``(t, t']`` (the only place a threshold enters a closure; :func:`_try_merge` reports it), so
the pass continues from there, or from the end when there is none, replaying the accepted
merges before it.

**Pairs of clusters.** Until a merge is accepted the clusters do not change, and between two
clusters only the first pair is tried; so where a batch's observations already lie in few
clusters, the batch is scanned from one pair per two clusters present in each pair of codes
(:meth:`_PairStream.compressed`: the first pair of clusters ``A`` and ``B`` among codes ``g``
and ``h`` is made of the two codes' smallest members in them), regenerated after each
accepted merge. At the high thresholds, where nearly every attempt is vetoed, that is a few
thousand pairs where the batch holds tens of millions; where clusters are still mostly
singletons (or merges keep being accepted) the batch is scanned pair by pair as before
(:data:`COMPRESS_SHARE`, :data:`COMPRESS_REGENS`).

The partitions are the dense path's (``tests/solvers/test_pairs.py`` on random code tables,
with and without pairs of clusters; ``tests/test_pipeline_pairs.py`` on rendered traces); the
counters in ``stats`` count this pass's attempts.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from vggc_cp.solvers.base import (
    FEASIBLE,
    SolveResult,
)
from vggc_cp.solvers.coded import CodedProblem
from vggc_cp.solvers.merge import (
    MergeStats,
    ThresholdPath,
    _Clusters,
    _try_merge,
    cut_path,
    get_selection,
    with_read_splits,
    within,
)
from vggc_cp.solvers.selection import PATH
from vggc_cp.trace import PICK, PLACE

#: Candidate pairs generated at once (a batch ends at a distance level).
BATCH = 1 << 20
#: Candidate pairs of the batches kept for the next thresholds.
CACHED = 4 << 20
#: A batch is scanned from its pairs of clusters (:meth:`_PairStream.compressed`) while that
#: list is under this share of the batch's pairs of observations ...
COMPRESS_SHARE = 0.25
#: ... and until this many merges were accepted in it (each one regenerates the list).
COMPRESS_REGENS = 8


class _CodedClusters(_Clusters):
    """:class:`~vggc_cp.solvers.merge._Clusters` whose distance sums are kept per code: for
    every root, the sum of its members' table rows (shape (G,)) and its members' code counts;
    the root of every observation is kept in a numpy array for the vectorized scan."""

    def _distance_sums(self, problem: CodedProblem):
        self.root_of = np.arange(problem.n_obs, dtype=np.int64)
        self.code_of = np.empty(problem.n_obs, dtype=np.int64)
        self.code_of[problem.pick_obs] = problem.codes_pick
        self.code_of[problem.place_obs] = problem.codes_place
        self.counts: list[dict[int, int]] = [{int(c): 1} for c in self.code_of.tolist()]
        return (problem.table_pick[problem.codes_pick],
                problem.table_place[problem.codes_place])

    def _absorb_sums(self, head: int, r: int) -> None:
        s = self.sums[self.roles[head]]
        s[self.local[head]] += s[self.local[r]]
        counts = self.counts[head]
        for c, k in self.counts[r].items():
            counts[c] = counts.get(c, 0) + k
        self.counts[r] = {}

    def link_sum(self, roots_a: list[int], roots_b: list[int]) -> float:
        p = self.p
        role = self.roles[roots_a[0]]
        if len(roots_a) == 1 and len(roots_b) == 1 and self.size[roots_a[0]] == 1 \
                and self.size[roots_b[0]] == 1:
            return float(p.table(role)[self.code_of[roots_a[0]], self.code_of[roots_b[0]]])
        s = self.sums[role]
        row = s[self.local[roots_a[0]]] if len(roots_a) == 1 else \
            s[[self.local[r] for r in roots_a]].sum(axis=0)
        total = 0.0
        for r in roots_b:
            for c, k in self.counts[r].items():
                total += k * row[c]
        return float(total)

    def commit(self, groups: dict[int, list[int]]) -> None:
        for head, absorbed in groups.items():
            for r in absorbed:
                self.root_of[self.members[r]] = head
        super().commit(groups)


def _after(rows: np.ndarray, others: np.ndarray, start: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(rows[k], others[m])`` for every ``m >= start[k]`` (``others`` sorted)."""
    counts = len(others) - start
    total = int(counts.sum())
    if total == 0:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty
    offsets = np.cumsum(counts) - counts
    idx = np.arange(total) - np.repeat(offsets, counts) + np.repeat(start, counts)
    return np.repeat(rows, counts), others[idx]


class _PairStream:
    """The within-role pairs at distance <= ``top``, in the dense path's order (distance,
    then ids), generated batch by batch from pairs of codes (pairs inside one cluster are
    dropped by the scan, :meth:`_Pass._scan`). A batch is a run of whole distance levels, or
    one level's pairs whose first id lies in a range (a level larger than a batch is split)."""

    def __init__(self, problem: CodedProblem, top: float, batch: int | None = None):
        batch = int(batch or BATCH)
        self.n = problem.n_obs
        self.role_of = problem.roles
        self.code_of = np.empty(self.n, dtype=np.int64)
        self.code_of[problem.pick_obs] = problem.codes_pick
        self.code_of[problem.place_obs] = problem.codes_place
        self.members: dict[int, list[np.ndarray]] = {}
        vals, roles, gs, hs, ns = [], [], [], [], []
        for role in (PICK, PLACE):
            obs = problem.pick_obs if role == PICK else problem.place_obs
            codes, table = problem.codes(role), problem.table(role)
            order = np.argsort(codes, kind="stable")
            size = np.bincount(codes, minlength=len(table))
            self.members[role] = np.split(obs[order], np.cumsum(size)[:-1])
            gi, hi = np.triu_indices(len(table))
            n = np.where(gi == hi, size[gi] * (size[gi] - 1) // 2, size[gi] * size[hi])
            v = table[gi, hi]
            keep = (n > 0) & (v <= top)
            vals.append(v[keep])
            roles.append(np.full(int(keep.sum()), role))
            gs.append(gi[keep])
            hs.append(hi[keep])
            ns.append(n[keep])
        v = np.concatenate(vals)
        order = np.argsort(v, kind="stable")
        self.v = v[order]
        self.role = np.concatenate(roles)[order]
        self.g = np.concatenate(gs)[order]
        self.h = np.concatenate(hs)[order]
        npairs = np.concatenate(ns)[order].astype(np.float64)
        self._npairs = npairs
        cum = np.cumsum(npairs)
        # batches (code pairs [a, b), first ids [i0, i1)): whole levels up to about ``batch``
        # pairs, or a level of more split into ranges of first ids of about ``batch`` pairs
        # each (pairs thin out as the first id grows: the ranges follow sqrt)
        self.bounds: list[tuple[int, int, int, int]] = []
        a = 0
        while a < len(self.v):
            level_end = int(np.searchsorted(self.v, self.v[a], side="right"))
            base = cum[a - 1] if a else 0.0
            level_pairs = cum[level_end - 1] - base
            if level_pairs > batch:
                k = int(np.ceil(level_pairs / batch))
                cuts = [int(round(self.n * (1 - np.sqrt(1 - q / k)))) for q in range(k + 1)]
                cuts[-1] = self.n
                for i0, i1 in zip(cuts, cuts[1:]):
                    if i1 > i0:
                        self.bounds.append((a, level_end, i0, i1))
                a = level_end
                continue
            b = int(np.searchsorted(cum, base + batch, side="left")) + 1
            b = min(max(b, level_end), len(self.v))
            b = int(np.searchsorted(self.v, self.v[b - 1], side="right"))
            if cum[b - 1] - base > batch and b > level_end:  # stop before a big level
                b = int(np.searchsorted(self.v, self.v[b - 1], side="left"))
            self.bounds.append((a, b, 0, self.n))
            a = b
        self.starts = [(float(self.v[a]), i0) for a, _, i0, _ in self.bounds]
        self._cache: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def batch_of(self, d: float, i: int) -> int:
        """Index of the batch holding the pair key ``(d, i, .)`` (or the next one)."""
        import bisect

        return max(bisect.bisect_right(self.starts, (d, i)) - 1, 0)

    def first_level(self, k: int) -> float:
        return self.starts[k][0]

    def pairs(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Batch ``k`` as ``(d, i, j)`` sorted like the dense candidates (the last few
        batches are kept)."""
        hit = self._cache.pop(k, None)
        if hit is None:
            hit = self._generate(k)
        self._cache[k] = hit
        while len(self._cache) > 1 and sum(len(b[0]) for b in self._cache.values()) > CACHED:
            self._cache.pop(next(iter(self._cache)))
        return hit

    def batch_pairs(self, k: int) -> float:
        """Pairs of observations in batch ``k`` (an upper bound where a level is split)."""
        a, b, _, _ = self.bounds[k]
        return float(self._npairs[a:b].sum())

    def compressed(self, k: int, after: tuple[float, int, int], roots: np.ndarray,
                   limit: float) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The pairs of batch ``k`` at or after the key ``after`` that the scan can try before
        the next accepted merge, sorted like the dense candidates; None when they would be
        more than ``limit``.

        Until a merge is accepted the clusters stay as they are (``roots``), and of all
        pairs between two clusters only the first is tried (the others meet a veto of the same
        epoch, or one cluster). Among the pairs of codes ``g`` and ``h`` whose both ids are at
        least ``L`` (which is what "first id at least ``L``" means for pairs ``i < j``), the
        first between clusters ``A`` and ``B`` is ``(min(a, b), max(a, b))`` with ``a`` the
        smallest member of ``g`` in ``A`` and ``b`` that of ``h`` in ``B``, so one pair per
        pair of clusters present in the two codes suffices; the rest of the row of ``after``'s
        first id is added pair by pair the same way. Pairs inside one cluster are left out."""
        a, b, i0, i1 = self.bounds[k]
        d0, ia, ja = after
        mins: dict[tuple[int, int, int], tuple[np.ndarray, np.ndarray]] = {}

        def cluster_mins(role: int, g: int, low: int) -> tuple[np.ndarray, np.ndarray]:
            key = (role, g, low)
            hit = mins.get(key)
            if hit is None:
                mg = self.members[role][g]
                mg = mg[np.searchsorted(mg, low):]
                r = roots[mg]
                u, first = np.unique(r, return_index=True)
                hit = mins[key] = (u, mg[first])
            return hit

        ds, iis, jjs = [], [], []
        one_d, one_i, one_j = [], [], []  # pairs of codes of one cluster each (most of them)
        total = 0
        row_code = (int(self.role_of[ia]), int(self.code_of[ia])) if 0 <= ia < self.n \
            else (-1, -1)
        lo = int(np.searchsorted(self.v[a:b], d0, side="left")) + a
        for v, role, g, h in zip(self.v[lo:b].tolist(), self.role[lo:b].tolist(),
                                 self.g[lo:b].tolist(), self.h[lo:b].tolist()):
            at_row = v == d0 and i0 <= ia < i1 and row_code[0] == role \
                and row_code[1] in (g, h)
            low = max(i0, ia + 1) if v == d0 else i0
            ug, mg = cluster_mins(role, g, low)
            uh, mh = (ug, mg) if g == h else cluster_mins(role, h, low)
            if len(ug) == 1 and len(uh) == 1 and g != h and not at_row:
                if ug[0] != uh[0]:
                    x, y = int(mg[0]), int(mh[0])
                    if min(x, y) < i1:
                        one_d.append(v)
                        one_i.append(min(x, y))
                        one_j.append(max(x, y))
                        total += 1
                continue
            if total + (len(ug) * (len(ug) - 1) // 2 if g == h else len(ug) * len(uh)) \
                    > limit:
                return None
            if g == h:
                order = np.argsort(mg)
                m = mg[order]
                p, q = np.triu_indices(len(m), 1)
                i, j = m[p], m[q]
            else:
                live = ug[:, None] != uh[None, :]
                x = np.broadcast_to(mg[:, None], live.shape)[live]
                y = np.broadcast_to(mh[None, :], live.shape)[live]
                i, j = np.minimum(x, y), np.maximum(x, y)
            keep = i < i1
            i, j = i[keep], j[keep]
            if at_row:  # the rest of the row of ``after``'s first id
                i, j = self._row_rest(role, g, h, ia, ja, roots, i, j)
            total += len(i)
            if total > limit:
                return None
            if len(i):
                ds.append(np.full(len(i), v))
                iis.append(i)
                jjs.append(j)
        if one_d:
            ds.append(np.asarray(one_d, dtype=np.float64))
            iis.append(np.asarray(one_i, dtype=np.int64))
            jjs.append(np.asarray(one_j, dtype=np.int64))
        return _sorted_pairs(ds, iis, jjs)

    def _row_rest(self, role: int, g: int, h: int, row: int, low: int, roots: np.ndarray,
                  i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(i, j)`` and the first pair ``(row, y)``, ``y >= low``, ``y > row``, per cluster
        of ``y`` other than ``row``'s, with ``y`` in the code that ``row`` is paired with."""
        mg, mh = self.members[role][g], self.members[role][h]
        k = int(np.searchsorted(mg, row))
        if k < len(mg) and mg[k] == row:
            others = mh
        else:
            k = int(np.searchsorted(mh, row))
            if not (k < len(mh) and mh[k] == row):
                return i, j
            others = mg
        ys = others[np.searchsorted(others, max(low, row + 1)):]
        r = roots[ys]
        u, first = np.unique(r, return_index=True)
        ys = ys[first[u != roots[row]]]
        return np.concatenate([np.full(len(ys), row), i]), np.concatenate([ys, j])

    def _generate(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a, b, i0, i1 = self.bounds[k]
        ds, iis, jjs = [], [], []
        for v, role, g, h in zip(self.v[a:b].tolist(), self.role[a:b].tolist(),
                                 self.g[a:b].tolist(), self.h[a:b].tolist()):
            mg = self.members[role][g]
            lo, hi = np.searchsorted(mg, (i0, i1))
            if g == h:  # (mg[r], mg[m]) for m > r, first ids in range
                rows = np.arange(lo, hi)
                parts = [(mg[rows], mg, rows + 1)]
            else:  # the smaller id first, from either code
                mh = self.members[role][h]
                lo2, hi2 = np.searchsorted(mh, (i0, i1))
                parts = [(mg[lo:hi], mh, np.searchsorted(mh, mg[lo:hi], side="right")),
                         (mh[lo2:hi2], mg, np.searchsorted(mg, mh[lo2:hi2], side="right"))]
            for rows, others, start in parts:
                i, j = _after(rows, others, start)
                if len(i):
                    ds.append(np.full(len(i), v))
                    iis.append(i)
                    jjs.append(j)
        return _sorted_pairs(ds, iis, jjs)


def _sorted_pairs(ds: list, iis: list, jjs: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pieces ``(d, i, j)`` of a batch joined and sorted by distance, then ``i``, then
    ``j`` (empty arrays when there is none)."""
    if not ds:
        empty = np.zeros(0, dtype=np.int64)
        return np.zeros(0), empty, empty
    d, i, j = np.concatenate(ds), np.concatenate(iis), np.concatenate(jjs)
    order = np.lexsort((j, i, d))
    return d[order], i[order], j[order]


class _Pass:
    """Congruence-closure merging along ascending thresholds (module docstring)."""

    def __init__(self, problem: CodedProblem, top: float, max_work: int = 2_000,
                 compress: bool = True):
        self.problem = problem
        self.stream = _PairStream(problem, top)
        self.compress = compress
        self.max_work = max_work
        self.commits: list[tuple[tuple[float, int, int], dict[int, list[int]]]] = []
        self.linkage_vetoes: list[tuple[tuple[float, int, int], float]] = []
        self.outcomes: list[tuple[tuple[float, int, int], str]] = []
        self._reset()
        self.at = (-np.inf, -1, -1)  # next pair to scan: the first >= this key

    def _reset(self) -> None:
        self.cl = _CodedClusters(self.problem)
        self.epoch = 0
        self.vetoed: dict[tuple[int, int], int] = {}
        self.replay: dict[tuple[int, int], tuple[int, str]] = {}
        self.depends: dict[int, list[tuple[tuple[int, int], int]]] = {}
        self.token = 0

    def _rewind(self, key: tuple[float, int, int]) -> None:
        """The state just before the pair ``key`` was scanned: accepted merges before it
        replayed on fresh clusters (the veto memories start empty: they only save work)."""
        self.commits = [c for c in self.commits if c[0] < key]
        self.linkage_vetoes = [v for v in self.linkage_vetoes if v[0] < key]
        self.outcomes = [o for o in self.outcomes if o[0] < key]
        self._reset()
        for _, groups in self.commits:
            self.cl.commit(groups)
            self.epoch += 1
        self.at = key

    def advance(self, threshold: float) -> tuple[np.ndarray, MergeStats]:
        """Labels and counters of the merge at ``threshold`` (not below the previous one)."""
        late = [k for k, link in self.linkage_vetoes if within(link, threshold)]
        if late:
            self._rewind(min(late))
        k = self.stream.batch_of(self.at[0], self.at[1])
        regens = 0
        while k < len(self.stream.bounds):
            if self.stream.first_level(k) > threshold:
                break
            short = None
            if self.compress and regens < COMPRESS_REGENS:
                short = self.stream.compressed(k, self.at, self.cl.root_of,
                                               COMPRESS_SHARE * self.stream.batch_pairs(k))
            if short is not None:  # pairs of clusters, until a merge is accepted
                d, i, j = short
                start = 0
            else:
                d, i, j = self.stream.pairs(k)
                lo = int(np.searchsorted(d, self.at[0], side="left"))
                hi = int(np.searchsorted(d, self.at[0], side="right"))
                codes = i[lo:hi] * self.stream.n + j[lo:hi]
                start = lo + int(np.searchsorted(codes, self.at[1] * self.stream.n
                                                 + self.at[2]))
            stop = int(np.searchsorted(d, threshold, side="right"))
            accepted = self._scan(d, i, j, start, stop, threshold,
                                  until_accepted=short is not None)
            if accepted is not None:  # regenerate the pairs of clusters after it
                self.at = (float(d[accepted]), int(i[accepted]), int(j[accepted]) + 1)
                regens += 1
                continue
            if stop < len(d):
                self.at = (float(d[stop]), int(i[stop]), int(j[stop]))
                break
            k += 1
            regens = 0
            self.at = ((*self.stream.starts[k], -1) if k < len(self.stream.bounds)
                       else (np.inf, -1, -1))
        cl = self.cl
        roots = cl.root_of
        p = self.problem
        labels = p.labels_from_colours(roots[p.pick_obs], roots[p.place_obs])
        kinds = [o[1] for o in self.outcomes]
        stats = MergeStats(len(kinds), kinds.count("accepted"), kinds.count("distance"),
                           kinds.count("exactly_one"), kinds.count("work"),
                           kinds.count("replayed"), kinds.count("hand"),
                           kinds.count("refused"))
        return labels, stats

    def _scan(self, d: np.ndarray, i: np.ndarray, j: np.ndarray, start: int, stop: int,
              threshold: float, until_accepted: bool = False) -> int | None:
        """Merge the pairs ``start:stop`` of a batch: per window, only the first pair between
        two clusters since the last accepted merge is tried (the others would be skipped).
        With ``until_accepted``, stop at the first accepted merge and return its index."""
        cl = self.cl
        n = self.stream.n
        window = 1024
        o = start
        while o < stop:
            end = min(o + window, stop)
            ri, rj = cl.root_of[i[o:end]], cl.root_of[j[o:end]]
            live = np.flatnonzero(ri != rj)
            accepted = None
            if len(live):
                a, b = ri[live], rj[live]
                key = np.minimum(a, b) * n + np.maximum(a, b)
                _, first = np.unique(key, return_index=True)
                first.sort()
                for f in first.tolist():
                    at = o + int(live[f])
                    if self._attempt(int(a[f]), int(b[f]), (float(d[at]), int(i[at]),
                                                            int(j[at])), threshold):
                        accepted = at
                        break
            if accepted is None:
                o = end
                window = min(window * 2, 1 << 18)
            elif until_accepted:
                return accepted
            else:
                o = accepted + 1
                window = 1024
        return None

    def _attempt(self, ri: int, rj: int, pair: tuple[float, int, int], threshold: float
                 ) -> bool:
        """One candidate pair between the clusters ``ri`` and ``rj`` (the dense loop of
        :func:`vggc_cp.solvers.merge._merge_sorted`); True when the merge was accepted."""
        key = (ri, rj) if ri < rj else (rj, ri)
        if self.vetoed.get(key) == self.epoch:
            return False
        memo = self.replay.get((ri, rj))
        if memo is not None:
            self.vetoed[key] = self.epoch
            self.outcomes.append((pair, "replayed"))
            return False
        read: set[int] = set()
        linkage: list[float] = []
        groups, why = _try_merge(self.cl, pair[1], pair[2], threshold, self.max_work, read,
                                 linkage)
        if groups is None:
            self.vetoed[key] = self.epoch
            self.outcomes.append((pair, why))
            if linkage and np.isfinite(linkage[0]):
                self.linkage_vetoes.append((pair, linkage[0]))
            self.token += 1
            self.replay[(ri, rj)] = (self.token, why)
            for r in read:
                self.depends.setdefault(r, []).append(((ri, rj), self.token))
            return False
        for h, absorbed in groups.items():
            for r in (h, *absorbed):
                for k, t in self.depends.pop(r, ()):
                    m = self.replay.get(k)
                    if m is not None and m[0] == t:
                        del self.replay[k]
        self.cl.commit(groups)
        self.commits.append((pair, groups))
        self.outcomes.append((pair, "accepted"))
        self.epoch += 1
        return True


def _result(problem: CodedProblem, threshold: float, labels: np.ndarray, stats: MergeStats,
            seconds: float) -> SolveResult:
    n_pick = len(np.unique(labels[problem.pick_obs]))
    n_place = len(np.unique(labels[problem.place_obs]))
    return SolveResult(labels, n_pick, n_place, problem.visual_score(labels), FEASIBLE, "merge",
                       seconds, stats={"threshold": threshold, **stats.__dict__})


def coded_merge(problem: CodedProblem, threshold: float, max_work: int = 2_000
                ) -> tuple[np.ndarray, MergeStats]:
    """:func:`vggc_cp.solvers.merge.congruence_merge` on a :class:`CodedProblem`."""
    return with_read_splits(problem,
                            *_Pass(problem, float(threshold), max_work).advance(float(threshold)))


def coded_threshold_path(problem: CodedProblem, thresholds: Sequence[float],
                         rule: str = "mdl", progress: bool = False) -> ThresholdPath:
    """:func:`vggc_cp.solvers.merge.threshold_path` on a :class:`CodedProblem`: one pass
    (module docstring), the same partitions."""
    fn = get_selection(rule, PATH)
    ts = np.sort(np.asarray(thresholds, dtype=np.float64))
    t0 = time.perf_counter()
    iterator = ts
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(ts, desc="merge thresholds", unit="thr")
    run = _Pass(problem, float(ts[-1]) if len(ts) else 0.0)
    results = []
    for t in iterator:
        t1 = time.perf_counter()
        labels, stats = run.advance(float(t))
        results.append(_result(problem, float(t), labels, stats, time.perf_counter() - t1))
    return cut_path(problem, ts, results, fn, rule, t0)
