"""The colour of a site's unlabelled runs: what its window shows, or, where its pixels are no
reading of it, what its stated runs hold (beyond the paper).

Between two actions at a site nothing changes there, so a run of frames that no action of its
episode labels holds one object (:func:`vggc_cp.vision.occupancy.settle`). A run the hand's
pose reads takes the colour its window shows (:func:`window_colour`); a site whose pixels read
its colour no better than saying the colour most of its stated runs hold gives its other
unread runs the stated shares of the colours (:func:`majority_colour`). Nothing reads action
names or ground-truth states.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.vision.covered import covered_frames
from vggc_cp.vision.density import kernel_posterior
from vggc_cp.vision.trust import run_colour_kappa, stated_colours


def window_colour(posterior: np.ndarray, looks: dict, examples: list[list[np.ndarray]],
                  bandwidth: float) -> dict[int, set[int]]:
    """Colour of the unlabelled runs of the sites read per pose, in place.

    The colours' examples are what the labelled frames show in the sites' windows
    (:func:`~vggc_cp.vision.untouched.window_chroma`, frames whose pose reads the site and
    that read present); a run takes the mean posterior of its frames that show an object,
    weighted by their strength. Nothing changes where a colour has fewer than two examples
    or a run no such frame.

    Parameters
    ----------
    posterior : ndarray, shape (N, A, C)
    looks : dict
        Site -> (chroma (N, 2), strength (N,), shows (N,) bool, run (N,), loose).
    examples : list of list of ndarray
        Per colour, the chroma arrays of its examples.
    bandwidth : float

    Returns
    -------
    dict
        Site -> the ids of the runs it set.
    """
    done: dict[int, set[int]] = {}
    pooled = [np.concatenate(parts) if parts else np.zeros((0, 2)) for parts in examples]
    if min(len(p) for p in pooled) < 2:
        return done
    for a, (chroma, strength, shows, run, loose) in looks.items():
        seen = loose[shows[loose]]
        if not len(seen):
            continue
        post = kernel_posterior(chroma[seen], pooled, bandwidth)
        done[int(a)] = {int(r) for r in np.unique(run[seen])}
        for r in np.unique(run[seen]):
            these = run[seen] == r
            w = strength[seen][these]
            posterior[loose[run[loose] == r], a] = np.average(post[these], axis=0, weights=w)
    return done


def majority_colour(posterior: np.ndarray, seen: np.ndarray, presence: np.ndarray,
                    runs: dict, above: dict[int, list[int]] | None = None,
                    read: dict[int, set[int]] | None = None) -> dict[int, np.ndarray]:
    """What colour the unread runs of a site hold when its pixels are no reading of it, in
    place: the colour as :func:`~vggc_cp.vision.occupancy.majority_guess` takes the presence.

    A site's pixels read its colour (``seen``, the posterior before the run means); judged
    one vote a stated run (:func:`~vggc_cp.vision.trust.run_colour_kappa`, on the frames no
    slot above covers), a reading that agrees with what the actions state no more often than
    saying the colour most stated runs hold (kappa at most 0) is not a reading of the site.
    On a robot's camera the footprint of a site may lie on the arm and read its grey for
    every colour, a vote of the same colour whatever the site holds; the run's mean of such
    a posterior (near one half each) was a coin toss that the object counts then settled
    either way (multifruit-4x6 robot s364, draw 38: two places never acted on in two
    episodes took each other's colours, and the graph split three states). Such a site's
    unlabelled runs, uncovered throughout and not read by a window
    (``read``, :func:`window_colour`), take the shares of the colours its stated runs hold
    (one each, half a run added to every colour), which the counts
    (:func:`~vggc_cp.vision.conservation.conserve`) may still overrule. Sites whose stated
    runs hold one colour (nothing judged) keep their pixels.

    Parameters
    ----------
    posterior, seen : ndarray, shape (N, A, C)
    presence : ndarray, shape (N, A)
    runs : dict
        Site -> (labels, run, loose, acting) of :func:`~vggc_cp.vision.occupancy.settle`.
    above : dict, optional
        Site -> sites stacked on it (:func:`~vggc_cp.vision.stacks.slots_above`).
    read : dict, optional
        Site -> ids of the runs a window read (:func:`window_colour`).

    Returns
    -------
    dict
        Site -> the colour shares its runs took, where it took them.

    Examples
    --------
    A site whose pixels always read colour 0, stated 0 in one run and 1 in three: no
    reading; its unlabelled run (frames 4-5) takes the stated shares.

    >>> labels = np.array([0, 1, 1, 1, -2, -2])
    >>> run, loose = np.array([0, 1, 2, 3, 4, 4]), np.array([4, 5])
    >>> seen = np.tile([[[0.6, 0.4]]], (6, 1, 1))
    >>> post = seen.copy()
    >>> out = majority_colour(post, seen, np.ones((6, 1)), {0: (labels, run, loose, None)})
    >>> np.round(post[4, 0], 3).tolist()
    [0.3, 0.7]
    """
    out: dict[int, np.ndarray] = {}
    n_col = posterior.shape[2]
    if n_col < 2:
        return out
    for a, (labels, run, loose, _) in runs.items():
        if not len(loose):
            continue
        tops = (above or {}).get(a, [])
        clear = ~covered_frames(presence, tops) if tops else np.ones(len(labels), dtype=bool)
        kappa, _, _ = run_colour_kappa(labels, run, clear, seen[:, a])
        if not np.isfinite(kappa) or kappa > 0.0:
            continue
        truth = stated_colours(labels, run, clear)
        shares = (np.bincount(truth, minlength=n_col) + 0.5) / (len(truth) + 0.5 * n_col)
        done = (read or {}).get(a, set())
        ids, inv = np.unique(run[loose], return_inverse=True)
        groups = np.split(loose[np.argsort(inv, kind="stable")],
                          np.cumsum(np.bincount(inv))[:-1])
        for r, members in zip(ids.tolist(), groups):
            if r not in done and clear[members].all():
                posterior[members, a] = shares
        out[int(a)] = shares
    return out
