"""Episodes on a learned graph: their chains of observations, the paths their actions walk,
and lone episodes moved onto the path they walk (beyond the paper).

A problem's transitions chain its observations into episodes (:func:`episode_chains`); an
episode's actions, walked on the learned graph from another node (:class:`WalkGraph`), may
give another path of that graph. An episode none of whose nodes another episode visits is
*lone* (:func:`lone_episodes`, :mod:`vggc_cp.solvers.lone_episodes` for the doubt it raises):
in a right graph that happens about as often as the share of nodes only one episode visits
allows, and more lone episodes than that are a reading of the images wrong for a whole
episode -- an arm hiding a site in every frame, two colours swapped -- that runs the episode
on a path of its own, parallel to the one it took (on the tuning split and draws 7-16, 15 runs
had one, every one a wrong graph; multifruit-4x6 robot s2: one episode of seven frames, five
nodes too many).

Where the recording starts its episodes alike (a robot reset to one home: every episode but
a few starts at one node, the *home*), where an episode starts is known before its images
are read: by Laplace's rule, an episode starts away from home with probability ``(n - m + 1)
/ (n + 2)`` when ``m`` of the ``n`` other episodes start at home. A lone episode whose first
node is not the home, where the others start there at odds of :data:`HOME_ODDS` to 1 or
more, is *off home* (:attr:`LoneEpisodes.off_home`): a doubt however many lone episodes
chance allows, and walked from the home only (multifruit-4x6 robot s373, draw 40: 77 of 78
episodes start at home, and one, read wrong in all its eight frames, ran on six nodes of its
own, 74 nodes for 68; the Poisson test gave it a chance of 0.054). An episode whose
recording starts it with a reset is no evidence either way (its first frame is pinned).

:func:`move_lone_episodes` moves such an episode onto the path its actions walk on the rest
of the graph where the lone episodes are more than chance gives (:data:`LONE_ALPHA`) and the
move makes the description length of the whole graph shorter (:func:`~vggc_cp.solvers.mdl.
description_length`, two-part MDL: the episode's nodes go, its transitions run on edges the
graph has). The merge ends there, after the read cuts (:func:`vggc_cp.solvers.merge.
with_read_splits`), so the path's graphs and the confidence's re-runs are one kind of graph.
A lone episode that no walk fits, or whose move the code does not favour, stays, and the
verdict's lone check (:func:`~vggc_cp.solvers.lone_episodes.lone_doubts`) names it. Only the
problem's transitions and the description length are read, never ground-truth states.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.mdl import description_length


def episode_starts(n_obs: int, dst: np.ndarray) -> np.ndarray:
    """The first observation of every episode: those no transition leads to, ascending.

    >>> episode_starts(6, np.array([1, 2, 4])).tolist()
    [0, 3, 5]
    """
    return np.setdiff1d(np.arange(n_obs), np.asarray(dst, dtype=np.int64))


def episode_chains(problem: Problem) -> list[np.ndarray]:
    """Every episode's observations in the order its transitions link them (a problem's
    transitions chain its observations: one successor and one predecessor at most), each
    from its first (:func:`episode_starts`)."""
    n = problem.n_obs
    nxt = np.full(n, -1, dtype=np.int64)
    nxt[problem.src] = problem.dst
    out = []
    for first in episode_starts(n, problem.dst):
        chain = [int(first)]
        while nxt[chain[-1]] >= 0:
            chain.append(int(nxt[chain[-1]]))
        out.append(np.array(chain, dtype=np.int64))
    return out


class WalkGraph:
    """The learned graph's edges: ``ahead[(u, a)]``, the nodes action ``a`` leads to from
    ``u``, and ``labels_of[(u, v)]``, the actions between ``u`` and ``v``."""

    def __init__(self, src: np.ndarray, act: np.ndarray, dst: np.ndarray):
        self.ahead: dict[tuple[int, int], set[int]] = {}
        self.labels_of: dict[tuple[int, int], set[int]] = {}
        for s, a, d in zip(src.tolist(), act.tolist(), dst.tolist()):
            self.ahead.setdefault((s, a), set()).add(d)
            self.labels_of.setdefault((s, d), set()).add(a)

    def walk(self, start: int, actions: np.ndarray, here: np.ndarray,
             tail: bool = False) -> np.ndarray | None:
        """The nodes ``actions`` visit from ``start``, where the episode now visits the nodes
        ``here``. An action that is an edge there leads where the edge does (None where it
        leads to two nodes); one that is none returns, where the episode returns to a node it
        visited before, to the node the walk visited then (None where the walk visited two
        there: one node of the episode would be two of the walk) -- a new edge, allowed where
        no other action joins the two nodes (Exactly-One); None otherwise.

        With ``tail``, an action that is no edge and leads the episode to a node it has not
        visited ends the walk: the rest of the episode keeps its nodes (``here``), a state the
        rest of the graph has not seen, entered by a new edge -- unless the rest returns to a
        node the walk has re-placed (one node would be two). A walk that ends at its first
        step is None."""
        path = [start]
        for k, a in enumerate(actions.tolist()):
            ahead = self.ahead.get((path[-1], a))
            if ahead is not None:
                if len(ahead) != 1:
                    return None
                path.append(next(iter(ahead)))
                continue
            before = {path[j] for j in np.flatnonzero(here[:k + 1] == here[k + 1])}
            if tail and not before:
                rest = here[k + 1:]
                if k == 0 or np.isin(rest, here[:k + 1]).any():
                    return None
                return np.concatenate([np.asarray(path, dtype=np.int64), rest])
            if len(before) != 1:
                return None
            (back,) = before
            if self.labels_of.get((path[-1], back), {a}) != {a}:
                return None
            path.append(back)
        return np.array(path, dtype=np.int64)


#: The chance of the lone episodes below which they are a doubt (a 5 % test).
LONE_ALPHA = 0.05
#: The odds at which the other episodes' starts make one node the home (module docstring):
#: 20 to 1, the odds the description-length margin and the object counts are taken at.
HOME_ODDS = 20.0


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
    off_home : tuple of ndarray of int
        The lone episodes that start away from the home (module docstring), in order.
    home : int
        The node most episodes start at (-1 where no episode is counted).
    home_starts : int
        How many episodes start there (``m``), of ``episodes`` (``n + 1``).
    episodes : int
        The episodes counted (those no recorded reset starts).
    """

    chains: tuple[np.ndarray, ...]
    share: float
    expected: float
    chance: float
    off_home: tuple[np.ndarray, ...] = ()
    home: int = -1
    home_starts: int = 0
    episodes: int = 0

    @property
    def surprising(self) -> bool:
        """Lone episodes less likely than :data:`LONE_ALPHA` by chance."""
        return bool(self.chains) and self.chance < LONE_ALPHA

    @property
    def doubtful(self) -> bool:
        """Lone episodes less likely than :data:`LONE_ALPHA` by chance, or one off home."""
        return self.surprising or bool(self.off_home)

    @property
    def doubted(self) -> tuple[np.ndarray, ...]:
        """The lone episodes in doubt: all where they are surprising, else those off home."""
        return self.chains if self.surprising else self.off_home

    def starts_for(self, chain: np.ndarray) -> set[int] | None:
        """The nodes a walk of ``chain`` may start from: the home for an episode off home,
        any (None) otherwise."""
        off = any(int(c[0]) == int(chain[0]) for c in self.off_home)
        return {self.home} if off else None


