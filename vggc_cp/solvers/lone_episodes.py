"""Lone episodes: an episode none of whose nodes another episode visits (beyond the paper).

A reading of the images can be wrong for a whole episode and still look trustworthy: an arm
that hides a site in every frame of the episode, two objects of different colours swapped
in the reading (multifruit-4x6 robot s2: red and yellow read the other way round at two
regions for all seven frames of one episode, at kappa 1.0). Every state the episode then
visits is one that no other episode visits: the episode runs on a path of its own, parallel
to the path it really took, and no bound on the readings' agreement
(:mod:`vggc_cp.solvers.read_doubts`) sees it.

In a right graph an episode visits some nodes that others visit too, unless the recording
is a few long walks through disjoint parts of the task. So the check asks how surprising the
lone episodes are, on the recording's own figures: with ``q`` the share of an episode's nodes
that no other episode visits (over every episode of two nodes or more), an episode of ``k``
distinct nodes is lone by chance with probability ``q ** k`` were the nodes lone
independently, so the number of lone episodes is about Poisson with mean
``lambda = sum_e q ** k_e``; :func:`lone_episodes` gives its tail probability at the count
seen, and :func:`lone_doubts` the path each lone episode's actions take on the rest of the
graph (the nodes it might really have visited). One long walk (``q = 1``) or a few walks
through disjoint parts are lone by chance (probability near 1): no doubt there.

On the tuning split and draws 7-16 (1713 runs, each graph as first learned at its code), a
lone episode appeared in 15 runs, every one of them a wrong graph; in 10 of them the lone
episodes' chance was below :data:`LONE_ALPHA`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.doubts import MERGE, Doubt, DoubtRule, Flips
from vggc_cp.solvers.mdl import description_length
from vggc_cp.solvers.merge import ThresholdPath
from vggc_cp.solvers.read_doubts import WalkGraph, dense_problem, episode_chains, node_majority

#: The chance of the lone episodes below which they are a doubt (a 5 % test).
LONE_ALPHA = 0.05


@dataclass(frozen=True, eq=False)
class LoneEpisodes:
    """The episodes whose nodes no other episode visits, and how surprising they are.

    Attributes
    ----------
    chains : tuple of ndarray of int
        Each lone episode's observations, in order (episodes of two nodes or more).
    share : float
        ``q``: the share of the episodes' node visits (an episode and a node it visits) that
        are to a node no other episode visits.
    expected : float
        ``lambda = sum_e q ** k_e``: the lone episodes expected by chance.
    chance : float
        The probability of at least ``len(chains)`` lone episodes under that Poisson law
        (1 where there is none).
    """

    chains: tuple[np.ndarray, ...]
    share: float
    expected: float
    chance: float

    @property
    def doubtful(self) -> bool:
        """Lone episodes less likely than :data:`LONE_ALPHA` by chance."""
        return bool(self.chains) and self.chance < LONE_ALPHA


def poisson_tail(count: int, mean: float) -> float:
    """``P(X >= count)`` for ``X`` Poisson with ``mean``.

    >>> round(poisson_tail(1, 1.0), 4), poisson_tail(0, 0.3), round(poisson_tail(2, 0.05), 5)
    (0.6321, 1.0, 0.00121)
    """
    if count <= 0:
        return 1.0
    below = sum(math.exp(-mean) * mean ** i / math.factorial(i) for i in range(count))
    return float(max(1.0 - below, 0.0))


def lone_episodes(problem: Problem, labels: np.ndarray) -> LoneEpisodes:
    """The episodes (chains of transitions, :func:`~vggc_cp.solvers.read_doubts.episode_chains`)
    of ``labels`` that visit no node another episode visits, and their chance (module
    docstring).

    Parameters
    ----------
    problem : Problem
        Its transitions chain the observations into episodes.
    labels : ndarray of int, shape (N,)

    Returns
    -------
    LoneEpisodes

    Examples
    --------
    Four episodes through nodes 0-1-2, and one through nodes 3-4 of its own:

    >>> from vggc_cp.solvers.base import Problem
    >>> src = np.array([0, 1, 3, 4, 6, 7, 9, 10, 12]); dst = src + 1
    >>> act = np.array([0, 1, 0, 1, 0, 1, 0, 1, 2])
    >>> roles = np.array([0, 1, 0] * 4 + [0, 1])
    >>> p = Problem(roles, src, act, dst, ("pick", "place"), np.zeros((9, 9)), np.zeros((5, 5)))
    >>> lone = lone_episodes(p, np.array([0, 1, 2] * 4 + [3, 4]))
    >>> [c.tolist() for c in lone.chains], round(lone.share, 3), round(lone.chance, 3)
    ([[12, 13]], 0.143, 0.032)
    >>> lone.doubtful
    True
    """
    labels = np.asarray(labels, dtype=np.int64)
    chains = [c for c in episode_chains(problem) if len(np.unique(labels[c])) >= 2]
    if not chains:
        return LoneEpisodes((), 0.0, 0.0, 1.0)
    nodes = [np.unique(labels[c]) for c in chains]
    visits = np.bincount(np.concatenate(nodes), minlength=int(labels.max()) + 1)
    own = [int(np.count_nonzero(visits[v] == 1)) for v in nodes]
    share = sum(own) / sum(len(v) for v in nodes)
    expected = float(sum(share ** len(v) for v in nodes))
    lone = tuple(c for c, v, k in zip(chains, nodes, own) if k == len(v))
    return LoneEpisodes(lone, float(share), expected, poisson_tail(len(lone), expected))


def lone_doubts(problem: Problem, path: ThresholdPath, labels: np.ndarray,
                lone: LoneEpisodes, rule: DoubtRule | None = None) -> tuple[Doubt, ...]:
    """A merge doubt per lone episode whose actions, walked from another node of its first
    node's role on the graph of every other episode
    (:meth:`~vggc_cp.solvers.read_doubts.WalkGraph.walk`), give a path of that graph: the
    episode's first node ``u`` and the walk's start ``w`` might be one state, the episode's
    frames that path's nodes. Of several such walks, the one whose flip costs the least
    description length. Evidence: that of :func:`~vggc_cp.solvers.doubts.find_doubts` for the
    flip, plus ``lone_episode`` (its first and last observation), ``moved_to`` (``w``),
    ``moved_path`` (the walk, one node per observation), ``read_sites`` (the sites whose
    reading differs between the episode's frames and the walk's nodes, where the problem
    reads sites), ``lone_chance`` and ``lone_expected``. At most ``rule.limit``, the most
    surprising episode first (in order of observation).
    """
    rule = rule or DoubtRule()
    if not lone.chains or rule.limit == 0:
        return ()
    labels = np.asarray(labels, dtype=np.int64)
    roles = np.full(int(labels.max()) + 1, -1)
    roles[labels] = np.asarray(problem.roles)
    act_of = np.full(problem.n_obs, -1, dtype=np.int64)
    act_of[problem.src] = problem.act
    sites = getattr(getattr(problem, "readings", None), "sites", None)
    found: list[Doubt] = []
    flips = None
    for chain in lone.chains[:rule.limit]:
        inside = np.zeros(problem.n_obs, dtype=bool)
        inside[chain] = True
        keep = ~inside[problem.src]
        graph = WalkGraph(labels[problem.src[keep]], problem.act[keep],
                          labels[problem.dst[keep]])
        here = labels[chain]
        mine = set(here.tolist())
        walks = []
        for other in np.flatnonzero(roles == roles[here[0]]):
            if int(other) in mine:
                continue
            moved = graph.walk(int(other), act_of[chain[:-1]], here)
            if moved is None or mine & set(moved.tolist()):
                continue
            flipped = labels.copy()
            flipped[chain] = moved
            walks.append((description_length(problem, flipped), int(other), moved, flipped))
        if not walks:
            continue
        _, other, moved, flipped = min(walks, key=lambda w: (w[0], w[1]))
        if flips is None:
            flips = Flips(dense_problem(problem), path, labels)
        u = int(here[0])
        found.append(flips.doubt(
            MERGE, (u, other), np.flatnonzero(labels == u), np.flatnonzero(labels == other),
            flipped, rule.typical, lone_episode=[int(chain[0]), int(chain[-1])],
            moved_to=other, moved_path=[int(v) for v in moved],
            read_sites=_differing_sites(problem, sites, labels, chain, moved),
            lone_chance=round(lone.chance, 6), lone_expected=round(lone.expected, 6)))
    return tuple(found)


def _differing_sites(problem, sites, labels: np.ndarray, chain: np.ndarray,
                     moved: np.ndarray) -> list[str]:
    """The sites (their actions' names) at which the episode's frames hold other than most
    observations of the walk's nodes; none where the problem reads no site."""
    if sites is None:
        return []
    held = np.asarray(sites.held)
    differ = (held[chain] != node_majority(held, labels)[moved]).any(axis=0)
    return sorted({problem.action_names[int(a)] for a in np.asarray(sites.action)[differ]})
