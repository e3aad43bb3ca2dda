"""The CUDA path of the batched Sinkhorn divergence agrees with the float64 NumPy reference.

Skipped where torch sees no CUDA device (CI); run on a GPU machine with
``python -m pytest tests/vision/test_vision_cuda.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from vggc_cp.vision.bench import synthetic_maps
from vggc_cp.vision.sinkhorn import cost_matrix, sinkhorn_divergence_matrix

torch = pytest.importorskip("torch")
pytestmark = pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")


@pytest.mark.parametrize(("grid", "eps", "dtype", "floor", "mode"), [
    (8, 0.05, "float32", 0.01, "scaling-float32"),
    (16, 0.05, "float32", 0.01, "scaling-float32"),
    (16, 0.05, "float64", 0.01, "scaling-float64"),
])
def test_cuda_agrees_with_numpy(grid, eps, dtype, floor, mode):
    rng = np.random.default_rng(7)
    maps = synthetic_maps(40, grid, rng, floor=floor)
    M = cost_matrix(grid)
    ref, _ = sinkhorn_divergence_matrix(maps, M, eps, dtype="float64", device="numpy",
                                        tol=1e-9)
    S, stats = sinkhorn_divergence_matrix(maps, M, eps, dtype=dtype, device="cuda")
    assert stats.mode == mode and stats.device == "torch-cuda"
    assert stats.unconverged == 0
    off = ~np.eye(len(maps), dtype=bool)
    assert np.max(np.abs(S - ref)[off] / np.maximum(ref[off], 1e-12)) < 1e-3
    assert np.allclose(S, S.T) and np.all(np.diag(S) == 0)
