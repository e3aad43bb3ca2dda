"""Batched, exact debiased Sinkhorn divergences between histograms on a patch grid.

The paper's visual distance (Sec. III of Ajith & Chamzas 2025) is the debiased Sinkhorn
divergence between two attention maps ``p, q`` (histograms on the same ``g x g`` patch grid):

.. math::

    S_\\varepsilon(p, q) = \\mathrm{OT}_\\varepsilon(p, q)
        - \\tfrac12 \\mathrm{OT}_\\varepsilon(p, p) - \\tfrac12 \\mathrm{OT}_\\varepsilon(q, q)

(Feydy et al. 2019). Here ``OT_eps(p, q) = <P*, M>`` is the **linear transport cost of the
entropic plan** ``P* = argmin_{P in U(p, q)} <P, M> - eps H(P)``, ``H(P) = -sum P (log P - 1)``
(Cuturi 2013) -- exactly the number ``ot.sinkhorn2(p, q, M, eps)`` returns (POT returns
``sum(M * G)`` of the plan ``G``, not the entropic objective), so our values agree with POT.

Ground cost
    ``M[k, l] = ||c_k - c_l||_2``, the Euclidean distance between patch centres. Patch
    ``(r, c)`` of a ``g x g`` grid (row-major index ``k = r g + c``) has its centre at
    ``((r + 1/2)/g, (c + 1/2)/g)``: the image is the unit square ``[0, 1]^2`` whatever the grid,
    so ``eps`` keeps its meaning across grid sizes (the largest cost is
    ``sqrt(2) (g - 1)/g < sqrt(2)``).

Algorithm
    Many problems share one cost matrix, so the Gibbs kernel ``K = exp(-M/eps)`` is formed
    once and every Sinkhorn half-step of a block of ``B`` problems is one matrix-matrix product
    ``K @ V`` (``n x n`` by ``n x B``, ``n = g^2``; ``K`` is symmetric because ``M`` is).

    * *Stabilised scaling.* Scalings ``u, v`` are renormalised per column after every step
      (``v <- v / max v``, ``u <- u max v``, which leaves the plan ``diag(u) K diag(v)``
      unchanged), so ``v <= 1`` and ``u <= exp(max M / eps)``: nothing overflows, and an entry
      that underflows carries less than ``1e-300`` of a column that holds at least
      ``exp(-max M / eps)``. This is the log-domain iteration ``log(K @ exp(g - max g)) + max g``
      without any ``exp``/``log`` per step. It is used while ``max M / eps`` stays below a
      per-dtype limit (:data:`SCALING_LIMITS`); for smaller ``eps`` the solver switches to
      true log-domain updates with ``logsumexp`` (slower, exact at any ``eps``).
    * *Over-relaxation* (Thibault et al. 2021; Lehmann et al. 2022):
      ``u <- u^(1-w) (a / K v)^w`` with ``w = 1.5`` by default. Same fixed point, several times
      fewer iterations; a problem that fails to converge is re-solved with ``w = 1``.
    * *Per-problem stopping.* The L1 error of both marginals of the current plan,
      ``|u * (K v) - a|_1 + ...``, is checked every iteration at the cost of an
      elementwise product (``K u`` is needed by the next step anyway). Converged columns
      leave the block and fresh problems take their slots (a stream), so the product stays
      wide and no problem iterates longer than it needs.
    * ``float32`` products (default) where the dynamic range allows; the final cost
      ``sum_i u_i ((K o M) v)_i`` is always evaluated in ``float64``.
    * Self terms ``OT_eps(p, p)`` are computed once per histogram; only the ``i < j`` pairs
      are solved; the output matrix is symmetric with a zero diagonal.

References
----------
M. Cuturi. *Sinkhorn Distances: Lightspeed Computation of Optimal Transport.* NeurIPS 2013.
J. Feydy, T. Sejourne, F.-X. Vialard, S. Amari, A. Trouve, G. Peyre. *Interpolating between
Optimal Transport and MMD using Sinkhorn Divergences.* AISTATS 2019.
A. Thibault, L. Chizat, C. Dossal, N. Papadakis. *Overrelaxed Sinkhorn-Knopp Algorithm for
Regularized Optimal Transport.* Algorithms 14(5), 2021.
B. Schmitzer. *Stabilized Sparse Scaling Algorithms for Entropy Regularized Transport
Problems.* SIAM J. Sci. Comput. 41(3), 2019.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial

import numpy as np

from vggc_cp.parallel import Executor
from vggc_cp.vision.backends import DEVICES, array_ops

#: Largest ``max(M) / eps`` for which the stabilised scaling iteration is used, per dtype.
#: ``float32``: ``exp(1.5 * 50)`` stays far from the float32 maximum (3.4e38) and the smallest
#: kernel entry far from its smallest normal; ``float64`` likewise with ``exp(1.5 * 450)``.
SCALING_LIMITS = {"float32": 50.0, "float64": 450.0}



def patch_centres(grid: int) -> np.ndarray:
    """Centres of a ``grid x grid`` patch grid in the unit square, row-major.

    Returns
    -------
    ndarray, float64, shape (grid**2, 2)
        ``[(r + 0.5)/grid, (c + 0.5)/grid]`` for patch ``k = r * grid + c``.
    """
    if grid < 1:
        raise ValueError(f"grid must be positive, got {grid}")
    x = (np.arange(grid, dtype=np.float64) + 0.5) / grid
    rr, cc = np.meshgrid(x, x, indexing="ij")
    return np.stack([rr.ravel(), cc.ravel()], axis=1)


def cost_matrix(grid: int) -> np.ndarray:
    """Euclidean ground cost between patch centres, float64 ``(grid**2, grid**2)``, symmetric."""
    c = patch_centres(grid)
    return np.sqrt(((c[:, None, :] - c[None, :, :]) ** 2).sum(-1))


@dataclass(frozen=True)
class SinkhornStats:
    """What one batched solve did.

    Attributes
    ----------
    problems : int
        Number of OT problems solved (pairs plus self terms).
    iterations_mean, iterations_max : float, int
        Sinkhorn iterations per problem (a relaxed ``u`` and ``v`` update is one iteration).
    unconverged : int
        Problems still above ``tol`` after ``max_iter`` iterations even without relaxation.
    max_marginal_error : float
        Largest final L1 marginal error over all problems.
    mode : str
        ``scaling-float32``, ``scaling-float64`` or ``log-float64``.
    device : str
    seconds : float
    """

    problems: int
    iterations_mean: float
    iterations_max: int
    unconverged: int
    max_marginal_error: float
    mode: str
    device: str
    seconds: float

    def describe(self) -> str:
        return (f"{self.problems} OT problems, {self.iterations_mean:.1f} iterations on average "
                f"(max {self.iterations_max}), max marginal error {self.max_marginal_error:.2e}, "
                f"{self.unconverged} unconverged, {self.mode} on {self.device}, "
                f"{self.seconds:.2f} s")


# ----------------------------------------------------------------------------- the solver


@dataclass
class _Block:
    """Solver state of the problems currently in flight (columns)."""

    ids: np.ndarray  # (B,) problem index of every column
    iters: np.ndarray  # (B,) iterations done
    a: object
    b: object
    u: object
    v: object
    ku: object  # K @ u for the current u
    best: np.ndarray  # (B,) smallest error seen (halving steps)
    best_at: np.ndarray  # (B,) iteration of the last halving


def _take(block: _Block, keep: np.ndarray, ops) -> _Block:
    m = ops.mask(keep)
    return _Block(block.ids[keep], block.iters[keep], block.a[:, m], block.b[:, m],
                  block.u[:, m], block.v[:, m], block.ku[:, m], block.best[keep],
                  block.best_at[keep])


def _concat(x, y, ops):
    if ops.name == "numpy":
        return np.concatenate([x, y], axis=1)
    return ops.torch.cat([x, y], dim=1)


def _relax(x, xn, omega: float):
    """Over-relaxed update ``x^(1-w) xn^w`` (``xn sqrt(xn / x)`` for w = 1.5, no pow)."""
    if omega == 1.0:
        return xn
    r = xn / x
    if omega == 1.5:
        return xn * r.sqrt() if hasattr(r, "sqrt") else xn * np.sqrt(r)
    return x * r ** omega


def _solve_scaling(ops, K, KM, H, src, dst, tol, max_iter, omega, block,
                   costs, iters_out, errs_out, on_done, check_every=2, stall=200):
    """Stabilised-scaling Sinkhorn for problems ``(H[:, src[t]], H[:, dst[t]])``.

    Writes ``costs[t]`` (float64 ``<P, M>``), ``iters_out[t]`` and ``errs_out[t]`` (L1 error of
    the column marginal after the row update) for every t. A problem leaves the block when its
    error is below ``tol``, when it is not finite, after ``max_iter`` iterations, or when its
    error has not halved in ``stall`` iterations (the precision floor of the dtype; the caller
    re-solves such problems in float64).
    """
    n_prob = len(src)
    n = H.shape[0]
    k_rowsum = K.sum(1)[:, None]
    queue = 0

    def fresh(count: int) -> _Block:
        nonlocal queue
        ids = np.arange(queue, queue + count)
        queue += count
        a = ops.cols(H, src[ids])
        b = ops.cols(H, dst[ids])
        ku = (k_rowsum.expand(n, count) if ops.name != "numpy"
              else np.repeat(k_rowsum, count, axis=1))
        return _Block(ids, np.zeros(count, dtype=np.int64), a, b, a * 0 + 1, b * 0 + 1, ku,
                      np.full(count, np.inf), np.zeros(count, dtype=np.int64))

    st = fresh(min(block, n_prob))
    refill_at = max(1, block // 8)
    it = 0
    while st.ids.size:
        it += 1
        v = _relax(st.v, st.b / st.ku, omega)
        c = ops.colmax(v)
        v = v * (1.0 / c)
        u = st.u * c
        kv = K @ v
        u = _relax(u, st.a / kv, omega)
        ku = K @ u
        st = _Block(st.ids, st.iters + 1, st.a, st.b, u, v, ku, st.best, st.best_at)
        if it % check_every:
            continue
        err_np = ops.numpy(abs(v * ku - st.b).sum(0)).astype(np.float64)
        improved = err_np < 0.5 * st.best
        st.best_at[improved] = st.iters[improved]
        st.best[improved] = err_np[improved]
        bad = ~np.isfinite(err_np)
        done = ((err_np < tol) | bad | (st.iters >= max_iter)
                | (st.iters - st.best_at >= stall))
        n_done = int(done.sum())
        if n_done and (n_done >= refill_at or n_done == st.ids.size or queue >= n_prob):
            dm = ops.mask(done)
            ud, vd = ops.float64(st.u[:, dm]), ops.float64(st.v[:, dm])
            cost = ops.numpy((ud * (KM @ vd)).sum(0))
            ids = st.ids[done]
            costs[ids] = np.where(bad[done], np.nan, cost)
            iters_out[ids] = st.iters[done]
            errs_out[ids] = np.where(bad[done], np.inf, err_np[done])
            on_done(int(np.count_nonzero(err_np[done] < tol)))
            st = _take(st, ~done, ops)
            room = min(block - st.ids.size, n_prob - queue)
            if room > 0:
                new = fresh(room)
                st = _Block(np.concatenate([st.ids, new.ids]),
                            np.concatenate([st.iters, new.iters]),
                            _concat(st.a, new.a, ops), _concat(st.b, new.b, ops),
                            _concat(st.u, new.u, ops), _concat(st.v, new.v, ops),
                            _concat(st.ku, new.ku, ops),
                            np.concatenate([st.best, new.best]),
                            np.concatenate([st.best_at, new.best_at]))


def _solve_log(ops, logK, M, H, src, dst, eps, tol, max_iter, omega, block,
               costs, iters_out, errs_out, on_done):
    """Log-domain Sinkhorn (true ``logsumexp``) for tiny ``eps``; float64, blocks of ``block``.

    Potentials are ``lu = log u``, ``lv = log v`` with ``P = diag(u) K diag(v)``.
    """
    n_prob = len(src)
    for start in range(0, n_prob, block):
        ids = np.arange(start, min(start + block, n_prob))
        la = ops.array(np.log(ops.numpy(ops.cols(H, src[ids]))), np.float64)
        lb = ops.array(np.log(ops.numpy(ops.cols(H, dst[ids]))), np.float64)
        lu = la * 0
        lv = lb * 0
        active = np.ones(ids.size, dtype=bool)
        iters = np.zeros(ids.size, dtype=np.int64)
        err_np = np.full(ids.size, np.inf)

        def lse_k(lx):  # log(K @ exp(lx)), (n, B)
            return ops.logsumexp(logK[:, :, None] + lx[None, :, :], axis=1)

        lku = lse_k(lu)
        for _ in range(max_iter):
            am = ops.mask(active)
            lvn = lb - lku
            lv_new = lvn if omega == 1.0 else (1 - omega) * lv + omega * lvn
            lkv = lse_k(lv_new)
            lun = la - lkv
            lu_new = lun if omega == 1.0 else (1 - omega) * lu + omega * lun
            lku_new = lse_k(lu_new)
            err = (abs(ops.exp(lu_new + lkv) - ops.exp(la)).sum(0)
                   + abs(ops.exp(lv_new + lku_new) - ops.exp(lb)).sum(0))
            lu = ops.where(am, lu_new, lu)
            lv = ops.where(am, lv_new, lv)
            lku = ops.where(am, lku_new, lku)
            e = ops.numpy(err)
            err_np = np.where(active, e, err_np)
            iters += active
            active &= np.isfinite(e) & (e >= tol)
            if not active.any():
                break
        # <P, M> with P_kl = exp(lu_k - M_kl/eps + lv_l), one column at a time
        for j in range(ids.size):
            lp = lu[:, j][:, None] + logK + lv[:, j][None, :]
            costs[ids[j]] = float(ops.numpy((ops.exp(lp) * M).sum()))
        iters_out[ids] = iters
        errs_out[ids] = np.where(np.isfinite(err_np), err_np, np.inf)
        on_done(ids.size)


def sinkhorn_costs(hists: np.ndarray, src: np.ndarray, dst: np.ndarray, M: np.ndarray,
                   eps: float, *, tol: float = 1e-6, max_iter: int = 20000,
                   omega: float = 1.5, dtype: str = "float32", device: str = "torch",
                   block: int = 2048, threads: int | None = None, domain: str = "auto",
                   on_done: Callable[[int], None] | None = None
                   ) -> tuple[np.ndarray, SinkhornStats]:
    """Entropic OT costs ``<P*, M>`` for many pairs of histograms sharing one cost matrix.

    Parameters
    ----------
    hists : ndarray, shape (H, n)
        Strictly positive histograms, each summing to 1.
    src, dst : ndarray of int, shape (T,)
        Problem ``t`` transports ``hists[src[t]]`` to ``hists[dst[t]]``.
    M : ndarray, shape (n, n)
        Symmetric ground cost.
    eps : float
        Entropic regularisation (POT's ``reg``).
    tol : float
        Stop a problem when the L1 errors of both marginals of its plan sum to less than tol.
    max_iter : int
        Iterations per problem before it is given up (relaxed first, then once more at w = 1).
    omega : float
        Over-relaxation weight in ``[1, 2)``; 1 is plain Sinkhorn.
    dtype : {"float32", "float64"}
        Precision of the iteration's matrix products (the cost is summed in float64). If
        ``max(M)/eps`` exceeds :data:`SCALING_LIMITS` ``[dtype]``, float64 is used, and beyond
        the float64 limit the log-domain iteration.
    device : {"numpy", "torch", "torch-cpu", "cuda"}
    block : int
        Problems in flight at once (columns of each matrix product).
    threads : int or None
        Worker threads on the CPU, each solving an interleaved share of the problems with one
        intra-op thread (numpy's BLAS and torch's pool are held at one thread meanwhile).
    domain : {"auto", "log"}
        ``log`` forces the log-domain iteration (``auto`` uses it only when needed).
    on_done : callable, optional
        Called with the number of problems just finished (progress bars).

    Returns
    -------
    costs : ndarray, float64, shape (T,)
        ``OT_eps`` of every problem; equals ``ot.sinkhorn2(hists[src[t]], hists[dst[t]], M,
        eps)`` at convergence.
    stats : SinkhornStats
    """
    t0 = time.perf_counter()
    hists = np.asarray(hists, dtype=np.float64)
    src = np.asarray(src, dtype=np.int64)
    dst = np.asarray(dst, dtype=np.int64)
    M = np.asarray(M, dtype=np.float64)
    if eps <= 0:
        raise ValueError(f"eps must be positive, got {eps}")
    if not 0 < omega < 2:
        raise ValueError(f"omega must lie in (0, 2), got {omega}")
    if hists.ndim != 2 or M.shape != (hists.shape[1], hists.shape[1]):
        raise ValueError(f"histograms {hists.shape} do not match the cost matrix {M.shape}")
    if np.any(hists <= 0) or not np.all(np.isfinite(hists)):
        raise ValueError("histograms must be finite and strictly positive")
    ratio = float(M.max()) / eps
    mode_dtype = dtype if ratio <= SCALING_LIMITS[dtype] else "float64"
    if domain not in ("auto", "log"):
        raise ValueError(f"domain must be 'auto' or 'log', got {domain!r}")
    log_mode = ratio > SCALING_LIMITS["float64"] or domain == "log"
    if log_mode:
        mode_dtype = "float64"
    n_prob = len(src)
    report = on_done if on_done is not None else (lambda k: None)

    def solver(prec: str):
        """``run(src, dst, omega, costs, iters, errs, on_done)`` at precision ``prec``."""
        ops = array_ops(device, prec)
        H = ops.array(hists.T, np.float64 if log_mode else None)
        if log_mode:
            logK = ops.array(-M / eps, np.float64)
            Mt = ops.array(M, np.float64)
            return ops, lambda s, d, w, c, i, e, cb: _solve_log(
                ops, logK, Mt, H, s, d, eps, tol, max_iter, w, max(1, min(block, 64)), c, i,
                e, cb)
        K = ops.array(np.exp(-M / eps))
        KM = ops.array(np.exp(-M / eps) * M, np.float64)
        return ops, lambda s, d, w, c, i, e, cb: _solve_scaling(
            ops, K, KM, H, s, d, tol, max_iter, w, block, c, i, e, cb,
            stall=200 if prec == "float32" else max_iter)

    mode = "log-float64" if log_mode else f"scaling-{mode_dtype}"
    ops, run = solver(mode_dtype)
    workers = max(1, int(threads or 1)) if ops.parallel else 1

    def solve(run_fn, s_idx, d_idx, w, cb):
        """Solve problems ``(s_idx, d_idx)`` split over ``workers`` threads (interleaved)."""
        c = np.full(len(s_idx), np.nan)
        i = np.zeros(len(s_idx), dtype=np.int64)
        e = np.full(len(s_idx), np.inf)

        def part(k: int) -> None:
            sel = np.arange(k, len(s_idx), workers)
            ck, ik, ek = np.full(sel.size, np.nan), np.zeros(sel.size, np.int64), \
                np.full(sel.size, np.inf)
            with ops.worker():
                run_fn(s_idx[sel], d_idx[sel], w, ck, ik, ek, cb)
            c[sel], i[sel], e[sel] = ck, ik, ek

        if workers == 1 or len(s_idx) < 2 * workers:
            part_all = np.arange(len(s_idx))
            with ops.worker():
                run_fn(s_idx[part_all], d_idx[part_all], w, c, i, e, cb)
        else:
            with ThreadPoolExecutor(max_workers=workers) as pool:
                for f in [pool.submit(part, k) for k in range(workers)]:
                    f.result()
        return c, i, e

    with ops.session():
        costs, iters, errs = solve(run, src, dst, omega, report)
        # problems stuck at the precision floor or oscillating: float64, then unrelaxed
        attempts = [] if mode_dtype == "float64" else [("float64", omega)]
        attempts += [] if omega == 1.0 else [("float64", 1.0)]
        for prec, w in attempts:
            retry = np.flatnonzero(~(errs < tol))
            if not retry.size:
                break
            _, run2 = solver(prec)
            c2, i2, e2 = solve(run2, src[retry], dst[retry], w, report)
            better = ~(e2 >= errs[retry])
            costs[retry[better]] = c2[better]
            errs[retry[better]] = e2[better]
            iters[retry] += i2
    finite = errs[np.isfinite(errs)]
    stats = SinkhornStats(
        problems=n_prob,
        iterations_mean=float(iters.mean()) if n_prob else 0.0,
        iterations_max=int(iters.max()) if n_prob else 0,
        unconverged=int(np.count_nonzero(~(errs < tol))),
        max_marginal_error=float(finite.max()) if finite.size else 0.0,
        mode=mode,
        device=ops.name,
        seconds=time.perf_counter() - t0,
    )
    return costs, stats


def row_blocks(m: int, rows: int | None = None) -> list[tuple[int, int]]:
    """Row spans ``[(a, b), ...]`` that split ``m`` histograms into blocks of ``rows`` rows
    (one block when ``rows`` is None or at least ``m``)."""
    step = max(1, rows or m)
    return [(a, min(a + step, m)) for a in range(0, max(m, 1), step)]


def block_problems(m: int, a: int, b: int) -> tuple[np.ndarray, np.ndarray]:
    """``(src, dst)`` of the row block ``[a, b)`` of an ``m x m`` divergence matrix: the self
    terms of rows ``a..b-1``, then the pairs ``(i, j > i)`` of those rows, row-major (the block
    ``(0, m)`` is every problem of :func:`sinkhorn_divergence_matrix`, in its order)."""
    rows = np.arange(a, b)
    iu = np.repeat(rows, m - 1 - rows)
    ju = (np.concatenate([np.arange(i + 1, m) for i in rows]) if len(rows)
          else np.zeros(0, dtype=np.int64))
    return np.concatenate([rows, iu]), np.concatenate([rows, ju])


def _block_costs(hists: np.ndarray, M: np.ndarray, eps: float, kwargs: dict,
                 span: tuple[int, int]) -> tuple[np.ndarray, SinkhornStats]:
    src, dst = block_problems(len(hists), *span)
    return sinkhorn_costs(hists, src, dst, M, eps, **kwargs)


def merge_stats(parts: list[SinkhornStats]) -> SinkhornStats:
    """One :class:`SinkhornStats` of several solves (the first when there is one)."""
    if len(parts) == 1:
        return parts[0]
    n = sum(p.problems for p in parts)
    modes = sorted({p.mode for p in parts})
    return SinkhornStats(
        problems=n,
        iterations_mean=(sum(p.iterations_mean * p.problems for p in parts) / n) if n else 0.0,
        iterations_max=max(p.iterations_max for p in parts),
        unconverged=sum(p.unconverged for p in parts),
        max_marginal_error=max(p.max_marginal_error for p in parts),
        mode="+".join(modes), device=parts[0].device,
        seconds=sum(p.seconds for p in parts))


def sinkhorn_divergence_matrix(hists: np.ndarray, M: np.ndarray, eps: float, *,
                               rows: int | None = None, executor: Executor | None = None,
                               **kwargs) -> tuple[np.ndarray, SinkhornStats]:
    """All pairwise debiased Sinkhorn divergences of a set of histograms.

    ``S[i, j] = OT(h_i, h_j) - OT(h_i, h_i)/2 - OT(h_j, h_j)/2`` for ``i < j`` (one problem per
    unordered pair, one self term per histogram), mirrored; the diagonal is 0.

    Parameters
    ----------
    hists : ndarray, shape (m, n)
    M : ndarray, shape (n, n)
    eps : float
    rows : int, optional
        Split the problems into row blocks of ``rows`` rows (:func:`row_blocks`), one task
        each; None: one block. The numbers depend on the blocks (float32 products of other
        widths), never on where they run.
    executor : vggc_cp.parallel.Executor, optional
        Where the blocks run (default: here, in order).
    **kwargs
        Passed to :func:`sinkhorn_costs` (``on_done`` is called here, per block when the
        blocks run elsewhere).

    Returns
    -------
    S : ndarray, float64, shape (m, m), symmetric, zero diagonal
    stats : SinkhornStats
    """
    m = len(hists)
    spans = row_blocks(m, rows)
    executor = executor or Executor()
    on_done = kwargs.pop("on_done", None)
    report = None
    if executor.inline:
        kwargs["on_done"] = on_done
    elif on_done is not None:
        def report(i, out):
            on_done(out[1].problems)
    outs = executor.map(partial(_block_costs, hists, M, eps, kwargs), spans, report)
    self_cost = np.concatenate([c[:b - a] for (a, b), (c, _) in zip(spans, outs)])
    pair_cost = np.concatenate([c[b - a:] for (a, b), (c, _) in zip(spans, outs)])
    iu, ju = np.triu_indices(m, k=1)
    S = np.zeros((m, m), dtype=np.float64)
    S[iu, ju] = pair_cost - 0.5 * self_cost[iu] - 0.5 * self_cost[ju]
    S[ju, iu] = S[iu, ju]
    return S, merge_stats([st for _, st in outs])


def sinkhorn_divergence_pairs(hists_a: np.ndarray, hists_b: np.ndarray, M: np.ndarray,
                              eps: float, **kwargs) -> tuple[np.ndarray, SinkhornStats]:
    """``S_eps(a_t, b_t)`` for row-aligned pairs; shapes (T, n), (T, n) -> (T,)."""
    t = len(hists_a)
    hists = np.concatenate([hists_a, hists_b], axis=0)
    ia, ib = np.arange(t), np.arange(t, 2 * t)
    src = np.concatenate([ia, ia, ib])
    dst = np.concatenate([ib, ia, ib])
    costs, stats = sinkhorn_costs(hists, src, dst, M, eps, **kwargs)
    return costs[:t] - 0.5 * costs[t:2 * t] - 0.5 * costs[2 * t:], stats


__all__ = ["DEVICES", "SCALING_LIMITS", "SinkhornStats", "cost_matrix", "patch_centres",
           "block_problems", "merge_stats", "row_blocks", "sinkhorn_costs",
           "sinkhorn_divergence_matrix", "sinkhorn_divergence_pairs"]
