"""Colours of task classes: which actions move objects of one class, and which classes look
alike (beyond the paper).

**Classes.** What a pick lifts is what the next place puts down, so a pick and the place that
follows it move one task class: the classes are the connected components of that relation
(:func:`action_classes`, names are not read).

**Colours.** Classes whose colours cannot be told apart are one colour: the chroma
``(r, g) / (r + g + b)`` of their objects must be clearly likelier under its own class's
kernel density (:mod:`vggc_cp.vision.density`) than under another's (:func:`colour_classes`).
The footprints give each class its examples (:func:`class_points`, :func:`action_colours`);
where they pool classes (on a robot's camera every footprint may read the arm's grey), the
windows the actions' labels teach read them again and may split what the footprints pooled
(:func:`window_colours`); two classes that one site's window shows in clearly different
colours are two, whatever windows lying on the arm show elsewhere (:func:`apart_at_sites`).
The windows are asked twice: anywhere in the frame, and only where the site's own actions
change it (a window anywhere may lie on the gripper, whose load goes with what the site
holds, and read its grey; one within the footprint, on a robot's camera mostly the arm, may
miss the object), and a pair either shows apart is two colours: an arm makes colours alike,
never different. A site's colour is the posterior of each colour given the chroma it
shows (:func:`colour_posteriors`).

**Actions the sequence does not link.** A pick that ends every episode it is in (the hand
still holds what it lifted) is linked to no place, so its class is its own and only the
pixels guess its colour: a few frames in which an arm may hide the object. Such an action
takes the colour of its twin instead (:func:`twin_colours`): what it lifts was put down by
the place at its slot, the action of the other kind that never breaks alternation with it in
any episode (as :func:`~vggc_cp.vision.slots.sequence_twins` asks of a twin), is seen
alternating with it most often, and acts nearest it by the trace's own picture of the places
(the after-looks where the hand rests at the place it acted on, else the footprints). The
pixels keep their colour where they clearly contradict the twin's, from two looks at least
(:data:`MIN_CONTRADICTING`): a pick taken once, last in its episode, has one look, one draw
of the noise and light (random-725 randomized: one look 2.7 kernel widths off green made the
hand's colour a class of one and the frame after it a node of its own).
"""

from __future__ import annotations

import numpy as np

from vggc_cp.trace import PICK, PLACE, Trace
from vggc_cp.vision.density import kernel_loglik, kernel_posterior
from vggc_cp.vision.occupancy import site_labels
from vggc_cp.vision.places import after_distances, trace_slots
from vggc_cp.vision.slots import EMPTY, acting_at, action_episodes, alternations
from vggc_cp.vision.untouched import (
    placed_starts,
    pose_readings,
    poses,
    site_window,
    window_chroma,
)

#: Most chroma examples a class keeps in :func:`pool_sites` (evenly spaced).
MAX_EXAMPLES = 2000
#: Looks of its own an unlinked action's chroma needs to contradict its twin's colour
#: (:func:`twin_colours`): one look is one draw of the noise, lighting and hand around it.
MIN_CONTRADICTING = 2
#: Looks of each of two classes one site needs before it can tell their colours apart
#: (:func:`apart_at_sites`).
MIN_SITE_LOOKS = 3


def action_classes(trace: Trace) -> np.ndarray:
    """Task class of every action, int64 array of shape (A,), from the trace's structure.

    What a pick lifts is what the next place puts down: a pick and the place that follows it
    (the two actions around one place-role observation) move an object of one class. The
    classes are the connected components of that relation (union-find); an action never
    linked that way is a class of its own. Names are not read.
    """
    parent = np.arange(trace.n_actions)

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return int(a)

    kinds = trace.action_kinds()
    prev, nxt = trace.actions[:-1], trace.actions[1:]
    link = (prev >= 0) & (nxt >= 0)
    for a, b in zip(prev[link], nxt[link]):
        if kinds[a] == PICK and kinds[b] == PLACE:
            ra, rb = find(int(a)), find(int(b))
            parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(a) for a in range(trace.n_actions)], dtype=np.int64)
    return np.unique(roots, return_inverse=True)[1].astype(np.int64)


