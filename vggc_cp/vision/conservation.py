"""Objects are conserved: what the untouched slots of an episode hold, as the counts require.

A pick lifts an object and the next place puts it down; nothing else creates or removes one.
So in every observation the number of objects of each colour on the slots, plus the one in the
hand, is the same, ``K_c`` (objects at places no action of the trace touches never change
and are left out of the count alike). ``K_c`` is the count under which the episodes'
readings are most likely (:func:`best_counts`), searched from the count most observations
show (:func:`object_counts`): a slot an arm hides in most frames can make the most frequent
count wrong, and the episodes whose actions state where the objects are outweigh it. Where
the recording does not settle the counts (a count one object away at least 1/20 as likely:
a slot above another read full where nothing stands, in a short recording), nothing is
assigned.

In an episode the actions state what every slot they touch holds (:func:`settle
<vggc_cp.vision.occupancy.settle>`); every other slot holds one thing for the whole episode,
and that is read from the images, well where a reading reaches it and not at all where an arm
hides it in every frame. The untouched slots together hold ``K_c`` less what the touched slots
and the hand hold, ``n_c`` objects of colour ``c``: the assignment of ``n_c`` slots to each
colour (the rest empty) that the readings make most likely is what they hold
(:func:`~vggc_cp.vision.assignment.episode_assignment`, the Hungarian method on
log-likelihoods).

A reading counts as far as it can be trusted: with settled presence ``p`` of a reading whose
agreement with the stated frames beyond chance is ``kappa`` (its held-out Cohen's kappa,
:func:`vggc_cp.vision.trust.reading_kappa`; 0 for a run no reading reaches), the probability
that the slot holds something is ``m + kappa (p - m)``, and of colour ``c`` that times the
run's colour posterior, with ``m`` what is known of the slot without the reading: how often it
holds something when an episode starts, as the first frames of the episodes whose actions
state it say, shrunk toward how often all its stated frames do by two frames
(:func:`start_rates`; :func:`base_rates`, Laplace's rule of succession). An untouched slot
holds all episode long what it held at the start, so that is its prior: where episodes start
alike (a robot reset to one home), an arm that hides a place and a weaker reading of an empty
one elsewhere no longer move an object between them (multifruit-4x6 robot s134: in one episode
both places read empty, the count put the missing red at the weaker reading of the two, and
the episode's three frames made nodes of their own). A slot nothing can read is decided by the
counts, the other slots and ``m``; at ``m = 1/2`` it was free room for any object the counts
had left over, and a count one too many could win (random-705 randomized: a level-2 place
taken once, read by nothing, held a fourth red in every episode). Where they cannot decide
(two unread slots, one object), the reading's low kappa is what the read doubts report
(:mod:`vggc_cp.solvers.read_doubts`). The counts pool every episode and weigh the readings by
their kappas; one episode's assignment rests on a few runs, and there a run that the poses of
the hand read weighs as far as its lower bound trusts it (``sure``: the few held-out frames of
the poses that read it, :func:`vggc_cp.vision.trust.pose_bounds`), so that one pose of huge
separation in a handful of taught frames, reading a run alone at the site's kappa of 1.0,
cannot empty a well-read place beside it (multifruit-4x6 robot s350, draw 36; session 46).

Stacks are facts too (a block on a block, where the actions state which slot is above which):
an untouched slot under one the actions fill in any frame of the episode holds something, and
one above a slot they empty holds nothing (:func:`~vggc_cp.vision.assignment.stack_forced`);
the other value costs as much as a reading that rules it out.

Objects rest on something: where the trace stacks slots, an episode takes the most likely
assignment that puts no object above an empty slot in any of its frames
(:func:`~vggc_cp.vision.assignment.grounded`, ranking the assignments with Murty's method,
:func:`~vggc_cp.vision.assignment.ranked_assignments`): a slot above one the counts leave full
may read full because it sees the object below, and then the object stands on the slot below,
not in the air (blocks-3 randomized s94: a block read on top of a two-block stack made three
nodes of their own). The counts are weighed on such assignments too
(:func:`~vggc_cp.vision.assignment.counted_loglik`): an object they could put only in the air
is no evidence for a count (blocks-2 randomized s243: an unread level-1 slot with a start
prior of 2/3 favoured a third block in each of twelve episodes, and the count came out three
for two).

A slot whose contents the counts set against its reading is trusted no more than their choice
is sure (:func:`count_trust`), so that a doubt may name it (multifruit-2x3 robot s242).

The counts decide only where they do: an episode whose best assignment changes a reading but
ties with another assignment (two slots read full with equal certainty and one object to
place: the counts would toss a coin) keeps its readings
(:func:`~vggc_cp.vision.assignment.runner_up`, or the next grounded assignment). So do an
episode none of whose first :data:`~vggc_cp.vision.assignment.MAX_RANKED` assignments stands
and one whose counts the stated slots already contradict (fewer objects left than they need,
or more than the untouched slots can hold). Nothing reads action names or ground-truth states."""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from vggc_cp.trace import PICK, Trace, hand_colours_along
from vggc_cp.vision.assignment import (
    counted_loglik,
    episode_assignment,
    grounded,
    in_the_air,
    runner_up,
    stack_forced,
)
from vggc_cp.vision.slots import acting_at

