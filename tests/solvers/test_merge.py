"""Congruence-closure merging: recovers states, respects constraints, vetoes bad closures."""

from __future__ import annotations

import numpy as np
from conftest import fruit_episode, make_trace

from vggc_cp.graph import check
from vggc_cp.solvers import Problem, get_solver
from vggc_cp.solvers.merge import congruence_merge

NAMES = ("pick_1", "pick_2", "pick_3", "place_1", "place_2", "place_3")


def problem_with_distances(trace, noise, between, seed=0):
    rng = np.random.default_rng(seed)
    roles = trace.roles()
    mats = []
    for role in (0, 1):
        st = trace.states[roles == role]
        same = st[:, None] == st[None, :]
        d = np.where(same, rng.uniform(0, noise, same.shape), rng.uniform(between, 1, same.shape))
        d = np.triu(d, 1)
        mats.append(d + d.T)
    return Problem.from_trace(trace.without_states(), *mats)


def test_recovers_states_and_is_valid():
    rng = np.random.default_rng(1)
    trace = make_trace([fruit_episode(rng, 6) for _ in range(4)], NAMES)
    problem = problem_with_distances(trace, noise=0.05, between=0.5)
    labels, stats = congruence_merge(problem, threshold=0.1)
    graph = problem.graph(labels)
    report = check(graph)
    assert report.ok and report.deterministic
    # one node per state
    for s in set(trace.states):
        assert len(set(labels[trace.states == s])) == 1
    assert len(set(labels)) == len(set(trace.states))
    assert stats.accepted > 0


def test_threshold_zero_merges_nothing_and_solver_wraps_it():
    rng = np.random.default_rng(2)
    trace = make_trace([fruit_episode(rng, 3)], NAMES)
    problem = problem_with_distances(trace, noise=0.05, between=0.5)
    labels, stats = congruence_merge(problem, threshold=0.0)
    assert len(set(labels)) == trace.n_obs and stats.attempts == 0
    res = get_solver("merge", threshold=0.1).solve(problem, 0, 0)
    assert res.status == "feasible" and res.n_nodes == len(set(trace.states))
    assert res.J == problem.visual_score(res.labels)


def test_forced_merge_beyond_threshold_is_vetoed():
    # two pick observations look alike but lead by the same action to place observations that
    # look very different: determinism would force those together, so the merge is refused
    trace = make_trace([["A", "pick_1", "X"], ["B", "pick_1", "Y"]], NAMES)
    roles = trace.roles()
    assert roles.tolist() == [0, 1, 0, 1]
    dist_pick = np.array([[0, 0.01], [0.01, 0]])
    dist_place = np.array([[0, 0.9], [0.9, 0]])
    problem = Problem.from_trace(trace, dist_pick, dist_place)
    labels, stats = congruence_merge(problem, threshold=0.1)
    assert len(set(labels)) == 4 and stats.vetoed_distance == 1
    # with similar successors the closure merges both pairs
    problem = Problem.from_trace(trace, dist_pick, np.array([[0, 0.05], [0.05, 0]]))
    labels, _ = congruence_merge(problem, threshold=0.1)
    assert len(set(labels)) == 2


def test_exactly_one_veto():
    # A -pick_1-> X and B -pick_2-> Y, everything alike: A and B merge first (different
    # actions force nothing); merging X and Y then would put pick_1 and pick_2 between one
    # ordered pair of nodes, which Exactly-One forbids
    trace = make_trace([["A", "pick_1", "X"], ["B", "pick_2", "Y"]], NAMES)
    near = np.array([[0, 0.01], [0.01, 0]])
    problem = Problem.from_trace(trace, near, near)
    labels, stats = congruence_merge(problem, threshold=0.1)
    assert check(problem.graph(labels)).ok
    assert len(set(labels)) == 3 and stats.vetoed_exactly_one == 1


