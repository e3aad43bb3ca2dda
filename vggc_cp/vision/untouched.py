"""Sites no action of an episode touches, read per pose of the hand (beyond the paper).

The actions of an episode say what a site holds wherever they act at it
(:func:`vggc_cp.vision.occupancy.site_labels`); an episode that never acts at a site leaves
it to the pixels. A robot's own camera sees its arm: it rests above the place it last acted
on, it hides or overlaps other places, and it is most of what each transition changes, so a
site's footprint and its one empty look (:mod:`vggc_cp.vision.footprints`) may describe the
arm rather than what the site holds. The labelled frames teach the reading instead:

**Pose.** What the hand does in a frame is set by the action that led to it (a robot that
rests above the place it last acted on, or one that goes home after each action, looks the
same after the same action). The *pose* of an observation is that action (``-1`` for the
first of an episode), or, where the hand rests above the place it acted on (the slots were
read from there, :mod:`vggc_cp.vision.places`) and pooling more frames per pose, the slot and
kind of that action (:func:`pose_groups`: the hand rests alike after every pick at one slot,
whatever it lifted); :func:`vggc_cp.vision.occupancy.settle` lets each site take the one
whose reading agrees best with labels it did not learn from. There, too, an episode's first
frame takes the pose whose mean frame it looks most like (:func:`placed_starts`): the hand
starts an episode resting at some place, and the frame shows which.

**Window.** Among the labelled frames of one pose the arm is the same; the site's pixels
differ by what it holds. ``W(p)``, the mean over the poses of ``|mean occupied - mean empty|``
(summed over the channels) over its standard error (``sqrt(sum_c var_o / n_o + var_e / n_e)``,
at least its median over the image), weighted by ``n_e n_o / (n_e + n_o)``, less its median
over the image, less ``support`` of its peak, on its heaviest connected component, is where
the site shows what it holds (:func:`site_window`): an object differs alike in every frame,
while the edges a shaking camera or a drifting light moves differ by chance, and arm,
lighting and other sites average out.

**Reading.** In a frame of pose ``b``, the deviation from the empty look of that pose,
``m(o) = sum_p W(p) |x_o(p) - e_b(p)|_1``, is scaled as the footprint presence is: 0 at the
median of the pose's empty frames and 1 at ``saturation`` of the way to the median of its
faintest typical object (the colour whose occupied frames deviate least), so that any object
of any class counts as present. An empty frame's own deviation is taken from the mean of the
pose's other empty frames, so that it cannot feign a separation. Each frame weighs
``d_b^2``, the separation of the pose's empty frames from those of the faintest object
(difference of the means over their pooled standard deviation); a pose whose labelled
frames do not show a separation at odds of :data:`READ_ODDS` (an arm that hides the site,
too few frames) weighs nothing. Looks of one kind count once per episode that shows them
(:data:`MIN_LOOKS` episodes of each kind): frames of one episode share its light, its shake
and the rest of its scene, so their spread says nothing of another episode's, and two nearly
equal frames of one run would feign a separation of hundreds of spreads (random-2 robot:
the pose that read region 0 empty under a red apple weighed 10^7, the ones that read it
full about 2). Two looks of a kind still tell a spread poorly (the variance of two falls
below a tenth of the true one one time in four: chi-square of one degree of freedom), so no
pose's looks are taken to vary less than the median over the site's poses says they do, as
the window floors its standard error (random-782 robot: a pose with four labelled frames,
two episodes of each kind, weighed 2600 and read a tomato one region off for a whole
episode; floored, 25). A run of observations between actions at the site holds one thing:
it takes the weighted mean of its frames' readings (:func:`pose_readings`,
:func:`run_presence`).

**Which reading.** Where the footprints already describe the site (a scene without an arm),
their presence is the better reading of one frame; where an arm stands over the site it is
not. The labelled frames tell which: a site takes the pose reading only where it agrees with
the actions' labels on more of them (weighted by strength) than the footprint presence does,
by more than the two shares' noise (:func:`reads_better`), each fifth of the episodes read
with what the other four fifths teach (:func:`held_out_agreement`;
:func:`vggc_cp.vision.occupancy.settle`). Five folds, not two: a pose is taught by the looks
of :data:`MIN_LOOKS` episodes of each kind, and one that a few episodes show can teach from
four fifths of them where half would leave it unread in one half and never judged -- and a
run such a pose reads is bounded by the frames that judged it
(:func:`vggc_cp.vision.trust.pose_bounds`; tuning split, robot look: 9 false alarms then 6,
43 passing runs then 44).

Nothing reads action names or ground-truth states.
"""