def colour_classes(points: list[np.ndarray], bandwidth: float, distinct: float = 1.0
                   ) -> np.ndarray:
    """Pool task classes whose colours cannot be told apart.

    A class is a colour of its own when its examples are clearly likelier under its own
    kernel density (each example left out of it) than under any other class's: the median
    log-likelihood ratio exceeds ``distinct`` nats. Otherwise (an action the trace never
    linked to its class, or two classes of one colour) it joins the class it is least
    distinct from, the least distinct first, until every class is distinct. A class of one
    example cannot show it and joins the class under whose density its example is likeliest
    (not whichever class comes first).

    Parameters
    ----------
    points : list of ndarray, shape (n_k, 2)
        Chroma of each task class's occupied observations.
    bandwidth : float
    distinct : float

    Returns
    -------
    ndarray of int, shape (K,)
        Colour of every task class, numbered from 0.
    """
    group = np.arange(len(points))
    while len(np.unique(group)) > 1:
        ids = list(np.unique(group))
        pooled = {g: np.concatenate([points[k] for k in np.flatnonzero(group == g)])
                  for g in ids}
        worst = None
        single = [g for g in ids if len(pooled[g]) == 1]
        if single:  # it cannot show a colour of its own: it joins its likeliest class
            g = single[0]
            others = [h for h in ids if h != g]
            lik = [float(kernel_loglik(pooled[g], pooled[h], bandwidth)[0]) for h in others]
            group[group == g] = others[int(np.argmax(lik))]
            continue
        for g in ids:
            own = pooled[g]
            # leave each example out of its own class's density
            d2 = ((own[:, None] - own[None]) ** 2).sum(-1) / bandwidth ** 2
            np.fill_diagonal(d2, np.inf)
            m = (-0.5 * d2).max(axis=1)
            loo = m + np.log(np.exp(-0.5 * d2 - m[:, None]).sum(axis=1) / (len(own) - 1))
            for h in ids:
                if h == g:
                    continue
                ratio = float(np.median(loo - kernel_loglik(own, pooled[h], bandwidth)))
                if ratio < distinct and (worst is None or ratio < worst[0]):
                    worst = (ratio, g, h)
        if worst is None:
            break
        _, g, h = worst
        group[group == g] = h
    return np.unique(group, return_inverse=True)[1].astype(np.int64)


def class_points(chroma: np.ndarray, counts: np.ndarray, classes: np.ndarray,
                 occupied: dict[int, np.ndarray]) -> list[np.ndarray]:
    """Chroma of every task class's occupied observations, each seen in its own action's
    footprint: one array (n_k, 2) per class, indexed by class (empty for a class never
    taken)."""
    n_cls = int(classes.max()) + 1 if len(classes) else 0
    return [np.concatenate([chroma[occupied[a], a] for a in
                            np.flatnonzero((classes == k) & (counts > 0))] or [np.zeros((0, 2))])
            for k in range(n_cls)]


def action_colours(points: list[np.ndarray], counts: np.ndarray, classes: np.ndarray,
                   bandwidth: float) -> np.ndarray:
    """Colour of every action, shape (A,) (-1 for an action never taken): the task classes
    (:func:`action_classes`) pooled by :func:`colour_classes` on the chroma of their actions'
    occupied observations (:func:`class_points`)."""
    colour = np.full(len(counts), -1, dtype=np.int64)
    known = [k for k in np.unique(classes) if (counts[classes == k] > 0).any()]
    if not known:
        return colour
    group = colour_classes([points[k] for k in known], bandwidth)
    for k, g in zip(known, group):
        colour[(classes == k) & (counts > 0)] = g
    return colour


