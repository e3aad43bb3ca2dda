"""Read doubts: nodes that only an untrustworthy reading of the images sets apart.

The footprints state what a site holds wherever an action of the episode acts there, and read
it from the images elsewhere (:mod:`vggc_cp.vision.occupancy`); under a robot arm resting above
the place it last acted on, that reading can be wrong for a whole episode and split one state
into two nodes that the re-runs and the description length both take as given. Every site's
reading carries its agreement with the stated frames beyond chance
(:attr:`~vggc_cp.solvers.base.SiteReads.kappa`); :func:`read_doubts` lists the node pairs that
only such readings, below :data:`READ_KAPPA`, tell apart, as merge doubts of
:mod:`vggc_cp.solvers.doubts`.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.doubts import MERGE, Doubt, DoubtRule, Flips
from vggc_cp.solvers.merge import PartitionClosure, ThresholdPath

#: Agreement beyond chance (Cohen's kappa) below which a site's reading does not settle that
#: two nodes are two states: below 0.6 is "moderate" agreement at best (Landis and Koch 1977).
READ_KAPPA = 0.6


def observation_episodes(problem: Problem) -> np.ndarray:
    """The episode of every observation: the chains its transitions link (an observation no
    transition touches is one of its own), numbered in order of first observation.

    >>> p = Problem(np.array([0, 1, 0, 0, 1]), np.array([0, 1, 3]), np.array([0, 1, 0]),
    ...             np.array([1, 2, 4]), ("pick", "place"), np.zeros((3, 3)), np.zeros((2, 2)))
    >>> observation_episodes(p).tolist()
    [0, 0, 0, 1, 1]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    n = problem.n_obs
    links = coo_matrix((np.ones(len(problem.src)), (problem.src, problem.dst)), shape=(n, n))
    _, comp = connected_components(links, directed=False)
    _, first = np.unique(comp, return_index=True)
    order = np.empty(len(first), dtype=np.int64)
    order[np.argsort(first)] = np.arange(len(first))
    return order[comp]


def read_doubts(problem: Problem, path: ThresholdPath, labels: np.ndarray,
                rule: DoubtRule | None = None, max_kappa: float = READ_KAPPA
                ) -> tuple[Doubt, ...]:
    """Merge doubts that only an untrustworthy reading of the images settles.

    Two nodes ``A`` and ``B`` of one role are such a doubt when

    * no episode visits both (nothing in the sequence sets them apart),
    * joining them, closed as the merge closes it
      (:class:`~vggc_cp.solvers.merge.PartitionClosure`), breaks neither Exactly-One nor the
      hand's colour, and no site is stated (by the actions) to hold two different things in
      one of the joined nodes,
    * the sites at which most of ``A``'s and most of ``B``'s observations hold different
      things are each read from the images on one side at least (not stated on both), and
      the best of those readings agrees with the stated observations beyond chance by less
      than ``max_kappa`` (:attr:`~vggc_cp.solvers.base.SiteReads.kappa`; Cohen's kappa).

    Then the two might be one state seen through a reading that errs (an arm over the site,
    a shaking camera): only acting at those sites from both nodes settles it. A right graph
    can hold such pairs too, but then the reading that tells them apart agrees with the
    stated frames (kappa near 1: two states that differ only where no action of theirs
    acts). Evidence: that of :func:`find_doubts` for the closure's join, plus
    ``read_sites`` (the separating sites' actions), ``read_kappa`` (the best of their
    kappas) and ``forced``. Ranked by ``read_kappa - max_kappa`` (all negative); at most
    ``rule.limit``.

    Parameters
    ----------
    problem : Problem or CodedProblem
        Its :attr:`~vggc_cp.solvers.base.Problem.readings` must hold
        :class:`~vggc_cp.solvers.base.SiteReads` (the footprints); else no doubt. A
        problem of descriptor codes is made dense only when a candidate pair is found.
    path : ThresholdPath
    labels : ndarray of int, shape (N,)
        The chosen partition.
    rule : DoubtRule, optional
    max_kappa : float
        The least agreement beyond chance that settles a separation (:data:`READ_KAPPA`).

    Returns
    -------
    tuple of Doubt
    """
    rule = rule or DoubtRule()
    readings = getattr(problem, "readings", None)
    sites = None if readings is None else readings.sites
    labels = np.asarray(labels, dtype=np.int64)
    if sites is None or path.selected is None or len(problem.act) == 0 or rule.limit == 0:
        return ()
    n = int(labels.max()) + 1
    held, stated = np.asarray(sites.held), np.asarray(sites.stated, dtype=bool)
    trust = np.nan_to_num(np.asarray(sites.kappa, dtype=np.float64), nan=np.inf)
    n_sites, n_vals = held.shape[1], int(held.max()) + 1 if held.size else 1
    role = np.full(n, -1)
    role[labels] = problem.roles
    rows, cols = np.repeat(labels, n_sites), np.tile(np.arange(n_sites), len(labels))
    counts = np.zeros((n, n_sites, n_vals), dtype=np.int64)
    np.add.at(counts, (rows, cols, held.ravel()), 1)
    facts = np.zeros((n, n_sites, n_vals), dtype=bool)
    told = stated.ravel()
    facts[rows[told], cols[told], held.ravel()[told]] = True
    majority, told_any = counts.argmax(axis=2), facts.any(axis=2)
    episode = observation_episodes(problem)
    visits = np.zeros((n, int(episode.max()) + 1), dtype=bool)
    visits[labels, episode] = True
    candidates = []
    for u in range(n):
        v = np.arange(u + 1, n)
        v = v[(role[v] == role[u]) & ~(visits[v] & visits[u]).any(axis=1)]
        v = v[((facts[v] | facts[u]).sum(axis=2) <= 1).all(axis=1)]
        sep = majority[v] != majority[u]
        told_both = told_any[v] & told_any[u]
        ok = sep.any(axis=1) & ~(sep & told_both).any(axis=1)
        for w, s in zip(v[ok], sep[ok]):
            best = float(trust[s].max())
            if best < max_kappa:
                candidates.append((best, u, int(w), np.flatnonzero(s)))
    if not candidates:
        return ()
    candidates.sort(key=lambda c: (c[0], c[1], c[2]))
    if hasattr(problem, "dense"):       # a problem of descriptor codes: its matrices now
        problem = problem.dense()
    closure = PartitionClosure(problem, labels)
    flips = Flips(problem, path, labels)
    found = []
    for best, u, w, sep in candidates:
        groups, _why = closure.join(u, w)
        if groups is None or any((facts[g].any(axis=0).sum(axis=1) > 1).any() for g in groups):
            continue
        flipped = labels.copy()
        for g in groups:
            flipped[np.isin(labels, g)] = g[0]
        found.append(flips.doubt(
            MERGE, (u, w), np.flatnonzero(labels == u), np.flatnonzero(labels == w), flipped,
            rule.typical, lambda steps, ev, b=best: round(b - max_kappa, 4),
            read_sites=sorted(problem.action_names[int(sites.action[k])] for k in sep),
            read_kappa=round(best, 4), forced=sum(len(g) - 1 for g in groups) - 1))
        if len(found) == rule.limit:
            break
    return tuple(found)