def test_cascade_rule_takes_the_end_of_the_largest_collapse():
    from vggc_cp.solvers.base import SolveResult
    from vggc_cp.solvers.merge import select_cascade, select_path_fewest

    def path(counts):
        return [SolveResult(np.arange(c), 0, 0, float(i), "feasible", "merge")
                for i, c in enumerate(counts)]

    # slow noise merges, a collapse 19 -> 6, then stable
    assert select_cascade(path([50, 48, 46, 41, 19, 6, 6, 6, 5])) == 5
    # collapse then a slow drift that never stabilises within 5 %: the last index
    assert select_cascade(path([40, 10, 8, 6])) == 3
    assert select_cascade(path([7])) == 0 and select_cascade([]) is None
    # the collapse pauses for one threshold (22 -> 21) before the long true plateau at 12
    # (a multifruit-2x3 trace, seed 1, keypoint attention): the longest plateau wins
    assert select_cascade(path([89, 78, 57, 39, 22, 21, 12, 12, 12, 12, 12, 12])) == 6
    # equally long plateaus: the first
    assert select_cascade(path([60, 20, 20, 10, 10, 4])) == 1
    assert select_path_fewest(path([9, 7, 7, 8])) == 1


def test_threshold_path_recovers_states_from_the_noise_scale():
    from vggc_cp.solvers.merge import default_thresholds, noise_scale, threshold_path

    rng = np.random.default_rng(3)
    trace = make_trace([fruit_episode(rng, 8) for _ in range(5)], NAMES)
    problem = problem_with_distances(trace, noise=0.05, between=0.5)
    assert 0 < noise_scale(problem) < 0.05
    ts = default_thresholds(problem)
    assert np.all(np.diff(ts) > 0) and len(ts) == 17
    path = threshold_path(problem)
    assert path.best.n_nodes == len(set(trace.states))
    assert check(problem.graph(path.best.labels)).ok
    rows = path.records()
    assert len(rows) == 17 and sum(r["selected"] for r in rows) == 1


def test_solve_cli_merge(tmp_path, capsys):
    from vggc_cp.cli import main
    from vggc_cp.solution import read_solution, verify_solution
    from vggc_cp.trace import save_trace

    rng = np.random.default_rng(4)
    trace = make_trace([fruit_episode(rng, 6) for _ in range(3)], NAMES, size=16, noise=4)
    path = tmp_path / "t.npz"
    save_trace(trace, path)
    out = tmp_path / "s.json"
    code = main(["solve", str(path), "-o", str(out), "--solver", "merge", "--grid", "4",
                 "--quiet", "--cache-dir", str(tmp_path / "cache")])
    assert code == 0, capsys.readouterr().err
    sol = read_solution(out)
    verify_solution(sol, trace)
    assert sol.solver == "merge" and sol.extra["select"] == "mdl"
    assert len(sol.extra["grid"]) == 24 and all("description_length" in r
                                                for r in sol.extra["grid"])
    assert main(["solve", str(path), "-o", str(out), "--solver", "merge", "--thresholds",
                 "0,-1", "--grid", "4"]) == 2
    assert main(["solve", str(path), "-o", str(out), "--solver", "merge", "--select",
                 "nope", "--grid", "4"]) == 2


