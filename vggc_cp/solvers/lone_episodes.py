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
``lambda = sum_e q ** k_e``; :func:`~vggc_cp.solvers.episodes.lone_episodes` gives its tail
probability at the count seen, and :func:`lone_doubts` the path each lone episode's actions
take on the rest of the graph (the nodes it might really have visited). One long walk
(``q = 1``) or a few walks through disjoint parts are lone by chance (probability near 1):
no doubt there.

On the tuning split and draws 7-16 (1713 runs, each graph as first learned at its code), a
lone episode appeared in 15 runs, every one of them a wrong graph; in 10 of them the lone
episodes' chance was below :data:`~vggc_cp.solvers.episodes.LONE_ALPHA`. Where a walk fits
and the description length favours it, the merge has already moved such an episode onto
that walk (:func:`~vggc_cp.solvers.episodes.move_lone_episodes`); what is left here is the
rest.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.doubts import MERGE, Doubt, DoubtRule, Flips
from vggc_cp.solvers.episodes import LoneEpisodes, LoneStarts, lone_walks
from vggc_cp.solvers.mdl import description_length
from vggc_cp.solvers.merge import ThresholdPath
from vggc_cp.solvers.read_doubts import dense_problem, node_majority


def lone_doubts(problem: Problem, path: ThresholdPath, labels: np.ndarray,
                lone: LoneEpisodes, rule: DoubtRule | None = None) -> tuple[Doubt, ...]:
    """A merge doubt per lone episode in doubt (:attr:`~vggc_cp.solvers.episodes.LoneEpisodes.
    doubted`: all of them where they are surprising, else those that start away from the
    recording's home) whose actions, walked from another node of its first node's role (the
    home, for an episode off home) on the graph of every other episode
    (:meth:`~vggc_cp.solvers.episodes.WalkGraph.walk`), give a path of that graph: the
    episode's first node ``u`` and the walk's start ``w`` might be one state, the episode's
    frames that path's nodes. Of several such walks, the one whose flip costs the least
    description length. Evidence: that of :func:`~vggc_cp.solvers.doubts.find_doubts` for the
    flip, plus ``lone_episode`` (its first and last observation), ``moved_to`` (``w``),
    ``moved_path`` (the walk, one node per observation), ``read_sites`` (the sites whose
    reading differs between the episode's frames and the walk's nodes, where the problem
    reads sites), ``lone_chance`` and ``lone_expected``. Where no walk fits, the closest
    merge the images leave between one of the episode's nodes and another node
    (:func:`_nearest_doubt`, ``nearest`` in its evidence), so that a flagged graph names a
    doubt. At most ``rule.limit``, the most surprising episode first (in order of
    observation).
    """
    rule = rule or DoubtRule()
    if not lone.doubted or rule.limit == 0:
        return ()
    labels = np.asarray(labels, dtype=np.int64)
    sites = getattr(getattr(problem, "readings", None), "sites", None)
    found: list[Doubt] = []
    flips = None
    for chain in lone.doubted[:rule.limit]:
        walks = lone_walks(problem, labels, chain, lone.starts_for(chain))
        if flips is None:
            flips = Flips(dense_problem(problem), path, labels)
        if not walks:
            found.extend(_nearest_doubt(flips, labels, chain, lone, rule))
            continue
        _, other, moved, flipped = min(walks, key=lambda w: (w[0], w[1]))
        u = int(labels[chain[0]])
        found.append(flips.doubt(
            MERGE, (u, other), np.flatnonzero(labels == u), np.flatnonzero(labels == other),
            flipped, rule.typical, lone_episode=[int(chain[0]), int(chain[-1])],
            moved_to=other, moved_path=[int(v) for v in moved],
            read_sites=_differing_sites(problem, sites, labels, chain, moved),
            lone_chance=round(lone.chance, 6), lone_expected=round(lone.expected, 6)))
    return tuple(found)


