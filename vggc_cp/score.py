"""The paper's visual score J and the visual affinity K_vis.

J (Eq. vis-score of the paper) sums, over every cluster of both roles, the mean pairwise
distance between the cluster's members; a singleton cluster contributes 0:

.. math::  J = \\sum_{c} \\frac{1}{|c|(|c|-1)/2} \\sum_{i<j \\in c} d(o_i, o_j)

References
----------
A. Ajith, C. Chamzas. *Learning Discrete Abstractions for Visual Rearrangement Tasks Using
Vision-Guided Graph Coloring*, arXiv:2509.14460, 2025.
"""

from __future__ import annotations

import numpy as np


def affinity(dist: np.ndarray, tau: float) -> np.ndarray:
    """K_vis = exp(-d / tau), elementwise; same shape as ``dist``."""
    if not 0 < tau < float("inf"):
        from vggc_cp.errors import VggcError

        raise VggcError(f"--tau must be positive and finite, got {tau}")
    return np.exp(-np.asarray(dist, dtype=np.float64) / tau)


def cluster_mean_distance(dist: np.ndarray, members: np.ndarray) -> float:
    """Mean of ``dist[i, j]`` over pairs ``i < j`` of ``members`` (0 for fewer than two)."""
    m = len(members)
    if m < 2:
        return 0.0
    sub = dist[np.ix_(members, members)]
    return float((sub.sum() - np.trace(sub)) / (m * (m - 1)))


def visual_score_role(dist: np.ndarray, colours: np.ndarray) -> float:
    """J restricted to one role.

    Parameters
    ----------
    dist : ndarray, shape (n, n)
        Symmetric within-role distances.
    colours : ndarray of int, shape (n,)
        Cluster of every observation of the role.
    """
    colours = np.asarray(colours)
    total = 0.0
    for c in np.unique(colours):
        total += cluster_mean_distance(dist, np.flatnonzero(colours == c))
    return total


def visual_score(labels: np.ndarray, roles: np.ndarray, dist_pick: np.ndarray,
                 dist_place: np.ndarray) -> float:
    """J of a full labelling (both roles).

    Parameters
    ----------
    labels : ndarray of int, shape (N,)
    roles : ndarray of int, shape (N,)  (0 pick, 1 place)
    dist_pick : ndarray, shape (n_pick, n_pick), rows in the order of ``flatnonzero(roles == 0)``
    dist_place : ndarray, shape (n_place, n_place)
    """
    labels = np.asarray(labels)
    roles = np.asarray(roles)
    return (visual_score_role(dist_pick, labels[roles == 0])
            + visual_score_role(dist_place, labels[roles == 1]))