def twin_colours(colour: np.ndarray, classes: np.ndarray, counts: np.ndarray,
                 kinds: np.ndarray, actions: np.ndarray, episodes: list[tuple[int, int]],
                 near: np.ndarray, points: list[np.ndarray] | None = None,
                 bandwidth: float = 0.02, distinct: float = 1.0) -> np.ndarray:
    """Colours of the actions the sequence links to no other action, from their twins
    (module docstring), shape (A,).

    An action whose task class holds no other taken action takes the colour of the action of
    the other kind, in a class of several, that never breaks alternation with it and is seen
    alternating with it most often (:func:`~vggc_cp.vision.slots.alternations`: the place
    that filled the slot a pick empties comes before it wherever both are in an episode),
    then the nearest (``near``, larger: nearer). It keeps its colour where no such action
    exists, where two are equally near, and where its own chroma, of
    :data:`MIN_CONTRADICTING` looks or more, contradicts the twin's colour
    (:func:`fits_colour`: the pixels decide where they are clear). The colours are
    numbered from 0 again.

    Parameters
    ----------
    colour, classes, counts, kinds : ndarray, shape (A,)
    actions : ndarray of int, shape (N-1,)
        The trace's actions (-1 between episodes).
    episodes : list of (first, last)
    near : ndarray, shape (A, A)
        How near two actions act: footprint overlaps, or minus the after-look distances.
    points : list of ndarray, shape (n_k, 2), optional
        Chroma of every task class (:func:`class_points`); without them the twin decides.
    bandwidth, distinct : float
        Of the colour kernel, and the nats by which the chroma must contradict the twin's
        colour to keep its own (:func:`colour_classes`' bar).

    Examples
    --------
    Pick 0 and place 1 are one class (red, 0), pick 2 and place 3 another (yellow, 1); pick
    4 ends both its episodes, right after place 1, so its class is its own and the pixels
    called it yellow. Place 1 is nearest it and never breaks alternation with it: red.

    >>> kinds = np.array([PICK, PLACE, PICK, PLACE, PICK])
    >>> actions = np.array([2, 3, 0, 1, 4, -1, 2, 3, 0, 1, 4])
    >>> near = np.array([[1, .5, 0, 0, .1], [.5, 1, 0, 0, .6], [0, 0, 1, .5, 0],
    ...                  [0, 0, .5, 1, .3], [.1, .6, 0, .3, 1]])
    >>> classes = np.array([0, 0, 1, 1, 2]); colour = np.array([0, 0, 1, 1, 1])
    >>> twin_colours(colour, classes, np.array([2, 2, 2, 2, 2]), kinds, actions,
    ...              [(0, 5), (6, 11)], near).tolist()
    [0, 0, 1, 1, 0]
    """
    out = colour.copy()
    taken = counts > 0
    sizes = np.bincount(classes[taken], minlength=int(classes.max()) + 1 if len(classes) else 0)
    alone = np.flatnonzero(taken & (sizes[classes] == 1) & (colour >= 0))
    if not len(alone):
        return out
    actions = np.asarray(actions)
    episode_of = action_episodes(len(actions), episodes)
    for a in alone:
        cand = np.flatnonzero(taken & (kinds != kinds[a]) & (sizes[classes] > 1) & (colour >= 0))
        if not len(cand):
            continue
        counts_ab = alternations(actions, episode_of, kinds, int(a), cand)
        keep = (counts_ab[:, 0] == 0) & (counts_ab[:, 1] > 0) & np.isfinite(near[a, cand])
        cand, seen = cand[keep], counts_ab[keep, 1]
        if not len(cand):
            continue
        # the most often seen alternating with it, then the nearest
        top = cand[seen == seen.max()]
        best = near[a, top].max()
        if (near[a, top] == best).sum() > 1:
            continue
        twin = int(colour[top[int(np.argmax(near[a, top]))]])
        if points is not None:
            ks = {int(classes[b]) for b in np.flatnonzero(taken & (colour == twin))} - \
                {int(classes[a])}
            examples = [points[k] for k in sorted(ks) if len(points[k])]
            own = points[classes[a]]
            if examples and len(own) >= MIN_CONTRADICTING and \
                    not fits_colour(own, np.concatenate(examples), bandwidth, distinct):
                continue
        out[a] = twin
    # colours numbered from 0 again (one only an unlinked action had is gone)
    known = out >= 0
    out[known] = np.unique(out[known], return_inverse=True)[1]
    return out