def _reference_merge(problem, threshold, max_work=2_000):
    """The plain closure (every forced merge rescans all transitions of the merged group,
    Exactly-One checked once at the end, no memory of vetoes beyond the current clusters):
    the definition the fast implementation must reproduce partition for partition."""
    n = problem.n_obs
    parent = list(range(n))
    members = {i: [i] for i in range(n)}
    out = [[] for _ in range(n)]
    inn = [[] for _ in range(n)]
    for s, a, d in zip(problem.src.tolist(), problem.act.tolist(), problem.dst.tolist()):
        out[s].append((a, d))
        inn[d].append((a, s))
    dist = {}
    for obs, mat in ((problem.pick_obs, problem.dist_pick), (problem.place_obs, problem.dist_place)):
        for x, ox in enumerate(obs.tolist()):
            for y, oy in enumerate(obs.tolist()):
                dist[ox, oy] = mat[x, y]

    def find(x):
        while parent[x] != x:
            x = parent[x]
        return x

    def attempt(i, j):
        over, groups, touched, queue, work = {}, {}, set(), [(i, j)], 0

        def head(x):
            r = find(x)
            return over.get(r, r)

        while queue:
            a, b = queue.pop()
            ha, hb = head(a), head(b)
            if ha == hb:
                continue
            work += 1
            if work > max_work:
                return None
            ra, rb = groups.get(ha, [ha]), groups.get(hb, [hb])
            ma = [o for r in ra for o in members[r]]
            mb = [o for r in rb for o in members[r]]
            if sum(dist[x, y] for x in ma for y in mb) / (len(ma) * len(mb)) > threshold:
                return None
            groups[ha] = ra + rb
            groups.pop(hb, None)
            for r in rb:
                over[r] = ha
            over.pop(ha, None)
            touched.discard(hb)
            touched.add(ha)
            for edges in (out, inn):
                seen = {}
                for o in ma + mb:
                    for act, o2 in edges[o]:
                        first = seen.setdefault(act, head(o2))
                        if first != head(o2):
                            queue.append((first, head(o2)))
        for h in touched:
            if head(h) != h:
                continue
            for edges in (out, inn):
                labels_to = {}
                for o in (o for r in groups.get(h, [h]) for o in members[r]):
                    for act, o2 in edges[o]:
                        if labels_to.setdefault(head(o2), act) != act:
                            return None
        return {h: [r for r in rs if r != h] for h, rs in groups.items() if head(h) == h}

    pairs = []
    for obs, mat in ((problem.pick_obs, problem.dist_pick), (problem.place_obs, problem.dist_place)):
        for x in range(len(obs)):
            for y in range(x + 1, len(obs)):
                if mat[x, y] <= threshold:
                    pairs.append((mat[x, y], int(obs[x]), int(obs[y])))
    attempts = accepted = 0
    vetoed, epoch = {}, 0
    for _, i, j in sorted(pairs):
        ri, rj = find(i), find(j)
        if ri == rj or vetoed.get((min(ri, rj), max(ri, rj))) == epoch:
            continue
        attempts += 1
        groups = attempt(i, j)
        if groups is None:
            vetoed[min(ri, rj), max(ri, rj)] = epoch
            continue
        for h, absorbed in groups.items():
            for r in absorbed:
                parent[r] = h
                members[h].extend(members.pop(r))
        epoch += 1
        accepted += 1
    roots = np.array([find(x) for x in range(n)])
    return problem.labels_from_colours(roots[problem.pick_obs], roots[problem.place_obs]), \
        attempts, accepted


def test_fast_closure_matches_the_plain_definition():
    # overlapping noise and between-state distances: wrong merges are tried, and refused for
    # distance and for Exactly-One, some again and again (replayed vetoes)
    rng = np.random.default_rng(7)
    replayed = exactly_one = distance = 0
    for seed in range(6):
        trace = make_trace([fruit_episode(rng, 6) for _ in range(4)], NAMES)
        problem = problem_with_distances(trace, noise=0.3, between=0.15, seed=seed)
        for threshold in (0.1, 0.2, 0.3, 0.5):
            labels, stats = congruence_merge(problem, threshold)
            ref, attempts, accepted = _reference_merge(problem, threshold)
            assert np.array_equal(labels, ref), (seed, threshold)
            assert (stats.attempts, stats.accepted) == (attempts, accepted)
            assert check(problem.graph(labels)).ok
            replayed += stats.vetoes_replayed
            exactly_one += stats.vetoed_exactly_one
            distance += stats.vetoed_distance
    assert replayed > 0 and exactly_one > 0 and distance > 0


def test_exactly_one_refuses_the_closure_before_it_goes_on():
    # X and Y (place) merge first. Merging A and B then sends pick_1 and pick_2 from one node
    # to one node (Exactly-One broken at once) and co-determinism would still force P with Q,
    # which are far apart: the closure stops at the Exactly-One break
    trace = make_trace([["P", "place_1", "A", "pick_1", "X"],
                        ["Q", "place_1", "B", "pick_2", "Y"]], NAMES)
    roles = trace.roles()
    assert roles.tolist() == [1, 0, 1, 1, 0, 1]  # P A X Q B Y
    dist_pick = np.array([[0, 0.02], [0.02, 0]])
    dist_place = np.full((4, 4), 0.9) - np.diag(np.full(4, 0.9))  # P X Q Y
    dist_place[1, 3] = dist_place[3, 1] = 0.01
    problem = Problem.from_trace(trace, dist_pick, dist_place)
    labels, stats = congruence_merge(problem, threshold=0.1)
    assert stats.accepted == 1 and stats.vetoed_exactly_one == 1 and stats.vetoed_distance == 0
    assert len(set(labels)) == 5 and labels[2] == labels[5]
    assert np.array_equal(labels, _reference_merge(problem, 0.1)[0])


