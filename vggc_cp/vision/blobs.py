"""Connected parts of a non-negative map: what acts in one place keeps one part."""

from __future__ import annotations

import numpy as np
from scipy import ndimage


def heaviest_component(m: np.ndarray) -> np.ndarray:
    """``m`` (shape (H, W), non-negative) kept on its connected component (8-neighbours) of
    largest mass: an action acts in one place; scattered residue elsewhere is not its.

    >>> m = np.zeros((3, 5)); m[0, 0] = 1.0; m[1:, 3:] = 0.5
    >>> heaviest_component(m).tolist()
    [[0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.5, 0.5], [0.0, 0.0, 0.0, 0.5, 0.5]]
    """
    lab, n = ndimage.label(m > 0, structure=np.ones((3, 3)))
    if n <= 1:
        return m
    mass = ndimage.sum(m, lab, index=np.arange(1, n + 1))
    return np.where(lab == 1 + int(np.argmax(mass)), m, 0.0)
