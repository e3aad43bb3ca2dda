"""Covered slots: the colour of a slot while another slot stacked on it holds something.

While a slot above holds an object, the slot below is read from pixels that object covers,
and its colour mostly reads the top object's. Between two actions at the slot it holds one
object, so a run of its frames that is uncovered somewhere takes the colour those frames
read (:func:`uncovered_colour`). A run covered throughout (:func:`covered_runs`) has no
such frame. How far a reading of those runs can be trusted is measured the way every
reading here is, against what the actions state
(:func:`~vggc_cp.vision.trust.run_colour_kappa` on the covered frames: the covered runs
whose colour the episode's actions state, one vote each). On stacks three high of two
colours (random-1082, draw 37) the covered pixels agreed with the stated colour at or below
chance (kappa -0.7 to 0.1): the order of a stack's lower objects was a coin toss, the
graph merged stack orders consistently, and nothing else the tool measured disagreed.

A camera that sees the stack from the side sees its lower objects below the top one, and
the look of the whole stack depends on every level's colour: the covered frames whose
colour the actions state are looks of their stacks, and a run covered throughout takes the
colours of its frames' nearest such looks where those read better, judged the same way
(:func:`nearest_covered`). Whichever reading a run took, :func:`covered_trust` carries its
measured agreement, and its lower confidence bound, onto the runs it decided, so the read
doubts (:mod:`vggc_cp.solvers.read_doubts`) see the ones that are no reading. Nothing reads
action names or ground-truth states.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.vision.stacks import slots_above
from vggc_cp.vision.trust import READ_Z, kappa_lower, run_colour_kappa


def covered_frames(presence: np.ndarray, tops: list[int]) -> np.ndarray:
    """Where a slot is covered: some slot stacked on it holds something (presence at least
    1/2 at one of the sites ``tops``), bool shape ``(N,)``.

    >>> covered_frames(np.array([[0.0, 0.9], [0.0, 0.2]]), [1]).tolist()
    [True, False]
    """
    return (np.asarray(presence)[:, tops] >= 0.5).any(axis=1)


def covered_runs(presence: np.ndarray, a: int, covered: np.ndarray, run: np.ndarray,
                 loose: np.ndarray) -> list[np.ndarray]:
    """The unlabelled runs of site ``a`` (observations ``loose``, run ids ``run``) that are
    covered in every frame (``covered``, :func:`covered_frames`) and read full: those whose
    colour no uncovered frame reads.

    >>> presence = np.array([[1.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]])
    >>> [m.tolist() for m in covered_runs(presence, 0, covered_frames(presence, [1]),
    ...                                   np.array([0, 0, 1, 2]), np.arange(4))]
    [[0, 1]]
    """
    out = []
    for r in np.unique(run[loose]):
        members = loose[run[loose] == r]
        if covered[members].all() and np.median(presence[members, a]) >= 0.5:
            out.append(members)
    return out


def _stacked_under(above: dict[int, list[int]], runs: dict, presence: np.ndarray):
    """Every site with a slot stacked on it and unlabelled frames: ``(a, tops, labels, run,
    loose, covered)`` (``runs[a]``'s labels, runs and unlabelled frames, and
    :func:`covered_frames`)."""
    for a, tops in above.items():
        labels, run, loose, _ = runs[a]
        if len(loose) and tops:
            yield a, tops, labels, run, loose, covered_frames(presence, tops)


def uncovered_colour(presence: np.ndarray, posterior: np.ndarray, seen: np.ndarray,
                     runs: dict, ov: np.ndarray, site_overlap: float,
                     above: dict[int, list[int]] | None = None) -> None:
    """The colour of a covered slot's unlabelled runs from its uncovered frames, in place.

    Between two actions at a slot what it holds does not change, but while another slot
    above it holds something its colour is read from pixels the object on top covers
    (:func:`~vggc_cp.vision.stacks.slots_above`). A run of a site that is uncovered in some
    of its frames (every site above it empty there, presence below 1/2) takes the mean
    colour those frames read (``seen``, the posterior before the run means); a run covered
    throughout keeps its mean.
    """
    above = slots_above(runs, ov, site_overlap) if above is None else above
    for a, _, _, run, loose, covered in _stacked_under(above, runs, presence):
        for r in np.unique(run[loose]):
            members = loose[run[loose] == r]
            clear = members[~covered[members]]
            if 0 < len(clear) < len(members):
                posterior[members, a] = seen[clear, a].mean(axis=0)


def covered_trust(presence: np.ndarray, seen: np.ndarray, runs: dict,
                  above: dict[int, list[int]], trust: np.ndarray, trust_low: np.ndarray,
                  z: float = READ_Z, read: dict | None = None
                  ) -> dict[int, tuple[float, float]]:
    """Trust the runs covered throughout (:func:`covered_runs`) as far as the reading of
    their colour agrees with the stated colours, in place: in ``trust`` (shape (N, A)) no
    more than its kappa, in ``trust_low`` no more than its lower confidence bound
    (:func:`~vggc_cp.vision.trust.kappa_lower`, at ``z``). The reading is the covered pixels'
    (:func:`~vggc_cp.vision.trust.run_colour_kappa` of ``seen``) or, for a site in ``read``, the nearest
    looks' (its (kappa, majority, votes), :func:`nearest_covered`). Sites with one colour
    (``seen`` of one column), or none of whose covered runs is stated, are left as they
    are.

    Returns
    -------
    dict
        Site -> (kappa, bound) it was given (those it lowered).
    """
    out: dict[int, tuple[float, float]] = {}
    if seen.shape[2] < 2:
        return out
    for a, _, labels, run, loose, covered in _stacked_under(above, runs, presence):
        if read and a in read:
            kappa, m, n = read[a]
        else:
            kappa, m, n = run_colour_kappa(labels, run, covered, seen[:, a])
        if not np.isfinite(kappa):
            continue
        low = float(kappa_lower(kappa, m, n, z))
        todo = covered_runs(presence, a, covered, run, loose)
        for members in todo:
            trust[members, a] = np.minimum(trust[members, a], kappa)
            old = trust_low[members, a]
            trust_low[members, a] = np.where(np.isnan(old), low, np.minimum(old, low))
        if todo:
            out[int(a)] = (kappa, low)
    return out


#: Nearest stated looks a covered frame votes with (:func:`nearest_covered`).
NEAREST_COVERED = 3


def _votes(a: np.ndarray, b: np.ndarray, told_run: np.ndarray, told_col: np.ndarray,
           own_run: np.ndarray | None, n_col: int, k: int) -> np.ndarray:
    """Colour votes (shape (F, n_col)) of the looks ``a`` (shape (F, P)): each one's ``k``
    nearest stated covered looks ``b`` (shape (T, P); runs ``told_run``, colours
    ``told_col``), never of its own run (``own_run``)."""
    d = np.maximum((a * a).sum(axis=1)[:, None] + (b * b).sum(axis=1)[None, :]
                   - 2.0 * (a @ b.T), 0.0)
    if own_run is not None:
        d[own_run[:, None] == told_run[None, :]] = np.inf
    kk = min(k, d.shape[1])
    near = np.argsort(d, axis=1, kind="stable")[:, :kk]
    ok = np.take_along_axis(np.isfinite(d), near, axis=1)
    out = np.zeros((len(a), n_col))
    for j in range(kk):
        np.add.at(out, (np.arange(len(a))[ok[:, j]], told_col[near[ok[:, j], j]]), 1.0)
    return out


def nearest_covered(x: np.ndarray, maps: np.ndarray, presence: np.ndarray,
                    posterior: np.ndarray, seen: np.ndarray, runs: dict,
                    above: dict[int, list[int]], k: int = NEAREST_COVERED,
                    z: float = READ_Z) -> dict[int, tuple[float, float, int]]:
    """The colour of the runs covered throughout from the nearest stated covered looks, in
    place, where that reads better than the covered pixels.

    A stack seen from the side shows its lower objects below the top one, and which colours
    it shows where depends on every level: a covered frame whose colour the actions state
    is a look of its stack. Each frame of an unlabelled run covered throughout votes with
    the colours of its ``k`` nearest such frames (squared differences over the footprints
    of the slot and the slots above it, ``maps`` > 0); the run takes the vote shares. The
    same vote for every stated covered run, from the other runs' frames only, is judged
    against its stated colour (:func:`~vggc_cp.vision.trust.run_colour_kappa`'s kappa, one vote a run); the
    looks replace the covered pixels' colour where their lower bound at ``z`` shows them
    better than chance (above 0) and beats the pixels' bound. (random-10 robot, tuning
    split: looks judged at kappa 0 to 0.45, bounds below 0, took the place of pixels judged
    at -0.2 to -1.7; neither is a reading, and the switch made a right graph a quiet miss.)

    Returns
    -------
    dict
        Site -> (kappa, majority, votes) of the looks' reading, where it was taken.
    """
    out: dict[int, tuple[float, float, int]] = {}
    n_col = posterior.shape[2]
    if n_col < 2 or maps is None or x is None:
        return out
    for a, tops, labels, run, loose, covered in _stacked_under(above, runs, presence):
        todo = covered_runs(presence, a, covered, run, loose)
        told = np.flatnonzero((labels >= 0) & covered)
        if not todo or len(np.unique(run[told])) < 2:
            continue
        window = (maps[[a, *tops]] > 0).any(axis=0)
        known = _looks(x, told, window)
        # each stated covered frame's vote from the other runs, judged one vote a run
        votes = np.zeros((len(labels), n_col))
        votes[told] = _votes(known, known, run[told], labels[told], run[told], n_col, k)
        kappa, m, n = run_colour_kappa(labels, run, covered, votes)
        if not np.isfinite(kappa):
            continue
        own, own_m, own_n = run_colour_kappa(labels, run, covered, seen[:, a])
        low = float(kappa_lower(kappa, m, n, z))
        if low <= 0.0 or (np.isfinite(own) and low <= kappa_lower(own, own_m, own_n, z)):
            continue
        for members in todo:
            v = _votes(_looks(x, members, window), known, run[told], labels[told], None,
                       n_col, k).sum(axis=0)
            posterior[members, a] = (v + 0.5) / (v.sum() + 0.5 * n_col)
        out[int(a)] = (kappa, m, n)
    return out


def _looks(x: np.ndarray, idx: np.ndarray, window: np.ndarray) -> np.ndarray:
    """The frames ``idx`` of ``x`` (shape (N, H, W, 3)) in the pixels ``window``, flat:
    shape (len(idx), 3 * window.sum()), float64."""
    return x[idx][:, window].reshape(len(idx), -1).astype(np.float64)
