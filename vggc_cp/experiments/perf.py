"""``vggc-cp bench solve``: the default ``solve`` against the previous default, in one run.

The previous default (before the pipeline) was the paper's saliency attention with batched
Sinkhorn divergences and congruence-closure merging with the ``cascade`` threshold rule; the
current one is :func:`vggc_cp.pipeline.learn_graph`. Both run on the same trace in the same
process, neither reads a distance cache, and the ratio of their wall times is printed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from vggc_cp.pipeline import learn_graph
from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.merge import threshold_path
from vggc_cp.trace import Trace
from vggc_cp.vision.distances import DistanceConfig, compute_distances


@dataclass(frozen=True)
class SolveTiming:
    """Seconds and node counts of both defaults on one trace."""

    default_seconds: float
    default_nodes: int
    default_evidence: str
    default_suspect: bool
    previous_seconds: float
    previous_nodes: int

    @property
    def ratio(self) -> float:
        return self.default_seconds / self.previous_seconds


def time_previous_default(trace: Trace, threads: int | None = None) -> tuple[float, int]:
    """Seconds and nodes of saliency Sinkhorn distances (uncached) + merge with ``cascade``."""
    t0 = time.perf_counter()
    cfg = DistanceConfig(use_cache=False, threads=threads)
    dp, dq = compute_distances(trace, cfg, progress=False)
    path = threshold_path(Problem.from_trace(trace, dp, dq), None, "cascade")
    return time.perf_counter() - t0, path.best.n_nodes


def bench_solve(trace: Trace, threads: int | None = None) -> SolveTiming:
    """Time the current default (:func:`learn_graph`, its keypoint fallback uncached) and the
    previous one on ``trace``."""
    from dataclasses import replace

    from vggc_cp.pipeline import LearnConfig

    options = LearnConfig()
    options = replace(options, distance=replace(options.distance, use_cache=False,
                                                threads=threads))
    t0 = time.perf_counter()
    learned = learn_graph(trace, options)
    seconds = time.perf_counter() - t0
    prev_s, prev_n = time_previous_default(trace, threads)
    return SolveTiming(seconds, learned.graph.n_nodes, learned.chosen.evidence,
                       learned.confidence.suspect, prev_s, prev_n)