#: Most examples of a colour :func:`fits_colour` compares with (evenly spaced).
MAX_FIT = 500


def fits_colour(own: np.ndarray, examples: np.ndarray, bandwidth: float,
                distinct: float = 1.0) -> bool:
    """Whether chroma ``own`` (n, 2) could be of the colour of ``examples`` (m, 2): its median
    likelihood under their kernel density is no more than ``distinct`` nats below the
    median of their own, each left out of it (at most :data:`MAX_FIT` examples, evenly
    spaced). True where there is nothing to compare (no chroma, fewer than two examples).

    >>> rng = np.random.default_rng(0)
    >>> red = [0.6, 0.3] + 0.01 * rng.standard_normal((50, 2))
    >>> fits_colour(np.array([[0.6, 0.31]]), red, 0.02), fits_colour(np.array([[0.4, 0.4]]),
    ...                                                                 red, 0.02)
    (True, False)
    """
    if not len(own) or len(examples) < 2:
        return True
    if len(examples) > MAX_FIT:
        examples = examples[np.linspace(0, len(examples) - 1, MAX_FIT).round().astype(int)]
    d2 = ((examples[:, None] - examples[None]) ** 2).sum(-1) / bandwidth ** 2
    np.fill_diagonal(d2, np.inf)
    m = (-0.5 * d2).max(axis=1)
    typical = float(np.median(m + np.log(np.exp(-0.5 * d2 - m[:, None]).sum(axis=1)
                                         / (len(examples) - 1))))
    return float(np.median(kernel_loglik(own, examples, bandwidth))) >= typical - distinct


def trace_twin_colours(trace: Trace, x: np.ndarray, ov: np.ndarray, colour: np.ndarray,
                       classes: np.ndarray, counts: np.ndarray, site_overlap: float,
                       points: list[np.ndarray] | None = None, bandwidth: float = 0.02
                       ) -> np.ndarray:
    """:func:`twin_colours` of ``trace``, nearness read as its slots are
    (:func:`~vggc_cp.vision.places.trace_slots`): minus the after-look distances where the
    hand rests at the place it acted on, else the footprint overlaps ``ov``. ``colour`` as
    it is where every action is linked to another (nothing computed)."""
    taken = counts > 0
    sizes = np.bincount(classes[taken], minlength=int(classes.max()) + 1 if len(classes) else 0)
    if not (taken & (sizes[classes] == 1)).any():
        return colour
    _, _, rests = trace_slots(trace, x, ov, colour, site_overlap)
    if rests:
        _, act, dst = trace.transitions()
        near = -after_distances(x, act, dst, trace.n_actions)
    else:
        near = ov
    return twin_colours(colour, classes, counts, trace.action_kinds(), trace.actions,
                        trace.episodes(), near, points, bandwidth)


def pooled(colour: np.ndarray, classes: np.ndarray, counts: np.ndarray) -> bool:
    """Whether the taken actions have fewer colours than task classes."""
    taken = counts > 0
    return len(np.unique(colour[taken])) < len(np.unique(classes[taken]))


