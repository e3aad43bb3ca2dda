"""Read doubts: nodes that only an untrustworthy reading of the images sets apart.

The footprints state what a site holds wherever an action of the episode acts there, and read
it from the images elsewhere (:mod:`vggc_cp.vision.occupancy`); under a robot arm resting above
the place it last acted on, that reading can be wrong for a whole episode and split one state
into two nodes that the re-runs and the description length both take as given. Every site's
reading carries its agreement with the stated frames beyond chance
(:attr:`~vggc_cp.solvers.base.SiteReads.kappa`); :func:`read_doubts` lists the node pairs that
only such readings, below :data:`READ_KAPPA`, tell apart, as merge doubts of
:mod:`vggc_cp.solvers.doubts`. A kappa is an estimate from the frames whose actions state the
site -- a few dozen in a small recording -- so it counts only as far as it can be shown to
(:func:`kappa_lower`, 95 % one-sided): fruit-2x3 robot s170, a site read at kappa 0.65 from 43
stated frames (at least 0.29) misread a whole episode, and the graph was quiet. Where a pose
of the hand read the run, the evidence bounds it by that pose's own stated frames
(``SiteReads.trust_low``, :func:`vggc_cp.vision.trust.pose_bounds`), and the lower of
the two bounds decides: a pose seen in a few stated frames shows little, however well the
site's other poses read (random-782 robot: one frame of such a pose read a yellow one region
off for a whole episode, the site's kappa 0.98).

The same misreading can also put a whole episode on the wrong path of a right-sized graph:
its untouched sites read as another state's, every node it visits is a node of the graph, and
its actions are edges there. :func:`episode_doubts` lists the episodes whose actions, walked
on the learned graph from another node, give another path whose nodes nothing the episode's
actions state rules out, and that only such readings tell apart from the one chosen, as split
doubts (the episode's first node might be two: its frames in that episode are the other
path's first node).
"""

from __future__ import annotations

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.closure import PartitionClosure
from vggc_cp.solvers.doubts import MERGE, SPLIT, Doubt, DoubtRule, Flips
from vggc_cp.solvers.episodes import WalkGraph, episode_chains
from vggc_cp.solvers.merge import ThresholdPath
from vggc_cp.vision.trust import READ_Z, kappa_lower, stated_shares

#: Agreement beyond chance (Cohen's kappa) below which a site's reading does not settle that
#: two nodes are two states: below 0.6 is "moderate" agreement at best (Landis and Koch 1977).
READ_KAPPA = 0.6

def bound_decided(evidence: dict) -> bool:
    """Whether a read doubt's kappa alone would have settled it, so that its lower bound
    (``read_kappa_low``) made the doubt: what its message must say.

    >>> bound_decided({"read_kappa": 0.65, "read_kappa_low": 0.33})
    True
    >>> bound_decided({"read_kappa": 0.3, "read_kappa_low": 0.1}), bound_decided({"read_kappa": 0.9})
    (False, False)
    """
    return (isinstance(evidence.get("read_kappa_low"), (int, float))
            and evidence["read_kappa"] >= READ_KAPPA)


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


def node_majority(held: np.ndarray, labels: np.ndarray, n: int | None = None) -> np.ndarray:
    """What most observations of every node hold at every site, int64 shape ``(n, S)``
    (``held``: shape ``(N, S)``, non-negative values; the least value on a tie, 0 for a node
    without observations).

    >>> node_majority(np.array([[1, 0], [1, 2], [2, 2], [0, 0]]), np.array([0, 0, 0, 1])).tolist()
    [[1, 2], [0, 0]]
    """
    held, labels = np.asarray(held), np.asarray(labels, dtype=np.int64)
    n = int(labels.max()) + 1 if n is None else n
    n_sites, n_vals = held.shape[1], int(held.max()) + 1 if held.size else 1
    rows, cols = np.repeat(labels, n_sites), np.tile(np.arange(n_sites), len(labels))
    counts = np.zeros((n, n_sites, n_vals), dtype=np.int64)
    np.add.at(counts, (rows, cols, held.ravel()), 1)
    return counts.argmax(axis=2)