from __future__ import annotations

import math

import numpy as np

from vggc_cp.vision.blobs import heaviest_component

#: Fewest labelled frames of each kind a pose needs to teach the reading (of separate
#: episodes, where :func:`pose_readings` is given them).
MIN_LOOKS = 2

#: Folds of the labelled episodes in which the pose readings are judged on frames they did
#: not learn from (:func:`held_out_frames`): each read with what the others teach.
HELD_OUT_FOLDS = 5

#: Odds at which a pose's labelled frames must show a separation for the pose to read the
#: site: ``z^2 / 2 >= ln 20`` for the difference of the means over its standard error, the
#: bar of the warning's description-length margin.
READ_ODDS = 20.0


def poses(actions: np.ndarray, group: np.ndarray | None = None) -> np.ndarray:
    """Pose of every observation, int64 of shape (N,): the action that led to it (or its
    ``group``, :func:`pose_groups`), -1 for the first observation of an episode.

    >>> poses(np.array([3, 1, -1, 2])).tolist()
    [-1, 3, 1, -1, 2]
    >>> poses(np.array([3, 1, -1, 2]), np.array([0, 0, 1, 1])).tolist()
    [-1, 1, 0, -1, 1]
    """
    actions = np.asarray(actions)
    out = np.full(len(actions) + 1, -1, dtype=np.int64)
    out[1:] = actions if group is None else np.where(actions >= 0,
                                                    group[np.maximum(actions, 0)], -1)
    return out