#: Log-likelihoods closer than this are a tie: the counts do not decide between them.
TIE = 1e-6
#: The object counts are used only where they are at least 20 times as likely as any count
#: one object away (the odds the sequence's twins are taken at, :mod:`vggc_cp.vision.slots`).
COUNT_ODDS = float(np.log(20.0))


def slot_groups(ov: np.ndarray, colour: np.ndarray, counts: np.ndarray, twin: np.ndarray,
                mates: np.ndarray | None, site_overlap: float) -> np.ndarray:
    """Slot of every action, int64 shape (A,): actions that act at one slot (an action, its
    twin and its mates, :func:`~vggc_cp.vision.slots.acting_at`, transitively) share one;
    -1 for an action never taken or of no colour.

    >>> ov = np.eye(4); colour = np.array([0, 0, 1, 1]); twin = np.array([1, 0, 3, 2])
    >>> slot_groups(ov, colour, np.ones(4, int), twin, None, 0.5).tolist()
    [0, 0, 1, 1]
    """
    n = len(colour)
    taken = np.flatnonzero((counts > 0) & (colour >= 0))
    rows, cols = [], []
    for a in taken:
        for b in acting_at(int(a), ov, colour, twin, site_overlap, mates):
            rows.append(int(a))
            cols.append(int(b))
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    _, comp = connected_components(graph, directed=False)
    out = np.full(n, -1, dtype=np.int64)
    _, out[taken] = np.unique(comp[taken], return_inverse=True)
    return out


def slots_below(above: dict[int, list[int]], slot: np.ndarray) -> dict[int, set[int]]:
    """Slot -> the other slots that must hold something where it does, from the sites stacked
    on each site (:func:`vggc_cp.vision.stacks.slots_above`).

    >>> slots_below({0: [2, 3], 2: [4]}, np.array([0, 0, 1, 1, 2]))
    {1: {0}, 2: {1}}
    """
    out: dict[int, set[int]] = {}
    for a, tops in above.items():
        for b in tops:
            if slot[a] >= 0 and slot[b] >= 0 and slot[a] != slot[b]:
                out.setdefault(int(slot[b]), set()).add(int(slot[a]))
    return out


def trusted(presence: np.ndarray, trust: np.ndarray, base: np.ndarray | float = 0.5
            ) -> np.ndarray:
    """The probability that a site holds something, a reading counted as far as its kappa
    trusts it: ``m + kappa (p - m)`` (module docstring), with ``m`` (``base``) what is
    known without the reading: 1/2, or the share of the site's stated frames in which it
    holds something (:func:`base_rates`; :func:`conserve` gives it :func:`start_rates`).

    >>> trusted(np.array([1.0, 0.0, 1.0]), np.array([1.0, 0.5, 0.0])).tolist()
    [1.0, 0.25, 0.5]
    >>> trusted(np.array([1.0]), np.array([0.0]), np.array([0.1])).tolist()
    [0.1]
    """
    return base + np.clip(trust, 0.0, 1.0) * (presence - base)


def base_rates(presence: np.ndarray, stated: np.ndarray) -> np.ndarray:
    """Share of each site's stated frames in which it holds something, shape (A,), shrunk
    toward 1/2 by one frame of each kind (Laplace's rule of succession); 1/2 where nothing
    is stated.

    >>> base_rates(np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]]),
    ...            np.array([[True, False], [True, False], [True, False]])).round(2).tolist()
    [0.4, 0.5]
    """
    full = (presence * stated).sum(axis=0)
    return (full + 1.0) / (stated.sum(axis=0) + 2.0)