def lone_start_doubts(problem: Problem, path: ThresholdPath, labels: np.ndarray,
                      starts: LoneStarts, rule: DoubtRule | None = None) -> tuple[Doubt, ...]:
    """Merge doubts for the first surprising lone start
    (:func:`~vggc_cp.solvers.episodes.lone_starts`): per node ``u`` of the episode's own
    first frames, the node of ``u``'s role the episode does not visit whose observations lie
    nearest (:func:`_nearest_doubt`), nearest first, with ``lone_start`` (the first and last
    of those frames) in the evidence -- what `suggest` probes, as for a lone episode no walk
    fits. At most ``rule.limit``; none where the starts are no surprise."""
    rule = rule or DoubtRule()
    if not starts.surprising or rule.limit == 0:
        return ()
    chain, j = starts.starts[0]
    flips = Flips(dense_problem(problem), path, np.asarray(labels, dtype=np.int64))
    return _nearest_doubt(flips, labels, chain[:j], starts, rule,
                          key="lone_start")[:rule.limit]


def _nearest_doubt(flips: Flips, labels: np.ndarray, chain: np.ndarray,
                   lone: LoneEpisodes | LoneStarts, rule: DoubtRule,
                   key: str = "lone_episode") -> tuple[Doubt, ...]:
    """Where no walk fits a lone episode (its actions are taken nowhere else from a node of
    the role: blocks-3 clean s386, draw 42, an episode that stacks a third block and takes it
    back four times), a merge doubt per node ``u`` of the episode: with the node ``v`` of
    ``u``'s role the episode does not visit whose observations lie nearest ``u``'s (least
    mean distance; of equally near ones, the one whose join the description length favours
    most), nearest first -- so that the warning names what to probe (`suggest` tries ``u``'s
    actions from ``v``). Evidence as for a walk, with ``nearest`` instead of
    ``moved_path``, the chain's first and last observation under ``key``."""
    problem = flips.problem
    labels = np.asarray(labels, dtype=np.int64)
    roles = np.asarray(problem.roles)
    sites = getattr(getattr(problem, "readings", None), "sites", None)
    mine = np.unique(labels[chain])
    found = []
    for u in mine.tolist():
        a = np.flatnonzero(labels == u)
        role = int(roles[a[0]])
        dist = problem.dist_pick if role == 0 else problem.dist_place
        near = []
        for v in np.setdiff1d(np.unique(labels[roles == role]), mine).tolist():
            b = np.flatnonzero(labels == v)
            near.append((round(float(dist[np.ix_(problem.local[a], problem.local[b])].mean()),
                               9), v, b))
        if not near:
            continue
        least = min(n[0] for n in near)
        ranked = []
        for _, v, b in (n for n in near if n[0] == least):
            flipped = labels.copy()
            flipped[a] = v
            ranked.append((description_length(problem, flipped), v, b, flipped))
        length, v, b, flipped = min(ranked, key=lambda r: (r[0], r[1]))
        found.append(((least, length, u), flips.doubt(
            MERGE, (u, v), a, b, flipped, rule.typical,
            **{key: [int(chain[0]), int(chain[-1])]}, moved_to=v, nearest=True,
            read_sites=_differing_sites(problem, sites, labels, a, np.full(len(a), v)),
            lone_chance=round(lone.chance, 6),
            lone_expected=round(lone.expected, 6))))
    return tuple(d for _, d in sorted(found, key=lambda f: f[0]))


def _differing_sites(problem, sites, labels: np.ndarray, chain: np.ndarray,
                     moved: np.ndarray) -> list[str]:
    """The sites (their actions' names) at which the episode's frames hold other than most
    observations of the walk's nodes; none where the problem reads no site."""
    if sites is None:
        return []
    held = np.asarray(sites.held)
    differ = (held[chain] != node_majority(held, labels)[moved]).any(axis=0)
    return sorted({problem.action_names[int(a)] for a in np.asarray(sites.action)[differ]})
