"""Visual distances of the paper: attention maps and debiased Sinkhorn divergences.

``d_vis(o_i, o_j) = S_eps(M(o_i), M(o_j))`` between observations of the same role, with
``M`` an attention map on a patch grid (:mod:`.attention`: ``saliency``, ``dinov2``) and
``S_eps`` the debiased Sinkhorn divergence (:mod:`.sinkhorn`); :mod:`.distances` runs the
stage on a trace and caches it. The affinity ``K_vis = exp(-d / tau)`` and the score ``J``
live in :mod:`vggc_cp.score` and are re-exported here.

Distances are cached per (trace content hash, every result-changing parameter) in
``$VGGC_CP_CACHE/distances`` when that variable is set, else ``./.cache/vggc-cp/distances``
(git-ignored), or in ``--cache-dir``; the file format is in :mod:`.distances`.

Typical use::

    from vggc_cp.vision import DistanceConfig, compute_distances
    dist_pick, dist_place = compute_distances(trace, DistanceConfig(eps=0.05))
"""

from vggc_cp.score import affinity, visual_score, visual_score_role
from vggc_cp.vision.attention import ATTENTION_BACKENDS, AttentionConfig, attention_maps
from vggc_cp.vision.distances import (
    CACHE_ENV,
    DistanceConfig,
    DistanceResult,
    cache_path,
    compute_distances,
    compute_distances_full,
    default_cache_dir,
    distance_matrices,
)
from vggc_cp.vision.sinkhorn import (
    SinkhornStats,
    cost_matrix,
    patch_centres,
    sinkhorn_costs,
    sinkhorn_divergence_matrix,
    sinkhorn_divergence_pairs,
)


def __getattr__(name: str):
    """Lazy access to the DINOv2 model (imports torch only when asked)."""
    if name in ("DinoVisionTransformer", "load_dinov2"):
        from vggc_cp.vision import dinov2

        return getattr(dinov2, name)
    raise AttributeError(f"module 'vggc_cp.vision' has no attribute {name!r}")


__all__ = [
    "ATTENTION_BACKENDS",
    "AttentionConfig",
    "CACHE_ENV",
    "DistanceConfig",
    "DistanceResult",
    "SinkhornStats",
    "affinity",
    "attention_maps",
    "cache_path",
    "compute_distances",
    "compute_distances_full",
    "cost_matrix",
    "default_cache_dir",
    "distance_matrices",
    "patch_centres",
    "sinkhorn_costs",
    "sinkhorn_divergence_matrix",
    "sinkhorn_divergence_pairs",
    "visual_score",
    "visual_score_role",
]
