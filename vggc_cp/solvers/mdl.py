"""Model selection by description length: the graph that explains the trace's actions best.

A task graph is a model of what the robot did: from node ``u`` it took action ``a`` with some
frequency, and (deterministically) went to the node the edge ``(u, a, v)`` names. Its
description length is the code length of the trace's actions under the graph plus the cost
of the graph's own parameters (BIC / two-part MDL), in nats::

    DL(G) = - sum_{(u, a)} n(u, a) log(n(u, a) / n(u))  +  1/2 log|D| * |E|

with ``n(u, a)`` the transitions taking ``a`` from an observation of node ``u``, ``n(u)`` their
sum and ``|E|`` the number of edges. Merging two states that afford different actions
raises the first term (the merged node's actions are less predictable); keeping near
duplicates apart raises the second (every copy repeats its edges). The true graph balances
them once the trace visits its states a few times each. Lower is better.

**What the actions state.** Where the evidence says what sites hold as symbols
(:class:`~vggc_cp.solvers.base.Readings`: the footprints give each site of each observation
empty or an object of a colour wherever an episode's actions state it, and 0, not coded,
elsewhere), the model codes those too:
every node has, per site, a distribution over the symbols its observations hold there::

    DL_read(G) = - sum_{(u, s, x)} n(u, s, x) log(n(u, s, x) / n(u))
                 + sum_{(u, s)} log K_s  +  1/2 log N * k

with ``n(u, s, x)`` the observations of node ``u`` that hold ``x`` at site ``s``, ``K_s`` the
symbols site ``s`` takes anywhere (stating what a node holds there costs ``log K_s``, as an
edge costs in the action code), ``N`` the observations and ``k`` the free parameters,
``sum_{(u, s)} (#symbols - 1)``. Two states that afford alike actions but hold different
things cost their mixed sites' entropy when merged, and a split gains nothing (stated facts
agree within a state); without this term, a coarse graph that predicts the actions as well
as the true one is the shorter code, however different the scenes it merges (a task of
identical objects, random-396: 16 nodes for 126 states). Only stated facts are coded: the
readings of sites no action touches were tried (every site's symbol) and made splits pay
wherever an arm or a covered slot misleads them. Sites alike on every observation (the
actions of one slot) are one site (:func:`vggc_cp.vision.holdings.site_readings`).

**Where the actions cannot choose, the trusted readings do.** Graphs whose description
lengths lie within :data:`TIE_NATS` (``ln 20``) of the least are a tie: the actions and stated
facts make none of them 20 times as probable as another (two states seen once each, one
node or two, cost the same edges). Among them, the rule adds the code length of what the
images read, where the actions do not state it, at the sites whose reading agrees with the
stated frames almost perfectly (kappa >= :data:`TRUSTED_KAPPA`;
:func:`trusted_readings`), coded as above (:func:`choice_lengths`). A split that only
separates frames read alike gains nothing; a merge of frames read differently pays. Beyond
the tie, the readings choose nothing: a run of frames read wrong at such a site (a moving
arm, a turned camera) would otherwise buy its own node wherever that is cheaper than its
entropy. The readings break a tie; they settle it only as far as they are surely right: the
confidence's margin is in the code of the actions and stated facts, plus the readings
whose 95 % lower bound of agreement reaches :data:`TRUSTED_KAPPA` in the frame they read
(:func:`surely_trusted_readings`, :func:`sure_reading_gap`), since a run of frames can be
read wrong at a site read well on average (multifruit-4x6 robot s91: the readings chose a
wrong graph, 60 nodes for 58, that the actions left within 3 nats of the least), while a
site read right in every one of a few hundred stated frames is read right where it is not
stated (random-3 clean: two states seen once each, one node or two cost the actions the
same, the images tell them apart at kappa 1.0, and the right graph was warned).

References
----------
J. Rissanen, *Modeling by shortest data description*, Automatica 14, 1978.
G. Schwarz, *Estimating the dimension of a model*, Annals of Statistics 6, 1978.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from vggc_cp.solvers.base import Problem, Readings, SolveResult
from vggc_cp.solvers.selection import PATH, register_selection


def description_length(problem: Problem, labels: np.ndarray) -> float:
    """``DL`` of the graph ``labels`` induces on ``problem``'s transitions (nats; lower is
    better). Returns ``inf`` for ``labels`` None.

    Parameters
    ----------
    problem : Problem
    labels : ndarray of int, shape (N,)
    """
    if labels is None:
        return float("inf")
    readings = getattr(problem, "readings", None)
    seen = 0.0 if readings is None else reading_length(readings, labels)
    n_trans = len(problem.act)
    if n_trans == 0:
        return seen
    src = np.asarray(labels, dtype=np.int64)[problem.src]
    n_act = max(problem.n_actions, 1)
    pair = src * n_act + problem.act
    keys, counts = np.unique(pair, return_counts=True)
    node = keys // n_act
    per_node = np.bincount(np.searchsorted(np.unique(node), node), weights=counts)
    totals = per_node[np.searchsorted(np.unique(node), node)]
    loglik = float(np.sum(counts * np.log(counts / totals)))
    return -loglik + 0.5 * np.log(n_trans) * len(keys) + seen


#: Description lengths within this many nats of the least are a tie: no graph of the tie is
#: 20 times as probable as another (the margin the confidence asks for, ``ln 20``).
TIE_NATS = math.log(20)

#: A site's reading is trusted to break a tie where it agrees with the frames whose actions
#: state the site at least this far beyond chance: "almost perfect" (Landis and Koch 1977,
#: from 0.81); where half the frames hold each of two symbols, at most 1 read in 20 wrong.
TRUSTED_KAPPA = 0.9


@register_selection("mdl", PATH)
def select_mdl(results: Sequence[SolveResult], problem: Problem | None = None) -> int | None:
    """The result of least description length (:func:`description_length`), where graphs
    tie (within :data:`TIE_NATS`) the least with the trusted readings coded too
    (:func:`choice_lengths`). Of graphs whose code lengths are equal (to 1e-9 nats), the one
    with fewer nodes: observations from which the trace takes no action (an episode's last)
    cost nothing wherever they go, and an equal code length does not pay for a node. Of
    equal graphs, the first (the lowest threshold)."""
    if not results:
        return None
    if problem is None:
        raise ValueError("the mdl rule needs the problem")
    scores = choice_lengths(problem, [r.labels for r in results])
    keys = [(round(float(c), 9), r.n_nodes if r.labels is not None else np.inf, i)
            for i, (c, r) in enumerate(zip(scores, results))]
    return int(min(keys)[2])


def surely_trusted_readings(readings: Readings | None, min_kappa: float = TRUSTED_KAPPA,
                            z: float | None = None) -> Readings | None:
    """:func:`trusted_readings` where the reading of each frame is *surely* trusted: the
    lower confidence bound (one-sided, at the normal quantile ``z``;
    :data:`~vggc_cp.vision.trust.READ_Z`, 95 %, by default) of the kappa of the reading
    that set it (``SiteReads.trust``, else the site's kappa), judged on the site's stated
    frames (:func:`~vggc_cp.vision.trust.kappa_lower`), and the bound the evidence gives
    that reading itself where it does (``SiteReads.trust_low``: the few stated frames of
    the poses that read it), reach ``min_kappa``. None where no such reading is left.

    Two sites read at kappa 1.0, each with two frames to read: judged on 200 stated frames
    (half of them full) both readings are sure, on 4 they are not (bound 0.19).

    >>> from vggc_cp.solvers.base import SiteReads
    >>> held = np.array([[0, 0], [1, 1]] * 100 + [[0, 1], [1, 0]])
    >>> stated = np.array([[True, True]] * 200 + [[False, False]] * 2)
    >>> many = SiteReads(held, stated, np.array([1.0, 1.0]), np.array([3, 7]))
    >>> surely_trusted_readings(Readings.from_rows(np.zeros((202, 1)), many)).symbols.tolist()
    [[0, 0], [1, 2], [2, 1]]
    >>> few = SiteReads(held[196:], stated[196:], np.array([1.0, 1.0]), np.array([3, 7]))
    >>> surely_trusted_readings(Readings.from_rows(np.zeros((6, 1)), few)) is None
    True
    """
    # imported here: the CLI's parser imports this module, and vision pulls in scipy
    from vggc_cp.vision.trust import READ_Z, kappa_lower, stated_shares

    sites = None if readings is None else readings.sites
    if sites is None:
        return None
    z = READ_Z if z is None else z
    held = np.asarray(sites.held, dtype=np.int64)
    stated = np.asarray(sites.stated, dtype=bool)
    kappa = np.asarray(sites.kappa, dtype=np.float64)
    own = getattr(sites, "trust", None)
    frame = (np.broadcast_to(kappa, held.shape) if own is None
             else np.asarray(own, dtype=np.float64))
    n_stated, share = stated_shares(held, stated)
    low = kappa_lower(frame, share[None, :], n_stated[None, :], z)
    told = getattr(sites, "trust_low", None)
    if told is not None:
        told = np.asarray(told, dtype=np.float64)
        low = np.where(np.isnan(told), low, np.minimum(low, told))
    judged = np.isfinite(kappa) & (n_stated > 0)       # a kappa judged on stated frames
    sure = (np.nan_to_num(low, nan=-1.0) >= min_kappa) & judged[None, :]
    rows = np.where(sure & ~stated, 1 + held, 0)
    rows = rows[:, rows.any(axis=0)]
    if not rows.any():
        return None
    return Readings.from_rows(rows)


def sure_reading_gap(problem: Problem, chosen: np.ndarray | None,
                     other: np.ndarray | None) -> float:
    """How many nats longer the surely trusted readings (:func:`surely_trusted_readings`)
    are coded given the graph ``other`` than given ``chosen`` (0 where there are none, or
    where either graph is None: a threshold the solver found no graph at): what they add
    to the description-length margin of ``chosen`` over ``other``."""
    if chosen is None or other is None:
        return 0.0
    sure = surely_trusted_readings(getattr(problem, "readings", None))
    if sure is None:
        return 0.0
    return float(reading_length(sure, other) - reading_length(sure, chosen))


def trusted_readings(readings: Readings | None, min_kappa: float = TRUSTED_KAPPA
                     ) -> Readings | None:
    """What the images read where the actions do not state it, at the sites read at least
    ``min_kappa`` beyond chance, as symbols (0 elsewhere; 1 empty, ``2 + c`` colour ``c``);
    None where no such site reads anything (or ``readings`` carries no site reads).

    >>> from vggc_cp.solvers.base import SiteReads
    >>> sites = SiteReads(held=np.array([[1, 0], [2, 1], [0, 1]]),
    ...                   stated=np.array([[False, False], [True, False], [False, True]]),
    ...                   kappa=np.array([0.95, 0.4]), action=np.array([3, 7]))
    >>> trusted_readings(Readings.from_rows(np.zeros((3, 1)), sites)).symbols.tolist()
    [[0], [1], [2]]
    """
    sites = None if readings is None else readings.sites
    if sites is None:
        return None
    trust = np.nan_to_num(np.asarray(sites.kappa, dtype=np.float64), nan=-1.0) >= min_kappa
    rows = np.where(trust[None, :] & ~np.asarray(sites.stated, dtype=bool),
                    1 + np.asarray(sites.held, dtype=np.int64), 0)
    rows = rows[:, trust]
    if not rows.any():
        return None
    return Readings.from_rows(rows)


def choice_lengths(problem: Problem, labels: Sequence[np.ndarray | None],
                   dls: Sequence[float] | None = None) -> np.ndarray:
    """What the mdl rule minimises over the graphs ``labels`` of a path: the description
    length (``dls``, computed where not given) of each graph within :data:`TIE_NATS` of
    the least, plus the code length of the trusted readings (:func:`trusted_readings`,
    :func:`reading_length`) where two or more graphs tie and there are any; ``inf`` for a
    graph beyond the tie. Shape (len(labels),), nats.

    Four picks, two of them read holding colour 0 at a trusted site and two colour 1: the
    actions favour one pick node by 0.69 nats (a tie), the readings two.

    >>> from vggc_cp.solvers.base import SiteReads
    >>> held = np.array([[1], [0], [1], [0], [2], [0], [2], [0]])
    >>> sites = SiteReads(held, np.zeros((8, 1), bool), np.array([1.0]), np.array([0]))
    >>> p = Problem(np.array([0, 1] * 4), np.array([0, 2, 4, 6]), np.zeros(4, np.int64),
    ...             np.array([1, 3, 5, 7]), ("pick_a", "place_a"), np.zeros((4, 4)),
    ...             np.zeros((4, 4)), readings=Readings.from_rows(np.zeros((8, 1)), sites))
    >>> one, two = np.array([0, 1] * 4), np.array([0, 1, 0, 1, 2, 3, 2, 3])
    >>> [round(float(description_length(p, lab)), 2) for lab in (one, two)]
    [0.69, 1.39]
    >>> [round(float(c), 2) for c in choice_lengths(p, [one, two])]
    [6.7, 5.78]
    """
    dls = np.array([description_length(problem, lab) for lab in labels] if dls is None
                   else dls, dtype=np.float64)
    out = np.full(len(dls), np.inf)
    finite = np.isfinite(dls)
    if not finite.any():
        return out
    tied = np.flatnonzero(finite & (dls <= dls[finite].min() + TIE_NATS))
    reads = (trusted_readings(getattr(problem, "readings", None)) if len(tied) > 1 else None)
    for i in tied:
        out[i] = dls[i] + (0.0 if reads is None else reading_length(reads, labels[i]))
    return out


def reading_length(readings: Readings, labels: np.ndarray) -> float:
    """``DL_read`` (module docstring) of the readings given the nodes ``labels``, in nats.
    Symbol 0 is no reading (not coded).

    Parameters
    ----------
    readings : Readings
        Codes of shape (N,) and symbols of shape (G, S).
    labels : ndarray of int, shape (N,)

    >>> r = Readings.from_rows(np.array([[1], [1], [2], [2], [0]]))
    >>> round(reading_length(r, np.array([0, 0, 1, 1, 1])), 3)   # each node: which of 2
    1.386
    >>> round(reading_length(r, np.array([0, 0, 0, 0, 0])), 3)   # log 2 + 4 log 2 + 1/2 log 5
    4.27
    """
    codes, symbols = readings.codes, readings.symbols
    n, n_sites = len(codes), symbols.shape[1]
    if n == 0 or n_sites == 0 or not symbols.any():
        return 0.0
    node = np.unique(np.asarray(labels, dtype=np.int64), return_inverse=True)[1].ravel()
    n_codes = len(symbols)
    pair, count = np.unique(node * n_codes + codes, return_counts=True)
    pnode, pcode = pair // n_codes, pair % n_codes
    width = int(symbols.max()) + 1
    n_nodes = int(node.max()) + 1
    site = np.repeat(np.arange(n_sites)[None, :], len(pair), axis=0)
    read = symbols[pcode]
    some = read > 0                                        # 0: nothing stated there
    key = ((site * n_nodes + pnode[:, None]) * width + read)[some]
    keys, inv = np.unique(key, return_inverse=True)
    c = np.bincount(inv.ravel(), weights=np.repeat(count, n_sites)[some.ravel()]
                    .astype(np.float64))
    cell = keys // width                                   # (site, node)
    cells, cinv = np.unique(cell, return_inverse=True)
    total = np.bincount(cinv.ravel(), weights=c)
    data = -float(np.sum(c * np.log(c / total[cinv.ravel()]))) + 0.0
    # what each node holds at each site: one of the symbols stated there anywhere
    model = float(np.log(readings.kinds)[cells // n_nodes].sum())
    return data + model + 0.5 * float(np.log(n)) * (len(keys) - len(cells))
