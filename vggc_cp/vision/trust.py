"""How far a site's reading can be trusted (beyond the paper).

Where the actions of an episode do not state what a site holds, the images read it
(:func:`vggc_cp.vision.occupancy.settle`). Every such reading is judged against the frames
whose actions do state it: its agreement beyond chance (Cohen's kappa against saying what
most stated frames hold, :func:`reading_kappa`), and, because a kappa judged on a few dozen
frames is itself uncertain, the lower confidence bound of that kappa (:func:`kappa_lower`).
A run that a reading per pose of the hand set is bounded by the stated frames of the poses
that read it (:func:`pose_bounds`). The doubts (:mod:`vggc_cp.solvers.read_doubts`) decide
on these bounds.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.vision.slots import UNLABELLED
from vggc_cp.vision.untouched import share_right

#: How sure a reading's agreement must be before it settles anything: the one-sided normal
#: quantile of the lower confidence bound taken on its kappa (1.645: 95 %).
READ_Z = 1.645


def kappa_lower(kappa, majority, n, z: float = READ_Z):
    """A lower confidence bound on a reading's kappa, from the number of frames ``n`` it was
    judged on.

    ``kappa = (p - m) / (1 - m)`` for agreement ``p`` with ``n`` stated frames of which the
    most common presence takes the share ``m``; the bound is that of ``p`` (Wilson's score
    interval, one-sided at the normal quantile ``z``) carried through. Infinite and NaN
    kappas (a site stated everywhere, or never) stay as they are; ``z = 0`` gives ``kappa``.

    >>> round(float(kappa_lower(0.647, 0.72, 43)), 3)
    0.289
    >>> float(kappa_lower(np.inf, 0.5, 10))
    inf
    """
    kappa, m, n = (np.asarray(v, dtype=np.float64) for v in (kappa, majority, n))
    if z <= 0:
        return kappa
    finite = np.isfinite(kappa) & (n > 0) & (m < 1.0)
    m_ = np.where(finite, m, 0.0)
    p = np.clip(m_ + np.where(finite, kappa, 0.0) * (1.0 - m_), 0.0, 1.0)
    n_ = np.maximum(n, 1.0)
    z2 = z * z
    lo = (p + z2 / (2 * n_) - z * np.sqrt(p * (1 - p) / n_ + z2 / (4 * n_ * n_))) / (1 + z2 / n_)
    return np.where(finite, (lo - m_) / np.maximum(1.0 - m_, 1e-12), kappa)


def stated_shares(held: np.ndarray, stated: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How many stated frames judge each site's reading, and the share among them of the
    commoner of full and empty (``majority`` of :func:`kappa_lower`); shapes (S,).

    >>> n, share = stated_shares(np.array([[0, 2], [1, 0], [1, 1]]),
    ...                          np.array([[True, True], [True, False], [True, False]]))
    >>> n.tolist(), share.round(2).tolist()
    ([3, 1], [0.67, 1.0])
    """
    held, stated = np.asarray(held), np.asarray(stated, dtype=bool)
    n_stated = stated.sum(axis=0)
    full = np.where(stated, held > 0, False).sum(axis=0) / np.maximum(n_stated, 1)
    return n_stated, np.maximum(full, 1.0 - full)


def reading_kappa(agreement_: float | None, labels: np.ndarray) -> float:
    """Agreement of a site's reading with its stated frames beyond chance (Cohen's kappa
    against saying what most stated frames hold).

    ``(p - m) / (1 - m)``, with ``p`` the share of stated frames the reading agrees with
    (:func:`~vggc_cp.vision.untouched.agreement`, held out for a pose reading) and ``m`` the share of the most common
    presence among them: 1 for a reading that is always right, 0 for one no better than the
    majority, negative below it. 0 when the site's unread runs take the majority
    (``agreement_`` None: no reading) or when every stated frame holds one presence (a
    reading never seen to tell the two apart); NaN when nothing is stated. A node that only
    such readings set apart from another (Landis and Koch 1977 call kappa below 0.6
    moderate agreement at best) is a doubt, :func:`vggc_cp.solvers.read_doubts.read_doubts`.

    >>> round(reading_kappa(0.8, np.array([0, 0, 0, -1, -2])), 3)   # majority 3/4
    0.2
    >>> reading_kappa(None, np.array([0, -1]))
    0.0
    """
    majority = majority_share(labels)
    if majority is None:
        return float("nan")
    if agreement_ is None or majority >= 1.0:
        return 0.0
    return float((agreement_ - majority) / (1.0 - majority))


