"""Checks that flag a graph from its doubts (:mod:`vggc_cp.solvers.doubts`), beside the chance
of change of :mod:`vggc_cp.solvers.confidence`:

* :func:`corroborate` -- a doubt on nodes the re-runs changed whose flip the actions favour by
  more than 3 nats (the chance of change corroborated);
* :func:`doubt_forbidden` -- the images (within the chosen threshold) and the actions (by more
  than 3 nats) both favour joining two nodes that Exactly-One forbids (then another decision
  conflicts with them), or that the hands' colours forbid where one node is one render or two
  (a misread action colour makes such a node);
* :func:`doubt_readings` -- nodes that only an untrustworthy reading of the images sets apart
  (:func:`vggc_cp.solvers.read_doubts.read_doubts`);
* :func:`doubt_lone` -- episodes that visit no node another episode visits, beyond chance
  (:func:`vggc_cp.solvers.episodes.lone_episodes`).

Where an episode starts is evidence too (:func:`start_odds`): an episode doubt that the other
episodes' starts contradict (it starts where they almost never do, and the doubt would move it
where they do) flags whatever its plan risk. Starts that back the images settle nothing
(session 53: quieting such doubts made two misses of a fresh draw silent, each warned only by
episode doubts that were right placements, or wrong in their other path too).
"""

from __future__ import annotations

import math

import numpy as np

from vggc_cp.solvers.confidence import Confidence
from vggc_cp.solvers.episodes import episode_starts
from vggc_cp.solvers.read_doubts import bound_decided

#: The share of plans between two observations that may fail before a graph stops being usable:
#: the robustness study's bar, Exec >= 90 % (:data:`vggc_cp.evaluate.metrics.MIN_EXEC`).
MAX_PLAN_RISK = 0.10


def misplaced_share(doubts, labels: np.ndarray) -> float:
    """The share of a state's renders that the episode doubts
    (:func:`vggc_cp.solvers.read_doubts.episode_doubts`), were they all right, would move to
    another node, averaged over the nodes: for every node ``v`` of the doubts' other paths,
    ``m_v / (n_v + m_v)`` with ``m_v`` the observations the doubts would move there and
    ``n_v`` those it holds, summed over those nodes and divided by the number of nodes.

    A plan between two observations (a start and a goal drawn state by state, as a user
    asks) starts or ends at a misplaced render with probability ``1 - (1 - s)^2`` for this
    share ``s``.

    >>> from vggc_cp.solvers.doubts import Doubt
    >>> d = Doubt("split", (0,), ((1,), (4,)), {"episode": [4, 5], "moved_path": [2, 3]})
    >>> round(misplaced_share([d], np.array([0, 1, 0, 1, 0, 1, 2, 3, 2, 3])), 4)
    0.1667
    """
    return float(_misplaced(doubts, labels).mean())


def _misplaced(doubts, labels: np.ndarray) -> np.ndarray:
    """Per node ``v``, ``m_v / (n_v + m_v)`` (:func:`misplaced_share`), shape (n,)."""
    labels = np.asarray(labels, dtype=np.int64)
    n = int(labels.max()) + 1
    moved = np.zeros(n)
    for d in doubts:
        path = (d.evidence or {}).get("moved_path")
        if isinstance(path, list):
            np.add.at(moved, np.asarray(path, dtype=np.int64), 1.0)
    sizes = np.bincount(labels, minlength=n).astype(np.float64)
    return moved / np.maximum(sizes + moved, 1.0)


