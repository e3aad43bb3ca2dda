"""Read splits: a node the sites' readings show to hold two states, split where the code is
shorter and the graph stays deterministic.

The merge (:mod:`vggc_cp.solvers.merge`) joins observations whose footprint distance lies
under one threshold for the whole trace. Two states seen once or twice each that differ at
one or two places of many lie closer than that threshold, and unless an action contradicts it
they become one node (multifruit-4x6 clean: two renders of ``---yyr|r`` and ``--yy-r|r``,
one each, in one node; AnyPath and OptPath fall below 100 %). What each site holds says
they differ, but in no one code: the description length codes what the actions *state*
(:mod:`vggc_cp.solvers.mdl`), the tie-break what the trusted readings *read* where the
actions do not state it, and here each render is stated where the other is read.

The **combined reading** of a site in an observation is what the actions state it holds
there, or what the images read where the site's reading is trusted
(:data:`~vggc_cp.solvers.mdl.TRUSTED_KAPPA`, per observation where the evidence gives it:
:attr:`~vggc_cp.solvers.base.SiteReads.trust`), and nothing elsewhere; sites read alike in
every observation are one. A node whose observations hold two symbols at a site is a
candidate; for each such site it is cut into the observations holding the site's most
common symbol and those holding another, an observation with nothing there going to the
side its other sites agree with more. A cut is made when

* the graph stays deterministic: every (node, action) that leads into the node leads into
  one side only, and every (node, action) that leaves it is left from one side only (so
  bipartiteness, Exactly-One and the hands' colours hold as before: a split only removes
  edges between a pair of nodes), and
* the node's code is shorter as two (two-part MDL, as :func:`~vggc_cp.solvers.mdl.
  description_length` and :func:`~vggc_cp.solvers.mdl.reading_length` code it): the
  actions taken from its observations, ``- sum_a n(a) log(n(a) / n) + 1/2 log|D|`` per
  distinct action, plus per site its combined readings, ``- sum_x n(x) log(n(x) / n)``,
  ``log K_s`` for stating the node's symbol and ``1/2 log N`` per extra symbol. Both codes
  are sums over nodes, so the cut changes only the node's own term.

Where a cut would send one (node, action) into both sides (or out of both), that node holds
two states as well: the one whose observations lead into one side and the one whose lead
into the other. It is cut with it, by those transitions, and so on, as a merge forces merges
(:func:`_joint_cut`, at most :data:`MAX_JOINT` nodes; an observation no transition decides
goes to the side its readings agree with), and the cuts are made together where their code,
summed, is shorter (multifruit-4x6 robot s259: two states seen once each sat in a
neighbour's node, the one before them in another's, and no cut alone kept the graph
deterministic; 59 nodes for 62, now 62). A node already cut whose one side would have to
lead into both refuses the whole cut. Where the actions stack slots (or the evidence does not
say whether they do: :attr:`~vggc_cp.solvers.base.SiteReads.stacked`), nodes are cut one at
a time only: what the actions state about a stacked slot depends on which level they are
read at, and a true state's own frames can then carry different stated facts; there the
determinism that refuses a lone cut is the guard, and joint cuts split true states (on the
tuning split, random-1 clean: 77 nodes for 77 became 80).

Of a node's cuts the shortest is made, and each side is examined again. The cut needs no
threshold of its own: a node of two states read apart at several sites pays their entropy
there once joined; a node whose frames one run of misread frames sets apart pays a node's
statement at every site once split, and keeps together where the misreading is brief. Where
a state's own frames are read differently in whole runs (a slot covered by another object,
read through it in some runs), the cut would split a true state: determinism refuses it
wherever one (node, action) reaches both sides, as it does for a state reached often.

Everything here reads the problem (transitions, readings) and the partition, never
ground-truth states. :func:`split_by_readings` cuts the merge's graph at every threshold of
the path (:func:`vggc_cp.solvers.merge.cut_path`) and in every re-run of the confidence
(:func:`vggc_cp.solvers.merge.with_read_splits`), so the plateau, the re-runs and the
doubts compare one kind of graph; a merge doubt whose join the cuts would part again is no
graph the method learns and is not listed (:func:`vggc_cp.solvers.doubts.find_doubts`). The
threshold itself is chosen on the merges' own graphs: chosen on the cut ones, the description
length moved to coarser thresholds whose remaining merges nothing states apart
(multifruit-4x6 robot s1: 50 nodes for 60, against 58 on the merges and 59 once cut).

References
----------
J. Rissanen, *Modeling by shortest data description*, Automatica 14, 1978.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.solvers.mdl import TRUSTED_KAPPA

#: Most nodes one cut may part together with those it forces (:func:`_joint_cut`).
MAX_JOINT = 8
#: Places at which two states of one node differ at least: an object moved empties one
#: place and fills another (a node's observations hold one thing in the hand). A joint cut
#: reads its own node apart at as many sites, and every node it forces at one at least
#: (:func:`_joint_cut`).
MOVE_PLACES = 2


def combined_readings(problem, min_trust: float = TRUSTED_KAPPA) -> np.ndarray | None:
    """What every site holds in every observation as the actions state it or a trusted
    reading reads it (module docstring): int64 shape (N, S'), 0 nothing, 1 empty, ``2 + c``
    colour ``c``; sites alike in every observation kept once. None without site reads or
    where no site says anything.

    >>> from vggc_cp.solvers.base import Readings, SiteReads
    >>> sites = SiteReads(held=np.array([[0, 0, 2], [1, 1, 2], [1, 1, 0]]),
    ...                   stated=np.array([[True, True, False], [False, False, False],
    ...                                    [False, False, False]]),
    ...                   kappa=np.array([0.95, 0.95, 0.5]), action=np.arange(3))
    >>> class P:
    ...     readings = Readings.from_rows(np.zeros((3, 1)), sites)
    >>> combined_readings(P()).tolist()    # sites 0 and 1 alike; site 2 stated nowhere, untrusted
    [[1], [2], [2]]
    """
    readings = getattr(problem, "readings", None)
    sites = None if readings is None else readings.sites
    if sites is None:
        return None
    held = np.asarray(sites.held, dtype=np.int64)
    trust = (np.broadcast_to(np.asarray(sites.kappa, dtype=np.float64), held.shape)
             if sites.trust is None else np.asarray(sites.trust, dtype=np.float64))
    known = np.asarray(sites.stated, dtype=bool) | (np.nan_to_num(trust, nan=-1.0) >= min_trust)
    rows = np.where(known, 1 + held, 0)
    rows = rows[:, rows.any(axis=0)]
    if rows.shape[1] == 0:
        return None
    return np.unique(rows, axis=1)


class _Code:
    """Code lengths of nodes (module docstring) for one problem and its combined readings."""

    def __init__(self, problem, rows: np.ndarray):
        n = len(rows)
        self.rows = rows
        self.width = int(rows.max()) + 1
        self.log_k = np.log(np.array([max(len(np.unique(c[c > 0])), 1) for c in rows.T],
                                     dtype=np.float64))
        act = np.asarray(problem.act, dtype=np.int64)
        self.act_of = np.full(n, -1, dtype=np.int64)
        self.act_of[np.asarray(problem.src, dtype=np.int64)] = act
        self.half_log_d = 0.5 * np.log(max(len(act), 1))
        self.half_log_n = 0.5 * np.log(max(n, 1))

    def length(self, obs: np.ndarray) -> float:
        """Nats to code the actions taken from, and the combined readings of, one node
        holding the observations ``obs``."""
        acts = self.act_of[obs]
        counts = np.bincount(acts[acts >= 0])
        counts = counts[counts > 0]
        out = 0.0
        if len(counts):
            out += (-float(np.sum(counts * np.log(counts / counts.sum())))
                    + self.half_log_d * len(counts))
        sub = self.rows[obs]
        per = np.stack([(sub == x).sum(axis=0) for x in range(1, self.width)], axis=1)
        total = per.sum(axis=1)
        seen = total > 0
        if not seen.any():
            return out
        per, total = per[seen].astype(np.float64), total[seen].astype(np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            ent = np.where(per > 0, per * np.log(per / total[:, None]), 0.0)
        symbols = (per > 0).sum(axis=1)
        return (out - float(ent.sum()) + float(self.log_k[seen].sum())
                + self.half_log_n * float(np.sum(symbols - 1)))


def _place(sub: np.ndarray, side: np.ndarray) -> np.ndarray:
    """``side`` with every observation at -1 put on the side whose observations its known
    sites agree with more (mean over the side of the sites both know alike less those they
    know differently; ties: side 0), in order, each placed observation counting for those
    after it. ``sub``: the node's combined readings, int shape (m, S')."""
    side = side.copy()
    width = int(sub.max()) + 1
    onehot = sub[:, :, None] == np.arange(1, width)          # (m, S, width - 1)
    same = [onehot[side == k].sum(axis=0) for k in (0, 1)]  # (S, width - 1) each
    size = [int(np.sum(side == k)) for k in (0, 1)]
    for i in np.flatnonzero(side < 0):
        row = sub[i]
        known = np.flatnonzero(row > 0)
        score = [float(np.sum(2 * same[k][known, row[known] - 1]
                              - same[k][known].sum(axis=1))) / max(size[k], 1)
                 for k in (0, 1)]
        k = int(score[1] > score[0])
        side[i] = k
        same[k] = same[k] + onehot[i]
        size[k] += 1
    return side


def _cuts(sub: np.ndarray):
    """The node's candidate cuts: per site holding two symbols, 0 for the observations of
    its most common symbol, 1 for those of another, and -1 for those with nothing there
    (placed by :func:`_place` once the cut is judged). Distinct cuts only."""
    seen = set()
    for s in range(sub.shape[1]):
        col = sub[:, s]
        values, counts = np.unique(col[col > 0], return_counts=True)
        if len(values) < 2:
            continue
        side = np.where(col == values[np.argmax(counts)], 0, np.where(col > 0, 1, -1))
        key = side.tobytes()
        if key not in seen:
            seen.add(key)
            yield side


def _deterministic(labels: np.ndarray, obs: np.ndarray, side: np.ndarray, src: np.ndarray,
                   act: np.ndarray, dst: np.ndarray, n_act: int) -> bool:
    """Whether cutting the node ``obs`` by ``side`` keeps every (node, action) into it, and
    every (node, action) out of it, on one side (observations at -1 count on neither)."""
    side_of = np.full(len(labels), -1, dtype=np.int64)
    side_of[obs] = side
    for end, other in ((dst, src), (src, dst)):
        mask = side_of[end] >= 0
        if not mask.any():
            continue
        keys = labels[other[mask]] * n_act + act[mask]
        pairs = np.unique(keys * 2 + side_of[end[mask]])
        if len(np.unique(pairs // 2)) < len(pairs):
            return False
    return True


def _lone_cut(labels: np.ndarray, obs: np.ndarray, sub: np.ndarray, side: np.ndarray,
              src: np.ndarray, act: np.ndarray, dst: np.ndarray, n_act: int
              ) -> np.ndarray | None:
    """The cut ``side`` of the node ``obs`` with its undecided observations placed
    (:func:`_place`), where it stands alone: deterministic with them on neither side and
    once placed (a cut refused with them on neither side is refused wherever they go); else
    None."""
    if not _deterministic(labels, obs, side, src, act, dst, n_act):
        return None
    placed = _place(sub, side)
    return placed if _deterministic(labels, obs, placed, src, act, dst, n_act) else None


def read_apart(sub: np.ndarray, side: np.ndarray) -> int:
    """At how many sites the two sides of a node are read apart: both sides hold something
    known there (:func:`combined_readings`, ``sub`` its rows of the node, shape (m, S')) and
    no symbol is held on both.

    >>> sub = np.array([[1, 2, 0], [1, 2, 1], [2, 3, 1], [2, 0, 2]])
    >>> read_apart(sub, np.array([0, 0, 1, 1]))      # site 2: symbol 1 on both sides
    2
    >>> read_apart(np.zeros((2, 3), np.int64), np.array([0, 1]))   # nothing known
    0
    """
    if not sub.size or sub.max() <= 0:
        return 0
    width = int(sub.max()) + 1
    held = [np.stack([(sub[side == k] == x).any(axis=0) for x in range(1, width)], axis=1)
            for k in (0, 1)]                                   # (S', width - 1) each
    known = held[0].any(axis=1) & held[1].any(axis=1)
    return int(np.sum(known & ~(held[0] & held[1]).any(axis=1)))


def _stacks(problem) -> bool:
    """Whether the problem's sites include slots the actions stack (or where that is not
    known): no joint cut there (module docstring)."""
    stacked = problem.readings.sites.stacked
    return stacked is None or bool(np.asarray(stacked).any())


def _as_function(lab: np.ndarray, src: np.ndarray, act: np.ndarray, dst: np.ndarray,
                 n_act: int) -> bool:
    """Whether the partition ``lab`` keeps the graph deterministic both ways: one (node,
    action) leads to one node, and one node is reached by one action from one node."""
    for one, other in ((src, dst), (dst, src)):
        pairs = np.unique(np.stack([lab[one] * n_act + act, lab[other]], axis=1), axis=0)
        if len(np.unique(pairs[:, 0])) < len(pairs):
            return False
    return True


def _joint_cut(labels: np.ndarray, u: int, side: np.ndarray, rows: np.ndarray,
               src: np.ndarray, act: np.ndarray, dst: np.ndarray, n_act: int,
               max_nodes: int = MAX_JOINT
               ) -> dict[int, tuple[np.ndarray, np.ndarray]] | None:
    """The cut of node ``u`` by ``side`` (over its observations in order; -1 undecided)
    together with the cuts it forces, as node -> (its observations, their sides); None
    where it forces more than ``max_nodes`` nodes apart, contradicts itself, or leaves a
    node whole.

    A cut of one node alone is refused where one (node, action) leads into both sides (or
    leaves from both): the node it leads from holds two states as well, the one whose
    observations lead into one side and the one whose lead into the other. So that node is
    cut too, by those transitions, and so on, as a merge forces merges
    (:mod:`vggc_cp.solvers.merge`); an observation no transition decides is placed by its
    readings (:func:`_place`). A node already cut whose one side would have to lead into
    both sides refuses the whole cut. The readings must show the cut: ``u``'s sides read
    apart (:func:`read_apart`) at :data:`MOVE_PLACES` sites, as two states differ, and every
    forced node's at one at least -- a node the readings cannot tell apart anywhere is cut
    by the transitions alone, and one read apart at a single place by one statement, which
    may be wrong (random-889 randomized: every node of a five-node cut read apart at one
    site each, 48 nodes for 48 became 53)."""
    n_nodes = int(labels.max()) + 1
    side_of = np.full(len(labels), -1, dtype=np.int64)
    cut = np.zeros(n_nodes, dtype=bool)
    cut[u] = True
    members = {int(u): np.flatnonzero(labels == u)}
    side_of[members[u]] = side
    while True:
        changed = False
        for end, other in ((dst, src), (src, dst)):
            # transitions into a cut node from an end whose node (and side) is known
            m = cut[labels[end]] & (~cut[labels[other]] | (side_of[other] >= 0))
            if not m.any():
                continue
            e, o, a = end[m], other[m], act[m]
            group = ((labels[o] * 2 + np.maximum(side_of[o], 0)) * n_act + a) * n_nodes \
                + labels[e]
            _, inv = np.unique(group, return_inverse=True)
            lo = np.full(inv.max() + 1, 2, dtype=np.int64)
            hi = np.full(inv.max() + 1, -1, dtype=np.int64)
            told = side_of[e] >= 0
            np.minimum.at(lo, inv[told], side_of[e][told])
            np.maximum.at(hi, inv[told], side_of[e][told])
            both = (lo < hi)[inv] & told
            if both.any():
                if cut[labels[o[both]]].any():
                    return None                    # a side of a cut node reaches both
                for v in np.unique(labels[o[both]]):
                    cut[v] = True
                    members[int(v)] = np.flatnonzero(labels == v)
                if len(members) > max_nodes:
                    return None
                side_of[o[both]] = side_of[e[both]]
                changed = True
            # an undecided end goes where the rest of its group goes
            follow = ~told & (lo == hi)[inv]
            if follow.any():
                side_of[e[follow]] = lo[inv[follow]]
                changed = True
        if changed:
            continue
        open_nodes = [v for v, obs in members.items() if (side_of[obs] < 0).any()]
        if not open_nodes:
            break
        for v in open_nodes:
            obs = members[v]
            side_of[obs] = _place(rows[obs], side_of[obs])
    out = {}
    for v, obs in members.items():
        sv = side_of[obs]
        if not 0 < sv.sum() < len(sv):
            return None
        if read_apart(rows[obs], sv) < (MOVE_PLACES if v == u else 1):
            return None                        # the readings do not show it
        out[v] = (obs, sv)
    lab = labels * 2
    lab[side_of >= 0] += side_of[side_of >= 0]
    return out if _as_function(lab, src, act, dst, n_act) else None


def split_by_readings(problem, labels: np.ndarray, rows: np.ndarray | None = None,
                      nodes=None) -> tuple[np.ndarray, int]:
    """The partition ``labels`` with every node the combined readings show to hold two
    states split (module docstring), and how many cuts were made. New nodes take ids after
    the largest; ``labels`` is not modified.

    Parameters
    ----------
    problem : Problem or CodedProblem
        Its transitions (``src``, ``act``, ``dst``) and ``readings.sites``; without site
        reads, ``labels`` is returned as is.
    labels : ndarray of int, shape (N,)
    rows : ndarray of int, shape (N, S'), optional
        :func:`combined_readings` of ``problem``, where already computed.
    nodes : iterable of int, optional
        Examine only these nodes (and the parts cut from them): whether a join the doubts
        consider would be cut again (:func:`vggc_cp.solvers.doubts.find_doubts`).

    Two picks and two places; the picks read 2 and 3 at a site, each after its own place,
    so the pick node is cut in two (the code is shorter and every edge keeps one end):

    >>> from vggc_cp.solvers.base import Readings, SiteReads
    >>> sites = SiteReads(held=np.array([[1], [0], [2], [0]]), stated=np.ones((4, 1), bool),
    ...                   kappa=np.array([1.0]), action=np.array([0]))
    >>> class P:
    ...     src, act, dst = np.array([1, 3]), np.array([1, 2]), np.array([0, 2])
    ...     readings = Readings.from_rows(np.zeros((4, 1)), sites)
    >>> lab, cuts = split_by_readings(P(), np.array([0, 1, 0, 2]))
    >>> lab.tolist(), cuts
    ([0, 1, 3, 2], 1)

    With the two places one node left by one action, that (node, action) would reach both
    sides, and the cut is refused:

    >>> P.act = np.array([1, 1])
    >>> split_by_readings(P(), np.array([0, 1, 0, 1]))[0].tolist()
    [0, 1, 0, 1]
    """
    labels = np.array(labels, dtype=np.int64)
    rows = combined_readings(problem) if rows is None else rows
    if rows is None or len(labels) < 2:
        return labels, 0
    code = _Code(problem, rows)
    joint = not _stacks(problem)
    src = np.asarray(problem.src, dtype=np.int64)
    act = np.asarray(problem.act, dtype=np.int64)
    dst = np.asarray(problem.dst, dtype=np.int64)
    n_act = int(act.max()) + 1 if len(act) else 1
    # nodes holding two symbols at some site
    cell = (labels[:, None] * rows.shape[1] + np.arange(rows.shape[1])) * code.width + rows
    cells = np.unique(cell[rows > 0])
    site_node = cells // code.width
    doubled = np.unique(site_node)[np.bincount(np.unique(site_node, return_inverse=True)[1]
                                               .ravel()) > 1]
    queue = sorted({int(c) // rows.shape[1] for c in doubled})
    if nodes is not None:
        queue = [u for u in queue if u in {int(x) for x in nodes}]
    nxt = int(labels.max()) + 1
    cuts = 0
    while queue:
        u = queue.pop(0)
        obs = np.flatnonzero(labels == u)
        if len(obs) < 2:
            continue
        best_gain, best_cut = 1e-9, None
        sub = rows[obs]
        for side in _cuts(sub):
            placed = _lone_cut(labels, obs, sub, side, src, act, dst, n_act)
            found = None if placed is None else {u: (obs, placed)}
            if found is None and joint:             # the cuts it forces, if any
                found = _joint_cut(labels, u, side, rows, src, act, dst, n_act)
            if found is None:
                continue
            gain = sum(code.length(part) - code.length(part[sv == 0])
                       - code.length(part[sv == 1]) for part, sv in found.values())
            if gain > best_gain:
                best_gain, best_cut = gain, found
        if best_cut is None:
            continue
        for v, (part, sv) in best_cut.items():
            labels[part[sv == 1]] = nxt
            queue += [v, nxt]
            nxt += 1
            cuts += 1
    return labels, cuts


#: How much longer a cut may make the code and still leave the node a doubt (nats): ln 20,
#: the odds the description-length margin of the chosen graph is read at.
NEAR_CUT_NATS = float(np.log(20.0))


def near_cuts(problem, labels: np.ndarray, max_nats: float = NEAR_CUT_NATS,
              rows: np.ndarray | None = None) -> list[tuple[int, np.ndarray, np.ndarray, float,
                                                            list[str]]]:
    """Nodes of ``labels`` that the combined readings read apart and that a cut would keep
    deterministic, but whose code the cut makes longer by less than ``max_nats``: the
    recording does not settle them at 20 to 1 either way. Two states seen once each in one
    node, read apart at one site, lose their cut by about 1 nat (the second node's statement
    at every site against one site's entropy): multifruit-4x6 robot s387 (draw 42), s352 and
    s366, each silent or warned by luck.

    Returns ``(node, observations of one side, of the other, nats the cut loses, sites read
    apart)`` per such node (its least losing lone cut), least loss first; empty without site
    reads. Reads the problem's transitions and readings only.

    Node 0 holds observations 0 and 2, read apart at site ``a`` only and alike at three
    others: the cut is not made (:func:`split_by_readings`), and it loses by 1.10 nats:

    >>> from vggc_cp.solvers.base import Readings, SiteReads
    >>> held = np.array([[1, 1, 0, 1], [0, 0, 1, 1], [2, 1, 0, 1], [0, 1, 1, 0]])
    >>> sites = SiteReads(held=held, stated=np.ones((4, 4), bool), kappa=np.ones(4),
    ...                   action=np.arange(4))
    >>> class P:
    ...     src, act, dst = np.array([1, 3]), np.array([1, 2]), np.array([0, 2])
    ...     readings = Readings.from_rows(np.zeros((4, 1)), sites)
    ...     action_names = ("a", "b", "c", "d")
    >>> split_by_readings(P(), np.array([0, 1, 0, 2]))[1]
    0
    >>> [(u, a.tolist(), b.tolist(), round(n, 2), st) for u, a, b, n, st in
    ...  near_cuts(P(), np.array([0, 1, 0, 2]))]
    [(0, [0], [2], 1.1, ['a'])]
    """
    labels = np.asarray(labels, dtype=np.int64)
    rows = combined_readings(problem) if rows is None else rows
    if rows is None or len(labels) < 2:
        return []
    code = _Code(problem, rows)
    src = np.asarray(problem.src, dtype=np.int64)
    act = np.asarray(problem.act, dtype=np.int64)
    dst = np.asarray(problem.dst, dtype=np.int64)
    n_act = int(act.max()) + 1 if len(act) else 1
    sites = getattr(problem.readings, "sites", None)
    out = []
    for u in np.unique(labels).tolist():
        obs = np.flatnonzero(labels == u)
        if len(obs) < 2:
            continue
        sub = rows[obs]
        best = None
        for side in _cuts(sub):
            placed = _lone_cut(labels, obs, sub, side, src, act, dst, n_act)
            if placed is None:
                continue
            loss = code.length(obs[placed == 0]) + code.length(obs[placed == 1])
            if best is None or loss < best[0]:
                best = (loss, placed)
        if best is not None:
            best = (best[0] - code.length(obs), best[1])
        if best is None or not 0.0 <= best[0] < max_nats:
            continue
        loss, placed = best
        a, b = obs[placed == 0], obs[placed == 1]
        names = []
        if sites is not None:
            held = np.asarray(sites.held)
            differ = (held[a][:, None, :] != held[b][None, :, :]).all(axis=(0, 1))
            names = sorted({problem.action_names[int(k)]
                            for k in np.asarray(sites.action)[differ]})
        out.append((int(u), a, b, float(loss), names))
    return sorted(out, key=lambda n: (n[3], n[0]))