def test_threshold_path_equals_separate_runs():
    from vggc_cp.solvers.merge import default_thresholds, threshold_path

    rng = np.random.default_rng(8)
    trace = make_trace([fruit_episode(rng, 6) for _ in range(4)], NAMES)
    problem = problem_with_distances(trace, noise=0.3, between=0.15, seed=3)
    # thresholds on the grid and exactly at candidate distances (a pair at the threshold is in)
    d = np.unique(problem.dist_pick[np.triu_indices(problem.n_pick, 1)])
    ts = np.concatenate([default_thresholds(problem, steps=6), d[[3, 10, 30, 60, 100]]])
    path = threshold_path(problem, ts[::-1])  # any order: sorted ascending
    assert path.thresholds == tuple(sorted(float(t) for t in ts))
    for t, res in zip(path.thresholds, path.results):
        single = get_solver("merge", threshold=t).solve(problem, 0, 0)
        assert np.array_equal(res.labels, single.labels)
        assert res.stats == single.stats and res.J == single.J and res.seconds > 0


def test_a_hand_holds_one_colour():
    # A -pick_red-> H1 -place_red-> X and B -pick_green-> H2 -place_green-> Y: the two holding
    # states look exactly alike (the held object out of view), the scenes around them do not
    names = ("pick_red", "pick_green", "place_red", "place_green")
    trace = make_trace([["A", "pick_red", "H1", "place_red", "X"],
                        ["B", "pick_green", "H2", "place_green", "Y"]], names)
    apart = np.full((4, 4), 0.9) - 0.9 * np.eye(4)
    alike = np.zeros((2, 2))
    blind = Problem.from_trace(trace.without_states(), apart, alike)
    labels, stats = congruence_merge(blind, threshold=0.1)
    assert labels[1] == labels[4] and stats.vetoed_hand == 0   # no colours: one holding node
    coloured = Problem.from_trace(trace.without_states(), apart, alike,
                                  action_colour=np.array([0, 1, 0, 1]))
    labels, stats = congruence_merge(coloured, threshold=0.1)
    assert labels[1] != labels[4] and stats.vetoed_hand == 1
    assert check(coloured.graph(labels)).ok and len(set(labels)) == 6
    # one colour for both classes (colours that cannot be told apart): no constraint
    one = Problem.from_trace(trace.without_states(), apart, alike,
                             action_colour=np.array([0, 0, 0, 0]))
    labels, stats = congruence_merge(one, threshold=0.1)
    assert labels[1] == labels[4] and stats.vetoed_hand == 0


def test_an_observation_where_an_action_was_refused_is_never_joined_with_one_that_took_it():
    # A -pick_1-> H1 -place_2-> X and B -pick_2-> H2 -place_1-> Y; the pick states A and B
    # look alike, and so do the holding states: the images alone make one node of each pair
    trace = make_trace([["A", "pick_1", "H1", "place_2", "X"],
                        ["B", "pick_2", "H2", "place_1", "Y"]], NAMES)
    pick = np.full((4, 4), 0.9) - 0.9 * np.eye(4)      # pick-role: A, X, B, Y
    pick[0, 2] = pick[2, 0] = 0.0                         # A and B alike
    place = np.zeros((2, 2))
    blind = Problem.from_trace(trace.without_states(), pick, place)
    labels, stats = congruence_merge(blind, threshold=0.1)
    assert labels[0] == labels[3] and stats.vetoed_refused == 0
    # pick_1 was refused in the state of B (observation 3): A and B are two states
    told = Problem(blind.roles, blind.src, blind.act, blind.dst, blind.action_names,
                   pick, place, refused=((3, 0),))
    labels, stats = congruence_merge(told, threshold=0.1)
    assert labels[0] != labels[3] and stats.vetoed_refused >= 1
    assert check(told.graph(labels)).ok
    # a refusal of an action neither takes (pick_3) changes nothing
    other = Problem(blind.roles, blind.src, blind.act, blind.dst, blind.action_names,
                    pick, place, refused=((3, 2),))
    assert congruence_merge(other, threshold=0.1)[0][0] == congruence_merge(other, 0.1)[0][3]