def majority_share(labels: np.ndarray) -> float | None:
    """The share of a site's stated frames that hold its most common presence (empty or
    occupied); None where nothing is stated.

    >>> majority_share(np.array([0, 0, 0, -1, -2])), majority_share(np.array([-2]))
    (0.75, None)
    """
    known = labels != UNLABELLED
    if not known.any():
        return None
    full = float(np.mean(labels[known] >= 0))
    return max(full, 1.0 - full)


def run_colour_kappa(labels: np.ndarray, run: np.ndarray, frames: np.ndarray,
                     seen: np.ndarray) -> tuple[float, float, int]:
    """How well a colour reading tells a slot's colour: Cohen's kappa of the colour each run
    reads against the colour its episode's actions state.

    Each run of the slot (observations between two actions at it) with frames among
    ``frames`` whose colour the actions state casts one vote: the colour of largest mean
    posterior over those frames (``seen``, before any run means), right or wrong. Frames of
    one run are one look and are not counted apart.

    Parameters
    ----------
    labels : ndarray of int, shape (N,)
        :func:`~vggc_cp.vision.occupancy.site_labels` (a colour, empty or unlabelled).
    run : ndarray of int, shape (N,)
    frames : ndarray of bool, shape (N,)
        The frames the reading is judged on (those a slot above covers,
        :func:`~vggc_cp.vision.covered.covered_frames`, or those none covers).
    seen : ndarray, shape (N, C)
        The site's colour posterior per frame.

    Returns
    -------
    kappa : float
        ``(p - m) / (1 - m)`` for the share ``p`` of right votes and the share ``m`` of the
        most common stated colour; NaN where no such run is stated, or all stated ones hold
        one colour (nothing shown either way).
    majority : float
        ``m``.
    n : int
        The votes.

    >>> labels = np.array([0, 0, 1, 1, 0, 1])
    >>> seen = np.array([[.9, .1], [.8, .2], [.2, .8], [.3, .7], [.1, .9], [.9, .1]])
    >>> k, m, n = run_colour_kappa(labels, np.arange(6), np.ones(6, bool), seen)
    >>> round(k, 3), m, n     # 4 of 6 right, against 1/2 by saying one colour
    (0.333, 0.5, 6)
    """
    told = (np.asarray(labels) >= 0) & np.asarray(frames, dtype=bool)
    ids, inv = np.unique(run[told], return_inverse=True)
    if not len(ids):
        return float("nan"), 1.0, 0
    truth = stated_colours(labels, run, told)
    sums = np.zeros((len(ids), seen.shape[1]))
    np.add.at(sums, inv, seen[told])
    vote = sums.argmax(axis=1)                  # the largest mean is the largest sum
    m = float(np.bincount(truth).max() / len(truth))
    if m >= 1.0:
        return float("nan"), m, len(ids)
    return (float(np.mean(truth == vote)) - m) / (1.0 - m), m, len(ids)


def stated_colours(labels: np.ndarray, run: np.ndarray, told: np.ndarray) -> np.ndarray:
    """The stated colour of every run with a frame among ``told`` (labelled full), in the
    order of the run ids, int64 shape (R,): one per run.

    >>> stated_colours(np.array([1, 1, 0, -1]), np.array([0, 0, 1, 2]), np.ones(4, bool)).tolist()
    [1, 0]
    """
    told = np.asarray(told, dtype=bool) & (np.asarray(labels) >= 0)
    _, first = np.unique(run[told], return_index=True)
    return np.asarray(labels)[told][first].astype(np.int64)