def window_colours(colour: np.ndarray, classes: np.ndarray, counts: np.ndarray,
                   footprint_points: list[np.ndarray], window_points: list[np.ndarray],
                   bandwidth: float, apart: set[tuple[int, int]] | None = None
                   ) -> np.ndarray:
    """Colours split again where the footprints pooled task classes, shape (A,).

    Pooling says two classes look alike; a footprint that lies on a robot arm says so of
    every class (it reads the arm's grey). The classes are pooled again
    (:func:`colour_classes`) on the chroma their labels show in the sites' windows
    (``window_points``, :func:`pool_sites` of :func:`window_site_chroma`), and two
    classes keep one colour only where both readings pool them: the windows split what the
    footprints pooled, never pool what the footprints tell apart. A class with fewer than
    two window examples cannot be read there: it follows the readable class of its
    footprint colour under whose footprint chroma its own (``footprint_points``) is
    likeliest, or stays with the footprints' choice where its colour has none -- but never
    with a class some site shows apart from it (``apart``). Without pooling, or with fewer
    than two readable classes and no pair apart, ``colour`` is returned as it is.

    Parameters
    ----------
    colour : ndarray of int, shape (A,)
        :func:`action_colours`.
    classes, counts : ndarray, shape (A,)
    footprint_points, window_points : list of ndarray, shape (n_k, 2)
        Chroma of each task class (indexed by class) in its footprints and in the windows.
    bandwidth : float
    apart : set of (int, int), optional
        Pairs of classes one site's window shows in different colours
        (:func:`apart_at_sites`): they are two colours even where the windows pooled over
        every site call them one (some windows lie on the arm), the class seen first
        keeping the colour.

    Examples
    --------
    Two classes of grey footprints (an arm) that the windows tell apart, and a third that
    only the footprints show:

    >>> rng = np.random.default_rng(0)
    >>> grey = [0.33 + 0.001 * rng.standard_normal((20, 2)) for _ in range(3)]
    >>> red = [0.6, 0.3] + 0.01 * rng.standard_normal((20, 2))
    >>> yellow = [0.45, 0.4] + 0.01 * rng.standard_normal((20, 2))
    >>> window_colours(np.zeros(3, int), np.arange(3), np.ones(3), grey,
    ...                [red, yellow, np.zeros((0, 2))], 0.02).tolist()
    [0, 1, 0]
    """
    taken = counts > 0
    known = [int(k) for k in np.unique(classes[taken])]
    if not pooled(colour, classes, counts):
        return colour
    readable = [k for k in known if len(window_points[k]) >= 2]
    apart = apart or set()
    if len(readable) < 2 and not apart:
        return colour
    first = {k: int(colour[(classes == k) & taken][0]) for k in known}
    seen = (dict(zip(readable, colour_classes([window_points[k] for k in readable],
                                              bandwidth).tolist()))
            if len(readable) >= 2 else {k: 0 for k in readable})
    seen = _split_apart(seen, apart)
    for k in known:
        if k in seen:
            continue
        near = [r for r in readable if first[r] == first[k]]
        lik = [float(np.median(kernel_loglik(footprint_points[k], footprint_points[r],
                                             bandwidth))) for r in near]
        seen[k] = seen[near[int(np.argmax(lik))]] if near else -1
    # a class too few windows read follows a readable one, except one a site shows apart
    # from it (multifruit-2x3 robot s327: no window read red, and the one site that showed
    # red and yellow apart was overruled by yellow's lead)
    seen = _split_apart(seen, apart)
    key = {k: (first[k], seen[k]) for k in known}
    ids = sorted(set(key.values()))
    out = np.full(len(colour), -1, dtype=np.int64)
    for k in known:
        out[(classes == k) & taken] = ids.index(key[k])
    return out


def colours_in_windows(trace: Trace, x: np.ndarray, ov: np.ndarray, maps: np.ndarray,
                       colour: np.ndarray, classes: np.ndarray, counts: np.ndarray,
                       points: list[np.ndarray], site_overlap: float, support: float,
                       saturation: float, bandwidth: float) -> np.ndarray:
    """The actions' colours (:func:`action_colours`), read again in the windows the labels
    teach where the footprints pooled task classes (:func:`pooled`), shape (A,); ``colour``
    itself where they pooled none.

    The windows are asked twice (:func:`window_site_chroma`): anywhere in the frame, and
    only where the site's own actions change it (``maps``, the actions' footprints). The
    classes are pooled again on the chroma the free windows show (:func:`window_colours`),
    and two classes that either reading shows apart at one site (:func:`apart_at_sites`)
    are two colours: an arm makes colours alike, never different.

    Parameters
    ----------
    trace, x, ov, classes, counts, site_overlap, support, saturation
        As for :func:`window_site_chroma`.
    maps : ndarray, shape (A, H, W)
        The actions' footprints.
    colour : ndarray of int, shape (A,)
        :func:`action_colours`.
    points : list of ndarray, shape (n_k, 2)
        The footprints' chroma of each task class (:func:`class_points`).
    bandwidth : float
        Width of the colour kernel.
    """
    if not pooled(colour, classes, counts):
        return colour
    free, near = (window_site_chroma(trace, x, ov, classes, counts, site_overlap, support,
                                     saturation, reach) for reach in (None, maps))
    return window_colours(colour, classes, counts, points, pool_sites(free, len(points)),
                          bandwidth, apart_at_sites(free, bandwidth)
                          | apart_at_sites(near, bandwidth))


