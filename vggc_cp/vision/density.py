"""Gaussian kernel densities of colours: the likelihood of a chroma under a class's examples."""

from __future__ import annotations

import numpy as np


def kernel_loglik(query: np.ndarray, examples: np.ndarray, bandwidth: float,
                  chunk: int = 256) -> np.ndarray:
    """Log of the Gaussian kernel density of ``examples`` (n, 2) at ``query`` (m, 2), up to
    the constant every density shares; shape (m,).

    >>> ex = np.array([[0.5, 0.3], [0.5, 0.3]])
    >>> kernel_loglik(np.array([[0.5, 0.3], [0.52, 0.3]]), ex, 0.02).round(2).tolist()
    [0.0, -0.5]
    """
    out = np.empty(len(query))
    for s in range(0, len(query), chunk):
        d2 = ((query[s:s + chunk, None, :] - examples[None]) ** 2).sum(-1) / bandwidth ** 2
        m = (-0.5 * d2).max(axis=1)
        out[s:s + chunk] = m + np.log(np.exp(-0.5 * d2 - m[:, None]).mean(axis=1))
    return out


def kernel_posterior(query: np.ndarray, examples: list[np.ndarray], bandwidth: float
                     ) -> np.ndarray:
    """Posterior of every class for every chroma of ``query`` (m, 2), shape (m, C): each
    class's likelihood a kernel density over its examples, equal priors.

    >>> red, yellow = np.array([[0.7, 0.15]]), np.array([[0.5, 0.4]])
    >>> kernel_posterior(np.array([[0.68, 0.16]]), [red, yellow], 0.02).round(3).tolist()
    [[1.0, 0.0]]
    """
    logp = np.stack([kernel_loglik(query, ex, bandwidth) for ex in examples], axis=1)
    w = np.exp(logp - logp.max(axis=1, keepdims=True))
    return w / w.sum(axis=1, keepdims=True)
