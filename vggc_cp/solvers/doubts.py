"""Doubts: the decisions of a learned graph that the trace does not settle.

The merge path (:mod:`vggc_cp.solvers.merge`) decides, at the chosen threshold ``t*``, which
observations are one state. Two kinds of decision can be close calls:

* a **merge doubt** -- two nodes ``A`` and ``B`` of one role that the graph keeps apart but
  that might be one state. Candidates: pairs that one of the ``window`` next larger
  thresholds of the path joins (most observations of each in one node there), and pairs
  whose average-linkage distance ``d(A, B)`` is at most ``t* * ratio**window`` (``ratio``:
  the grid's step); the ``max_pairs`` closest of them are examined. The join is closed on the chosen partition as the merge would close it
  (:class:`~vggc_cp.solvers.closure.PartitionClosure`: determinism and co-determinism,
  transitively). When Exactly-One forbids the closure, the pair is a candidate only when
  ``d(A, B) <= t*``: the images put the two nodes together and only the constraints keep
  them apart, so some other decision conflicts with it (``forbidden: "exactly_one"``; or
  ``"hand"``: the closure would join place observations whose hands hold different colours,
  which only a wrong colour of some action could allow);
* a **split doubt** -- a node ``N`` that might be two states: one of the ``window`` next
  smaller thresholds splits it; its two sides ``P`` (the larger) and ``Q`` are the two
  clusters of the last merge of average-linkage clustering on its observations' distances
  (the cut a person would draw between its renders). Sides closer than one grid step above the path's
  lowest threshold (the noise scale, or a hundredth of the top distances) differ by
  rendering noise only and make no doubt.

A join that the read cuts (:mod:`vggc_cp.solvers.read_splits`) would part again -- the
combined readings of its node show two states, and cutting keeps the graph deterministic and
its code shorter -- is no graph the method learns, and is no merge doubt.

Evidence each way (a :class:`Doubt`'s ``evidence``; the two sides are ``A``/``B`` or
``P``/``Q``):

``distance``, ``threshold``, ``spread``, ``separation``
    Average-linkage visual distance between the two sides (mean over pairs of their
    observations), the chosen ``t*``, the larger of the sides' mean within-side distances
    (0 for one observation), and ``distance / max(spread, noise scale, t*/1000)``: near 1
    the sides look as alike as the renders within a side; far above 1 they look different.
``steps``
    Where the images decide, in grid steps from ``t*``: ``log(x / t*) / log(ratio)``, with
    ``x`` the threshold a merge doubt's join needs (the largest average-linkage distance
    between two nodes its closure joins; ``distance`` when forbidden) or a split doubt's
    ``distance``. A merge doubt with ``steps > 0`` is kept apart by the threshold; a split
    doubt with ``steps < 0`` is held together by it.
``dl_change``
    Description length (:func:`~vggc_cp.solvers.mdl.description_length`) of the graph with
    the decision flipped (merge doubt: the closure's groups joined, or just ``A`` and ``B``
    when forbidden; split doubt: ``Q`` given a node of its own) minus that of the chosen
    graph, in nats per transition (``dl_nats``: in nats). Positive: the actions the trace
    took favour the chosen decision; negative: they favour the flip. ``dl_nats`` is a log
    odds: 3 nats (odds of 20 to 1) is "strong" evidence in the usual reading of Bayes
    factors (Kass and Raftery 1995).
``thresholds_apart``, ``thresholds_together``
    Thresholds of the path at which most observations of the two sides lie in different
    nodes / in one node.
``threshold_needed``, ``forced``, ``forbidden``
    Merge doubts: ``x`` above, the number of other node pairs the closure joins, and
    ``"exactly_one"``, ``"hand"`` (or ``null``) as above.
``only_a``, ``only_b``
    Action names taken in the trace from one side and never from the other: what the
    robot could try from the other side to settle the doubt (``vggc-cp suggest``).
``closeness``
    The ranking key, ``visual + dl_nats / max_nats`` with ``visual = max(0, steps) /
    window`` for a merge doubt and ``max(0, -steps) / window`` for a split doubt: 0 when
    the images favour the flip, 1 at ``window`` steps. Smaller is a closer call (negative:
    the actions favour the flip).

A candidate is a **doubt** when ``visual <= 1`` and ``closeness <= 1``: neither the images
(within ``window`` grid steps) nor the actions (less than ``max_nats``, strong evidence)
settle it. Doubts are ranked by ``closeness`` and at most ``limit`` are kept; the
observations of each side are its ``typical`` most typical ones (least mean distance to
the others of its side).

**Disputed pairs** (:func:`disputed_doubts`): where a warning names no decision near ``t*``,
the held-out prediction may: a graph learned without an episode sends one of its transitions
to node ``A`` and the images put the transition's end in node ``B``. The pair is a merge doubt
whatever its closeness, with ``contradicted`` added to its evidence.

**The runner-up's differences** (:func:`runner_up_doubts`): where the warning is that a graph
of another size is nearly as probable and no doubt lies between the two thresholds, the nodes
that graph splits or joins are the doubts, whatever their closeness (``runner_up`` is then
set in their evidence, and ``closeness`` is the flip's ``dl_nats``).

Everything here reads the problem (distances, actions) and the path only, never
ground-truth states.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.closure import PartitionClosure
from vggc_cp.solvers.mdl import description_length
from vggc_cp.solvers.merge import ThresholdPath, noise_scale
from vggc_cp.solvers.read_splits import combined_readings, split_by_readings

MERGE = "merge"
SPLIT = "split"
KINDS = (MERGE, SPLIT)


@dataclass(frozen=True)
class DoubtRule:
    """When a candidate decision counts as a doubt (module docstring).

    Attributes
    ----------
    window : int
        Thresholds of the path looked at on each side of the chosen one.
    max_nats : float
        Description-length change (nats) that settles a decision on its own (3: odds of
        20 to 1).
    limit : int
        Most doubts of each kind the checks judge (the re-runs', the readings' pairs, the
        readings' episodes).
    listed : int
        Most doubts a solution lists (those checks' and every further one, most pressing
        first): what ``vggc-cp suggest`` can propose episodes for -- two rounds of its
        default 20 where one probe settles one doubt (multifruit-4x6 robot: 28 episodes
        read at one pose's bound, of which a list of ``limit`` let one round pin 8).
    typical : int
        Observations listed per side (the most typical: least mean distance to their side).
    max_pairs : int
        Candidate node pairs examined for merge doubts, closest first.
    """

    window: int = 3
    max_nats: float = 3.0
    limit: int = 10
    listed: int = 40
    typical: int = 3
    max_pairs: int = 400

    def __post_init__(self):
        if self.window < 1:
            raise ValueError(f"window must be at least 1, got {self.window}")
        if not self.max_nats > 0:
            raise ValueError(f"max_nats must be positive, got {self.max_nats}")
        if self.limit < 0 or self.typical < 1 or self.max_pairs < 0:
            raise ValueError("limit and max_pairs must be >= 0 and typical >= 1")
        if self.listed < self.limit:
            raise ValueError(f"listed ({self.listed}) must be at least limit ({self.limit})")


@dataclass(frozen=True)
class Doubt:
    """One decision the evidence does not settle.

    Attributes
    ----------
    kind : str
        ``merge`` (nodes ``nodes[0]`` and ``nodes[1]`` might be one state) or ``split``
        (node ``nodes[0]`` might be two: its observations ``sides[0]`` against ``sides[1]``).
    nodes : tuple of int
    observations : tuple of tuple of int
        A few observation indices of each side (the most typical first).
    evidence : dict
        The figures of the module docstring (JSON-ready).
    closeness : float
        The ranking key (smaller: a closer call).
    """

    kind: str
    nodes: tuple[int, ...]
    observations: tuple[tuple[int, ...], tuple[int, ...]]
    evidence: dict = field(compare=False)
    closeness: float = 0.0

    def as_dict(self) -> dict:
        """The solution JSON's record: ``{"kind", "nodes", "observations", "evidence"}``."""
        return {"kind": self.kind, "nodes": [int(u) for u in self.nodes],
                "observations": [[int(o) for o in side] for side in self.observations],
                "evidence": dict(self.evidence)}


def _dist(problem: Problem, role: int) -> np.ndarray:
    return problem.dist_pick if role == 0 else problem.dist_place


class _Sides:
    """Distances between groups of observations of one role."""

    def __init__(self, problem: Problem):
        self.p = problem

    def block(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d = _dist(self.p, int(self.p.roles[a[0]]))
        return d[np.ix_(self.p.local[a], self.p.local[b])]

    def link(self, a: np.ndarray, b: np.ndarray) -> float:
        return float(self.block(a, b).mean())

    def spread(self, a: np.ndarray) -> float:
        if len(a) < 2:
            return 0.0
        blk = self.block(a, a)
        return float(blk.sum() / (len(a) * (len(a) - 1)))

    def halves(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The two clusters of the last merge of average-linkage clustering on ``a``'s
        distances: the larger (ties: the one holding ``a[0]``) first."""
        from scipy.cluster.hierarchy import fcluster, linkage
        from scipy.spatial.distance import squareform

        blk = self.block(a, a)
        blk = (blk + blk.T) / 2
        np.fill_diagonal(blk, 0.0)
        cut = fcluster(linkage(squareform(blk, checks=False), method="average"), 2,
                       criterion="maxclust")
        one, two = a[cut == cut[0]], a[cut != cut[0]]
        return (one, two) if len(one) >= len(two) else (two, one)

    def typical(self, a: np.ndarray, k: int) -> tuple[int, ...]:
        """The ``k`` observations of ``a`` of least mean distance to the others."""
        mean = self.block(a, a).mean(axis=1)
        order = np.lexsort((a, mean))
        return tuple(int(a[i]) for i in order[:k])


def _actions_from(problem: Problem, obs: np.ndarray) -> set[int]:
    mask = np.isin(problem.src, obs)
    return set(problem.act[mask].tolist())


def _dominant(labels: np.ndarray | None, obs: np.ndarray) -> int:
    if labels is None:
        return -1
    vals, counts = np.unique(labels[obs], return_counts=True)
    return int(vals[np.argmax(counts)])


def _count_together(path: ThresholdPath, a: np.ndarray, b: np.ndarray) -> tuple[int, int]:
    together = sum(1 for r in path.results if r.labels is not None
                   and _dominant(r.labels, a) == _dominant(r.labels, b))
    total = sum(1 for r in path.results if r.labels is not None)
    return total - together, together


def _grid_ratio(thresholds: tuple[float, ...]) -> float:
    ts = np.asarray(thresholds, dtype=np.float64)
    ts = ts[ts > 0]
    if len(ts) < 2:
        return 1.25
    r = float(np.median(ts[1:] / ts[:-1]))
    return r if r > 1.0 + 1e-9 else 1.25


def find_doubts(problem: Problem, path: ThresholdPath, labels: np.ndarray,
                selected: int | None = None, rule: DoubtRule | None = None
                ) -> tuple[Doubt, ...]:
    """The doubts of the partition ``labels`` chosen on ``path`` (module docstring).

    Parameters
    ----------
    problem : Problem
    path : ThresholdPath
        The merge path the partition was chosen on (thresholds ascending).
    labels : ndarray of int, shape (N,)
        The chosen partition (usually ``path.results[selected].labels``).
    selected : int, optional
        Index of the chosen threshold (default ``path.selected``).
    rule : DoubtRule, optional

    Returns
    -------
    tuple of Doubt
        Closest call first, at most ``rule.limit``.
    """
    rule = rule or DoubtRule()
    k = path.selected if selected is None else int(selected)
    labels = np.asarray(labels, dtype=np.int64)
    if k is None or len(problem.act) == 0 or rule.limit == 0:
        return ()
    t_star = float(path.thresholds[k])
    ratio = _grid_ratio(path.thresholds)
    log_r = math.log(ratio)
    noise = noise_scale(problem)
    # one grid step above the path's lowest threshold (the noise scale, or a hundredth of
    # the top distances): sides closer than this differ by rendering noise only
    floor = max(noise, float(path.thresholds[0])) * ratio
    n_trans = len(problem.act)
    dl0 = description_length(problem, labels)
    sides = _Sides(problem)
    members = {int(u): np.flatnonzero(labels == u) for u in np.unique(labels)}
    role_of = {u: int(problem.roles[m[0]]) for u, m in members.items()}
    acts = {u: _actions_from(problem, m) for u, m in members.items()}
    names = problem.action_names

    def steps_of(x: float) -> float:
        if x <= 0 or t_star <= 0:
            return -float("inf") if x <= 0 else float("inf")
        return math.log(x / t_star) / log_r

    found: list[Doubt] = []

    # ---- merge doubts: pairs apart here, joined nearby above or close in distance
    pairs: set[tuple[int, int]] = set()
    for j in range(k + 1, min(k + 1 + rule.window, len(path.results))):
        lab = path.results[j].labels
        if lab is None:
            continue
        by_dom: dict[int, list[int]] = {}
        for u, m in members.items():
            by_dom.setdefault(_dominant(lab, m), []).append(u)
        for group in by_dom.values():
            for x in range(len(group)):
                for y in range(x + 1, len(group)):
                    if role_of[group[x]] == role_of[group[y]]:
                        pairs.add((min(group[x], group[y]), max(group[x], group[y])))
    limit_d = t_star * ratio ** rule.window
    for role in (0, 1):
        us = sorted(u for u in members if role_of[u] == role)
        if len(us) < 2:
            continue
        d = _dist(problem, role)
        loc = [problem.local[members[u]] for u in us]
        # average linkage between nodes: one matrix product over a membership matrix
        onehot = np.zeros((d.shape[0], len(us)))
        for c, li in enumerate(loc):
            onehot[li, c] = 1.0
        sizes = onehot.sum(axis=0)
        link = (onehot.T @ d @ onehot) / np.outer(sizes, sizes)
        iu, ju = np.nonzero(np.triu(link <= limit_d, 1))
        pairs |= {(us[a], us[b]) for a, b in zip(iu.tolist(), ju.tolist())}
    closure = PartitionClosure(problem, labels) if pairs else None
    rows = combined_readings(problem) if pairs else None
    # the closest pairs first, at most max_pairs of them (a bound on the work)
    ranked = sorted((sides.link(members[a], members[b]), a, b) for a, b in pairs)
    for dist_ab, a, b in ranked[:rule.max_pairs]:
        groups, why = closure.join(a, b)
        merged = labels.copy()
        if groups is None:
            # the constraints forbid the join: a doubt only where the images put the two
            # nodes within the chosen threshold (then some other decision conflicts)
            if dist_ab > t_star:
                continue
            need = dist_ab
            merged[members[b]] = a
        else:
            need = 0.0
            for g in groups:
                for x in range(len(g)):
                    for y in range(x + 1, len(g)):
                        need = max(need, sides.link(members[g[x]], members[g[y]]))
                for u in g[1:]:
                    merged[members[u]] = g[0]
        if rows is not None and split_by_readings(problem, merged, rows,
                                                  (merged[members[a][0]],))[1]:
            continue  # the read cuts would part the join again: no graph the method learns
        spread = max(sides.spread(members[a]), sides.spread(members[b]))
        ev = _evidence(dist_ab, t_star, spread, max(noise, 1e-3 * t_star), steps_of(need),
                       (description_length(problem, merged) - dl0) / n_trans,
                       _count_together(path, members[a], members[b]),
                       acts[a] - acts[b], acts[b] - acts[a], names, n_trans)
        ev["threshold_needed"] = round(need, 6)
        ev["forced"] = None if groups is None else sum(len(g) - 1 for g in groups) - 1
        ev["forbidden"] = why or None
        doubt = _keep(MERGE, (a, b), (sides.typical(members[a], rule.typical),
                                      sides.typical(members[b], rule.typical)), ev, rule)
        if doubt is not None:
            found.append(doubt)

    # ---- split doubts: nodes that a nearby smaller threshold splits
    for u, m in members.items():
        for j in range(k - 1, max(k - 1 - rule.window, -1), -1):
            lab = path.results[j].labels
            if lab is None:
                continue
            if len(np.unique(lab[m])) < 2:
                continue
            p_side, q_side = sides.halves(m)
            if len(q_side) == 0:
                break  # its renders are identical: nothing to cut
            dist_pq = sides.link(p_side, q_side)
            if dist_pq <= floor:
                break  # the sides differ by rendering noise only: not a doubt
            split = labels.copy()
            split[q_side] = int(labels.max()) + 1
            spread = max(sides.spread(p_side), sides.spread(q_side))
            ap, aq = _actions_from(problem, p_side), _actions_from(problem, q_side)
            ev = _evidence(dist_pq, t_star, spread, max(noise, 1e-3 * t_star), steps_of(dist_pq),
                           (description_length(problem, split) - dl0) / n_trans,
                           _count_together(path, p_side, q_side), ap - aq, aq - ap, names,
                           n_trans)
            doubt = _keep(SPLIT, (u,), (sides.typical(p_side, rule.typical),
                                        sides.typical(q_side, rule.typical)), ev, rule)
            if doubt is not None:
                found.append(doubt)
            break
    found.sort(key=lambda x: (x.closeness, x.kind, x.nodes))
    return tuple(found[:rule.limit])


class Flips:
    """The evidence of flipping one decision of the chosen partition ``labels`` on ``path``
    (the figures of the module docstring), for doubts named from outside the window (here,
    and :mod:`vggc_cp.solvers.read_doubts`)."""

    def __init__(self, problem: Problem, path: ThresholdPath, labels: np.ndarray):
        self.problem, self.path, self.labels = problem, path, labels
        self.t_star = float(path.thresholds[path.selected])
        self.log_r = math.log(_grid_ratio(path.thresholds))
        self.noise = max(noise_scale(problem), 1e-3 * self.t_star)
        self.dl0 = description_length(problem, labels)
        self.sides = _Sides(problem)

    def steps(self, x: float) -> float:
        return (math.log(x / self.t_star) / self.log_r if x > 0 and self.t_star > 0
                else 0.0)

    def doubt(self, kind: str, nodes: tuple[int, ...], a: np.ndarray, b: np.ndarray,
              flipped: np.ndarray, typical: int, closeness=None, **extra) -> Doubt:
        """The doubt whose sides are the observations ``a`` and ``b`` and whose flip gives
        the partition ``flipped``; ``closeness(steps, evidence)`` ranks it (default: its
        ``dl_nats``). ``extra`` joins the evidence before ``closeness``."""
        p, sides, n_trans = self.problem, self.sides, len(self.problem.act)
        d = sides.link(a, b)
        steps = self.steps(d)
        acts_a, acts_b = _actions_from(p, a), _actions_from(p, b)
        ev = _evidence(d, self.t_star, max(sides.spread(a), sides.spread(b)), self.noise,
                       steps, (description_length(p, flipped) - self.dl0) / n_trans,
                       _count_together(self.path, a, b), acts_a - acts_b, acts_b - acts_a,
                       p.action_names, n_trans)
        ev.update(extra)
        ev["closeness"] = round(ev["dl_nats"] if closeness is None else closeness(steps, ev),
                                4)
        return Doubt(kind, nodes, (sides.typical(a, typical), sides.typical(b, typical)), ev,
                     ev["closeness"])

    def joined(self, a: int, b: np.ndarray) -> np.ndarray:
        """The partition with the observations ``b`` put in node ``a``."""
        out = self.labels.copy()
        out[b] = a
        return out


def disputed_doubts(problem: Problem, path: ThresholdPath, labels: np.ndarray,
                    disputed, rule: DoubtRule | None = None) -> tuple[Doubt, ...]:
    """Merge doubts that the held-out prediction names (:class:`~vggc_cp.solvers.heldout.
    HeldOut`'s ``disputed``): a graph learned without an episode predicted that one of its
    transitions ends in node ``A``, and the images put its end in node ``B``. ``A`` and ``B``
    might be one state (or the end's render was misplaced). Each pair (most transitions
    first, at most ``rule.limit``) is a doubt whatever the window says: the check that
    warned named it. Its evidence is that of :func:`find_doubts`' merge doubts (the join of
    the two nodes alone, its ``steps`` from the distance between them) plus
    ``contradicted``, the left-out transitions that dispute it.

    Parameters
    ----------
    problem : Problem
    path : ThresholdPath
    labels : ndarray of int, shape (N,)
        The chosen partition.
    disputed : sequence of (int, int, int)
        ``(predicted, observed, count)``.
    rule : DoubtRule, optional

    Returns
    -------
    tuple of Doubt
    """
    rule = rule or DoubtRule()
    labels = np.asarray(labels, dtype=np.int64)
    if path.selected is None or len(problem.act) == 0 or rule.limit == 0:
        return ()
    flips = Flips(problem, path, labels)

    def closeness(steps: float, ev: dict) -> float:
        return max(0.0, steps) / rule.window + ev["dl_nats"] / rule.max_nats

    found, seen = [], set()
    for x, y, count in disputed:
        a, b = min(int(x), int(y)), max(int(x), int(y))
        ma, mb = np.flatnonzero(labels == a), np.flatnonzero(labels == b)
        if (a, b) in seen or not len(ma) or not len(mb) or \
                problem.roles[ma[0]] != problem.roles[mb[0]]:
            continue
        seen.add((a, b))
        found.append(flips.doubt(MERGE, (a, b), ma, mb, flips.joined(a, mb), rule.typical,
                                 closeness, contradicted=int(count)))
        if len(found) == rule.limit:
            break
    return tuple(found)


def runner_up_doubts(problem: Problem, path: ThresholdPath, labels: np.ndarray,
                     other: np.ndarray, rule: DoubtRule | None = None) -> tuple[Doubt, ...]:
    """The decisions that set the chosen partition ``labels`` apart from ``other`` (the
    runner-up graph, nearly as probable): a chosen node ``other`` splits is a split doubt
    (its sides: the largest of ``other``'s groups within it against the rest), two chosen
    nodes ``other`` joins a merge doubt (the two largest). Listed whatever their closeness
    (a split whose sides differ by rendering noise alone included: the warning rests on
    it), the description length settling none; at most ``rule.limit``, the decision whose
    flip costs the fewest nats first. For a warning that :func:`find_doubts` finds nothing
    to point at, even toward the runner-up's threshold.

    Parameters
    ----------
    problem : Problem
    path : ThresholdPath
    labels, other : ndarray of int, shape (N,)
        The chosen partition and the runner-up's.
    rule : DoubtRule, optional

    Returns
    -------
    tuple of Doubt
    """
    rule = rule or DoubtRule()
    labels, other = np.asarray(labels, dtype=np.int64), np.asarray(other, dtype=np.int64)
    if path.selected is None or len(problem.act) == 0 or rule.limit == 0:
        return ()
    flips = Flips(problem, path, labels)
    found = []
    for u in np.unique(labels):
        m = np.flatnonzero(labels == u)
        groups, sizes = np.unique(other[m], return_counts=True)
        if len(groups) < 2:
            continue
        big = groups[np.argmax(sizes)]
        p_side, q_side = m[other[m] == big], m[other[m] != big]
        found.append(flips.doubt(SPLIT, (int(u),), p_side, q_side,
                                 flips.joined(int(labels.max()) + 1, q_side), rule.typical))
    for v in np.unique(other):
        inside, sizes = np.unique(labels[other == v], return_counts=True)
        if len(inside) < 2:
            continue
        a, b = sorted(int(x) for x in inside[np.argsort(-sizes, kind="stable")[:2]])
        ma, mb = np.flatnonzero(labels == a), np.flatnonzero(labels == b)
        if problem.roles[ma[0]] != problem.roles[mb[0]]:
            continue
        found.append(flips.doubt(MERGE, (a, b), ma, mb, flips.joined(a, mb), rule.typical))
    for doubt in found:
        doubt.evidence["runner_up"] = True
    found.sort(key=lambda x: (x.closeness, x.kind, x.nodes))
    return tuple(found[:rule.limit])


def _evidence(distance: float, threshold: float, spread: float, noise: float, steps: float,
              dl_change: float, apart_together: tuple[int, int], only_a: set[int],
              only_b: set[int], names: tuple[str, ...], n_trans: int) -> dict:
    return {"distance": round(distance, 6), "threshold": round(threshold, 6),
            "spread": round(spread, 6),
            "separation": round(distance / max(spread, noise), 4),
            "steps": round(steps, 3) if math.isfinite(steps) else None,
            "dl_change": round(float(dl_change), 6),
            "dl_nats": round(float(dl_change) * n_trans, 4),
            "thresholds_apart": apart_together[0], "thresholds_together": apart_together[1],
            "only_a": sorted(names[a] for a in only_a),
            "only_b": sorted(names[a] for a in only_b)}


def _keep(kind: str, nodes: tuple[int, ...], obs, ev: dict, rule: DoubtRule) -> Doubt | None:
    """The doubt of a candidate, or None when the evidence settles it (module docstring)."""
    steps = ev["steps"]
    if steps is None:
        return None
    # visual evidence for the chosen decision, in windows: a merge doubt's nodes are apart
    # because the join needs a larger threshold; a split doubt's sides are together because
    # their distance is below the threshold. 0 where the images favour the other decision.
    visual = max(0.0, steps if kind == MERGE else -steps) / rule.window
    closeness = visual + ev["dl_nats"] / rule.max_nats
    if visual > 1.0 or closeness > 1.0:
        return None
    ev["closeness"] = round(closeness, 4)
    return Doubt(kind, nodes, obs, ev, closeness)


# ------------------------------------------------------------------ reading and printing


def _int_list(value, where: str, source: str) -> list[int]:
    from vggc_cp.errors import SolutionError

    if not isinstance(value, list) or not all(
            isinstance(x, int) and not isinstance(x, bool) and x >= 0 for x in value):
        raise SolutionError(f"{source}: field {where!r} must be a list of non-negative "
                            f"integers")
    return [int(x) for x in value]


def parse_doubts(value, source: str = "<solution>") -> tuple[Doubt, ...]:
    """The doubts of a solution JSON's ``doubts`` field (None, absent: none).

    Raises
    ------
    SolutionError
        A record that is not ``{"kind", "nodes", "observations", "evidence"}`` as written by
        :meth:`Doubt.as_dict` (names the index and field).
    """
    from vggc_cp.errors import SolutionError

    if value is None:
        return ()
    if not isinstance(value, list):
        raise SolutionError(f"{source}: field 'doubts' must be a list")
    out = []
    for k, rec in enumerate(value):
        where = f"doubts[{k}]"
        if not isinstance(rec, dict):
            raise SolutionError(f"{source}: field {where!r} must be an object")
        kind = rec.get("kind")
        if kind not in KINDS:
            raise SolutionError(f"{source}: field '{where}.kind' is {kind!r}, expected one "
                                f"of {', '.join(KINDS)}")
        nodes = _int_list(rec.get("nodes"), f"{where}.nodes", source)
        if len(nodes) != (2 if kind == MERGE else 1):
            raise SolutionError(f"{source}: field '{where}.nodes' must name "
                                f"{2 if kind == MERGE else 1} node(s) for a {kind} doubt")
        obs = rec.get("observations")
        if not isinstance(obs, list) or len(obs) != 2:
            raise SolutionError(f"{source}: field '{where}.observations' must be two lists")
        sides = tuple(tuple(_int_list(side, f"{where}.observations[{i}]", source))
                      for i, side in enumerate(obs))
        evidence = rec.get("evidence", {})
        if not isinstance(evidence, dict):
            raise SolutionError(f"{source}: field '{where}.evidence' must be an object")
        closeness = evidence.get("closeness", 0.0)
        closeness = float(closeness) if isinstance(closeness, (int, float)) else 0.0
        out.append(Doubt(kind, tuple(nodes), sides, dict(evidence), closeness))
    return tuple(out)