def _split_apart(group: dict[int, int], apart: set[tuple[int, int]]) -> dict[int, int]:
    """``group`` (class -> colour) with every colour that holds a pair of ``apart`` split:
    each class, in order, joins the first part of its colour that holds no class it is apart
    from, else starts a part of its own.

    >>> _split_apart({0: 0, 1: 0, 2: 0, 3: 1}, {(0, 2)})
    {0: 0, 1: 0, 2: 1, 3: 2}
    """
    parts: dict[int, list[list[int]]] = {}
    for k in sorted(group):
        mine = parts.setdefault(group[k], [])
        for part in mine:
            if not any((min(k, j), max(k, j)) in apart for j in part):
                part.append(k)
                break
        else:
            mine.append([k])
    out, next_id = {}, 0
    for g in sorted(parts):
        for part in parts[g]:
            for k in part:
                out[k] = next_id
            next_id += 1
    return out


def colour_posteriors(chroma: np.ndarray, examples: list[np.ndarray], bandwidth: float
                      ) -> np.ndarray:
    """Posterior of every colour for the chroma seen in every site, shape (N, A, C).

    Each colour's likelihood is a kernel density over its examples (Gaussian kernel of width
    ``bandwidth``): a class of several looks keeps every look, which one prototype and spread
    would not. Equal priors. One colour (or none): all ones.
    """
    n, n_act = chroma.shape[:2]
    if len(examples) <= 1:
        return np.ones((n, n_act, 1))
    return kernel_posterior(chroma.reshape(-1, 2), examples, bandwidth).reshape(
        n, n_act, len(examples))


def window_site_chroma(trace: Trace, x: np.ndarray, ov: np.ndarray, classes: np.ndarray,
                       counts: np.ndarray, site_overlap: float, support: float,
                       saturation: float, maps: np.ndarray | None = None
                       ) -> list[dict[int, np.ndarray]]:
    """Chroma of the task classes where the actions' labels show them, site by site: for
    every taken action whose site has a window, the chroma (n, 2) of each class its labelled
    frames show there, keyed by class (:func:`pool_sites` pools them per class).

    Every taken action's site is labelled with the classes as its colours
    (:func:`~vggc_cp.vision.occupancy.site_labels`); the frames they label teach the site's
    window (:func:`~vggc_cp.vision.untouched.site_window`), and each frame labelled with a class
    gives the chroma of what deviates in it from its pose's empty look
    (:func:`~vggc_cp.vision.untouched.window_chroma`; an episode's first frame takes the
    pose it looks like, :func:`~vggc_cp.vision.untouched.placed_starts`), where its pose
    shows the site at :data:`~vggc_cp.vision.untouched.READ_ODDS` and the frame reads present
    (:func:`~vggc_cp.vision.untouched.pose_readings`). A footprint on a robot arm reads the
    arm's grey for every class; the window lies where the objects differ.

    Parameters
    ----------
    trace : Trace
        Its actions and episodes (never its states).
    x : ndarray of float32, shape (N, H, W, 3)
        Working frames.
    ov : ndarray, shape (A, A)
    classes : ndarray of int, shape (A,)
        :func:`action_classes`.
    counts : ndarray, shape (A,)
    site_overlap, support, saturation : float
        Of :class:`~vggc_cp.vision.footprints.FootprintConfig`.
    maps : ndarray, shape (A, H, W), optional
        The actions' footprints: each window then lies where the actions acting at its site
        change the frames (``reach`` of :func:`~vggc_cp.vision.untouched.site_window`);
        without them, anywhere.
    """
    colour = np.where(counts > 0, classes, -1)
    twin, mates, _ = trace_slots(trace, x, ov, colour, site_overlap)
    # an episode's first frame takes the pose it looks like: where the hand rests at the
    # place it last acted on, one pose of every start lies anywhere (multifruit-2x3 robot
    # s361: fourteen appended episodes, pooled as one such pose, put the only window that
    # showed red and yellow apart on the arm)
    kinds, episodes = trace.action_kinds(), trace.episodes()
    pose = placed_starts(x, poses(trace.actions))
    episode = trace.episode_index()
    sites: list[dict[int, np.ndarray]] = []
    for a in np.flatnonzero(counts > 0):
        acting = acting_at(int(a), ov, colour, twin, site_overlap, mates)
        labels = site_labels(trace.actions, episodes, acting, kinds, colour)
        reach = None if maps is None else (maps[acting] > 0).any(axis=0)
        window = site_window(x, labels, pose, EMPTY, support, reach)
        if window is None:
            continue
        chroma = window_chroma(x, labels, pose, window, EMPTY)
        # only the poses that show the site, and frames in which the object shows
        reading, strength = pose_readings(x, labels, pose, window, EMPTY, saturation,
                                          episode)
        seen = (labels >= 0) & np.isfinite(chroma[:, 0]) & (strength > 0) & (reading > 0.5)
        sites.append({int(k): chroma[seen & (labels == k)] for k in np.unique(labels[seen])})
    return sites