class _NodeReads:
    """What the observations of every node of ``labels`` hold at every site: ``facts``
    (bool, shape ``(n, S, V)``: a value stated by the actions in one of the node's
    observations), ``majority`` (shape ``(n, S)``: the value most of them hold, stated or
    read), ``role`` (shape ``(n,)``), ``trust`` (every site's kappa, NaN as infinity: a
    site read nowhere is never an untrustworthy reading), ``frame_trust`` (shape ``(N, S)``:
    how far the reading that set each observation can be trusted, infinity where stated;
    the site's kappa where the readings do not say) and the sites' ``held`` and
    ``stated``, and ``action``, the action naming every site; ``trust_low`` and
    ``frame_trust_low``, the same carried to their lower confidence bounds at ``z``
    (:func:`kappa_lower`, over each site's stated frames): what decides."""

    def __init__(self, sites, labels: np.ndarray, roles: np.ndarray, z: float = READ_Z):
        self.labels, self.action = labels, np.asarray(sites.action)
        self.n = n = int(labels.max()) + 1
        self.held = held = np.asarray(sites.held)
        self.stated = stated = np.asarray(sites.stated, dtype=bool)
        self.trust = np.nan_to_num(np.asarray(sites.kappa, dtype=np.float64), nan=np.inf)
        # how far the reading that set every observation can be trusted (the site's kappa
        # where the evidence does not say)
        own = getattr(sites, "trust", None)
        # (a site whose kappa says nothing read, or never settled, stays never untrustworthy)
        self.frame_trust = (np.broadcast_to(self.trust, held.shape) if own is None
                            else np.where(stated | np.isinf(self.trust), np.inf,
                                          np.asarray(own, dtype=np.float64)))
        # a kappa judged on few stated frames is trusted only as far as its lower bound
        n_stated, share = stated_shares(held, stated)
        self.trust_low = kappa_lower(self.trust, share, n_stated, z)
        self.frame_trust_low = kappa_lower(self.frame_trust, share[None, :],
                                           n_stated[None, :], z)
        # and where the evidence bounds a reading itself (the poses that read it), no higher
        told = getattr(sites, "trust_low", None)
        if told is not None and z > 0:
            told = np.asarray(told, dtype=np.float64)
            self.frame_trust_low = np.where(np.isfinite(self.frame_trust) & ~np.isnan(told),
                                            np.minimum(self.frame_trust_low, told),
                                            self.frame_trust_low)
        n_sites, n_vals = held.shape[1], int(held.max()) + 1 if held.size else 1
        self.role = np.full(n, -1)
        self.role[labels] = roles
        rows, cols = np.repeat(labels, n_sites), np.tile(np.arange(n_sites), len(labels))
        self.facts = np.zeros((n, n_sites, n_vals), dtype=bool)
        told = stated.ravel()
        self.facts[rows[told], cols[told], held.ravel()[told]] = True
        self.majority = node_majority(held, labels, n)

    @classmethod
    def of(cls, problem: Problem, path: ThresholdPath, labels: np.ndarray, rule: DoubtRule,
           z: float = READ_Z) -> _NodeReads | None:
        """None where nothing is read (no sites, no chosen threshold, no transition)."""
        readings = getattr(problem, "readings", None)
        sites = None if readings is None else readings.sites
        if sites is None or path.selected is None or len(problem.act) == 0 or rule.limit == 0:
            return None
        return cls(sites, np.asarray(labels, dtype=np.int64), np.asarray(problem.roles), z)