def sole_edges(doubts, labels: np.ndarray, src: np.ndarray, act: np.ndarray, dst: np.ndarray
               ) -> set[tuple[int, int, int]]:
    """The edges ``(u, a, v)`` of the graph of ``labels`` that only the doubts' episodes
    show: every transition behind them starts inside an episode of a doubt
    (``evidence["episode"]``, its first and last observation). Were those episodes another
    path, the edges would not be there.

    >>> from vggc_cp.solvers.doubts import Doubt
    >>> d = Doubt("split", (0,), ((1,), (4,)), {"episode": [4, 5]})
    >>> labels = np.array([0, 1, 0, 1, 2, 3])
    >>> sorted(sole_edges([d], labels, np.array([0, 1, 2, 4]), np.array([0, 1, 0, 2]),
    ...                   np.array([1, 2, 3, 5])))
    [(2, 2, 3)]
    """
    labels = np.asarray(labels, dtype=np.int64)
    src, act, dst = (np.asarray(v, dtype=np.int64) for v in (src, act, dst))
    inside = np.zeros(len(src), dtype=bool)
    for d in doubts:
        span = (d.evidence or {}).get("episode")
        if isinstance(span, list) and len(span) == 2:
            inside |= (src >= span[0]) & (src <= span[1])
    keys = list(zip(labels[src].tolist(), act.tolist(), labels[dst].tolist()))
    outside = {k for k, i in zip(keys, inside) if not i}
    return {k for k, i in zip(keys, inside) if i and k not in outside}


def plans_through(edges, sole: set, n: int) -> np.ndarray:
    """For every ordered pair of nodes ``(u, v)``, the share of the shortest plans from ``u``
    to ``v`` on the graph of ``edges`` (``(u, a, v)`` triples over ``n`` nodes) that take an
    edge of ``sole``: shape (n, n), 0 where ``v`` is ``u`` or out of reach. A plan is drawn
    uniformly among the shortest, as Exec draws it (:mod:`vggc_cp.evaluate.metrics`); the
    counts are the paths of the breadth-first layers, with and without those edges.

    >>> plans_through([(0, 0, 1), (1, 1, 2), (0, 2, 3), (3, 3, 2)], {(0, 2, 3)}, 4)[0].tolist()
    [0.0, 0.0, 0.5, 1.0]
    """
    return _plan_shares(edges, sole, n)[0]


