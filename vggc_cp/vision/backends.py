"""Array backends of the batched Sinkhorn solver: the same operations on numpy or torch.

:func:`array_ops` gives the solver of :mod:`vggc_cp.vision.sinkhorn` one object whose methods
(products, column slices, ``logsumexp``, ...) run on numpy (CPU) or torch (CUDA
when asked and present, else CPU); torch is imported only when a torch device is asked for.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np

#: Devices :func:`~vggc_cp.vision.sinkhorn.sinkhorn_costs` accepts: ``numpy`` (CPU), ``torch``
#: (CUDA when available, else CPU), ``torch-cpu``, ``cuda``.
DEVICES = ("numpy", "torch", "torch-cpu", "cuda")
DTYPES = ("float32", "float64")


class NumpyOps:
    """Array operations of the solver on numpy (CPU; one BLAS thread per worker thread)."""

    name = "numpy"

    def __init__(self, dtype: str) -> None:
        self.dtype = np.dtype(dtype)

    def array(self, x: np.ndarray, dtype=None):
        return np.ascontiguousarray(x, dtype=self.dtype if dtype is None else dtype)

    def cols(self, h, idx: np.ndarray):
        return h[:, idx]

    def colmax(self, x):
        return x.max(axis=0)

    def numpy(self, x) -> np.ndarray:
        return np.asarray(x)

    def mask(self, m: np.ndarray):
        return m

    def logsumexp(self, x, axis: int):
        mx = x.max(axis=axis, keepdims=True)
        mx = np.where(np.isfinite(mx), mx, 0.0)
        return np.log(np.exp(x - mx).sum(axis=axis)) + np.squeeze(mx, axis=axis)

    def float64(self, x):
        return np.asarray(x, dtype=np.float64)

    def exp(self, x):
        return np.exp(x)

    def where(self, m, x, y):
        return np.where(m, x, y)

    parallel = True

    @contextlib.contextmanager
    def session(self) -> Iterator[None]:
        """One BLAS thread per worker while solving (restored after), as :class:`TorchOps`.

        The solver's worker threads each own a slice of the problems and call BLAS at once.
        OpenBLAS's own thread pool, entered by two Python threads at a time, can hang the
        process (OpenBLAS#1844, numpy#17752): ``threadpoolctl`` keeps it at one thread.
        """
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1, user_api="blas"):
            yield

    @contextlib.contextmanager
    def worker(self) -> Iterator[None]:
        yield


class TorchOps:
    """Array operations of the solver on torch (CUDA when asked and present, else CPU)."""

    def __init__(self, dtype: str, device: str) -> None:
        from vggc_cp.interrupts import deferred

        with deferred():  # a Ctrl-C inside torch's initialisation aborts the process
            import torch

        self.torch = torch
        self.dtype = getattr(torch, dtype)
        if device == "cuda" and not torch.cuda.is_available():
            raise ValueError("device 'cuda' asked for, but torch sees no CUDA device")
        if device == "torch":
            device = "cuda" if torch.cuda.is_available() else "cpu"
        elif device == "torch-cpu":
            device = "cpu"
        self.device = torch.device(device)
        self.name = f"torch-{self.device.type}"

    def array(self, x, dtype=None):
        dt = self.dtype if dtype is None else getattr(self.torch, np.dtype(dtype).name)
        return self.torch.as_tensor(np.ascontiguousarray(x), dtype=dt, device=self.device)

    def cols(self, h, idx: np.ndarray):
        return h[:, self.torch.as_tensor(idx, device=self.device)]

    def colmax(self, x):
        return x.amax(dim=0)

    def numpy(self, x) -> np.ndarray:
        return x.detach().cpu().numpy()

    def mask(self, m: np.ndarray):
        return self.torch.as_tensor(m, device=self.device)

    def logsumexp(self, x, axis: int):
        return self.torch.logsumexp(x, dim=axis)

    def float64(self, x):
        return x.to(self.torch.float64)

    def exp(self, x):
        return self.torch.exp(x)

    def where(self, m, x, y):
        return self.torch.where(m, x, y)

    @property
    def parallel(self) -> bool:
        return self.device.type == "cpu"

    @contextlib.contextmanager
    def session(self) -> Iterator[None]:
        """One intra-op thread per worker while solving (restored after).

        Parallelism comes from worker threads that each own a slice of the problems (torch
        releases the GIL), not from torch's intra-op pool: on a loaded machine the pool's
        barriers make every small product wait for the slowest core.
        """
        if self.device.type != "cpu":
            yield
            return
        old = self.torch.get_num_threads()
        self.torch.set_num_threads(1)
        try:
            yield
        finally:
            self.torch.set_num_threads(old)

    @contextlib.contextmanager
    def worker(self) -> Iterator[None]:
        """Flush denormals to zero in the calling thread (a per-thread CPU flag; restored).

        Products of tiny scalings with small kernel entries are denormal floats, which make
        CPU matrix products several times slower. A flushed value is below 1e-38 (float32)
        while every column holds at least ``exp(-max M / eps) > 1e-22``, so the result does not
        change beyond rounding.
        """
        if self.device.type != "cpu":
            yield
            return
        self.torch.set_flush_denormal(True)
        try:
            yield
        finally:
            self.torch.set_flush_denormal(False)


def array_ops(device: str, dtype: str):
    """The operations of the Sinkhorn solver on ``device`` (:data:`DEVICES`) in ``dtype``
    (``float32`` or ``float64``); unknown names raise ValueError listing the known ones."""
    if device not in DEVICES:
        raise ValueError(f"unknown device {device!r}; known: {', '.join(DEVICES)}")
    if dtype not in DTYPES:
        raise ValueError(f"unknown dtype {dtype!r}; known: {', '.join(DTYPES)}")
    return NumpyOps(dtype) if device == "numpy" else TorchOps(dtype, device)