def read_doubts(problem: Problem, path: ThresholdPath, labels: np.ndarray,
                rule: DoubtRule | None = None, max_kappa: float = READ_KAPPA,
                z: float = READ_Z) -> tuple[Doubt, ...]:
    """Merge doubts that only an untrustworthy reading of the images settles.

    Two nodes ``A`` and ``B`` of one role are such a doubt when

    * no episode visits both (nothing in the sequence sets them apart),
    * joining them, closed as the merge closes it
      (:class:`~vggc_cp.solvers.closure.PartitionClosure`), breaks neither Exactly-One nor the
      hand's colour, and no site is stated (by the actions) to hold two different things in
      one of the joined nodes,
    * the sites at which most of ``A``'s and most of ``B``'s observations hold different
      things are each read from the images on one side at least (not stated on both), and
      the best of those readings agrees with the stated observations beyond chance by less
      than ``max_kappa`` (:attr:`~vggc_cp.solvers.base.SiteReads.kappa`; Cohen's kappa) --
      less, that is, than it can be shown to at ``z`` (:func:`kappa_lower`: a kappa judged
      on a few dozen stated frames is known to within about 0.2).

    Then the two might be one state seen through a reading that errs (an arm over the site,
    a shaking camera): only acting at those sites from both nodes settles it. A right graph
    can hold such pairs too, but then the reading that tells them apart agrees with the
    stated frames (kappa near 1: two states that differ only where no action of theirs
    acts). Evidence: that of :func:`find_doubts` for the closure's join, plus
    ``read_sites`` (the separating sites' actions), ``read_kappa`` (the best of their
    kappas), ``read_kappa_low`` (the best of their lower bounds, which decided),
    ``forced``, ``read_told`` (per node, of ``nodes``, the separating sites the actions state
    in one of its observations: the doubt falls once one is stated in both) and
    ``read_acting`` (:class:`SiteActions`: per separating site, the actions seen changing
    it). Ranked by ``read_kappa_low - max_kappa`` (all negative); at most ``rule.limit``.

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
    z : float
        How sure that agreement must be: the normal quantile of the lower bound
        (:data:`READ_Z`; 0 takes the kappas as they are).

    Returns
    -------
    tuple of Doubt
    """
    rule = rule or DoubtRule()
    nodes = _NodeReads.of(problem, path, labels, rule, z)
    if nodes is None:
        return ()
    n, role, trust, low = nodes.n, nodes.role, nodes.trust, nodes.trust_low
    facts, majority = nodes.facts, nodes.majority
    told_any = facts.any(axis=2)
    labels = nodes.labels
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
            best = float(low[s].max())
            if best < max_kappa:
                candidates.append((best, u, int(w), np.flatnonzero(s)))
    if not candidates:
        return ()
    candidates.sort(key=lambda c: (c[0], c[1], c[2]))
    problem = dense_problem(problem)
    closure = PartitionClosure(problem, labels)
    flips = Flips(problem, path, labels)
    acting = SiteActions(nodes, problem)
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
            read_sites=sorted(problem.action_names[int(nodes.action[k])] for k in sep),
            read_kappa=round(float(trust[sep].max()), 4), read_kappa_low=round(best, 4),
            forced=sum(len(g) - 1 for g in groups) - 1, read_acting=acting.named(sep),
            read_told=[acting.names(sep[told_any[x, sep]]) for x in (u, w)]))
        if len(found) == rule.limit:
            break
    return tuple(found)


class SiteActions:
    """The actions the recording shows changing what each site holds: a transition between
    two frames that both state the site (:attr:`~vggc_cp.solvers.base.SiteReads.stated`)
    and hold different things there. Any of them, taken, states the site for the frames
    around it as the site's own action does (the footprints state a site over the run
    between two actions that act on it), so that a probe of a read doubt may be any of
    them (:mod:`vggc_cp.solvers.suggest`)."""

    def __init__(self, nodes: _NodeReads, problem: Problem):
        held, stated = nodes.held, nodes.stated
        src, dst = np.asarray(problem.src), np.asarray(problem.dst)
        changed = stated[src] & stated[dst] & (held[src] != held[dst])
        act = np.asarray(problem.act)
        self._names = problem.action_names
        self._site = nodes.action
        self._acting = [np.unique(act[changed[:, k]]) for k in range(held.shape[1])]

    def names(self, sites: np.ndarray) -> list[str]:
        """The names of ``sites`` (site indices), sorted."""
        return sorted(self._names[int(self._site[k])] for k in sites)

    def named(self, sites: np.ndarray) -> dict[str, list[str]]:
        """``{site name: names of the actions seen changing it}`` for ``sites``."""
        return {self._names[int(self._site[k])]: [self._names[int(a)] for a in self._acting[k]]
                for k in sorted(sites, key=lambda k: self._names[int(self._site[k])])}


