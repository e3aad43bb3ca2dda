"""Baselines of the paper's Table 1: PCA-HDBSCAN roadmap and Latent Space Roadmap.

Both return :class:`~vggc_cp.solvers.base.SolveResult` and write the solution JSON of
``FORMATS.md`` (:func:`baseline_solution`), so evaluate, plan and compare work on them.
"""

from vggc_cp.baselines.base import (
    BASELINES,
    NO_CONSTRAINTS,
    Baseline,
    Candidate,
    GraphStats,
    baseline_solution,
    get_baseline,
    graph_stats,
    parse_params,
    register_baseline,
    select,
    selection_key,
)
from vggc_cp.baselines.lsr import LatentSpaceRoadmap, LsrConfig
from vggc_cp.baselines.pca_hdbscan import PcaHdbscanConfig, PcaHdbscanRoadmap

__all__ = ["BASELINES", "NO_CONSTRAINTS", "Baseline", "Candidate", "GraphStats",
           "LatentSpaceRoadmap", "LsrConfig", "PcaHdbscanConfig", "PcaHdbscanRoadmap",
           "baseline_solution", "get_baseline", "graph_stats", "parse_params", "register_baseline", "select",
           "selection_key"]
