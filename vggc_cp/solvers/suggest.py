"""What to record next: episodes whose outcomes would settle a graph's doubts.

For every doubt (:mod:`vggc_cp.solvers.doubts`) of a learned graph, :func:`suggest_episodes`
proposes episodes a robot can run:

* **start** -- an episode start of the trace (a state the robot can be put in, as the
  trace shows it; its observation index is recorded), the one from which the learned
  graph's shortest plan (:func:`vggc_cp.graph.shortest_plan`, BFS) to the probe's node is
  shortest (ties: the lowest observation index);
* **plan** -- that plan's actions;
* **probe** -- one action whose outcome tells the two readings apart:

  - merge doubt that only a reading of the images settles (``read_sites`` in its evidence,
    :func:`~vggc_cp.solvers.read_doubts.read_doubts`): it falls once one of those sites is
    stated in both nodes, so the probes come as a unit per site (:func:`_pair_units`): from
    each node not yet stated there (``read_told``), an action at that site -- its own or one
    the recording shows changing it (``read_acting``) -- that the learned graph takes
    there, or one step on (:func:`_read_probes`); one probe where the other node is stated
    there already (random-2 robot, tuning: each of its four pairs was stated at some read
    site in one node at least). Where
    ``read_told`` is not known, or no site has a way for both, from each node an action
    at one of those sites as before. Where
    the reading is right it is legal and states what the site holds, which no reading can
    be wrong about; where it is wrong, the refusal contradicts the node. Only where the graph
    has none, an action of the node's role at the sites, legal or not -- a place only where
    the hand holds what it needs (the node's own places show which, :func:`hand_classes`):
    one refused for the hand's reason says nothing of the site. Then, as for every merge
    doubt:
  - merge doubt (``A`` and ``B`` might be one state): an action taken from ``A`` in the trace
    and never from ``B``, tried from ``B`` (and the other way round). If it is legal there,
    ``B`` affords what ``A`` affords: one more reason to merge them; if it is illegal (the
    simulator reports it), they differ. An illegal action is no transition of the trace
    (the learner reads it as a refusal, :mod:`vggc_cp.recorded`), so each such probe comes
    with a confirming one that is: the same action again from ``A`` (more renders of ``A``
    doing what ``B`` was never seen to do). When both nodes afford the same actions, an action
    they share is repeated from each (those whose outcomes differ first): do they lead to
    one node?
  - split doubt that only a reading of the images settles (an episode put on its path by
    that reading, :func:`~vggc_cp.solvers.read_doubts.episode_doubts`): from the episode's
    start, and from ``N`` as the graph reaches it, the same probes at those sites as for a
    read merge doubt of ``N``. Then, as for every split doubt:
  - split doubt (node ``N``, sides ``P`` and ``Q``): ``N`` is entered as the trace entered
    a typical observation of one side (the same predecessor node and action, or the same
    episode start), then an action taken from the other side only is tried, and (the
    confirming probe) one taken from this side only. Where no action sets the sides apart,
    the node's own actions are tried from each side.

A node never seen to act (its observations end episodes) affords nothing the graph knows; it is
probed with the actions of its role, the ones the trace takes most often first, legal or not
(blocks-2 robot s179: a split doubt of two episode ends had no probe, and nothing was recorded).

Each episode tests one doubtful (node, action) pair; a unit of episodes (the two sides of a
read pair at one site) is proposed whole or not at all. First the best unit of every doubt
(its cheapest at the read sites, where it has one: what settles a read doubt), the doubts in
their rank -- the verdict flags a graph while any read pair stands, and before, the many
one-action probes of episode doubts took every place (random-2 robot, tuning: 20 of 20, none
for its four pairs); then the best of every other (doubt, direction); then the rest; these
last by the transitions they add, then by the doubt's rank, then in the order the list above
gives a doubt's probes (a probe from the node tested before the one that confirms it). The
best units go round the decisions the doubts question (:func:`decision_key`): the first doubt
of each decision in its rank before a second of any (random-14 robot, tuning: 34 episode
doubts of one node took all 20 places, the three true merges ranked after them none). An
episode whose first action the recording already saw refused from its start
(:mod:`vggc_cp.recorded`) is not proposed again: its outcome is known. Only observations,
actions and the recording's refusals are read, never ground-truth states.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vggc_cp.graph import TaskGraph, bfs_distances, shortest_plan
from vggc_cp.recorded import recorded_facts
from vggc_cp.solvers.doubts import MERGE
from vggc_cp.trace import PLACE, action_kind
from vggc_cp.vision.resets import components


@dataclass(frozen=True)
class Proposal:
    """One episode to record.

    Attributes
    ----------
    start_observation : int
        An episode start of the trace.
    actions : tuple of str
        The plan, then the probe (the last action).
    doubt : int
        Index of the doubt it tests (in the solution's ``doubts``).
    probe_node : int
        The node the probe is taken from (as the learned graph predicts it).
    why : str
    """

    start_observation: int
    actions: tuple[str, ...]
    doubt: int
    probe_node: int
    why: str

    @property
    def score(self) -> float:
        """Doubtful (node, action) pairs tested per transition."""
        return 1.0 / max(len(self.actions), 1)

    def as_dict(self) -> dict:
        return {"start_observation": int(self.start_observation),
                "actions": list(self.actions), "doubt": int(self.doubt),
                "probe_node": int(self.probe_node), "score": round(self.score, 4),
                "why": self.why}


@dataclass
class _Unit:
    """Probes proposed together (:func:`suggest_episodes`): ``doubt`` (its index) and
    ``side`` (the direction tested), ``unread`` (no probe at the doubt's read sites),
    ``order`` (where :func:`_probes` gave the first), ``proposals`` (None where no plan
    reaches the probe's node)."""

    doubt: int
    side: object
    unread: bool
    order: int
    proposals: list

    @property
    def cost(self) -> int:
        """The transitions the unit adds."""
        return sum(len(p.actions) for p in self.proposals)


class _Router:
    """Shortest plans on the learned graph from the trace's episode starts."""

    def __init__(self, graph: TaskGraph, labels: np.ndarray, starts: list[int]):
        self.graph = graph
        self.start_of: dict[int, int] = {}
        for o in sorted(starts):
            self.start_of.setdefault(int(labels[o]), int(o))
        self._routes: dict[int, tuple[int, list[str]] | None] = {}

    def route(self, target: int) -> tuple[int, list[str]] | None:
        """``(start observation, plan action names)`` to ``target``, or None (each target's
        searched once: many probes of many doubts lead to one node)."""
        if target not in self._routes:
            self._routes[target] = self._search(target)
        return self._routes[target]

    def _search(self, target: int) -> tuple[int, list[str]] | None:
        dist = bfs_distances(self.graph, target, reverse=True)
        best = min(((dist[u], o, u) for u, o in self.start_of.items() if u in dist),
                   default=None)
        if best is None:
            return None
        _, obs, node = best
        plan = shortest_plan(self.graph, node, target)
        if plan is None:
            return None
        return obs, [self.graph.action_names[a] for _, a, _ in plan]


def _actions_of(graph: TaskGraph, u: int) -> dict[str, int]:
    return {graph.action_names[a]: v for a, v in graph.successors(u)}


def suggest_episodes(trace, labels, doubts, max_episodes: int = 20, per_doubt: int = 3
                     ) -> list[Proposal]:
    """Episodes to record for ``doubts`` of the graph ``labels`` induces on ``trace``
    (module docstring).

    Parameters
    ----------
    trace : Trace
        Observations' actions and episodes only are read.
    labels : ndarray of int, shape (N,)
    doubts : sequence of Doubt
    max_episodes : int
        Most proposals returned (best first).
    per_doubt : int
        Most probes per doubt and direction.

    Returns
    -------
    list of Proposal
    """
    labels = np.asarray(labels, dtype=np.int64)
    src, act, dst = trace.transitions()
    graph = TaskGraph.from_labels(labels, trace.roles(), src, act, dst, trace.action_names)
    starts = [first for first, _ in trace.episodes()]
    router = _Router(graph, labels, starts)
    start_set = set(starts)
    classes = hand_classes(graph)
    units: dict[tuple, _Unit] = {}
    for k, doubt in enumerate(doubts):
        if any(u not in graph.members for u in doubt.nodes):
            continue
        for j, (side, unit, read, (fixed, target, tail, probe_node, probe, why)) in enumerate(
                _probes(graph, trace, labels, doubt, per_doubt, start_set, classes)):
            if fixed is not None:
                start, plan = fixed, []
            else:
                r = router.route(target)
                start, plan = r if r is not None else (None, None)
            p = None if plan is None else Proposal(start, (*plan, *tail, probe), k,
                                                   probe_node, why)
            key = (k, side, j if unit is None else unit)
            units.setdefault(key, _Unit(k, side, not read, j, [])).proposals.append(p)
    # a unit (the probes that settle something together: the two sides of a read pair at
    # one site) is proposed whole or not at all. First the best unit of every doubt, the
    # doubts in their rank (the verdict flags a graph while any read pair stands, so none
    # may be crowded out by the short probes of many episodes); then the best of every
    # other (doubt, side); then the rest. Each unit costs the transitions it adds; a
    # doubt's best is its cheapest at the read sites where it has one (what settles a read
    # doubt), else its cheapest; a side's best its cheapest; ties in the order _probes
    # gives (a probe from the node tested before the one that confirms it); the last two
    # parts by cost, then doubt, then that order.
    whole = [u for u in units.values() if None not in u.proposals]
    best: dict[int, _Unit] = {}
    for u in sorted(whole, key=lambda u: (u.unread, u.cost, u.order)):
        best.setdefault(u.doubt, u)
    # many doubts may question one decision (34 episodes of random-14 robot, each doubting
    # that node 28 is one state): the best units go round the decisions, one doubt of each
    # in its rank before a second of any
    turn = _decision_turns(doubts)
    sides, rest, groups = [], [], {(u.doubt, u.side) for u in best.values()}
    for u in sorted(whole, key=lambda u: (u.cost, u.doubt, u.order)):
        if u is not best[u.doubt]:
            (rest if (u.doubt, u.side) in groups else sides).append(u)
            groups.add((u.doubt, u.side))
    out: list[Proposal] = []
    # an episode whose first action the recording already saw refused from its start is
    # refused again (the start is a reset to one state): its outcome is known
    index = {name: k for k, name in enumerate(trace.action_names)}
    refused = set(recorded_facts(trace).refusals)
    seen: set = {(p.start_observation, p.actions) for u in units.values() for p in u.proposals
                 if p is not None and (p.start_observation, index[p.actions[0]]) in refused}
    for u in [best[k] for k in sorted(best, key=lambda k: (turn[k], k))] + sides + rest:
        new = [p for p in u.proposals if (p.start_observation, p.actions) not in seen]
        if new and len(out) + len(new) <= max_episodes:
            seen.update((p.start_observation, p.actions) for p in new)
            out += new
    return out


def decision_key(doubt) -> tuple:
    """The decision ``doubt`` questions: the two nodes of a merge doubt, the node of a split
    doubt and the node its evidence would move an episode to (``moved_to``), if any.

    >>> from vggc_cp.solvers.doubts import Doubt
    >>> decision_key(Doubt("merge", (7, 3), ((1,), (2,)), {}))
    ('merge', 3, 7)
    >>> decision_key(Doubt("split", (28,), ((1,), (2,)), {"moved_to": 31}))
    ('split', 28, 31)
    """
    if doubt.kind == MERGE:
        return (MERGE, *sorted(int(u) for u in doubt.nodes))
    moved = (doubt.evidence or {}).get("moved_to")
    return (doubt.kind, *(int(u) for u in doubt.nodes),
            int(moved) if isinstance(moved, int) else -1)


def _decision_turns(doubts) -> list[int]:
    """For each doubt, how many doubts before it in the list question its decision
    (:func:`decision_key`): 0 for the first of each."""
    seen: dict[tuple, int] = {}
    turns = []
    for d in doubts:
        key = decision_key(d)
        turns.append(seen.get(key, 0))
        seen[key] = turns[-1] + 1
    return turns


def _probes(graph: TaskGraph, trace, labels, doubt, per_doubt: int, start_set: set[int],
            classes: dict[str, int]):
    """Yield ``(side, (start, target, tail, probe node, probe action, why))``, the most
    telling first (the order :func:`suggest_episodes` breaks ties of length in): the episode
    starts at observation ``start`` (when not None) or at the best start for a plan to node
    ``target``; then ``tail`` actions, then the probe. ``side`` names the direction tested
    (the node probed, or the half of a split node entered)."""
    if doubt.kind == MERGE:
        a, b = doubt.nodes
        # only the images' reading at some sites sets the two apart (read_doubts): act at
        # one of them from each node not yet stated there, so that the actions state what
        # the site holds in both (which no reading can be wrong about)
        pairs = _pair_units(graph, doubt, classes)[:per_doubt]
        for site, unit in pairs:
            for x, (tail, v, name, by) in unit:
                y = b if x == a else a
                also = (f" (node {y} is stated there already)" if len(unit) == 1 else
                        f" (and from node {y}: both stated there settle it)")
                yield "pair", site, True, (None, x, tail, v, name,
                                     f"merge doubt {a}+{b}: only the images' reading of "
                                     f"{site}'s site tells them apart{also}; "
                                     f"{_probe_words(x, tail, v, name, by)}")
        for x in (a, b) if not pairs else ():
            y = b if x == a else a
            for tail, v, name, by in _read_probes(graph, doubt, x, classes, y)[:per_doubt]:
                yield x, None, True, (None, x, tail, v, name,
                                f"merge doubt {a}+{b}: only the images' reading of {name}'s "
                                f"site tells them apart; {_probe_words(x, tail, v, name, by)}")
        acts_a, acts_b = _actions_of(graph, a), _actions_of(graph, b)
        only_a = sorted(set(acts_a) - set(acts_b))
        only_b = sorted(set(acts_b) - set(acts_a))
        for x, y, only in ((b, a, only_a), (a, b, only_b)):
            for name in only[:per_doubt]:
                yield x, None, False, (None, x, (), x, name,
                          f"merge doubt {a}+{b}: {name} was taken from node {y}, never from "
                       f"node {x}; legal from {x}: they may be one state, illegal: they "
                       f"differ")
                yield x, None, False, (None, y, (), y, name,
                          f"merge doubt {a}+{b}: {name} again from node {y}, which the trace "
                       f"saw take it: more renders of {y} doing what {x} was never seen to do")
        if only_a or only_b:
            return
        if acts_a:
            # both afford the same actions: repeat them from each (those whose outcomes
            # differ first): more renders of both and of where they lead
            shared = sorted(acts_a, key=lambda n: (acts_a[n] == acts_b.get(n), n))
            for name in shared[:per_doubt]:
                for x in (a, b):
                    yield x, None, False, (None, x, (), x, name,
                              f"merge doubt {a}+{b}: {name} leads from {a} to {acts_a[name]} and "
                           f"from {b} to {acts_b[name]}; repeated from {x}: one node or two?")
            return
        # neither was seen to act (episodes ended there): what they afford is unknown; the
        # role's most common actions from each, legal or not, tell
        for name in _role_actions(graph, trace, a)[:per_doubt]:
            for x in (a, b):
                yield x, None, False, (None, x, (), x, name,
                          f"merge doubt {a}+{b}: no action was taken from either; {name} "
                          f"from {x}: do they afford alike, and lead to one node?")
        return
    (u,) = doubt.nodes
    sides = [tuple(side) for side in doubt.observations]
    ev = doubt.evidence or {}
    episode = ev.get("episode")
    if isinstance(episode, list) and episode and int(episode[0]) in start_set:
        # an episode only the images' reading put on its path (episode_doubts): act at those
        # sites from its start, and from the node as the graph reaches it
        first = int(episode[0])
        moved = ev.get("moved_to")
        moved = int(moved) if isinstance(moved, int) else None
        for tail, v, name, by in _read_probes(graph, doubt, u, classes, moved)[:per_doubt]:
            yield 1, None, True, (first, None, tail, v, name,
                      f"split doubt {u}: the episode from observation {first} might start at "
                      f"node {ev.get('moved_to')}; from its start, "
                      f"{_probe_words(u, tail, v, name, by)}, which tells node {u} from "
                      f"node {ev.get('moved_to')}")
            yield 0, None, True, (None, u, tail, v, name,
                      f"split doubt {u}: from node {u} as the graph reaches it, "
                      f"{_probe_words(u, tail, v, name, by)}: what the site holds in the "
                      f"node's other observations")
    if isinstance(ev.get("only_a"), list) and isinstance(ev.get("only_b"), list):
        # the actions each whole side took and the other never did (find_doubts)
        names = set(graph.action_names)
        only = (sorted(a for a in ev["only_b"] if a in names),
                sorted(a for a in ev["only_a"] if a in names))
    else:  # from the listed observations only
        side_acts = []
        for side in sides:
            seen = set()
            for o in side:
                if o < trace.n_obs - 1 and trace.actions[o] >= 0:
                    seen.add(trace.action_names[int(trace.actions[o])])
            side_acts.append(seen)
        only = (sorted(side_acts[1] - side_acts[0]), sorted(side_acts[0] - side_acts[1]))
    alike = not only[0] and not only[1]
    # where no action sets the sides apart: the node's actions, or where it was never seen
    # to act (episodes ended there), its role's most common ones, legal or not
    shared = ((sorted(_actions_of(graph, u)) or _role_actions(graph, trace, u))[:per_doubt]
              if alike else [])
    for s in (0, 1):
        entry = _entry(trace, labels, sides[s], start_set)
        if entry is None:
            continue
        start, target, tail, o = entry
        if alike:
            for name in shared:
                yield s, None, False, (start, target, tail, u, name,
                          f"split doubt {u}: node {u} entered as the trace entered observation "
                          f"{o} (one side), then {name}; no action sets the sides apart in the "
                          f"trace: does it do here what it does from the other side?")
            continue
        for name in only[s][:per_doubt]:
            yield s, None, False, (start, target, tail, u, name,
                      f"split doubt {u}: node {u} entered as the trace entered observation {o} "
                      f"(one side), then {name}, taken in the trace from the other side only: "
                   f"legal and alike -> one state; illegal -> two")
        for name in only[1 - s][:per_doubt]:
            yield s, None, False, (start, target, tail, u, name,
                      f"split doubt {u}: node {u} entered as the trace entered observation {o} "
                      f"(one side), then {name}, which only that side took in the trace: "
                   f"more renders of that side doing what the other was never seen to do")


def _role_actions(graph: TaskGraph, trace, node: int) -> list[str]:
    """The actions ``node``'s role can take (picks from a node whose hand is empty, places
    from one that holds something), the ones the trace takes most often first (ties by
    name): probes for a node never seen to act."""
    role = graph.node_role.get(node)
    taken = np.bincount(trace.actions[trace.actions >= 0], minlength=len(trace.action_names))
    fits = [k for k, n in enumerate(trace.action_names) if action_kind(n) == role]
    return [trace.action_names[k] for k in sorted(fits, key=lambda k: (-taken[k],
                                                                       trace.action_names[k]))]


def hand_classes(graph: TaskGraph) -> dict[str, int]:
    """Place actions that need one thing in the hand, as the graph shows it: the places taken
    from one node share its hand, transitively; ``{action name: class}`` for every place
    the graph takes (a place never taken is in none).

    >>> from vggc_cp.trace import PICK, PLACE
    >>> names = ("pick_a_0", "place_a_0", "place_a_1", "place_b_1")
    >>> g = TaskGraph.from_labels(np.array([0, 1, 2, 1, 3]), [PICK, PLACE, PICK, PLACE, PICK],
    ...                           np.array([0, 1, 3]), np.array([0, 1, 2]), np.array([1, 2, 4]),
    ...                           names)
    >>> hand_classes(g)
    {'place_a_0': 0, 'place_a_1': 0}
    """
    pairs, places = [], set()
    for u in graph.members:
        mine = [a for a, _ in graph.successors(u)
                if action_kind(graph.action_names[a]) == PLACE]
        places.update(mine)
        pairs += [(mine[0], a) for a in mine[1:]]
    comp = components(len(graph.action_names), pairs)
    taken = sorted(places)
    ids = {c: i for i, c in enumerate(dict.fromkeys(int(comp[a]) for a in taken))}
    return {graph.action_names[a]: ids[int(comp[a])] for a in taken}


def _site_actions(doubt, site: str) -> set[str]:
    """The actions that state what a read doubt's ``site`` holds: its own, and those the
    recording shows changing it (the evidence's ``read_acting``)."""
    acting = (doubt.evidence or {}).get("read_acting")
    more = acting.get(site) if isinstance(acting, dict) else None
    return {site, *(n for n in more if isinstance(n, str))} if isinstance(more, list) else {site}


def _pair_units(graph: TaskGraph, doubt, classes: dict[str, int]
                ) -> list[tuple[str, list[tuple[int, tuple]]]]:
    """For a read merge doubt of nodes ``a`` and ``b``: ``(site, [(node, read probe), ...])``
    per read site at which every one of the two not yet stated there (the evidence's
    ``read_told``) has a way to act (:func:`_read_probes`, with the actions that state the
    site): the doubt falls only where one site is stated in both nodes
    (:func:`~vggc_cp.solvers.read_doubts.read_doubts`), so a probe of each node at
    different sites settles nothing, and a node stated there already needs none. Sites
    needing fewer probes first, then those whose probes are the graph's own ways, then
    fewer actions; none without ``read_told``."""
    ev = doubt.evidence or {}
    names, told = ev.get("read_sites"), ev.get("read_told")
    if not isinstance(names, list) or not (isinstance(told, list) and len(told) == 2
                                           and all(isinstance(t, list) for t in told)):
        return []
    a, b = doubt.nodes
    units = []
    for site in (n for n in names if isinstance(n, str)):
        unit = []
        for x, y, stated in ((a, b, told[0]), (b, a, told[1])):
            if site in stated:
                continue
            ways = _read_probes(graph, doubt, x, classes, y, _site_actions(doubt, site))
            if not ways:
                break
            unit.append((x, ways[0]))
        else:
            if unit:
                guess = sum(w[3] is None for _, w in unit)
                units.append(((len(unit), guess, sum(len(w[0]) for _, w in unit), site),
                              site, unit))
    return [(site, unit) for _, site, unit in sorted(units)]


def _read_probes(graph: TaskGraph, doubt, node: int, classes: dict[str, int],
                 other: int | None = None, at: set[str] | None = None
                 ) -> list[tuple[tuple[str, ...], int, str, int | None]]:
    """Ways to state what a read doubt's sites (its evidence's ``read_sites``) hold at
    ``node``: ``(tail, probe node, probe, by)``, the actions ``tail`` then ``probe``, taken
    from ``probe_node`` (where the graph predicts ``tail`` leads); ``by``, the node whose
    edges they are (None: no edge's); none for another doubt.

    The graph's own edges first: an action at a site that ``node`` takes (``tail`` empty),
    then one that a node one of its actions leads to takes (that action in ``tail``). Where
    the doubted reading is right, such a probe is legal, and a legal action states what its
    site holds -- the frames of the new episode up to it, and, through the reset that starts
    it, the observation it starts from; where the reading is wrong, the refusal contradicts
    the node itself. Then the same ways of ``other``, the node the doubt says ``node`` might
    be, tried from ``node``: legal, ``node`` holds there what ``other`` holds (a lone episode
    whose own nodes act nowhere near the read sites, multifruit-4x6 robot s2: a place the
    start state takes, then the pick at the read site, joins it to its state). Only where
    neither has such a way, the actions of the node's role at the sites, legal or not: a
    refused pick rules one value out, which settles the site only where one is left, and a
    refused place settles nothing of a site that several colours may fill (multifruit-4x6
    robot s0: 15 of 20 such probes, place_yellow_0 from the start state, were refused and
    recorded nothing). A place whose hand another class of places needs (``classes``,
    :func:`hand_classes`) is left out: refused, it says what the hand holds, not what the
    site holds (the learner ignores it, :mod:`vggc_cp.vision.resets`). Each probe action
    once, by its first way. The actions at a site are its own and those the recording
    shows changing it (:func:`_site_actions`); ``at``, when given, those of the sites to
    state instead."""
    names = (doubt.evidence or {}).get("read_sites")
    if not isinstance(names, list):
        return []
    if at is None:
        at = {n for site in names if isinstance(site, str) for n in _site_actions(doubt, site)}
    at_sites = {n for n in at if n in graph.action_names}
    taken = _actions_of(graph, node)
    mine = {classes[n] for n in taken if n in classes}

    def hand_fits(n: str) -> bool:      # not a place another hand needs
        return not mine or n not in classes or classes[n] in mine

    out = [(t, v, n, node) for t, v, n in _edge_ways(graph, node, at_sites)]
    if other is not None and other != node and other in graph.members:
        out += [(t, taken.get(t[0], node) if t else node, n, other)
                for t, _, n in _edge_ways(graph, other, at_sites)
                if hand_fits(t[0] if t else n)]   # the action taken from node
    if out:
        seen: set[str] = set()
        return [p for p in out if not (p[2] in seen or seen.add(p[2]))]
    role = graph.node_role.get(node)
    fits = [n for n in at_sites if action_kind(n) == role]
    if role == PLACE:
        fits = [n for n in fits if hand_fits(n)]
    return [((), node, n, None) for n in sorted(fits, key=lambda n: (n not in classes, n))]


def _edge_ways(graph: TaskGraph, x: int, at_sites: set[str]
               ) -> list[tuple[tuple[str, ...], int, str]]:
    """``(tail, node, action)``: the actions at ``at_sites`` that ``x`` takes (no tail),
    then those a node one of its actions leads to takes (that action the tail), by name."""
    taken = _actions_of(graph, x)
    out = [((), x, n) for n in sorted(at_sites & set(taken))]
    for first, v in sorted(taken.items()):
        out += [((first,), v, n) for n in sorted(at_sites & set(_actions_of(graph, v)))]
    return out


def _probe_words(node: int, tail: tuple[str, ...], probe_node: int, name: str,
                 by: int | None) -> str:
    """What a read probe does, in words (:func:`_read_probes`)."""
    then = f"{' '.join(tail)} (to node {probe_node}), then " if tail else ""
    if by == node:
        return (f"{then}{name}, which the graph takes from node {probe_node}, states what "
                f"its site holds (legal: as read at node {node}; refused: the reading is "
                f"wrong)")
    if by is not None:
        return (f"{then}{name}, as the graph takes it from node {by}"
                f"{' one step on' if tail else ''}, states what its site holds (legal: node "
                f"{node} holds there what node {by} holds; refused: they differ)")
    return (f"{then}{name} from node {probe_node} states what its site holds there (legal: "
            f"it holds what {name} needs; illegal: it does not)")


def _entry(trace, labels, side, start_set):
    """How to reach ``side``'s situation: ``(start, target, tail, observation)`` -- the
    side's observation is an episode start (``start``), or its predecessor node
    (``target``) and the action that entered it (``tail``); None if neither."""
    for o in side:
        if o in start_set:
            return int(o), None, (), int(o)
    for o in side:
        if o > 0 and trace.actions[o - 1] >= 0:
            return (None, int(labels[o - 1]),
                    (trace.action_names[int(trace.actions[o - 1])],), int(o))
    return None


def episodes_document(trace, proposals: list[Proposal], solution: str = "") -> dict:
    """The ``vggc-episodes/1`` JSON object of ``proposals`` (``docs/FORMATS.md``)."""
    from vggc_cp.sim.append import EPISODES_FORMAT

    return {"format": EPISODES_FORMAT, "trace_sha256": trace.content_hash(),
            "solution": str(solution), "episodes": [p.as_dict() for p in proposals]}