def poisson_tail(count: int, mean: float) -> float:
    """``P(X >= count)`` for ``X`` Poisson with ``mean``.

    >>> round(poisson_tail(1, 1.0), 4), poisson_tail(0, 0.3), round(poisson_tail(2, 0.05), 5)
    (0.6321, 1.0, 0.00121)
    """
    if count <= 0:
        return 1.0
    below = sum(math.exp(-mean) * mean ** i / math.factorial(i) for i in range(count))
    return float(max(1.0 - below, 0.0))


def episode_visits(problem: Problem, labels: np.ndarray):
    """How the episodes of two nodes or more share the nodes of ``labels``: ``(visits,
    free, own, share)`` -- how many such episodes visit every node (shape ``(n,)``), those
    no recorded reset starts as ``(chain, nodes)`` pairs, how many of each one's nodes no
    other episode visits, and ``q``, the share of their node visits that are such (0 where
    there is none). An episode a recorded reset starts (its first frame shows an earlier
    observation's state) shares that node, or the graph breaks the fact (broken_facts): it
    counts in the others' visits, but is no episode that could be lone by chance
    (:func:`lone_episodes`, :func:`lone_starts`)."""
    labels = np.asarray(labels, dtype=np.int64)
    chains = [c for c in episode_chains(problem) if len(np.unique(labels[c])) >= 2]
    nodes = [np.unique(labels[c]) for c in chains]
    visits = np.bincount(np.concatenate(nodes), minlength=int(labels.max()) + 1) if nodes \
        else np.zeros(0, dtype=np.int64)
    pinned = {int(b) for _, b in getattr(problem, "resets", ())}
    free = [(c, v) for c, v in zip(chains, nodes) if int(c[0]) not in pinned]
    own = [int(np.count_nonzero(visits[v] == 1)) for _, v in free]
    share = sum(own) / sum(len(v) for _, v in free) if free else 0.0
    return visits, free, own, share