def pool_sites(sites: list[dict[int, np.ndarray]], n_cls: int) -> list[np.ndarray]:
    """Every class's chroma over the sites of :func:`window_site_chroma`, one array (n_k, 2)
    per class, at most :data:`MAX_EXAMPLES` (evenly spaced).

    >>> pool_sites([{0: np.zeros((2, 2))}, {0: np.ones((1, 2)), 1: np.ones((3, 2))}], 3)[0].shape
    (3, 2)
    """
    out = []
    for k in range(n_cls):
        parts = [site[k] for site in sites if k in site]
        pts = np.concatenate(parts) if parts else np.zeros((0, 2))
        if len(pts) > MAX_EXAMPLES:
            pts = pts[np.linspace(0, len(pts) - 1, MAX_EXAMPLES).round().astype(int)]
        out.append(pts)
    return out


def apart_at_sites(sites: list[dict[int, np.ndarray]], bandwidth: float,
                   distinct: float = 1.0, min_looks: int = MIN_SITE_LOOKS
                   ) -> set[tuple[int, int]]:
    """Pairs of classes ``(k, j)``, ``k < j``, that some site shows in clearly different
    colours: both with ``min_looks`` looks or more there, and :func:`colour_classes` on those
    looks alone keeps them apart.

    A window that lies on the arm shows every class as the arm's grey there, and pooled over
    the sites that grey makes two colours alike; one that lies on the objects shows two
    classes of one colour alike wherever both are seen. So two classes that one site tells
    apart are two colours, whatever the other sites show (:func:`window_colours`).

    >>> rng = np.random.default_rng(0)
    >>> grey = lambda: 0.33 + 0.003 * rng.standard_normal((6, 2))
    >>> red = [0.8, 0.1] + 0.01 * rng.standard_normal((6, 2))
    >>> yellow = [0.45, 0.4] + 0.01 * rng.standard_normal((6, 2))
    >>> sorted(apart_at_sites([{0: grey(), 1: grey()}, {0: red, 1: yellow}], 0.02))
    [(0, 1)]
    >>> apart_at_sites([{0: grey(), 1: grey()}, {0: red}], 0.02)
    set()
    """
    apart = set()
    for site in sites:
        shown = sorted(k for k, pts in site.items() if len(pts) >= min_looks)
        for i, k in enumerate(shown):
            for j in shown[i + 1:]:
                if (k, j) not in apart and len(np.unique(
                        colour_classes([site[k], site[j]], bandwidth, distinct))) == 2:
                    apart.add((k, j))
    return apart