def near_cut_doubts(problem, path: ThresholdPath, labels: np.ndarray, near,
                    rule: DoubtRule | None = None) -> tuple[Doubt, ...]:
    """A split doubt per node the readings read apart but whose cut the code does not
    settle at 20 to 1 (``near``: :func:`vggc_cp.solvers.read_splits.near_cuts`): the two
    sides of its least losing cut, with ``read_cut_nats`` (what the cut loses) and
    ``read_sites`` (the sites that read the sides apart) in the evidence. At most
    ``rule.limit``, least loss first."""
    rule = rule or DoubtRule()
    if not near or rule.limit == 0:
        return ()
    labels = np.asarray(labels, dtype=np.int64)
    flips = Flips(dense_problem(problem), path, labels)
    out = []
    for u, a, b, loss, sites in near[:rule.limit]:
        flipped = labels.copy()
        flipped[b] = int(labels.max()) + 1
        out.append(flips.doubt(SPLIT, (int(u),), a, b, flipped, rule.typical,
                               read_cut_nats=round(float(loss), 4), read_sites=list(sites)))
    return tuple(out)


def dense_problem(problem):
    """A problem of descriptor codes made dense (its matrices), any other as it is."""
    return problem.dense() if hasattr(problem, "dense") else problem


def episode_doubts(problem: Problem, path: ThresholdPath, labels: np.ndarray,
                   rule: DoubtRule | None = None, max_kappa: float = READ_KAPPA,
                   z: float = READ_Z, resets=()) -> tuple[Doubt, ...]:
    """Episodes that only an untrustworthy reading of the images puts on their path.

    An episode's actions, walked on the learned graph from another node of its first
    node's role, may give another path: an action that is an edge there leads where the
    edge does (to one node); one that is none may return where the episode returns, to the
    node the walk visited whenever the episode was at the node it now returns to (a pick
    and a place that put an object back), where Exactly-One allows the new edge. The
    episode's frames could then be that path's nodes instead -- the nodes stay, the edges
    stay or one is added -- when

    * no site that the actions state in one of its frames holds another value, stated,
      in the other path's node at that step, nor differs from what most of that node's
      observations hold, no frame had an action refused (:mod:`vggc_cp.recorded`) that
      the other path's node takes, no frame was reset to (or from) an observation of
      another episode that is not in the other path's node (``resets``: the recording
      states the two show one state; an episode recorded on request from an episode's
      start pins it, and is pinned by it), and
    * the sites at which its frames differ from what most observations of the other
      path's nodes hold are read at every such frame (not stated), and the best of those
      readings agrees with the stated observations beyond chance by less than
      ``max_kappa`` -- each site judged by the reading that set it in those frames
      (:attr:`~vggc_cp.solvers.base.SiteReads.trust`: a run that no pose of the hand reads
      takes a weaker reading than the site's kappa says, or a guess), and taken at its
      lower bound at ``z`` as in :func:`read_doubts`; and
    * one of those sites' slots is read below ``max_kappa`` as its kappa stands (the
      weakest slot, :func:`weakest_slot`): the counts of objects tie the untouched slots
      of an episode together (:mod:`vggc_cp.vision.conservation`), so a slot read wrong
      carries the others with it, and a misplaced episode needs one to start from. Where
      every slot that sets the paths apart reads substantially, only the few stated frames
      behind the kappas are in question, not the reading: measured on 691 candidate
      episodes of the robot traces of the tuning split and draws 42-43, all 11 truly misplaced
      ones had a slot read below 0.6 (0.52 at most), and this condition drops 25 of the 55
      right episodes the bounds alone had doubted, 30 stay (draws 42 and 43, seen: five false
      alarms fewer, random-1131, random-1135 and random-1145 robot, random-1138 clean,
      multifruit-4x6 robot s395; no miss went quiet).

    The episode's first node ``N`` that other episodes visit too is then a split doubt: its
    observations in that episode (side ``Q``) might be on the other path, the rest of ``N``
    (side ``P``) stay. (A node whose every observation lies in the episode is no such side:
    joining it to another node is a merge question, :func:`read_doubts`, which the closure
    may forbid where the episode's other nodes are shared -- multifruit-2x3 robot s242: two
    frames of one episode made a node of their own, the next two sat in a node of another
    state, and joining the first two to their state's node would have joined those two
    states; only moving the episode keeps the graph.) An episode all of whose nodes are its
    own is a lone episode (:mod:`vggc_cp.solvers.lone_episodes`), not listed here. ``M``
    is the other path's first node. Evidence: that of
    :func:`~vggc_cp.solvers.doubts.find_doubts` for moving the whole episode onto the other
    path, plus ``episode`` (its first and last observation), ``moved_from`` (the episode's
    first node), ``moved_to`` (``M``),
    ``moved_path`` (the other path's nodes, one per observation of the episode),
    ``read_sites``, ``read_kappa``, ``read_kappa_low``, ``read_acting`` as for
    :func:`read_doubts`, and ``read_weakest`` (the weakest slot's sites and its kappa,
    ``{"sites": [...], "kappa": k}``). Ranked
    by ``read_kappa_low - max_kappa``; the episode with the least trustworthy reading
    first, one doubt per episode, at most ``rule.limit``.

    Parameters
    ----------
    problem : Problem or CodedProblem
        Its :attr:`~vggc_cp.solvers.base.Problem.readings` must hold
        :class:`~vggc_cp.solvers.base.SiteReads`; else no doubt.
    path : ThresholdPath
    labels : ndarray of int, shape (N,)
        The chosen partition.
    rule : DoubtRule, optional
    max_kappa : float
        The least agreement beyond chance that settles a placement (:data:`READ_KAPPA`).
    z : float
        As for :func:`read_doubts`.
    resets : sequence of (int, int)
        The recording's resets (:attr:`~vggc_cp.recorded.RecordedFacts.resets`).

    Returns
    -------
    tuple of Doubt
    """
    rule = rule or DoubtRule()
    nodes = _NodeReads.of(problem, path, labels, rule, z)
    if nodes is None:
        return ()
    labels = nodes.labels
    held, stated, facts, majority = nodes.held, nodes.stated, nodes.facts, nodes.majority
    graph = WalkGraph(labels[problem.src], problem.act, labels[problem.dst])
    sizes = np.bincount(labels, minlength=nodes.n)
    act_of = np.full(problem.n_obs, -1, dtype=np.int64)
    act_of[problem.src] = problem.act
    site_rows = np.arange(held.shape[1])
    # what the recording says was refused where (vggc_cp.recorded): a node that takes it is
    # no place for that observation
    refused_at: dict[int, set[int]] = {}
    for o, k in problem.refused:
        refused_at.setdefault(int(o), set()).add(int(k))
    # and which observations it says show one state: a move may not part them
    shown_as: dict[int, set[int]] = {}
    for a, b in resets:
        shown_as.setdefault(int(a), set()).add(int(b))
        shown_as.setdefault(int(b), set()).add(int(a))
    slot_of = slots_of(held)
    candidates = []
    for chain in episode_chains(problem):
        here = labels[chain]
        frames = chain.tolist()
        in_chain = set(frames)
        # the split doubt's node: the first of the episode's nodes that other episodes visit
        shared = here[np.bincount(here, minlength=nodes.n)[here] < sizes[here]]
        if len(chain) < 2 or not len(shared):
            continue
        best_move = None
        for other in np.flatnonzero(nodes.role == nodes.role[here[0]]):
            moved = graph.walk(int(other), act_of[chain[:-1]], here)
            if moved is None or (moved == here).all():
                continue
            walked = list(zip(frames, moved.tolist()))
            if any((v, k) in graph.ahead for o, v in walked for k in refused_at.get(o, ())):
                continue  # the other path takes an action the recording refused there
            if shown_as and any(labels[p] != v for o, v in walked
                                for p in shown_as.get(o, ()) if p not in in_chain):
                continue  # it would part what the recording says shows one state
            differ = held[chain] != majority[moved]
            # another stated value in the other node at a stated site, or a stated site
            # that the other node's observations mostly hold otherwise: ruled out
            clash = facts[moved].copy()
            clash[np.arange(len(chain))[:, None], site_rows, held[chain]] = False
            if ((clash.any(axis=2) | differ) & stated[chain]).any() or not differ.any():
                continue
            # the best reading among the sites that set the episode apart, each as far as
            # the reading that set it in the episode's frames can be trusted
            sep = differ.any(axis=0)
            best, point = (
                float(min(np.where(differ, frames[chain], np.inf)[:, sep].min(axis=0).max(),
                          sites[sep].max()))
                for frames, sites in ((nodes.frame_trust_low, nodes.trust_low),
                                      (nodes.frame_trust, nodes.trust)))
            if best >= max_kappa or (best_move is not None and best >= best_move[0]):
                continue
            weak, weak_kappa = weakest_slot(differ, nodes.frame_trust[chain], nodes.trust,
                                            slot_of)
            if weak_kappa < max_kappa:
                best_move = (best, int(other), moved, sep, point, weak, weak_kappa)
        if best_move is not None:
            candidates.append((best_move[0], int(chain[0]), chain, int(shared[0]),
                               *best_move[1:]))
    if not candidates:
        return ()
    candidates.sort(key=lambda c: (c[0], c[1]))
    problem = dense_problem(problem)
    flips = Flips(problem, path, labels)
    acting = SiteActions(nodes, problem)
    found = []
    for best, _first, chain, u, other, moved, sep, point, weak, weak_kappa in \
            candidates[:rule.limit]:
        mine = chain[labels[chain] == u]
        rest = np.setdiff1d(np.flatnonzero(labels == u), mine)
        flipped = labels.copy()
        flipped[chain] = moved
        found.append(flips.doubt(
            SPLIT, (u,), rest, mine, flipped, rule.typical,
            lambda steps, ev, b=best: round(b - max_kappa, 4),
            episode=[int(chain[0]), int(chain[-1])], moved_from=int(labels[chain[0]]),
            moved_to=other,
            moved_path=[int(v) for v in moved],
            read_sites=sorted(problem.action_names[int(a)] for a in nodes.action[sep]),
            read_kappa=round(point, 4), read_kappa_low=round(best, 4),
            read_acting=acting.named(np.flatnonzero(sep)),
            read_weakest={"sites": acting.names(weak), "kappa": round(weak_kappa, 4)}))
    return tuple(found)