def _plan_shares(edges, sole: set, n: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`plans_through`'s shares and, bool (n, n), which ``v != u`` each ``u`` reaches."""
    out_edges: list[list[tuple[int, bool]]] = [[] for _ in range(n)]
    for u, a, v in set(edges):
        out_edges[u].append((v, (u, a, v) in sole))
    share = np.zeros((n, n))
    reached = np.zeros((n, n), dtype=bool)
    for u in range(n):
        depth = {u: 0}
        every, clear = {u: 1.0}, {u: 1.0}
        layer = [u]
        while layer:
            nxt: list[int] = []
            for w in layer:
                for v, risky in out_edges[w]:
                    if depth.get(v, depth[w] + 1) != depth[w] + 1:
                        continue
                    if v not in depth:
                        depth[v] = depth[w] + 1
                        every[v] = clear[v] = 0.0
                        nxt.append(v)
                    every[v] += every[w]
                    clear[v] += 0.0 if risky else clear[w]
            layer = nxt
        for v in depth:
            if v != u:
                share[u, v] = 1.0 - clear[v] / every[v]
                reached[u, v] = True
    return share, reached


def plan_risk(doubts, labels: np.ndarray, src: np.ndarray, act: np.ndarray,
              dst: np.ndarray) -> float:
    """The share of plans between two nodes that fail were the episode doubts right: the
    plan starts or ends at a misplaced render (:func:`misplaced_share`, per node), or takes
    an edge only those episodes show (:func:`sole_edges`, :func:`plans_through`); averaged
    over the ordered pairs of nodes one reaches from the other.

    >>> from vggc_cp.solvers.doubts import Doubt
    >>> d = Doubt("split", (0,), ((1,), (4,)), {"episode": [4, 5], "moved_path": [2, 3]})
    >>> labels = np.array([0, 1, 0, 1, 2, 3])
    >>> src, act, dst = np.array([0, 1, 2, 4]), np.array([0, 1, 0, 2]), np.array([1, 2, 3, 5])
    >>> round(plan_risk([d], labels, src, act, dst), 3)   # of 0->1, 1->0, 2->3: the last
    0.333
    """
    labels = np.asarray(labels, dtype=np.int64)
    n = int(labels.max()) + 1
    misplaced = _misplaced(doubts, labels)
    edges = list(zip(labels[src].tolist(), np.asarray(act).tolist(), labels[dst].tolist()))
    through, pairs = _plan_shares(edges, sole_edges(doubts, labels, src, act, dst), n)
    fail = 1.0 - (1.0 - misplaced[:, None]) * (1.0 - misplaced[None, :]) * (1.0 - through)
    return float(fail[pairs].mean()) if pairs.any() else 0.0


#: The odds of the other episodes' starts against where an episode starts at which they
#: contradict it: 20 to 1 (3 nats), the bar of the description-length margin and of the
#: doubts' ``dl_nats``.
START_ODDS = 20.0


def start_odds(doubt, labels: np.ndarray, dst: np.ndarray,
               starts: np.ndarray | None = None) -> float:
    """How much more often the *other* episodes start at an episode doubt's first node than
    at the other path's (``moved_path[0]``): ``(n_now + 1/2) / (n_alt + 1/2)`` over their
    first observations' nodes (:func:`~vggc_cp.solvers.episodes.episode_starts`; half a
    start added to each, the Krichevsky-Trofimov estimate), 1 where the two paths start at
    one node or the doubt names no other path. ``starts`` (when given) are those first
    observations, found once for many doubts.

    Where episodes are recorded from a home state, every one starts at its node. At
    ``1 / START_ODDS`` the starts and the reading that placed the episode point apart: it
    starts where the others almost never do, and the doubt would move it where they do
    (multifruit-4x6 robot s410, draw 46: of 15 doubted episodes the one truly misplaced
    started at a node of its own, its other path at the home node, fifteenth in the list) --
    a warning whatever its plan risk. Odds the other way (the images put it at the home,
    the doubt would move it off) settle nothing: a home node can hold renders of another
    start state read wrong, and episode doubts that are right placements are at times the
    only warning of a graph wrong elsewhere (quieting them made multifruit-4x6 robot s352
    silent in session 48, and random-1205 and multifruit-4x6 robot s429, draw 49, in
    session 53).

    Ten other episodes start at node 0 and none at node 1:

    >>> from vggc_cp.solvers.doubts import SPLIT, Doubt
    >>> d = Doubt(SPLIT, (0,), ((0,), (20,)), {"episode": [20, 21], "moved_path": [1, 2]})
    >>> labels = np.array([0, 2] * 11)
    >>> start_odds(d, labels, np.arange(1, 22, 2))
    21.0
    """
    ev = doubt.evidence
    path = ev.get("moved_path")
    if not isinstance(path, list) or not path:
        return 1.0
    labels = np.asarray(labels, dtype=np.int64)
    first = int(ev["episode"][0])
    now, alt = int(labels[first]), int(path[0])
    if now == alt:
        return 1.0
    starts = episode_starts(len(labels), dst) if starts is None else starts
    at = labels[starts[starts != first]]
    return (float(np.sum(at == now)) + 0.5) / (float(np.sum(at == alt)) + 0.5)


def doubt_readings(conf: Confidence, doubts, labels: np.ndarray | None = None,
                   problem=None, limit: int | None = None) -> Confidence:
    """``conf`` flagged when a doubt rests on an untrustworthy reading
    (:func:`vggc_cp.solvers.read_doubts.read_doubts`: its evidence has ``read_kappa``): two nodes
    that nothing the actions state sets apart, told apart only by what the images read at
    sites whose reading agrees with the stated frames less than substantially beyond
    chance; or episodes that only such a reading puts on their path
    (:func:`vggc_cp.solvers.read_doubts.episode_doubts`: its evidence has ``episode``, too)
    whose start the other episodes' starts contradict (given the ``problem``:
    :func:`start_odds` at most ``1 / START_ODDS``), or (of the others, the first ``limit``)
    that, were they misplaced, would fail more than :data:`MAX_PLAN_RISK` of the plans
    between two observations (with ``labels`` only): plans that start or end at a misplaced
    render (:func:`misplaced_share`) or, given the ``problem`` (its transitions), that also
    take an edge only those episodes show (:func:`plan_risk`). Fewer, the graph stays usable either way: the episode is a note
    (it joins the reasons when another check flags). Re-runs and the description length
    cannot see either: both take the reading as given. The reason names the nodes (the
    episode), the sites and what to record.
    """
    read = [d for d in doubts if "read_kappa" in d.evidence]
    pairs = [d for d in read if "episode" not in d.evidence]
    moves = [d for d in read if "episode" in d.evidence]
    for d in pairs[:1]:
        ev = d.evidence
        more = _more(len(pairs) - 1, "pair(s)")
        conf = conf.flagged(
            f"nodes {d.nodes[0]} and {d.nodes[1]} might be one state{more}: only the images' "
            f"reading at {_sites(ev)} tells them apart, and it agrees with the frames whose "
            f"actions state it {_agreement(ev)}; record episodes that act there from both "
            f"nodes (`vggc-cp suggest SOLUTION TRACE -o next.json`)")
    against = []
    if moves and labels is not None and problem is not None:
        starts = episode_starts(len(labels), problem.dst)
        odds = [start_odds(d, labels, problem.dst, starts) for d in moves]
        against = [(o, d) for o, d in zip(odds, moves) if o <= 1.0 / START_ODDS]
        moves = [d for o, d in zip(odds, moves) if o > 1.0 / START_ODDS]
    moves = moves[:limit]
    if against:
        o, d = against[0]
        ev = d.evidence
        first, last = ev["episode"]
        more = _more(len(against) - 1, "episode(s)")
        conf = conf.flagged(
            f"the episode of observations {first}-{last} starts at node {labels[first]}, "
            f"and might start at node {ev['moved_path'][0]} instead{more}: the other "
            f"episodes start there {1.0 / o:.0f} times as often as at node {labels[first]} "
            f"(half a start added to each), and only the images' reading at {_sites(ev)} "
            f"puts it where it is, which agrees with the frames whose actions state it "
            f"{_agreement(ev)}; record an episode from that episode's start that acts there "
            f"(`vggc-cp suggest SOLUTION TRACE -o next.json`)")
    if moves:
        d, ev = moves[0], moves[0].evidence
        first, last = ev["episode"]
        more = _more(len(moves) - 1, "episode(s)")
        if labels is None:
            risk = 0.0
        elif problem is None:
            risk = 1.0 - (1.0 - misplaced_share(moves, labels)) ** 2
        else:
            risk = plan_risk(moves, labels, problem.src, problem.act, problem.dst)
        also = "" if problem is None else " or take a transition only such episodes show"
        reason = (
            f"the episode of observations {first}-{last} might be another path of the graph, "
            f"from node {ev['moved_to']} instead of node {ev.get('moved_from', d.nodes[0])}"
            f"{more}: only the images' "
            f"reading at {_sites(ev)} puts it where it is, and it agrees with the frames whose "
            f"actions state it {_agreement(ev)}{_weakest(ev)}; if so, {100 * risk:.1f} % of "
            f"plans between "
            f"two observations start or end at a misplaced one{also}; record an episode from "
            f"that episode's start that acts there (`vggc-cp suggest SOLUTION TRACE -o "
            f"next.json`)")
        conf = (conf.flagged(reason) if labels is None or risk > MAX_PLAN_RISK
                else conf.noted(reason))
    return conf


def _more(n: int, what: str) -> str:
    """`` (and n more such what)``, or nothing where ``n`` is 0."""
    return f" (and {n} more such {what})" if n > 0 else ""


def _sites(evidence: dict) -> str:
    return ", ".join(evidence.get("read_sites", [])) or "some site"


def _weakest(evidence: dict) -> str:
    """The slot read worst among an episode doubt's sites, in words (empty where the
    evidence does not name it, or it is the only slot).

    >>> ev = {"read_sites": ["pick_red_1", "pick_red_2", "place_red_1", "place_red_2"],
    ...       "read_weakest": {"sites": ["pick_red_1", "place_red_1"], "kappa": 0.31}}
    >>> _weakest(ev)
    '; the counts of objects tie these sites together, and the one read worst, pick_red_1, place_red_1, agrees only 0.31 beyond chance'
    >>> _weakest({"read_sites": ["pick_red_1"], "read_weakest": {"sites": ["pick_red_1"],
    ...                                                          "kappa": 0.31}}), _weakest({})
    ('', '')
    """
    weak = evidence.get("read_weakest")
    if not isinstance(weak, dict) or set(weak["sites"]) >= set(evidence.get("read_sites", [])):
        return ""
    return (f"; the counts of objects tie these sites together, and the one read worst, "
            f"{', '.join(weak['sites'])}, agrees only {weak['kappa']:.2f} beyond chance")


def _agreement(evidence: dict) -> str:
    """How far a read doubt's reading agrees with the stated frames, in words: its kappa,
    and where that alone would have settled it, the lower bound that did not.

    >>> _agreement({"read_kappa": 0.3})
    'only 0.30 beyond chance (kappa; 0.6 is substantial)'
    >>> _agreement({"read_kappa": 0.65, "read_kappa_low": 0.33})
    '0.65 beyond chance (kappa), but the stated frames show only 0.33 for sure (95 % lower bound; 0.6 is substantial)'
    """
    kappa = evidence["read_kappa"]
    if not bound_decided(evidence):
        return f"only {kappa:.2f} beyond chance (kappa; 0.6 is substantial)"
    return (f"{kappa:.2f} beyond chance (kappa), but the stated frames show only "
            f"{evidence['read_kappa_low']:.2f} for sure (95 % lower bound; 0.6 is substantial)")


#: A node of at most this many observations is one render or two: what keeps it apart from
#: another node weighs more than the node's own evidence.
FEW_RENDERS = 2


def doubt_forbidden(conf: Confidence, doubts, labels: np.ndarray, max_nats: float = 3.0,
                    problem=None) -> Confidence:
    """``conf`` flagged when a constraint forbids a join that the images and the actions both
    favour: a merge doubt whose ``steps`` is at most 0 (the images put the two nodes within
    the chosen threshold) and whose flip shortens the description length by more than
    ``max_nats`` (``dl_nats``; odds of 20 to 1 for 3), while

    * Exactly-One forbids it (``forbidden == "exactly_one"``): the join would put two labels
      between one ordered pair of nodes, so some *other* decision of the graph conflicts with
      what the images and the actions say here; or
    * the hands' colours forbid it (``"hand"``) and one of the two nodes has at most
      :data:`FEW_RENDERS` observations: the hand's colour is itself read from the images
      (the colour of the objects an action moves), and one misread action colour can make
      such a node. (Two well-rendered nodes whose hands hold different colours are usually
      two states that look alike: not flagged.) Given the ``problem`` (its transitions),
      only where an action into or out of that node's observations is itself seen in at
      most :data:`FEW_RENDERS` transitions: an action the trace shows more often has its
      colour from as many looks, which one misread look does not set (multifruit-4x6
      clean and randomized s312, s315, randomized s308: a place node of one render at an
      episode's end, entered by a pick seen 4-9 times, kept apart from a node whose hand
      holds the other colour -- two true states, warned; random-939 randomized: a node
      entered by a pick seen once, a miss, still warned).

    The reason names the nodes and what to record.

    >>> from vggc_cp.solvers.doubts import Doubt
    >>> c = Confidence("mdl", 1.0, 5, None, 4.0, False, ())
    >>> d = Doubt("merge", (0, 1), ((0, 2), (3,)), {"forbidden": "hand", "steps": -0.5,
    ...                                             "dl_nats": -15.0})
    >>> doubt_forbidden(c, [d], np.array([0, 2, 0, 1])).suspect
    True
    >>> doubt_forbidden(c, [d], np.array([0, 0, 0, 1, 1, 1])).suspect   # three renders each
    False
    """
    labels = np.asarray(labels)
    seen = (None if problem is None else
            np.bincount(np.asarray(problem.act), minlength=len(problem.action_names)))
    for d in doubts:
        ev = d.evidence
        steps, nats, why = ev.get("steps"), ev.get("dl_nats"), ev.get("forbidden")
        if d.kind != "merge" or why not in ("exactly_one", "hand") or \
                not isinstance(steps, (int, float)) or steps > 0 or \
                not isinstance(nats, (int, float)) or nats >= -max_nats:
            continue
        a, b = d.nodes
        if why == "exactly_one":
            reason = (f"nodes {a} and {b} look alike (within the threshold) and the actions "
                      f"favour one node by {-nats:.1f} nats, but Exactly-One forbids the join: "
                      f"another decision of the graph conflicts with them")
        else:
            sizes = [int(np.sum(labels == u)) for u in d.nodes]
            if min(sizes) > FEW_RENDERS:
                continue
            small, other = (a, b) if sizes[0] <= sizes[1] else (b, a)
            if seen is not None:
                mine = np.flatnonzero(labels == small)
                near = np.asarray(problem.act)[np.isin(problem.src, mine)
                                               | np.isin(problem.dst, mine)]
                if len(near) and seen[near].min() > FEW_RENDERS:
                    continue    # its hand's colour rests on actions seen in many looks
            reason = (f"node {small} ({min(sizes)} observation(s)) is kept apart from node "
                      f"{other} only by the colour its hand is read to hold: the images put "
                      f"them within the threshold and the actions favour one node by "
                      f"{-nats:.1f} nats; an action's colour may be misread")
        reason += ("; `vggc-cp doubts SOLUTION TRACE -o doubts.png` shows it and `vggc-cp "
                   "suggest SOLUTION TRACE -o next.json` the episodes to record next")
        return conf.flagged(reason)
    return conf


def corroborate(conf: Confidence, doubts, max_nats: float = 3.0) -> Confidence:
    """``conf`` flagged also when a decision that the re-runs changed is one the trace's
    actions reject: a doubt (:mod:`vggc_cp.solvers.doubts`) on unstable nodes whose flip
    shortens the description length by more than ``max_nats`` (a Bayes factor above
    ``exp(max_nats)``, 20 for 3 nats: "strong" evidence, Kass and Raftery 1995).

    The two readings are independent: the re-runs test the images and the constraints on
    less of the recording, the description length the actions of all of it. Either alone
    is common on right graphs of few episodes; both on one decision is not.
    """
    unstable = set(conf.unstable)
    if not unstable:
        return conf
    for d in doubts:
        nats = d.evidence.get("dl_nats")
        if not isinstance(nats, (int, float)) or nats >= -max_nats:
            continue
        if not unstable.intersection(int(u) for u in d.nodes):
            continue
        what = ("nodes {} and {} might be one state".format(*d.nodes) if d.kind == "merge"
                else f"node {d.nodes[0]} might be two states")
        reason = (f"{what}: re-runs change {'them' if d.kind == 'merge' else 'it'} and the "
                  f"actions favour that by {-nats:.1f} nats (odds {math.exp(min(-nats, 50)):.0f} "
                  f"to 1); `vggc-cp doubts SOLUTION TRACE -o doubts.png` shows it and "
                  f"`vggc-cp suggest SOLUTION TRACE -o next.json` the episodes to record next")
        return conf.flagged(reason)
    return conf


def doubt_near_cuts(conf: Confidence, near) -> Confidence:
    """``conf`` flagged when a node that the readings read apart keeps together only because
    its cut would make the code longer by less than ln 20 nats
    (:func:`vggc_cp.solvers.read_splits.near_cuts`): the recording does not settle at 20 to
    1 whether the node is one state or two (two states seen once each share a node:
    multifruit-4x6 robot s387, draw 42, silent). The reason names the node, a few
    observations of each side, the sites and what to record.

    >>> c = Confidence("mdl", 1.0, 5, None, 4.0, False, ())
    >>> near = [(7, np.array([268]), np.array([341]), 1.02, ["place_red_1"])]
    >>> doubt_near_cuts(c, near).reasons[0][:60]
    'node 7 might be two states: the readings set observations 26'
    >>> doubt_near_cuts(c, []).suspect
    False
    """
    if not near:
        return conf
    u, a, b, loss, sites = near[0]
    more = _more(len(near) - 1, "node(s)")
    return conf.flagged(
        f"node {u} might be two states{more}: the readings set observations "
        f"{', '.join(str(int(o)) for o in a[:3])} apart from "
        f"{', '.join(str(int(o)) for o in b[:3])} at {', '.join(sites) or 'some site'}, and "
        f"cutting the node makes the code only {loss:.2f} nats longer (< ln 20 = 3.00): the "
        f"recording does not settle it; record episodes that act there from the node "
        f"(`vggc-cp suggest SOLUTION TRACE -o next.json`)")


def doubt_lone(conf: Confidence, lone) -> Confidence:
    """``conf`` flagged when episodes that visit no node another episode visits are less
    likely than :data:`~vggc_cp.solvers.episodes.LONE_ALPHA` by chance, or one of them starts
    away from the node the other episodes start at (at odds of
    :data:`~vggc_cp.solvers.episodes.HOME_ODDS` to 1 or more;
    :func:`~vggc_cp.solvers.episodes.lone_episodes`): such an episode's images may have
    been read wrong throughout, which no bound on the readings sees. The reason names the
    episode, the chance (or the home) and what to record.

    >>> from vggc_cp.solvers.episodes import LoneEpisodes
    >>> c = Confidence("mdl", 1.0, 5, None, 4.0, False, ())
    >>> lone = LoneEpisodes((np.array([9, 10, 11]),), 0.1, 0.01, 0.01)
    >>> doubt_lone(c, lone).suspect, doubt_lone(c, LoneEpisodes((), 0.0, 0.0, 1.0)).suspect
    (True, False)
    """
    if not lone.doubtful:
        return conf
    chains = lone.doubted
    chain = chains[0]
    more = _more(len(chains) - 1, "episode(s)")
    if lone.surprising:
        why = (f"{len(lone.chains)} such episode(s) where {lone.expected:.3f} would be "
               f"expected by chance (chance {lone.chance:.3f}; {100 * lone.share:.0f} % of "
               f"the episodes' nodes are their own)")
    else:
        why = (f"it does not start at node {lone.home}, where {lone.home_starts} of the "
               f"other {lone.episodes - 1} episodes start (odds of "
               f"{lone.home_starts + 1} to {lone.episodes - lone.home_starts} that an episode "
               f"starts there)")
    return conf.flagged(
        f"the episode of observations {int(chain[0])}-{int(chain[-1])} visits only nodes no "
        f"other episode visits{more}: {why}, so its images may have been read wrong "
        f"throughout; record an episode from that episode's start "
        f"(`vggc-cp suggest SOLUTION TRACE -o next.json`)")


def doubt_lone_starts(conf: Confidence, starts) -> Confidence:
    """``conf`` flagged when episodes that begin on nodes of their own and then join the
    graph are less likely than :data:`~vggc_cp.solvers.episodes.LONE_ALPHA` by chance
    (:func:`~vggc_cp.solvers.episodes.lone_starts`): the first frames of such an episode
    may have been read wrong, while the arm still rested where the previous episode left it.
    The reason names the episode, its first frames, the chance and what to record.

    >>> from vggc_cp.solvers.episodes import LoneStarts
    >>> c = Confidence("mdl", 1.0, 5, None, 4.0, False, ())
    >>> found = LoneStarts(((np.array([20, 21, 22, 23, 24]), 3),), 0.02, 0.006, 0.006)
    >>> flagged = doubt_lone_starts(c, found)
    >>> flagged.suspect, doubt_lone_starts(c, LoneStarts((), 0.0, 0.0, 1.0)).suspect
    (True, False)
    >>> print(flagged.reasons[0][:84])
    the episode of observations 20-24 starts on nodes no other episode visits (its first
    """
    if not starts.surprising:
        return conf
    chain, j = starts.starts[0]
    more = _more(len(starts.starts) - 1, "episode(s)")
    return conf.flagged(
        f"the episode of observations {int(chain[0])}-{int(chain[-1])} starts on nodes no "
        f"other episode visits (its first {j} observation(s)) and then joins the graph{more}: "
        f"{len(starts.starts)} such episode(s) where {starts.expected:.3f} would be expected "
        f"by chance (chance {starts.chance:.3f}; {100 * starts.share:.0f} % of the episodes' "
        f"nodes are their own), so its first images may have been read wrong; record an "
        f"episode from that episode's start (`vggc-cp suggest SOLUTION TRACE -o next.json`)")