def start_rates(presence: np.ndarray, stated: np.ndarray, firsts: np.ndarray,
                prior: float = 2.0) -> np.ndarray:
    """Share of the episodes' stated first frames in which each site holds something, shape
    (A,), shrunk toward the share of all its stated frames (:func:`base_rates`) by ``prior``
    frames: where few episodes state a site at their start, what its other frames hold is
    the better guess (a slot stated at the start of one episode, full there, is no 2 to 1
    bet on being full at every start).

    >>> presence = np.array([[1.0], [0.0], [0.0], [0.0], [1.0]])
    >>> stated = np.ones((5, 1), dtype=bool)
    >>> base_rates(presence, stated).round(3).tolist()
    [0.429]
    >>> start_rates(presence, stated, np.array([0])).round(3).tolist()
    [0.619]
    """
    full = (presence[firsts] * stated[firsts]).sum(axis=0)
    return (full + prior * base_rates(presence, stated)) / (stated[firsts].sum(axis=0) + prior)


def held_colours(actions: np.ndarray, kinds: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """Colour of what the hand holds in every observation, int64 shape (N,), -1 for nothing:
    after a pick, what it lifted; before a place, what it puts down
    (:func:`~vggc_cp.trace.hand_colours_along`, as :func:`vggc_cp.solvers.base.hand_colours`
    reads a problem).

    >>> held_colours(np.array([0, 1, -1, 0]), np.array([0, 1]), np.array([2, 2])).tolist()
    [-1, 2, -1, -1, 2]
    """
    src = np.flatnonzero(np.asarray(actions) >= 0)
    act = np.asarray(actions)[src]
    lifted = np.asarray(kinds)[act] == PICK
    return hand_colours_along(len(actions) + 1, src, act, src + 1, lifted, ~lifted, colour)


def object_counts(values: np.ndarray, held: np.ndarray, n_col: int) -> np.ndarray:
    """The number of objects of each colour on the slots and in the hand that most
    observations show, int64 shape (C,): where the search for ``K_c`` starts
    (:func:`best_counts`).

    Parameters
    ----------
    values : ndarray of int, shape (N, S)
        What every slot holds as settled: -1 empty, else a colour.
    held : ndarray of int, shape (N,)
        :func:`held_colours`.

    >>> values = np.array([[0, -1], [-1, -1], [0, -1], [0, 0]])    # one misread frame
    >>> object_counts(values, np.array([-1, 0, -1, -1]), 1).tolist()   # in the hand at 1
    [1]
    """
    out = np.zeros(n_col, dtype=np.int64)
    for c in range(n_col):
        per_frame = (values == c).sum(axis=1) + (held == c)
        out[c] = int(np.bincount(per_frame).argmax())
    return out


def best_counts(episodes: list[tuple], start: np.ndarray) -> tuple[np.ndarray, float]:
    """``K_c``: the object counts under which the episodes' readings are most likely, and by
    how much they beat the counts one object away.

    Each episode contributes the log-likelihood of its best assignment
    (:func:`~vggc_cp.vision.assignment.counted_loglik`) given what its touched slots and the
    hand hold; the counts move one object of one colour at a time from ``start`` while that raises the total (a
    slot misread in most frames would make the most frequent count wrong; the episodes
    whose actions state where the objects are outweigh it).

    Parameters
    ----------
    episodes : list of (fixed, p_occupied, colour_post[, forced[, floats]])
        ``fixed`` (C,): objects of each colour the touched slots and the hand hold at the
        episode's start; the rest as for :func:`~vggc_cp.vision.assignment.counted_loglik`.
    start : ndarray of int, shape (C,)

    Returns
    -------
    counts : ndarray of int64, shape (C,)
    margin : float
        Log-likelihood of ``counts`` less the best of the counts one object away (``inf``
        where there is none).

    >>> ones = np.ones((2, 1))
    >>> eps = [(np.array([1]), np.array([0.9, 0.1]), ones)] * 3 + \\
    ...       [(np.array([0]), np.array([0.9, 0.9]), ones)]          # one episode misread
    >>> counts, margin = best_counts(eps, np.array([3]))           # from the wrong start
    >>> counts.tolist(), round(margin, 2)
    ([2], 8.79)
    """
    seen: dict[tuple, float] = {}

    def total(k):
        key = tuple(int(v) for v in k)
        if key not in seen:
            seen[key] = sum(counted_loglik(p, post, k - fixed, *rest)
                            for fixed, p, post, *rest in episodes)
        return seen[key]

    def neighbours(k):
        for c in range(len(k)):
            for step in (-1, 1):
                near = k.copy()
                near[c] += step
                if near[c] >= 0:
                    yield near

    best, score = np.asarray(start, dtype=np.int64).copy(), total(start)
    improved = True
    while improved:
        improved = False
        for k in neighbours(best):
            t = total(k)
            if t > score + 1e-9:
                best, score, improved = k, t, True
                break
    margin = min((score - total(k) for k in neighbours(best)), default=np.inf)
    return best, float(margin)


def count_trust(margin: float) -> float:
    """How far a slot's contents that the counts set against its reading can be trusted at
    most, on the scale of a reading's kappa: ``tanh(margin / 2)`` = ``2 P - 1``, ``P`` the
    chance of the episode's best assignment against the next (``margin`` nats apart), 0 for a
    coin toss and 1 for a sure one. (Two assignments 0.34 nats apart, multifruit-2x3 robot
    s242: an object put on the weaker of two readings of an empty place, 0.17; at the
    counts' own odds of 20 to 1, 0.90.)

    >>> [round(count_trust(m), 2) for m in (0.0, 0.34, float(np.log(20.0)), float("inf"))]
    [0.0, 0.17, 0.9, 1.0]
    """
    return float(np.tanh(max(float(margin), 0.0) / 2.0))


def conserve(trace: Trace, presence: np.ndarray, posterior: np.ndarray, stated: np.ndarray,
             trust: np.ndarray, slot: np.ndarray, colour: np.ndarray,
             above: dict[int, list[int]] | None = None, odds: float = COUNT_ODDS,
             sure: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """What every episode's untouched slots hold, as the object counts require (module
    docstring).

    Parameters
    ----------
    trace : Trace
        Its actions and episodes (never its states).
    presence, posterior : ndarray, shapes (N, A) and (N, A, C)
        Settled (:func:`vggc_cp.vision.occupancy.settle`).
    stated : ndarray of bool, shape (N, A)
        Where the actions state what a site holds.
    trust : ndarray, shape (N, A)
        How far each settled presence can be trusted, in [0, 1] (kappa of its reading).
    slot : ndarray of int, shape (A,)
        :func:`slot_groups`.
    colour : ndarray of int, shape (A,)
    above : dict, optional
        Site -> sites stacked on it (:func:`vggc_cp.vision.stacks.slots_above`).
    odds : float
        The log-likelihood by which the counts must beat every count one object away
        (:func:`best_counts`) to be used; :data:`COUNT_ODDS` (20 to 1) by default.
    sure : ndarray, shape (N, A), optional
        How far each reading can be trusted for sure (a lower bound, at most ``trust``): what
        an episode's assignment weighs it by. The counts, which pool every episode, weigh
        the readings by ``trust``; one episode's assignment rests on a few runs, and a run
        that one pose of few taught frames read weighs no more than that pose's frames show
        (multifruit-4x6 robot s350, draw 36: one frame read a place full at kappa 1.0, bound
        0.52, in three episodes, and the counts emptied the well-read place beside it).
        None: ``trust``.

    Returns
    -------
    presence, posterior : ndarray
        Copies, the untouched slots of every episode set to 0 / 1 and one-hot colours.
    changed : int
        Slot-episodes whose contents changed.
    trust : ndarray, shape (N, A)
        A copy of ``trust``; where the counts changed what a slot holds, no more than how
        sure their choice is (:func:`count_trust` of the episode's best assignment over the
        next). Never more than before: the choice rests on the other slots' readings, as
        far as their kappas trust them, and a kappa read off few stated frames is surer than
        they show (multifruit-2x3 robot s4: counts set at kappa 1.0, bound 0.20, would
        have hidden the episode that is misplaced).
    """
    presence, posterior, trust = presence.copy(), posterior.copy(), trust.copy()
    n_slots = int(slot.max()) + 1 if len(slot) and slot.max() >= 0 else 0
    if n_slots == 0:
        return presence, posterior, 0, trust
    n_col = posterior.shape[2]
    members = [np.flatnonzero(slot == s) for s in range(n_slots)]
    # an unread slot holds what the stated first frames of episodes say it usually holds
    # when an episode starts, not a coin toss: a slot nobody can read would otherwise take
    # any object the counts have left over, and an untouched slot holds all episode long
    # what it held at the start
    firsts = np.array([first for first, _ in trace.episodes()], dtype=np.int64)
    rates = start_rates(presence, stated, firsts)
    soft = trusted(presence, trust, rates)
    p = np.stack([presence[:, m].mean(axis=1) for m in members], axis=1)        # (N, S)
    p_soft = np.stack([soft[:, m].mean(axis=1) for m in members], axis=1)
    if sure is None:
        p_sure = p_soft
    else:
        soft = trusted(presence, np.minimum(sure, trust), rates)
        p_sure = np.stack([soft[:, m].mean(axis=1) for m in members], axis=1)
    post = np.stack([posterior[:, m].mean(axis=1) for m in members], axis=1)    # (N, S, C)
    told = np.stack([stated[:, m].any(axis=1) for m in members], axis=1)
    values = np.where(p >= 0.5, post.argmax(axis=-1), -1)
    held = held_colours(trace.actions, trace.action_kinds(), colour)
    below = slots_below(above or {}, slot)
    # every episode: the slots it leaves untouched, what the others and the hand hold
    plans = []
    for first, last in trace.episodes():
        frames = np.arange(first, last + 1)
        acted = np.zeros(n_slots, dtype=bool)
        steps = trace.actions[first:last]
        steps = slot[steps[steps >= 0]]
        acted[steps[steps >= 0]] = True
        loose = np.flatnonzero(~acted & ~told[frames].any(axis=0))
        fixed = np.setdiff1d(np.arange(n_slots), loose)
        holds = np.array([(values[first, fixed] == c).sum() + (held[first] == c)
                          for c in range(n_col)])
        forced = stack_forced(values[frames] >= 0, loose, below)
        plans.append((first, last, loose, holds, p_soft[frames][:, loose].mean(axis=0),
                      post[frames][:, loose].mean(axis=0), forced,
                      in_the_air(values[frames] >= 0, loose, below) if below else None,
                      p_sure[frames][:, loose].mean(axis=0)))
    # the counts are weighed on the assignments the stacks allow, as they are then assigned:
    # an object the counts can only put in the air is no evidence for them
    total, margin = best_counts([(h, ps, po, fo, fl) for *_, h, ps, po, fo, fl, _ in plans],
                                object_counts(values, held, n_col))
    if margin < odds:
        return presence, posterior, 0, trust   # the recording does not settle the counts
    changed = 0
    for first, last, loose, holds, _, post_loose, forced, floats, p_loose in plans:
        need = total - holds
        if not len(loose) or (need < 0).any() or need.sum() > len(loose):
            continue                       # the stated slots already break the counts
        if floats is not None:
            # the most likely assignment with nothing in the air, in any frame of the
            # episode (the touched slots change, the untouched do not)
            new, best, second = grounded(p_loose, post_loose, need, forced, floats)
            if new is None:
                continue                   # every assignment leaves an object in the air
        else:
            new, best = episode_assignment(p_loose, post_loose, need, forced)
            second = runner_up(p_loose, post_loose, need, new, forced)
        if (new != values[first, loose]).any() and best - second < TIE:
            continue                       # another assignment as likely: a coin toss
        sure = count_trust(best - second)
        for i, s in enumerate(loose):
            changed += int(new[i] != values[first, s])
            cols = members[s]
            if new[i] != values[first, s]:
                # set against the reading: no surer than the counts' choice (which rests on
                # the other slots' readings, so never surer than the reading it overruled)
                trust[first:last + 1, cols] = np.minimum(trust[first:last + 1, cols], sure)
            if new[i] < 0:
                presence[first:last + 1, cols] = 0.0
            else:
                presence[first:last + 1, cols] = 1.0
                posterior[first:last + 1, cols] = np.eye(n_col)[new[i]]
    return presence, posterior, changed, trust
