"""Stacks: which slot stands on which, as the actions state it (and trusted readings
confirm where they cannot).

A block on a block: the slot above holds something only when the slot below does. Which site
is stacked on which is read from the sites' labels
(:func:`~vggc_cp.vision.occupancy.site_labels`), the footprints' overlaps and the sequence
(:func:`slots_above`, :func:`sequence_stacked`); where no frame states both slots, from the
lower slot's trusted reading (:func:`read_labels`, :func:`stack_odds`). The stacks feed the
support of :mod:`vggc_cp.vision.support`, the object counts of
:mod:`vggc_cp.vision.conservation` and the colour of covered slots
(:func:`vggc_cp.vision.covered.uncovered_colour`). Nothing reads action names or
ground-truth states.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.vision.slots import EMPTY, UNLABELLED, odds_met

#: Least trust (kappa) at which a site's reading stands in for its labels when the stacks
#: are read (:func:`slots_above`): substantial agreement (Landis and Koch 1977).
STACK_TRUST = 0.6


def slots_above(runs: dict, ov: np.ndarray, site_overlap: float,
                presence: np.ndarray | None = None, trust: np.ndarray | None = None
                ) -> dict[int, list[int]]:
    """For every site, the sites of other slots stacked on it, as the actions state them.

    Site ``b`` is above site ``a`` when ``b`` is no action at ``a``'s slot, wherever the
    actions state both, ``b`` holds something only when ``a`` does, while ``a`` is stated to
    hold something with ``b`` empty at least once (a block on a block: the one below holds
    whenever the one above does), and either their footprints overlap by ``site_overlap`` or
    more or the sequence says so by itself (:func:`sequence_stacked`: a footprint on an arm
    may miss the block below).

    An upper slot the recording fills once or twice may be full only in episodes that never
    act at the slot below it (random-23 clean: level 1 of region 0, stated in two episodes
    that never act at level 0, was read full in all 120 frames of the others, 78 of them
    over a bare region). With ``presence`` and ``trust`` (of
    :func:`~vggc_cp.vision.occupancy.settle`), ``a``'s trusted reading (trust at least
    :data:`STACK_TRUST`) then stands in for its labels where the actions leave it unstated
    (:func:`read_labels`), for footprints that overlap: the stack is taken where its odds
    (:func:`stack_odds`) beat those of the reverse stack (a reading full in nearly every
    frame says little: the level 1 above would otherwise be "below" its own base).

    Parameters
    ----------
    runs : dict
        Site -> (labels, run, loose, acting) of :func:`~vggc_cp.vision.occupancy.settle`.
    presence, trust : ndarray, shape (N, A), optional
        The sites' presence and its trust, as read (:func:`~vggc_cp.vision.occupancy.settle`).
    """
    read = {} if presence is None or trust is None else \
        {a: read_labels(la, presence[:, a], trust[:, a]) for a, (la, *_) in runs.items()}
    out: dict[int, list[int]] = {}
    for a, (la, run_a, _, acting) in runs.items():
        for b, (lb, run_b, _, _) in runs.items():
            if b == a or b in acting:
                continue
            if _full_only_on(la, lb) is not None and \
                    (ov[a, b] >= site_overlap or sequence_stacked(la, lb, run_b)):
                out.setdefault(a, []).append(b)
            elif read and ov[a, b] >= site_overlap:
                up = stack_odds(read[a], lb, run_b)
                if up > max(stack_odds(read[b], la, run_a), 0.0):
                    out.setdefault(a, []).append(b)
    return out


def stacked_sites(above: dict[int, list[int]], n: int) -> np.ndarray:
    """Which of ``n`` sites stand in a stack, under another (a key of ``above``, as
    :func:`slots_above` gives it) or on one (one of its values), bool shape ``(n,)``.

    >>> stacked_sites({0: [2]}, 4).tolist()
    [True, False, True, False]
    """
    out = np.zeros(n, dtype=bool)
    out[[int(s) for s in above] + [int(b) for on in above.values() for b in on]] = True
    return out


def _full_only_on(la: np.ndarray, lb: np.ndarray) -> np.ndarray | None:
    """Where labels ``la`` and ``lb`` both state their sites and ``b`` holds something (bool
    mask), if ``b`` holds something only where ``a`` does and ``a`` holds something with
    ``b`` empty at least once (a block on a block); else None."""
    both = (la != UNLABELLED) & (lb != UNLABELLED)
    full_b = both & (lb >= 0)
    if not full_b.any() or not (la[full_b] >= 0).all() or \
            not ((la >= 0) & (lb == EMPTY) & both).any():
        return None
    return full_b


def read_labels(labels: np.ndarray, presence: np.ndarray, trust: np.ndarray,
                min_trust: float = STACK_TRUST) -> np.ndarray:
    """A site's labels, with its reading where the actions leave it unstated and the reading
    is trusted at ``min_trust`` or more (full: colour 0 stands for any colour).

    >>> read_labels(np.array([0, UNLABELLED, UNLABELLED, UNLABELLED]),
    ...             np.array([1.0, 0.9, 0.1, 0.9]), np.array([1.0, 0.8, 0.8, 0.2])).tolist()
    [0, 0, -1, -2]
    """
    out = labels.copy()
    loose = (labels == UNLABELLED) & (trust >= min_trust)
    out[loose] = np.where(presence[loose] > 0.5, 0, EMPTY)
    return out


def stack_odds(la: np.ndarray, lb: np.ndarray, run_b: np.ndarray) -> float:
    """Log-odds that site ``b`` is stacked on site ``a`` from their labels: 0 unless ``b``
    holds something only where ``a`` does and ``a`` holds something with ``b`` empty at
    least once; else ``k ln(1/q)`` for ``k`` separate runs of ``b`` filled (with ``a``
    full) and ``a`` full in a share ``q`` of its labelled frames, as in
    :func:`sequence_stacked`.

    >>> la = np.array([0, 0, 0, -1]); lb = np.array([0, -1, -1, -1])
    >>> round(stack_odds(la, lb, np.arange(4)), 3)        # k = 1, q = 3/4
    0.288
    >>> stack_odds(lb, la, np.arange(4))                  # the reverse: never
    0.0
    """
    full_b = _full_only_on(la, lb)
    if full_b is None:
        return 0.0
    q = float(np.mean(la[la != UNLABELLED] >= 0))
    return len(np.unique(run_b[full_b])) * float(np.log(1.0 / q))


def sequence_stacked(la: np.ndarray, lb: np.ndarray, run_b: np.ndarray) -> bool:
    """Whether the stated frames alone take site ``b`` for one stacked on site ``a``.

    ``b`` never holds something without ``a`` (checked by :func:`slots_above`). By chance,
    an unrelated ``a`` holds something in a share ``q`` of its stated frames, so ``k``
    separate times that ``b`` is filled with ``a`` full (runs of ``b`` between actions at
    it) are ``(1/q)^k`` times likelier from a stack, taken at odds of
    :data:`~vggc_cp.vision.slots.TWIN_ODDS` (20 to 1) as the sequence's twins are.

    >>> la = np.array([0, 0, 0, 0, -1, -1]); lb = np.array([0, -1, 0, -1, -1, -1])
    >>> sequence_stacked(la, lb, np.array([0, 1, 2, 3, 4, 4]))   # q = 4/6, k = 2: 2.25 < 20
    False
    >>> la = np.array([0] * 6 + [-1] * 10); lb = np.array([0, -1] * 3 + [-1] * 10)
    >>> sequence_stacked(la, lb, np.arange(16))                   # q = 6/16, k = 3: 19 < 20
    False
    """
    stated_a = la != UNLABELLED
    if not stated_a.any():
        return False
    q = float(np.mean(la[stated_a] >= 0))
    if not 0 < q < 1:
        return False
    k = len(np.unique(run_b[stated_a & (lb >= 0)]))
    return bool(odds_met(k, q))
