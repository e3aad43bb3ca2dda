"""Batched debiased Sinkhorn divergence (``vggc_cp.vision.sinkhorn``) against POT."""

from __future__ import annotations

import numpy as np
import ot
import pytest

from vggc_cp.vision.bench import synthetic_maps
from vggc_cp.vision.sinkhorn import (
    cost_matrix,
    patch_centres,
    sinkhorn_costs,
    sinkhorn_divergence_matrix,
    sinkhorn_divergence_pairs,
)


def pot_divergences(maps, pairs, M, eps, method, stop=1e-12):
    """S_eps from POT's per-pair ``ot.sinkhorn2`` (self terms once per map), converged."""
    kw = dict(method=method, stopThr=stop, numItermax=200000)
    cache = {}

    def self_term(i):
        if i not in cache:
            cache[i] = float(ot.sinkhorn2(maps[i], maps[i], M, eps, **kw))
        return cache[i]

    return np.array([float(ot.sinkhorn2(maps[i], maps[j], M, eps, **kw))
                     - 0.5 * self_term(i) - 0.5 * self_term(j) for i, j in pairs])


def random_pairs(m, k, rng):
    iu, ju = np.triu_indices(m, k=1)
    sel = rng.choice(len(iu), size=k, replace=False)
    return np.stack([iu[sel], ju[sel]], axis=1)


# 225 pairs in all; the last two cases run the log-domain iteration (forced, then because
# max M / eps = 530 > 450 makes exp(-M / eps) useless even in float64): slow, as POT's
# sinkhorn_log reference needs thousands of iterations per problem.
@pytest.mark.parametrize(("grid", "eps", "n_pairs", "dtype", "domain", "floor", "mode"), [
    (8, 0.2, 40, "float32", "auto", 0.05, "scaling-float32"),
    (8, 0.1, 50, "float32", "auto", 0.05, "scaling-float32"),
    (8, 0.05, 50, "float32", "auto", 0.05, "scaling-float32"),
    (8, 0.05, 40, "float64", "auto", 0.05, "scaling-float64"),
    pytest.param(16, 0.05, 20, "float32", "auto", 0.05, "scaling-float32",
                 marks=pytest.mark.slow),  # a 256-patch grid: seconds on 2 cores
    pytest.param(8, 0.05, 15, "float32", "log", 0.05, "log-float64", marks=pytest.mark.slow),
    pytest.param(4, 0.002, 10, "float32", "auto", 0.2, "log-float64", marks=pytest.mark.slow),
])
def test_agrees_with_pot(grid, eps, n_pairs, dtype, domain, floor, mode):
    rng = np.random.default_rng(grid * 1000 + int(eps * 1e4))
    maps = synthetic_maps(30, grid, rng, floor=floor)
    M = cost_matrix(grid)
    pairs = random_pairs(len(maps), n_pairs, rng)
    S, stats = sinkhorn_divergence_pairs(maps[pairs[:, 0]], maps[pairs[:, 1]], M, eps,
                                         tol=1e-8, dtype=dtype, domain=domain)
    assert stats.mode == mode
    assert stats.unconverged == 0
    method = "sinkhorn_log" if mode.startswith("log") else "sinkhorn"
    ref = pot_divergences(maps, pairs, M, eps, method, stop=1e-10)
    assert np.max(np.abs(S - ref) / np.abs(ref)) < 1e-4


def test_costs_are_pots_linear_cost_not_the_entropic_objective():
    rng = np.random.default_rng(1)
    maps = synthetic_maps(2, 8, rng)
    M = cost_matrix(8)
    costs, _ = sinkhorn_costs(maps, np.array([0]), np.array([1]), M, 0.05, tol=1e-10,
                              dtype="float64")
    plan = ot.sinkhorn(maps[0], maps[1], M, 0.05, stopThr=1e-12, numItermax=100000)
    assert costs[0] == pytest.approx(float((plan * M).sum()), rel=1e-7)


@pytest.mark.parametrize("device", ["numpy", "torch-cpu"])
@pytest.mark.parametrize("threads", [1, 2])
def test_devices_and_threads_agree(device, threads):
    rng = np.random.default_rng(2)
    maps = synthetic_maps(24, 8, rng)
    M = cost_matrix(8)
    ref, _ = sinkhorn_divergence_matrix(maps, M, 0.05, dtype="float64", device="numpy",
                                        tol=1e-9)
    S, stats = sinkhorn_divergence_matrix(maps, M, 0.05, device=device, threads=threads)
    assert stats.unconverged == 0
    off = ~np.eye(len(maps), dtype=bool)
    assert np.max(np.abs(S - ref)[off] / ref[off]) < 1e-4


def test_matrix_is_symmetric_non_negative_with_zero_diagonal():
    rng = np.random.default_rng(3)
    maps = synthetic_maps(40, 8, rng)
    S, stats = sinkhorn_divergence_matrix(maps, cost_matrix(8), 0.05)
    assert S.shape == (40, 40)
    assert np.array_equal(S, S.T)
    assert np.all(np.diag(S) == 0)
    assert S[~np.eye(40, dtype=bool)].min() > 0
    assert stats.problems == 40 + 40 * 39 // 2


def test_identical_maps_give_zero():
    rng = np.random.default_rng(4)
    maps = synthetic_maps(5, 8, rng)
    S, _ = sinkhorn_divergence_pairs(maps, maps.copy(), cost_matrix(8), 0.05)
    assert np.all(np.abs(S) < 1e-7)
    dup = np.concatenate([maps, maps])
    D, _ = sinkhorn_divergence_matrix(dup, cost_matrix(8), 0.05)
    assert np.all(np.abs(D[np.arange(5), np.arange(5) + 5]) < 1e-7)


def test_shift_by_one_patch_is_farther_than_noise():
    g = 12
    rng = np.random.default_rng(5)
    base = np.full((g, g), 1e-3)
    base[4:6, 3:5] = 1.0
    base[8, 8] = 0.7
    shifted = np.roll(base, 1, axis=1)
    noisy = base * (1 + 0.3 * rng.random((g, g)))
    maps = np.stack([base, shifted, noisy]).reshape(3, -1)
    maps /= maps.sum(1, keepdims=True)
    S, _ = sinkhorn_divergence_matrix(maps, cost_matrix(g), 0.02)
    assert S[0, 1] > 3 * S[0, 2] > 0


def test_patch_centres_live_in_the_unit_square():
    c = patch_centres(4)
    assert c.shape == (16, 2)
    assert c.min() == pytest.approx(0.125) and c.max() == pytest.approx(0.875)
    assert cost_matrix(4)[0, 15] == pytest.approx(np.sqrt(2) * 0.75)


def test_rejects_bad_histograms():
    M = cost_matrix(4)
    h = np.full((2, 16), 1 / 16)
    h[0, 0] = 0
    with pytest.raises(ValueError, match="strictly positive"):
        sinkhorn_costs(h, np.array([0]), np.array([1]), M, 0.1)
    with pytest.raises(ValueError, match="eps"):
        sinkhorn_costs(np.full((2, 16), 1 / 16), np.array([0]), np.array([1]), M, 0.0)
