"""``vggc-cp bench distance``: our batched Sinkhorn divergence against POT, on the same pairs.

Three implementations compute ``S_eps(p, q)`` for the same list of histogram pairs (and the
self terms of the histograms they touch), with the same cost matrix, ``eps`` and tolerance:

* ours: :func:`vggc_cp.vision.sinkhorn.sinkhorn_costs` (batched, stabilised scaling);
* naive: a Python loop of ``ot.sinkhorn2(a, b, M, eps)`` per problem;
* POT batched: ``ot.batch.solve_batch(M[None].repeat(B), eps, a, b, method="sinkhorn")``
  in chunks (POT >= 0.9.6; ``value_linear`` is ``<P, M>``, the same quantity).

POT's solvers stop when the L2 norm of one marginal's error is below ``tol``; ours stops on
the L1 error of a marginal, which is never smaller, so the comparison favours POT. The naive
loop and POT's batched solver are slow, so they run on the first ``naive_pairs`` /
``batch_pairs`` pairs (with the self terms of the maps those pairs touch). Rates are pairs
per second *at the same number of OT problems per pair as ours*: a method's seconds per OT
problem times ``(pairs + self terms) / pairs`` of our run (otherwise the small subsets, whose
pairs share few maps, would charge the baselines far more self terms per pair). The largest
relative difference of ``S_eps`` is taken over the pairs that both sides computed.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vggc_cp.vision.sinkhorn import cost_matrix, sinkhorn_costs


def synthetic_maps(n: int, grid: int, rng: np.random.Generator, floor: float = 0.01
                   ) -> np.ndarray:
    """Attention-like maps: 2-5 Gaussian blobs of 0.5-1.5 patches plus a floor, ``(n, g*g)``."""
    yy, xx = np.mgrid[:grid, :grid] + 0.5
    out = np.empty((n, grid * grid))
    for i in range(n):
        h = np.zeros((grid, grid))
        for _ in range(int(rng.integers(2, 6))):
            cy, cx = rng.uniform(0, grid, 2)
            s = rng.uniform(0.5, 1.5)
            h += np.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / (2 * s * s))
        h = (1 - floor) * h / h.sum() + floor / h.size
        out[i] = (h / h.sum()).ravel()
    return out


@dataclass(frozen=True)
class BenchResult:
    """Figures of one run (pairs per second of each method, ratios, agreement)."""

    pairs: int
    ours_pairs_per_s: float
    naive_pairs: int
    naive_pairs_per_s: float
    batch_pairs: int
    batch_pairs_per_s: float
    max_rel_diff_naive: float
    max_rel_diff_batch: float
    ours_stats: str

    @property
    def ratio_naive(self) -> float:
        return self.ours_pairs_per_s / self.naive_pairs_per_s

    @property
    def ratio_batch(self) -> float:
        return self.ours_pairs_per_s / self.batch_pairs_per_s


def _problems(pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cross problems of ``pairs`` (P, 2) and the self problems of the histograms they use."""
    used = np.unique(pairs)
    return pairs, used, np.searchsorted(used, pairs)


def _divergences(cross: np.ndarray, selfc: np.ndarray, pos: np.ndarray) -> np.ndarray:
    return cross - 0.5 * selfc[pos[:, 0]] - 0.5 * selfc[pos[:, 1]]


def run_bench(maps: np.ndarray, pairs: np.ndarray, eps: float, *, tol: float = 1e-6,
              naive_pairs: int = 60, batch_pairs: int = 16, batch_size: int = 16,
              threads: int | None = 2, device: str = "torch", max_iter: int = 20000,
              log: Callable[[str], None] = print) -> BenchResult:
    """Time the three implementations on ``pairs`` ``(P, 2)`` of rows of ``maps`` ``(m, n)``."""
    import ot
    import ot.batch

    grid = int(round(np.sqrt(maps.shape[1])))
    M = cost_matrix(grid)
    pairs = np.asarray(pairs, dtype=np.int64)

    # ours: cross pairs + self terms, all in one call
    _, used, pos = _problems(pairs)
    src = np.concatenate([used, pairs[:, 0]])
    dst = np.concatenate([used, pairs[:, 1]])
    t0 = time.perf_counter()
    costs, stats = sinkhorn_costs(maps, src, dst, M, eps, tol=tol, max_iter=max_iter,
                                  threads=threads, device=device)
    t_ours = time.perf_counter() - t0
    ours = _divergences(costs[len(used):], costs[:len(used)], pos)
    log(f"ours         {len(pairs)} pairs in {t_ours:.2f} s ({stats.describe()})")

    # naive: a loop of ot.sinkhorn2
    sub = pairs[:naive_pairs]
    _, used_n, pos_n = _problems(sub)
    t0 = time.perf_counter()
    self_n = np.array([float(ot.sinkhorn2(maps[i], maps[i], M, eps, stopThr=tol,
                                          numItermax=max_iter)) for i in used_n])
    cross_n = np.array([float(ot.sinkhorn2(maps[i], maps[j], M, eps, stopThr=tol,
                                           numItermax=max_iter)) for i, j in sub])
    t_naive = time.perf_counter() - t0
    naive = _divergences(cross_n, self_n, pos_n)
    log(f"naive        {len(sub)} pairs in {t_naive:.2f} s (ot.sinkhorn2 per problem)")

    # POT's batched solver
    subb = pairs[:batch_pairs]
    _, used_b, pos_b = _problems(subb)
    a_idx = np.concatenate([used_b, subb[:, 0]])
    b_idx = np.concatenate([used_b, subb[:, 1]])
    vals = np.empty(len(a_idx))
    t0 = time.perf_counter()
    for s in range(0, len(a_idx), batch_size):
        ia, ib = a_idx[s:s + batch_size], b_idx[s:s + batch_size]
        Mb = np.broadcast_to(M, (len(ia),) + M.shape).copy()
        res = ot.batch.solve_batch(Mb, eps, maps[ia], maps[ib], max_iter=max_iter, tol=tol,
                                   method="sinkhorn")
        vals[s:s + len(ia)] = np.asarray(res.value_linear)
    t_batch = time.perf_counter() - t0
    batch = _divergences(vals[len(used_b):], vals[:len(used_b)], pos_b)
    log(f"POT batched  {len(subb)} pairs in {t_batch:.2f} s (ot.batch.solve_batch, "
        f"chunks of {batch_size})")

    def rel(x, ref):
        return float(np.max(np.abs(x - ref) / np.maximum(np.abs(ref), 1e-300)))

    per_pair = (len(pairs) + len(used)) / len(pairs)  # OT problems per pair in our run

    def rate(seconds: float, problems: int) -> float:
        return 1.0 / (seconds / problems * per_pair)

    return BenchResult(
        pairs=len(pairs), ours_pairs_per_s=len(pairs) / t_ours,
        naive_pairs=len(sub), naive_pairs_per_s=rate(t_naive, len(sub) + len(used_n)),
        batch_pairs=len(subb), batch_pairs_per_s=rate(t_batch, len(a_idx)),
        max_rel_diff_naive=rel(ours[:len(sub)], naive),
        max_rel_diff_batch=rel(ours[:len(subb)], batch),
        ours_stats=stats.describe())


def random_pairs(m: int, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` distinct unordered pairs ``i < j`` of ``range(m)``, shape (count, 2)."""
    total = m * (m - 1) // 2
    count = min(count, total)
    iu, ju = np.triu_indices(m, k=1)
    pick = rng.choice(total, size=count, replace=False)
    return np.stack([iu[pick], ju[pick]], axis=1)