def lone_episodes(problem: Problem, labels: np.ndarray) -> LoneEpisodes:
    """The episodes (chains of transitions, :func:`episode_chains`) of ``labels`` that visit
    no node another episode visits, and their chance (module docstring). An episode that a
    recorded reset starts (the problem's ``resets``) is counted in no figure but the others'
    visits: its first node is one an earlier observation's episode visits (a suggested round
    of 20 one-action episodes raised the expected count of multifruit-4x6 robot s2 from 0.03
    to 0.11, and its lone episode was quiet, 69 nodes for 64).

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
    _, free, own, share = episode_visits(problem, labels)
    if not free:
        return LoneEpisodes((), 0.0, 0.0, 1.0)
    expected = float(sum(share ** len(v) for _, v in free))
    lone = tuple(c for (c, v), k in zip(free, own) if k == len(v))
    # where the episodes start: the home, and the lone episodes that start elsewhere
    first = labels[[int(c[0]) for c, _ in free]]
    home = int(np.bincount(first).argmax())
    m = int(np.count_nonzero(first == home))
    off = tuple(c for c in lone if labels[c[0]] != home
                and (m + 1) / (len(free) - 1 - m + 1) >= HOME_ODDS)
    return LoneEpisodes(lone, float(share), expected, poisson_tail(len(lone), expected),
                        off, home, m, len(free))


def lone_walks(problem: Problem, labels: np.ndarray, chain: np.ndarray,
               starts: set[int] | None = None):
    """Every path the actions of the episode ``chain`` (its observations in order) walk on the
    graph of the other episodes (:meth:`WalkGraph.walk` with its ``tail``: a walk may end
    where the rest of the graph has not seen the state the episode goes on to, and the rest
    keeps its nodes), from a node of its first node's role that it does not visit (of
    ``starts`` only, where given), through none of its nodes: ``(description length of the
    graph with the episode moved there, start node, path, moved labels)``, by start node."""
    labels = np.asarray(labels, dtype=np.int64)
    roles = np.full(int(labels.max()) + 1, -1)
    roles[labels] = np.asarray(problem.roles)
    act_of = np.full(problem.n_obs, -1, dtype=np.int64)
    act_of[problem.src] = problem.act
    inside = np.zeros(problem.n_obs, dtype=bool)
    inside[chain] = True
    keep = ~inside[problem.src]
    graph = WalkGraph(labels[problem.src[keep]], problem.act[keep], labels[problem.dst[keep]])
    here = labels[chain]
    mine = set(here.tolist())
    out = []
    for other in np.flatnonzero(roles == roles[here[0]]):
        if int(other) in mine or (starts is not None and int(other) not in starts):
            continue
        moved = graph.walk(int(other), act_of[chain[:-1]], here, tail=True)
        if moved is None:
            continue
        ours = np.isin(moved, list(mine))
        walked = int(np.argmax(ours)) if ours.any() else len(moved)
        if not np.array_equal(moved[walked:], here[walked:]):
            continue            # the walk passes through one of the episode's own nodes
        flipped = labels.copy()
        flipped[chain] = moved
        out.append((description_length(problem, flipped), int(other), moved, flipped))
    return out


def move_lone_episodes(problem: Problem, labels: np.ndarray) -> tuple[np.ndarray, int]:
    """``labels`` with the lone episodes moved onto the path their actions walk (module
    docstring), and how many were moved: where the lone episodes are less likely than
    :data:`LONE_ALPHA` by chance, each in turn (in order of observation), else each lone
    episode off home (walked from the home only), goes to its walk of least description
    length (ties: the lowest start node) if that is shorter than the graph's as it is. Node
    numbers are kept (the moved episode's own nodes are left empty).

    Examples
    --------
    Four episodes through nodes 0-1-2 and a fifth, the same actions, through nodes 3-4 of its
    own: moved onto 0-1, the code is shorter by two nodes.

    >>> src = np.array([0, 1, 3, 4, 6, 7, 9, 10, 12]); dst = src + 1
    >>> act = np.array([0, 1, 0, 1, 0, 1, 0, 1, 0])
    >>> roles = np.array([0, 1, 0] * 4 + [0, 1])
    >>> p = Problem(roles, src, act, dst, ("pick", "place"), np.zeros((9, 9)), np.zeros((5, 5)))
    >>> labels, moved = move_lone_episodes(p, np.array([0, 1, 2] * 4 + [3, 4]))
    >>> labels.tolist()[-2:], moved
    ([0, 1], 1)
    """
    labels = np.asarray(labels, dtype=np.int64)
    lone = lone_episodes(problem, labels)
    if not lone.doubtful:
        return labels, 0
    moved, now = 0, description_length(problem, labels)
    for chain in lone.doubted:
        walks = lone_walks(problem, labels, chain, lone.starts_for(chain))
        if not walks:
            continue
        length, _, _, flipped = min(walks, key=lambda w: (w[0], w[1]))
        if length < now:
            labels, now, moved = flipped, length, moved + 1
    return labels, moved


#: Distinct nodes an episode's lone start must have before it counts
#: (:func:`lone_starts`). A start state the rest of the recording never saw, as a random
#: start often is, leads to states it never saw either: its first action's outcome, and
#: back (blocks-3 clean s47: an episode starts holding a block over two, stacks the third
#: and takes it back, two nodes of its own, right). Two own nodes are one rare start;
#: three are not (random-29 robot after two suggested rounds: three misread frames).
LONE_START_NODES = 3


@dataclass(frozen=True, eq=False)
class LoneStarts:
    """The episodes that begin on nodes no other episode visits and then join the graph the
    others walk, and how surprising they are (:func:`lone_starts`).

    Attributes
    ----------
    starts : tuple of (ndarray of int, int)
        Each such episode's observations in order, and the position of its first
        observation on a node another episode visits.
    share : float
        ``q``: the share of the episodes' node visits that are to a node no other episode
        visits (as :attr:`LoneEpisodes.share`).
    expected : float
        ``lambda = sum_e q ** LONE_START_NODES`` over the episodes that could have one
        (more distinct nodes than that).
    chance : float
        The probability of at least ``len(starts)`` such episodes under that Poisson law (1
        where there is none).
    """

    starts: tuple[tuple[np.ndarray, int], ...]
    share: float
    expected: float
    chance: float

    @property
    def surprising(self) -> bool:
        """Lone starts less likely than :data:`LONE_ALPHA` by chance."""
        return bool(self.starts) and self.chance < LONE_ALPHA


def lone_starts(problem: Problem, labels: np.ndarray) -> LoneStarts:
    """The episodes whose first :data:`LONE_START_NODES` or more nodes no other episode
    visits and which go on to a node another does, and their chance.

    A reading of the images can go wrong for the first frames of an episode only: the arm
    still rests where the previous episode left it, over a place it hides, until the first
    actions move it (random-29 robot after two rounds of suggested episodes: one episode's
    first three frames on three nodes of their own, the first of them the very state the
    episode comes back to two actions later; 25 nodes for 22, no other check raised). Such an
    episode then starts on a path of its own and joins the graph where the reading comes
    right. By chance, with ``q`` the share of the episodes' node visits that no other
    episode shares (:func:`lone_episodes`), an episode's first three nodes are all its own
    with probability about ``q ** 3``; the count of such starts is about Poisson with mean
    ``sum_e q ** 3`` over the episodes of four nodes or more (two own nodes are what one rare
    start state gives, :data:`LONE_START_NODES`). An episode whose first nodes
    it visits again after it joins is not counted (its nodes are not a start only), nor one
    that a recorded reset starts (its first frame is pinned to an earlier one), nor a lone
    episode (no node of it is shared).

    On the tuning split, none is surprising (calibration.md, session 55).

    Examples
    --------
    Twelve episodes through nodes 0-1-2-3-0 and one that starts on nodes 4, 5 and 6 of its
    own and joins at node 3:

    >>> from vggc_cp.solvers.base import Problem
    >>> labels = np.array([0, 1, 2, 3, 0] * 12 + [4, 5, 6, 3, 0])
    >>> src = np.arange(65).reshape(13, 5)[:, :4].ravel(); dst = src + 1
    >>> act = np.tile([0, 1, 2, 3], 13)
    >>> roles = np.array([0, 1, 0, 1, 0] * 13)
    >>> p = Problem(roles, src, act, dst, ("pick", "place") * 2, np.zeros((39, 39)),
    ...             np.zeros((26, 26)))
    >>> found = lone_starts(p, labels)
    >>> [(c.tolist(), j) for c, j in found.starts], round(found.chance, 4), found.surprising
    ([([60, 61, 62, 63, 64], 3)], 0.0024, True)
    """
    labels = np.asarray(labels, dtype=np.int64)
    visits, free, _, share = episode_visits(problem, labels)
    if not free:
        return LoneStarts((), 0.0, 0.0, 1.0)
    found, could = [], 0
    for c, v in free:
        if len(v) > LONE_START_NODES:
            could += 1
        shared = np.flatnonzero(visits[labels[c]] > 1)
        if not len(shared):
            continue                       # a lone episode (lone_episodes)
        j = int(shared[0])
        own = labels[c[:j]]
        if len(np.unique(own)) < LONE_START_NODES or np.isin(labels[c[j:]], own).any():
            continue
        found.append((c, j))
    expected = float(could * share ** LONE_START_NODES)
    return LoneStarts(tuple(found), float(share), expected,
                      poisson_tail(len(found), expected))