def placed_starts(x: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``pose`` with every episode's first frame (pose -1) given the pose whose mean frame it
    looks most like (mean absolute difference): where the hand rests where it last acted, an
    episode starts with the hand at some place, and its first frame shows which.

    >>> x = np.zeros((4, 1, 1, 3), np.float32); x[1] = x[3] = 1.0
    >>> placed_starts(x, np.array([-1, 5, 6, -1])).tolist()
    [6, 5, 6, 5]
    """
    out = pose.copy()
    first = np.flatnonzero(pose < 0)
    kinds = [b for b in np.unique(pose) if b >= 0]
    if not len(first) or not kinds:
        return out
    flat = x.reshape(len(x), -1)
    means = np.stack([flat[pose == b].mean(axis=0, dtype=np.float64) for b in kinds])
    for i in first:
        out[i] = kinds[int(np.argmin(np.abs(means - flat[i]).mean(axis=1)))]
    return out


def pose_groups(kinds: np.ndarray, twin: np.ndarray, mates: np.ndarray) -> np.ndarray:
    """Actions after which the hand looks alike, int64 of shape (A,): one group per slot
    (an action, its twin and its mates, transitively) and kind. After a pick the hand holds
    what it lifted, after a place it is empty, so the two kinds are never one pose.

    >>> from vggc_cp.trace import PICK, PLACE
    >>> kinds = np.array([PICK, PLACE, PICK, PLACE, PICK])
    >>> mates = np.zeros((5, 5), bool); mates[0, 2] = mates[2, 0] = True
    >>> pose_groups(kinds, np.array([1, 0, 3, 2, -1]), mates).tolist()
    [0, 1, 0, 1, 2]
    """
    from scipy.sparse.csgraph import connected_components

    n = len(kinds)
    link = np.asarray(mates, dtype=bool).copy()
    paired = np.flatnonzero(np.asarray(twin) >= 0)
    link[paired, np.asarray(twin)[paired]] = True
    _, slot = connected_components(link, directed=False)
    keys = [(int(slot[a]), int(kinds[a])) for a in range(n)]
    ids = {k: i for i, k in enumerate(dict.fromkeys(keys))}
    return np.array([ids[k] for k in keys], dtype=np.int64)


def _groups(labels: np.ndarray, pose: np.ndarray, empty: int,
            episode: np.ndarray | None = None):
    """Per pose with enough labelled looks of both kinds: (pose, empty frames, occupied).
    With ``episode``, looks of one kind count once per episode that shows them."""
    for b in np.unique(pose):
        at = pose == b
        e, o = np.flatnonzero(at & (labels == empty)), np.flatnonzero(at & (labels >= 0))
        if episode is not None:
            enough = min(len(np.unique(episode[e])), len(np.unique(episode[o]))) >= MIN_LOOKS
        else:
            enough = min(len(e), len(o)) >= MIN_LOOKS
        if enough:
            yield int(b), e, o


def site_window(x: np.ndarray, labels: np.ndarray, pose: np.ndarray, empty: int,
                support: float, reach: np.ndarray | None = None) -> np.ndarray | None:
    """Where a site shows what it holds (module docstring), shape (H, W), summing to 1.

    Parameters
    ----------
    x : ndarray of float32, shape (N, H, W, 3)
        Working frames.
    labels : ndarray of int, shape (N,)
        :func:`~vggc_cp.vision.occupancy.site_labels` of the site.
    pose : ndarray of int, shape (N,)
        :func:`poses`.
    empty : int
        The label of an empty site.
    support : float
        Share of the peak subtracted.
    reach : ndarray of bool, shape (H, W), optional
        The pixels that acting at the site changes (its actions' footprints): the window
        lies among them. Elsewhere a pixel can only show what merely goes with what the site
        holds -- an object in the hand, another region that the count of objects ties to it.
        The colour windows are read with it and without it
        (:func:`~vggc_cp.vision.colours.window_site_chroma`: a window on the gripper reads
        the arm's grey for every class); the presence readings without it (there the
        footprint, on a robot's camera mostly the arm, left out pixels that read right:
        calibration.md, session 34).

    Returns
    -------
    ndarray or None
        None when no pose has :data:`MIN_LOOKS` labelled frames of each kind, or nothing
        differs (within ``reach``).
    """
    acc = np.zeros(x.shape[1:3], dtype=np.float64)
    total = 0.0
    for _, e, o in _groups(labels, pose, empty):
        w = len(e) * len(o) / (len(e) + len(o))
        diff = np.abs(x[o].mean(axis=0) - x[e].mean(axis=0)).sum(axis=-1)
        # in units of its standard error: a pixel that differs because the camera shakes or
        # the light drifts (a marker's edge) varies within both kinds of frame; an object's
        # pixels differ alike in every frame. The error's floor is its median over the image,
        # so that a pixel that never varies cannot claim certainty.
        err = np.sqrt((x[o].var(axis=0) / len(o) + x[e].var(axis=0) / len(e)).sum(axis=-1))
        acc += w * diff / np.maximum(err, np.median(err) + 1e-6)
        total += w
    if total == 0:
        return None
    m = np.maximum(acc / total - np.median(acc / total), 0.0)
    if reach is not None:
        m = np.where(reach, m, 0.0)
    m = heaviest_component(np.maximum(m - support * m.max(), 0.0))
    s = m.sum()
    return m / s if s > 0 else None


def pose_readings(x: np.ndarray, labels: np.ndarray, pose: np.ndarray, window: np.ndarray,
                  empty: int, saturation: float, episode: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Every observation's reading of the site from its pose (module docstring).

    Parameters
    ----------
    x, labels, pose, empty
        As for :func:`site_window`.
    window : ndarray, shape (H, W)
        :func:`site_window`.
    saturation : float
        Share of the way from the empty to the faintest object's median at which presence
        is 1.
    episode : ndarray of int, shape (N,), optional
        Episode of every observation: a pose then needs labelled frames of each kind from
        :data:`MIN_LOOKS` separate episodes (without it, :data:`MIN_LOOKS` frames).

    Returns
    -------
    reading : ndarray of float64, shape (N,)
        Presence in ``[0, 1]``.
    strength : ndarray of float64, shape (N,)
        ``d_b^2`` of the observation's pose; 0 where the pose cannot read the site: too few
        labelled looks of a kind, or a separation of its labelled frames short of
        :data:`READ_ODDS`. Each pose's variances (of its empty and of its occupied looks)
        are at least the median over the poses of their pooled variance, in ``d_b`` and in
        the odds alike.
    """
    on = window > 0
    weight = window[on]
    pixels = x[:, on]                                                    # (N, P, 3)
    reading = np.zeros(len(x))
    strength = np.zeros(len(x))
    taught = []
    for b, e, o in _groups(labels, pose, empty, episode):
        ref = pixels[e].mean(axis=0)
        dev = lambda idx, ref=ref: np.abs(pixels[idx] - ref).sum(axis=-1) @ weight  # noqa: E731
        # an empty frame is judged on the mean of the others (it would pull its own reference
        # toward itself and feign a separation where the arm hides the site)
        loo = (len(e) * ref - pixels[e]) / (len(e) - 1)
        de = np.abs(pixels[e] - loo).sum(axis=-1) @ weight
        # the faintest typical object: the colour whose occupied frames deviate least
        looks = [dev(o[labels[o] == c]) for c in np.unique(labels[o])
                 if (labels[o] == c).sum() >= MIN_LOOKS] or [dev(o)]
        do = min(looks, key=np.median)
        taught.append((b, de, do, dev))
    # a spread told by a few looks may be far too small (two nearly alike frames feign a
    # separation of thousands of spreads): no pose's looks vary less than the poses'
    # median says the site's looks vary
    floor = float(np.median([0.5 * (de.var() + do.var()) for _, de, do, _ in taught])) \
        if taught else 0.0
    for b, de, do, dev in taught:
        var_e, var_o = max(de.var(), floor), max(do.var(), floor)
        lo, hi = np.median(de), np.median(do)
        spread = np.sqrt(0.5 * (var_e + var_o))
        error = np.sqrt(var_e / len(de) + var_o / len(do))
        z = (do.mean() - de.mean()) / error if error > 0 else 0.0
        if not hi > lo or spread == 0 or z <= 0 or z * z / 2 < math.log(READ_ODDS):
            continue                   # the arm hides the site, or too few frames to tell
        these = np.flatnonzero(pose == b)
        reading[these] = np.clip((dev(these) - lo) / (saturation * (hi - lo)), 0.0, 1.0)
        strength[these] = ((do.mean() - de.mean()) / spread) ** 2
    return reading, strength


def window_chroma(x: np.ndarray, labels: np.ndarray, pose: np.ndarray, window: np.ndarray,
                  empty: int) -> np.ndarray:
    """Chromaticity ``(r, g) / (r + g + b)`` of what deviates from the empty look of its pose
    in the window, for every observation, shape (N, 2); ``nan`` where the observation's pose
    has fewer than :data:`MIN_LOOKS` frames labelled empty.

    The deviating pixels weigh ``W(p) |x_o(p) - e_b(p)|_1``, as the footprints weigh theirs
    (:func:`vggc_cp.vision.footprints.describe`), but against the empty look of the frame's
    own pose: an arm that rests over the site looks the same in both and drops out.

    >>> x = np.zeros((4, 1, 2, 3), np.float32); x[2:, 0, 0] = [0.8, 0.1, 0.1]
    >>> w = np.array([[1.0, 0.0]])
    >>> window_chroma(x, np.array([-1, -1, 0, 0]), np.zeros(4, int), w, -1)[2].round(2).tolist()
    [0.8, 0.1]
    """
    on = window > 0
    weight = window[on]
    pixels = x[:, on]                                                    # (N, P, 3)
    out = np.full((len(x), 2), np.nan)
    for b in np.unique(pose):
        these = np.flatnonzero(pose == b)
        e = these[labels[these] == empty]
        if len(e) < MIN_LOOKS:
            continue
        dev = np.abs(pixels[these] - pixels[e].mean(axis=0)).sum(axis=-1) * weight   # (n, P)
        mean = np.einsum("np,npc->nc", dev, pixels[these])
        mean /= np.maximum(dev.sum(axis=1), 1e-12)[:, None]
        out[these] = mean[:, :2] / np.maximum(mean.sum(axis=1, keepdims=True), 1e-12)
    return out


def agreement(reading: np.ndarray, strength: np.ndarray, labels: np.ndarray,
              empty: int) -> float:
    """Share of the labelled observations (weighted by ``strength``) whose reading says what
    their label says (present above 1/2); 0 when none can be read.

    >>> agreement(np.array([0.9, 0.2, 0.6]), np.array([1.0, 1.0, 2.0]), np.array([0, -1, -1]), -1)
    0.5
    """
    known = (labels == empty) | (labels >= 0)
    w = strength[known]
    if not w.sum() > 0:
        return 0.0
    right = (reading[known] > 0.5) == (labels[known] >= 0)
    return float(np.average(right, weights=w))


def held_out_agreement(x: np.ndarray, labels: np.ndarray, pose: np.ndarray,
                       episode: np.ndarray, empty: int, support: float, saturation: float
                       ) -> float:
    """:func:`agreement` of the pose reading on labelled frames it did not learn from: the
    episodes with labels are dealt into :data:`HELD_OUT_FOLDS` folds (in turn, in order),
    each fold is read with the window and looks the other folds teach, and the folds are
    pooled (0 when nothing can be read; :func:`held_out_frames`). A reading judged on the
    frames that taught it would flatter itself against the footprint presence.

    Parameters
    ----------
    x, labels, pose, empty, support, saturation
        As for :func:`site_window` and :func:`pose_readings`.
    episode : ndarray of int, shape (N,)
        Episode of every observation.
    """
    return share_right(*held_out_frames(x, labels, pose, episode, empty, support, saturation))


def share_right(right: np.ndarray, weight: np.ndarray) -> float:
    """The ``weight``-weighted share of frames read ``right``; 0 when nothing weighs.

    >>> share_right(np.array([True, False, True]), np.array([1.0, 1.0, 0.0]))
    0.5
    """
    total = weight.sum()
    return float((weight * right).sum() / total) if total > 0 else 0.0


def reads_better(held: float, n_held: int, own: float, n_own: int, z: float) -> bool:
    """Whether a pose reading's held-out agreement ``held`` (over ``n_held`` judged frames)
    beats the footprint presence's ``own`` (over its ``n_own`` labelled frames) by more than
    ``z`` standard errors of the difference of two shares.

    Both are estimates from a few dozen frames: a reading taken on a difference within their
    noise changes what the runs read for nothing it can show (blocks-3 clean s337: a pose
    reading at 0.831 against 0.829 on 70 frames, and the stack it read split 16 states into
    25 nodes).

    >>> reads_better(0.997, 64, 0.938, 64, 1.645), reads_better(0.831, 70, 0.829, 70, 1.645)
    (True, False)
    """
    se = math.sqrt(held * (1.0 - held) / max(n_held, 1) + own * (1.0 - own) / max(n_own, 1))
    return held - own > z * se


def held_out_frames(x: np.ndarray, labels: np.ndarray, pose: np.ndarray,
                    episode: np.ndarray, empty: int, support: float, saturation: float,
                    folds: int = HELD_OUT_FOLDS) -> tuple[np.ndarray, np.ndarray]:
    """Every labelled frame judged by the reading the other ``folds - 1`` folds of the
    episodes teach (:func:`held_out_agreement`): whether it reads what the label says, and
    the strength it reads with.

    Returns
    -------
    right : ndarray of bool, shape (N,)
    weight : ndarray of float64, shape (N,)
        ``strength`` of the held-out reading; 0 where unlabelled or not read.
    """
    known = (labels == empty) | (labels >= 0)
    # the episodes with labels, dealt into the folds in turn
    taught = np.unique(episode[known])
    fold_of = np.full(int(episode.max()) + 1 if len(episode) else 0, -1)
    fold_of[taught] = np.arange(len(taught)) % folds
    right = np.zeros(len(labels), dtype=bool)
    weight = np.zeros(len(labels))
    for fold in range(min(folds, len(taught))):
        judged = fold_of[episode] == fold
        teach = np.where(judged, empty - 1, labels)      # neither empty nor a colour
        window = site_window(x, teach, pose, empty, support)
        if window is None:
            continue
        reading, strength = pose_readings(x, teach, pose, window, empty, saturation, episode)
        held = judged & known
        right[held] = (reading[held] > 0.5) == (labels[held] >= 0)
        weight[held] = strength[held]
    return right, weight


def run_presence(reading: np.ndarray, strength: np.ndarray, runs: np.ndarray,
                 loose: np.ndarray) -> dict[int, float]:
    """Presence of every run of the unlabelled observations ``loose``: the mean of its frames'
    readings weighted by their strength; runs with no readable frame are left out.

    >>> run_presence(np.array([1.0, 0.0, 0.8, 0.2]), np.array([4.0, 1.0, 0.0, 0.0]),
    ...              np.array([0, 0, 1, 1]), np.array([0, 1, 2, 3]))
    {0: 0.8}
    """
    out = {}
    for r in np.unique(runs[loose]):
        members = loose[runs[loose] == r]
        w = strength[members]
        if w.sum() > 0:
            out[int(r)] = float(np.average(reading[members], weights=w))
    return out