def slots_of(held: np.ndarray) -> np.ndarray:
    """The slot of every site: sites that hold alike in every observation are one slot
    (the pick and place of one place, the actions of its colours), int64 shape ``(S,)``
    numbered in order of first site (``held``: shape ``(N, S)``).

    >>> slots_of(np.array([[1, 0, 1, 2], [0, 0, 0, 1]])).tolist()
    [0, 1, 0, 2]
    >>> slots_of(np.zeros((3, 0), dtype=np.int64)).tolist()
    []
    """
    held = np.asarray(held)
    if held.shape[1] == 0:
        return np.zeros(0, dtype=np.int64)
    _, first, inverse = np.unique(held.T, axis=0, return_index=True, return_inverse=True)
    order = np.empty(len(first), dtype=np.int64)
    order[np.argsort(first)] = np.arange(len(first))
    return order[np.asarray(inverse).ravel()]


def weakest_slot(differ: np.ndarray, frame_trust: np.ndarray, site_trust: np.ndarray,
                 slot_of: np.ndarray) -> tuple[np.ndarray, float]:
    """The slot read worst among those that set an episode apart from another path, and
    how far its reading can be trusted as it stands (no lower bound).

    A site's reading in the episode is trusted as far as the least trusted reading that set
    it in a frame where the two paths differ there, and no further than its kappa; a slot
    as far as its best site; the weakest slot is the least of those.

    Parameters
    ----------
    differ : ndarray of bool, shape (F, S)
        Where the episode's frames differ from the other path's nodes.
    frame_trust : ndarray, shape (F, S)
        How far the reading that set every frame can be trusted (infinite where stated).
    site_trust : ndarray, shape (S,)
        Every site's kappa (infinite where nothing is read).
    slot_of : ndarray of int, shape (S,)
        :func:`slots_of`.

    Returns
    -------
    sites : ndarray of int
        The weakest slot's sites.
    kappa : float

    >>> differ = np.array([[True, True, True]])
    >>> weakest_slot(differ, np.array([[0.9, 0.3, 0.5]]), np.array([1.0, 1.0, 0.4]),
    ...              np.array([0, 1, 1]))
    (array([1, 2]), 0.4)
    """
    per_site = np.minimum(np.where(differ, frame_trust, np.inf).min(axis=0), site_trust)
    sep = np.unique(slot_of[differ.any(axis=0)])
    per_slot = [float(per_site[slot_of == s].max()) for s in sep]
    k = int(np.argmin(per_slot))
    return np.flatnonzero(slot_of == sep[k]), per_slot[k]
