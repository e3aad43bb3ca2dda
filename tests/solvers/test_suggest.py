"""``suggest`` (:mod:`vggc_cp.solvers.suggest`): every proposal starts at an episode start and
its actions execute under the benchmark's dynamics from the true state there (the plan
always; the probe too where the doubt's two nodes are truly one state)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vggc_cp.graph import TaskGraph
from vggc_cp.sim.explore import random_walk
from vggc_cp.sim.tasks import get_benchmark
from vggc_cp.solvers.doubts import MERGE, SPLIT, Doubt
from vggc_cp.solvers.suggest import (
    decision_key,
    episodes_document,
    hand_classes,
    suggest_episodes,
)
from vggc_cp.trace import Trace, load_trace

SHIPPED = Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz"


def _true_labels(trace):
    _, labels = np.unique(trace.states, return_inverse=True)
    return labels.astype(np.int64)


def _legal(bench, state, actions):
    valid, _ = bench.apply(str(state), actions)
    return valid


def _walk_trace(benchmark: str, steps: int, seed: int):
    """A random walk of ``benchmark`` as a trace with blank images: ``(bench, trace,
    states)``."""
    bench = get_benchmark(benchmark)
    walk = random_walk(bench, steps, np.random.default_rng(seed))
    states = np.array(walk.states)
    trace = Trace(np.zeros((len(states), 4, 4, 3), np.uint8), np.asarray(walk.actions),
                  tuple(bench.action_names), states, {"benchmark": benchmark})
    return bench, trace, states


def _split_busiest_pick_state(trace):
    """The true labels with the later renders of the most visited pick state made a node of
    their own (an over-split); returns the labels, the state, its observations and the two
    nodes."""
    labels = _true_labels(trace)
    keys, counts = np.unique(trace.states[trace.roles() == 0], return_counts=True)
    state = keys[np.argmax(counts)]
    obs = np.flatnonzero(trace.states == state)
    a, b = int(labels[obs[0]]), int(labels.max()) + 1
    labels[obs[len(obs) // 2:]] = b
    return labels, state, obs, a, b


def test_merge_doubt_of_one_state_split_in_two_is_probed_with_legal_actions():
    trace = load_trace(SHIPPED)
    bench = get_benchmark(trace.meta["benchmark"])
    labels, _state, obs, a, b = _split_busiest_pick_state(trace)
    doubt = Doubt(MERGE, (a, b), (tuple(obs[:2]), tuple(obs[-2:])), {})
    proposals = suggest_episodes(trace.without_states(), labels, [doubt])
    assert proposals, "a merge doubt between two nodes of one state gets probes"
    starts = {first for first, _ in trace.episodes()}
    for p in proposals:
        assert p.start_observation in starts and p.doubt == 0 and p.actions
        assert p.probe_node in (a, b)
        assert all(_legal(bench, trace.states[p.start_observation], p.actions)), p
    doc = episodes_document(trace, proposals, "s.json")
    assert doc["format"] == "vggc-episodes/1"
    assert doc["trace_sha256"] == trace.content_hash()
    assert [e["actions"] for e in doc["episodes"]] == [list(p.actions) for p in proposals]
    assert len(proposals[0].actions) == min(len(p.actions) for p in proposals)
    assert {p.probe_node for p in proposals} == {a, b}  # both directions are probed


def test_plans_to_doubtful_nodes_of_a_right_graph_execute():
    """Doubts between distinct states of the true graph: the plan to the probe's node is
    legal from the start; the probe may be illegal (that is the answer it asks for)."""
    trace = load_trace(SHIPPED)
    bench = get_benchmark(trace.meta["benchmark"])
    labels = _true_labels(trace)
    roles = trace.roles()
    pick_nodes = sorted({int(u) for u in labels[roles == 0]})
    place_nodes = sorted({int(u) for u in labels[roles == 1]})
    node_obs = {u: tuple(np.flatnonzero(labels == u)[:3]) for u in pick_nodes + place_nodes}
    doubts = [Doubt(MERGE, (pick_nodes[0], pick_nodes[1]),
                    (node_obs[pick_nodes[0]], node_obs[pick_nodes[1]]), {}),
              Doubt(MERGE, (place_nodes[0], place_nodes[2]),
                    (node_obs[place_nodes[0]], node_obs[place_nodes[2]]), {}),
              Doubt(SPLIT, (pick_nodes[2],),
                    (node_obs[pick_nodes[2]][:2], node_obs[pick_nodes[2]][2:]), {}),
              # halves that took the same actions (find_doubts' evidence says so)
              Doubt(SPLIT, (pick_nodes[1],),
                    (node_obs[pick_nodes[1]][:2], node_obs[pick_nodes[1]][2:]),
                    {"only_a": [], "only_b": []})]
    proposals = suggest_episodes(trace.without_states(), labels, doubts, max_episodes=50)
    assert {p.doubt for p in proposals} == {0, 1, 2, 3}
    for p in proposals:
        valid = _legal(bench, trace.states[p.start_observation], p.actions)
        assert all(valid[:-1]), p
        if p.doubt in (2, 3):  # a split doubt of a true node: every action is legal
            assert all(valid), p


def test_a_doubt_only_a_reading_settles_is_probed_at_the_read_sites_first():
    """A read doubt (``read_sites`` in its evidence) on a pick state split in two: every
    probe acts at one of those sites; the first from each node is an action at a site that
    the graph takes there (or one step on), which -- the graph being the truth split in two --
    executes, so that it states what the site holds; the others are legal exactly where the
    state holds what they need."""
    trace = load_trace(SHIPPED)
    bench = get_benchmark(trace.meta["benchmark"])
    labels, state, obs, a, b = _split_busiest_pick_state(trace)
    picks = sorted(n for n in trace.action_names if n.startswith("pick"))
    sites = [picks[0], picks[-1], "place" + picks[0][4:]]
    doubt = Doubt(MERGE, (a, b), (tuple(obs[:2]), tuple(obs[-2:])),
                  {"read_sites": sites, "read_kappa": 0.2})
    proposals = suggest_episodes(trace.without_states(), labels, [doubt], max_episodes=40)
    read = [p for p in proposals if "reading" in p.why]
    assert read and all(p.actions[-1] in sites for p in read)
    edges = [p for p in read if "which the graph takes" in p.why]
    assert edges and read[0] in edges
    for p in edges:
        assert all(_legal(bench, trace.states[p.start_observation], p.actions)), p
    for p in read:
        # the plan is legal; the probe is legal exactly where the state holds its object
        assert all(_legal(bench, trace.states[p.start_observation], p.actions[:-1]))
    legal = [_legal(bench, state, (name,))[-1] for name in sites[:2]]
    assert any(legal)


def test_an_episode_a_reading_placed_is_probed_from_its_start():
    """A split doubt of an episode that only a reading put on its path (``episode`` in its
    evidence): the first proposals act at the read sites from the episode's own start, a
    state the robot can be put in; a probe the graph predicts (its edge) executes there, any
    other is legal exactly where the state holds what it needs."""
    trace = load_trace(SHIPPED)
    bench = get_benchmark(trace.meta["benchmark"])
    labels = _true_labels(trace)
    (first, last), *_ = trace.episodes()
    u = int(labels[first])
    rest = tuple(int(o) for o in np.flatnonzero(labels == u) if o > last)[:2]
    picks = sorted(n for n in trace.action_names if n.startswith("pick"))
    doubt = Doubt(SPLIT, (u,), (rest, (first,)),
                  {"episode": [first, last], "moved_to": u + 1, "read_sites": picks[:2],
                   "read_kappa": 0.3})
    proposals = suggest_episodes(trace.without_states(), labels, [doubt])
    from_start = [p for p in proposals if p.start_observation == first and len(p.actions) == 1]
    assert {p.actions[0] for p in from_start} == set(picks[:2])
    assert proposals[0] in from_start and "states what its site holds" in proposals[0].why
    state = trace.states[first]
    for p in from_start:
        held = _legal(bench, state, p.actions)[-1]
        slot = int(p.actions[0].rsplit("_", 1)[1])
        assert held == (state.split("|")[0][slot] != "-")
        assert held or "which the graph takes" not in p.why


def test_a_read_site_a_place_node_cannot_act_on_is_stated_one_step_on():
    """Two colours, a place state (the hand full) whose read site holds an object: no place
    there is legal, and a refused place settles nothing of a site either colour may fill
    (multifruit-4x6 robot s0: 15 of 20 such probes recorded nothing). The first probe from
    the node is the graph's way to state it: a place the node takes, then the pick at the
    site that the node it leads to takes -- which executes, and lifts what the site holds."""
    bench, trace, states = _walk_trace("multifruit-2x3", 300, 1)
    labels = _true_labels(trace)
    graph = TaskGraph.from_labels(labels, trace.roles(), *trace.transitions(),
                                  trace.action_names)
    found = None
    for o in np.flatnonzero(trace.roles() == 1):
        grid = str(states[o]).split("|")[0]
        u = int(labels[o])
        for site, held in enumerate(grid):
            at = [n for n in bench.action_names if n.endswith(f"_{site}")]
            nxt = [v for a, v in graph.successors(u)]
            if held != "-" and any(f"pick_{c}_{site}" in {graph.action_names[a] for a, _ in
                                                          graph.successors(v)}
                                   for v in nxt for c in ("red", "yellow")):
                found = (o, u, site, at)
                break
        if found:
            break
    assert found is not None
    o, u, site, at = found
    doubt = Doubt(MERGE, (u, u), ((int(o),), (int(o),)), {"read_sites": at, "read_kappa": 0.2})
    (p, *_) = [p for p in suggest_episodes(trace.without_states(), labels, [doubt],
                                            max_episodes=60) if "reading" in p.why]
    assert p.actions[-1].startswith("pick_") and p.actions[-1].endswith(f"_{site}")
    assert len(p.actions) >= 2 and p.actions[-2].startswith("place_")
    assert all(_legal(bench, states[p.start_observation], p.actions))


def test_a_node_never_seen_to_act_is_probed_with_its_role_s_actions():
    """A split doubt of a node whose every observation ends an episode (blocks-2 robot s179:
    node 7, two episode ends; the suggestions were none, and nothing was recorded): the node
    is entered as the trace entered it, then probed with the actions of its role, the most
    taken first; the plan and the entry execute from the true start."""
    trace = load_trace(SHIPPED)
    bench = get_benchmark(trace.meta["benchmark"])
    labels = _true_labels(trace)
    ends = np.array([last for _, last in trace.episodes()])
    # a fresh node for the last observation of two episodes that end in one state
    states, counts = np.unique(trace.states[ends], return_counts=True)
    state = states[np.argmax(counts)]
    pair = ends[trace.states[ends] == state][:2]
    assert len(pair) == 2
    u = int(labels.max()) + 1
    labels[pair] = u
    doubt = Doubt(SPLIT, (u,), ((int(pair[0]),), (int(pair[1]),)),
                  {"only_a": [], "only_b": []})
    proposals = suggest_episodes(trace.without_states(), labels, [doubt])
    assert proposals and all(p.probe_node == u for p in proposals)
    role = int(trace.roles()[pair[0]])
    kinds = {n: k for n, k in zip(trace.action_names, trace.action_kinds())}
    taken = np.bincount(trace.actions[trace.actions >= 0], minlength=len(trace.action_names))
    probes = [p.actions[-1] for p in proposals]
    assert all(kinds[n] == role for n in probes)
    assert max(taken[list(trace.action_names).index(n)] for n in probes) == max(
        taken[k] for k, n in enumerate(trace.action_names) if kinds[n] == role)
    for p in proposals:      # everything but the probe is what the trace did
        assert all(_legal(bench, trace.states[p.start_observation], p.actions[:-1])), p
        assert "no action sets the sides apart" in p.why


def test_a_place_probe_at_a_read_site_needs_what_the_node_holds():
    """Two colours: a read doubt between two place states (the hand full) whose sites carry
    places of both colours. A place of the colour the hand does not hold is refused for the
    hand's reason and says nothing of the site, so only places of the colour the node's own
    places show are proposed (:func:`hand_classes`); a place of that colour is legal exactly
    where the site is free."""
    bench, trace, states = _walk_trace("multifruit-2x3", 150, 0)
    labels = _true_labels(trace)
    places = sorted(n for n in bench.action_names if n.startswith("place"))
    classes = hand_classes(TaskGraph.from_labels(labels, trace.roles(), *trace.transitions(),
                                                 trace.action_names))
    assert len(set(classes.values())) == 2  # red places, yellow places
    held = {}
    for o in np.flatnonzero(trace.roles() == 1):
        held.setdefault(int(labels[o]), str(states[o]).split("|")[1])
    a = next(u for u, h in held.items() if h == "r")
    b = next(u for u, h in held.items() if h == "y")
    doubt = Doubt(MERGE, (a, b), ((int(np.flatnonzero(labels == a)[0]),),
                                  (int(np.flatnonzero(labels == b)[0]),)),
                  {"read_sites": places, "read_kappa": 0.2})
    proposals = [p for p in suggest_episodes(trace.without_states(), labels, [doubt],
                                             max_episodes=60) if "reading" in p.why]
    assert {p.probe_node for p in proposals} == {a, b}
    for p in proposals:
        colour = "red" if held[p.probe_node] == "r" else "yellow"
        assert p.actions[-1].split("_")[1] == colour
        valid, after = bench.apply(str(states[p.start_observation]), p.actions)
        assert all(valid[:-1])  # the plan runs
        before = after[-2] if len(after) > 1 else str(states[p.start_observation])
        site = int(p.actions[-1].rsplit("_", 1)[1])
        # the hand holds the probe's colour there: legal exactly where the site is free
        assert before.split("|")[1] == held[p.probe_node]
        assert valid[-1] == (before.split("|")[0][site] == "-")


def test_read_probes_are_the_node_s_edges_then_the_other_node_s_then_its_role_s():
    """:func:`_read_probes` on a small graph: node 0 (hand empty) takes pick_a_0 to node 1,
    which takes place_a_1; node 3 takes pick_b_5. At read site pick_b_5: node 0 has no way
    of its own, so node 3's edge is tried from node 0 (``by`` 3); without the other node, the
    role's action, legal or not (``by`` None). At place_a_1: node 0's own way, one step on."""
    from vggc_cp.solvers.suggest import _read_probes

    names = ("pick_a_0", "pick_b_5", "place_a_1")
    graph = TaskGraph.from_labels(np.array([0, 1, 2, 3, 4]), [0, 1, 0, 0, 1],
                                  np.array([0, 1, 3]), np.array([0, 2, 1]),
                                  np.array([1, 2, 4]), names)
    classes = hand_classes(graph)
    doubt = Doubt(MERGE, (0, 3), ((0,), (3,)), {"read_sites": ["pick_b_5"]})
    assert _read_probes(graph, doubt, 0, classes, 3) == [((), 0, "pick_b_5", 3)]
    assert _read_probes(graph, doubt, 0, classes) == [((), 0, "pick_b_5", None)]
    assert _read_probes(graph, doubt, 3, classes, 0) == [((), 3, "pick_b_5", 3)]
    doubt = Doubt(MERGE, (0, 3), ((0,), (3,)), {"read_sites": ["place_a_1", "pick_b_5"]})
    assert _read_probes(graph, doubt, 0, classes, 3) == [(("pick_a_0",), 1, "place_a_1", 0),
                                                        ((), 0, "pick_b_5", 3)]
    assert _read_probes(graph, Doubt(MERGE, (0, 3), ((0,), (3,)), {}), 0, classes, 3) == []


def test_a_read_pair_is_probed_at_one_site_from_each_node_not_stated_there():
    """:func:`_pair_units` on the small graph of the test above: a read pair falls only where
    one site is stated in both nodes. Node 0 stated at pick_b_5 already: one probe, from
    node 3, its own edge there. Neither stated: one probe from each at that site (node 0 by
    node 3's way). A site whose reading an action of node 0 is seen to change
    (``read_acting``) is probed with that action, taken from node 0 itself."""
    from vggc_cp.solvers.suggest import _pair_units

    names = ("pick_a_0", "pick_b_5", "place_a_1")
    graph = TaskGraph.from_labels(np.array([0, 1, 2, 3, 4]), [0, 1, 0, 0, 1],
                                  np.array([0, 1, 3]), np.array([0, 2, 1]),
                                  np.array([1, 2, 4]), names)
    classes = hand_classes(graph)

    def doubt(**ev):
        return Doubt(MERGE, (0, 3), ((0,), (3,)), {"read_sites": ["pick_b_5"], **ev})

    assert _pair_units(graph, doubt(), classes) == []      # no read_told: per node, as before
    assert _pair_units(graph, doubt(read_told=[["pick_b_5"], []]), classes) == [
        ("pick_b_5", [(3, ((), 3, "pick_b_5", 3))])]
    assert _pair_units(graph, doubt(read_told=[[], []]), classes) == [
        ("pick_b_5", [(0, ((), 0, "pick_b_5", 3)), (3, ((), 3, "pick_b_5", 3))])]
    acted = doubt(read_sites=["place_a_1"], read_told=[[], ["place_a_1"]],
                  read_acting={"place_a_1": ["pick_a_0"]})
    assert _pair_units(graph, acted, classes) == [("place_a_1", [(0, ((), 0, "pick_a_0", 0))])]


def test_a_read_pair_is_not_crowded_out_by_cheaper_probes_of_other_doubts():
    """A read pair whose nodes a plan reaches, ranked first, then an episode doubt per
    episode with one-action probes from its start: with room for as many episodes as there
    are episode doubts, the pair still gets its probe at the site its one node is not stated
    at -- the best unit of every doubt comes first, the doubts in their rank, not the
    shortest probes of all -- and that probe is legal where the reading is right."""
    trace = load_trace(SHIPPED)
    bench = get_benchmark(trace.meta["benchmark"])
    labels = _true_labels(trace)
    graph = TaskGraph.from_labels(labels, trace.roles(), *trace.transitions(),
                                  trace.action_names)
    starts = {int(labels[first]) for first, _ in trace.episodes()}
    picks = sorted(n for n in trace.action_names if n.startswith("pick"))
    # a pick state no episode starts in (a plan leads there), and one it might be
    a = next(u for u in sorted(graph.members) if u not in starts and graph.node_role[u] == 0
             and {graph.action_names[k] for k, _ in graph.successors(u)} & set(picks))
    b = next(u for u in sorted(graph.members) if u != a and graph.node_role[u] == 0)
    site = sorted({graph.action_names[k] for k, _ in graph.successors(a)} & set(picks))[0]
    obs = np.flatnonzero(labels == a)
    pair = Doubt(MERGE, (a, b), (tuple(obs[:2]), tuple(np.flatnonzero(labels == b)[:2])),
                 {"read_sites": [site], "read_kappa": 0.2, "read_told": [[], [site]]})
    episodes = []
    for first, last in trace.episodes():
        u = int(labels[first])
        episodes.append(Doubt(SPLIT, (u,), ((first,), (first,)),
                              {"episode": [first, last], "moved_to": u,
                               "read_sites": [n for n in picks if n != site],
                               "read_kappa": 0.3}))
    proposals = suggest_episodes(trace.without_states(), labels, [pair, *episodes],
                                 max_episodes=len(episodes))
    assert len(proposals) == len(episodes)
    assert min(len(p.actions) for p in proposals) == 1 < len(proposals[0].actions)
    (mine,) = [p for p in proposals if p.doubt == 0]
    assert mine.probe_node == a and mine.actions[-1] == site
    assert f"node {b} is stated there already" in mine.why
    assert all(_legal(bench, trace.states[mine.start_observation], mine.actions))


def test_probes_go_round_the_decisions_before_a_second_doubt_of_one():
    """Many doubts of one decision (random-14 robot: 34 episodes each doubting that node 28
    is one state, the three true merges ranked after them): with room for three episodes,
    the first doubt of each decision is probed before a second of any (a merge doubt of two
    other nodes, ranked last)."""
    trace = load_trace(SHIPPED)
    labels, _state, obs, a, b = _split_busiest_pick_state(trace)
    same = [Doubt(SPLIT, (a,), ((int(obs[k]),), (int(obs[-1 - k]),)), {"moved_to": b})
            for k in range(5)]
    graph = TaskGraph.from_labels(labels, trace.roles(), *trace.transitions(),
                                  trace.action_names)
    d, c = [u for u in sorted(graph.members) if u not in (a, b) and graph.node_role[u] == 1][:2]
    pair = Doubt(MERGE, (d, c), (tuple(np.flatnonzero(labels == d)[:2]),
                                 tuple(np.flatnonzero(labels == c)[:2])), {})
    assert decision_key(pair) == (MERGE, min(c, d), max(c, d))
    assert len({decision_key(d) for d in same}) == 1
    proposals = suggest_episodes(trace.without_states(), labels, [*same, pair],
                                 max_episodes=3)
    assert 5 in {p.doubt for p in proposals}, "the merge doubt ranked last gets a probe"


def test_an_episode_the_recording_saw_refused_is_not_proposed_again():
    """A probe refused at its first action from its start observation would be refused
    again (the start is a reset to one state): once the recording states the refusal
    (``meta["appended"]``), the same episode is not proposed."""
    trace = load_trace(SHIPPED).without_states()
    labels, _state, obs, a, b = _split_busiest_pick_state(load_trace(SHIPPED))
    doubt = Doubt(MERGE, (a, b), (tuple(obs[:2]), tuple(obs[-2:])), {})
    first = suggest_episodes(trace, labels, [doubt])
    p = first[0]
    meta = dict(trace.meta or {})
    meta["appended"] = [{"observations": trace.n_obs, "episodes": [
        {"start_observation": p.start_observation, "executed": [],
         "illegal_action": p.actions[0]}]}]
    refused = Trace(trace.observations, trace.actions, trace.action_names, None, meta)
    again = suggest_episodes(refused, labels, [doubt])
    assert (p.start_observation, p.actions) not in {(q.start_observation, q.actions)
                                                    for q in again}
    assert len(again) >= len(first) - sum(q.start_observation == p.start_observation and
                                          q.actions[0] == p.actions[0] for q in first)