def pose_bounds(right: np.ndarray, weight: np.ndarray, labels: np.ndarray, pose: np.ndarray,
                strength: np.ndarray, run: np.ndarray, loose: np.ndarray,
                z: float = READ_Z) -> dict[int, float]:
    r"""How far each run a pose reading sets can be trusted for sure (``trust_low`` of
    :func:`~vggc_cp.vision.occupancy.settle`).

    A run's reading is the mean of its frames' pose readings weighted by their ``strength``
    (:func:`~vggc_cp.vision.untouched.run_presence`), so its agreement is taken as the same
    mean of its poses' agreements: pose ``b`` agrees on the share ``p_b`` of its ``n_b``
    held-out frames (:func:`~vggc_cp.vision.untouched.held_out_frames`, weighted by
    strength; the majority's share ``m``, no better than chance, where it read none), and
    with ``w_b`` the run's strength in frames of pose ``b``,

    .. math::

        p = \frac{\sum_b w_b p_b}{\sum_b w_b}, \qquad
        n = \frac{(\sum_b w_b)^2}{\sum_b w_b^2 / \max(n_b, 1)},

    the frames a share of that variance would rest on. The bound is the kappa of ``p``
    (:func:`reading_kappa`) carried to its lower bound over ``n`` (:func:`kappa_lower`), at
    least 0. A run one pose reads is bounded by that pose's frames alone: however well the
    site's other poses read, a pose that few stated frames show reading right counts for
    little (random-782 robot); a run several poses read rests on all their frames -- each
    pose's few frames alone would bound it as if it were read once. (21 of the 40 false
    alarms of the tuning split and draws 33-34 at cceb7fa were raised by episode doubts
    alone, many at kappa 1.00 with a bound near 0; this bound removes four of them.)

    >>> labels = np.array([0, 0, -1, -1, -2, -2])
    >>> right = np.array([True, True, True, True, False, False])
    >>> weight = np.array([1.0, 1.0, 1.0, 1.0, 0.0, 0.0])
    >>> pose = np.array([0, 0, 0, 0, 0, 1])
    >>> b = pose_bounds(right, weight, labels, pose, np.ones(6), np.array([0, 0, 0, 0, 1, 1]),
    ...                 np.array([4, 5]))
    >>> round(b[1], 2)      # pose 0 right on its 4 frames, pose 1 read none: chance
    0.0
    """
    m = majority_share(labels)
    if m is None:
        return {}
    share, frames = {}, {}
    for b in np.unique(pose[loose]):
        at = (pose == b) & (weight > 0)
        frames[int(b)] = n_b = int(at.sum())
        share[int(b)] = m if n_b == 0 else share_right(right[at], weight[at])
    out = {}
    for r in np.unique(run[loose]):
        members = loose[run[loose] == r]
        w = strength[members]
        if w.sum() <= 0:
            continue
        poses_, first, at = np.unique(pose[members], return_index=True, return_inverse=True)
        order = np.argsort(first)                        # the poses as the run meets them
        wb = np.bincount(at, weights=w)[order]           # the run's strength per pose
        poses_ = poses_[order]
        pb = np.array([share[int(b)] for b in poses_])
        nb = np.array([max(frames[int(b)], 1) for b in poses_], dtype=np.float64)
        p = float(wb @ pb / wb.sum())
        n = float(wb.sum() ** 2 / (wb ** 2 / nb).sum())
        kappa = 0.0 if m >= 1.0 else (p - m) / (1.0 - m)  # reading_kappa, m known
        out[int(r)] = max(float(kappa_lower(kappa, m, n, z)), 0.0)
    return out
