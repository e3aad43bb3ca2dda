"""Stacks: which slot stands on which, as the actions state it (and trusted readings
confirm where they cannot).

A block on a block: the slot above holds something only when the slot below does. Which site
is stacked on which is read from the sites' labels
(:func:`~vggc_cp.vision.occupancy.site_labels`), the footprints' overlaps and the sequence
(:func:`slots_above`, :func:`sequence_stacked`); where no frame states both slots, from the
lower slot's trusted reading (:func:`read_labels`, :func:`stack_odds`); where neither says it,
from the footprints' geometry: a known stack continued by one more step of its direction and
length (:func:`column_steps`). The stacks feed the
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


#: Least cosine between a known stack's step (the footprint centroid of the slot below to that
#: of the slot above) and the step a column is continued by (:func:`column_steps`).
COLUMN_COS = 0.9
#: The continued step's length over the known one's, at least and at most: perspective and a
#: footprint on an arm change it (blocks-3 robot s425: 0.64), but no slot is half a level up,
#: and two levels at once would be twice the step.
COLUMN_RATIO = (0.5, 1.5)


def centroids(maps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each footprint's centre of mass (row, column) and its mass, shapes ``(A, 2)`` and
    ``(A,)`` (negative weights count as none; a footprint of no mass is centred at 0, 0).

    >>> m = np.zeros((2, 4, 4)); m[0, 1, 2] = 1.0; m[0, 3, 2] = 1.0
    >>> c, mass = centroids(m)
    >>> c[0].tolist(), mass.tolist()
    ([2.0, 2.0], [2.0, 0.0])
    """
    m = np.clip(np.asarray(maps, dtype=np.float64), 0.0, None)
    h, w = m.shape[1:]
    mass = m.sum(axis=(1, 2))
    rows = (m.sum(axis=2) * np.arange(h)).sum(axis=1)
    cols = (m.sum(axis=1) * np.arange(w)).sum(axis=1)
    centre = np.stack([rows, cols], axis=1) / np.maximum(mass, 1e-12)[:, None]
    return centre, mass


def column_steps(above: dict[int, list[int]], runs: dict, ov: np.ndarray, site_overlap: float,
                 maps: np.ndarray, presence: np.ndarray | None = None,
                 trust: np.ndarray | None = None) -> dict[int, list[int]]:
    """``above`` (:func:`slots_above`) with each known stack continued upward by a slot no
    frame states together with its top.

    :func:`slots_above` needs frames where the actions state both slots. A slot of the third
    level that only episodes acting there reach -- they start with two blocks in the column
    and loop a place and a pick on top -- is never stated with the level below, so nothing
    says it stands on it; its frames' reading of that level (an arm hiding it) then sets
    what they hold, and the readings can put a whole episode one block off at sites they
    trust (blocks-3 robot s425 and s429: two silent misses of draws 48 and 49). A camera sees
    a column of slots as steps of one direction and about one length: where site ``a`` is
    known below ``b``, a site ``c`` whose footprint overlaps ``b``'s by ``site_overlap`` or
    more and whose centroid is one more step on -- the step from ``b`` to ``c`` at a cosine
    of at least :data:`COLUMN_COS` to the step from ``a`` to ``b`` (:func:`centroids`), its
    length within :data:`COLUMN_RATIO` of it -- stands on ``b``, with the sites acting at its
    slot, unless

    * some frame states both ``b`` and ``c`` (then the labels have had their say),
    * ``c`` is known to stand on a slot other than ``a``'s (another column), or
    * ``b``'s trusted reading (at least :data:`STACK_TRUST`) is empty in most frames where
      ``c`` is stated full and ``b`` is not stated.

    Only images and the actions' footprints are read, never action names.

    Parameters
    ----------
    above : dict
        Site -> sites stacked on it (:func:`slots_above`).
    runs : dict
        Site -> (labels, run, loose, acting) of :func:`~vggc_cp.vision.occupancy.settle`.
    ov : ndarray, shape (A, A)
        Footprint overlaps.
    site_overlap : float
    maps : ndarray, shape (A, H, W)
        The action footprints.
    presence, trust : ndarray, shape (N, A), optional
        The sites' presence and its trust, as read.

    Returns
    -------
    dict
        A new mapping; ``above`` is not changed.

    Examples
    --------
    Sites 0, 1 and 2 are one column, 3 px a level; 0 is known below 1, and 2 is never
    stated with 1: it stands on 1. Site 3, as far off to the side, does not.

    >>> u, e = -2, -1
    >>> maps = np.zeros((4, 12, 12)); maps[0, 9, 5] = maps[1, 6, 5] = maps[2, 3, 5] = 1
    >>> maps[3, 6, 8] = 1
    >>> ov = np.ones((4, 4))
    >>> lab = [np.array(v) for v in ([0, 0, u, u], [e, 0, u, u], [u, u, 0, e], [u, u, 0, e])]
    >>> runs = {a: (lab[a], np.arange(4), np.zeros(0, int), np.array([a])) for a in range(4)}
    >>> column_steps({0: [1]}, runs, ov, 0.2, maps)
    {0: [1], 1: [2]}
    """
    centre, mass = centroids(maps)
    out = {a: list(on) for a, on in above.items()}
    for _ in range(len(runs)):            # a continued column may be continued again
        more = _continued(out, runs, ov, site_overlap, centre, mass, presence, trust)
        if more == out:
            break
        out = more
    return out


def _continued(above, runs, ov, site_overlap, centre, mass, presence, trust):
    """One pass of :func:`column_steps` over ``above`` (a new mapping)."""
    under: dict[int, set[int]] = {}
    for a, on in above.items():
        for b in on:
            under.setdefault(int(b), set()).add(int(a))
    out = {a: list(on) for a, on in above.items()}
    for a, on in above.items():
        for b in on:
            if a not in runs or b not in runs or mass[a] <= 0 or mass[b] <= 0:
                continue
            step = centre[b] - centre[a]
            length = float(np.linalg.norm(step))
            if length <= 0:
                continue
            lb, _, _, acting_b = runs[b]
            for c, (lc, _, _, acting_c) in runs.items():
                if c == a or c in acting_b or mass[c] <= 0 or ov[b, c] < site_overlap or \
                        c in out.get(b, []) or not under.get(c, set()) <= set(runs[a][3]):
                    continue
                ahead = centre[c] - centre[b]
                far = float(np.linalg.norm(ahead))
                if far <= 0 or ahead @ step / (far * length) < COLUMN_COS or \
                        not COLUMN_RATIO[0] <= far / length <= COLUMN_RATIO[1]:
                    continue
                if ((lb != UNLABELLED) & (lc != UNLABELLED)).any():
                    continue
                if presence is not None and trust is not None:
                    sure = (lc >= 0) & (lb == UNLABELLED) & (trust[:, b] >= STACK_TRUST)
                    if sure.any() and np.mean(presence[sure, b] < 0.5) > 0.5:
                        continue
                for d in (c, *acting_c):
                    if int(d) not in out.get(b, []) and int(d) not in acting_b:
                        out.setdefault(b, []).append(int(d))
    return out
