"""Resets and refusals a recording states (``meta["appended"]``) and the undo pairs it declares
(``meta["undo"]``): read from a real appended trace they are true of its ground truth (the undo
pairs of every task's dynamics); a record that does not fit the trace is refused at load,
naming the field; solvers see them, so the hashes do too."""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest

from vggc_cp.errors import TraceError
from vggc_cp.recorded import NO_FACTS, recorded_facts
from vggc_cp.sim.append import EpisodeRequest, append_episodes
from vggc_cp.sim.explore import generate
from vggc_cp.sim.tasks import get_benchmark
from vggc_cp.trace import load_trace, save_trace


@pytest.fixture(scope="module")
def appended():
    trace = generate("fruit-2x3", 10, seed=3, size=16).trace
    bench = get_benchmark(trace.meta["benchmark"])
    starts = [first for first, _ in trace.episodes()]
    requests = []
    for k, start in enumerate([starts[0], starts[-1], starts[0]]):
        state, acts = str(trace.states[start]), []
        for _ in range(k + 1):
            name = bench.valid_actions(state)[0]
            acts.append(name)
            state = bench.step(state, name)
        bad = next(a for a in bench.action_names if bench.step(state, a) is None)
        requests.append(EpisodeRequest(start, (*acts, bad)))
    never = next(a for a in bench.action_names
                 if bench.step(str(trace.states[starts[0]]), a) is None)
    requests.append(EpisodeRequest(starts[0], (never,)))
    return trace, append_episodes(trace, requests).trace, bench


def test_resets_and_refusals_of_a_recording_are_true(appended):
    trace, new, bench = appended
    before = recorded_facts(trace)
    assert not before.resets and not before.refusals and before.undo
    facts = recorded_facts(new)
    assert facts.undo == before.undo              # appending keeps the declaration
    assert len(facts.resets) == 3 and len(facts.refusals) == 4
    for a, b in facts.resets:      # the episode's first observation shows the start's state
        assert b >= trace.n_obs and a < trace.n_obs and new.actions[b - 1] == -1
        assert new.states[a] == new.states[b]
    for o, k in facts.refusals:    # the refused action is illegal in the state it met
        assert bench.step(str(new.states[o]), new.action_names[k]) is None
    # the refusal with nothing recorded is met in the start observation's state
    assert facts.refusals[-1][0] == trace.episodes()[0][0]


def test_solvers_see_the_facts_so_the_hashes_do(appended):
    _, new, _ = appended
    bare = replace(new, meta={k: v for k, v in new.meta.items() if k != "appended"})
    assert bare.content_hash() != new.content_hash()
    assert bare.identity_hash() != new.identity_hash()
    # the rest of meta is never read
    other = replace(new, meta={**new.meta, "seed": 99})
    assert other.content_hash() == new.content_hash()


@pytest.mark.parametrize("change, field", [
    (lambda r: r[0]["episodes"][0].update(executed=["pick_nothing"]), "episodes[0].executed"),
    (lambda r: r[0]["episodes"][1]["executed"].reverse(), "episodes[1].executed"),
    (lambda r: r[0]["episodes"][0].update(start_observation=10**6),
     "episodes[0].start_observation"),
    (lambda r: r[0].update(observations="3"), "[0].observations"),
    (lambda r: r[0]["episodes"].pop(0), "episodes[0].executed"),
    (lambda r: r[0]["episodes"].pop(2), "appended[0]"),
])
def test_a_record_that_does_not_fit_the_trace_is_refused_at_load(appended, tmp_path, change,
                                                                  field):
    _, new, _ = appended
    meta = copy.deepcopy(new.meta)
    change(meta["appended"])
    path = tmp_path / "bad.npz"
    save_trace(replace(new, meta=meta), path)
    with pytest.raises(TraceError) as err:
        load_trace(path)
    msg = str(err.value)
    assert msg.startswith(f"{path}: field 'meta.appended") and field + "'" in msg


@pytest.mark.parametrize("name", ["fruit-2x3", "multifruit-2x3", "blocks-2", "blocks-3",
                                  "random-3", "random-7", "random-12"])
def test_the_undo_pairs_a_task_declares_are_true_of_its_dynamics(name):
    bench = get_benchmark(name)
    pairs = bench.undo_pairs
    kinds = {n: n.split("_")[0] for n in bench.action_names}
    assert pairs and all(kinds[p] == "pick" and kinds[q] == "place" for p, q in pairs)
    assert len({a for pair in pairs for a in pair}) == 2 * len(pairs) == len(bench.action_names)
    states = bench.all_states()
    assert len(states) <= 20000, "a small task: every state is checked"
    for s in states:
        for p, q in pairs:
            for first, then in ((p, q), (q, p)):
                mid = bench.step(s, first)
                if mid is not None:          # legal: the other one is legal and comes back
                    assert bench.step(mid, then) == s, (name, s, first, then)


@pytest.mark.parametrize("name", ["fruit-4x6", "multifruit-2x3", "blocks-3", "random-3",
                                  "random-7", "random-12"])
def test_the_sites_a_task_declares_offer_one_pick_and_one_place_per_state(name):
    bench = get_benchmark(name)
    sites = bench.sites
    assert sorted(a for g in sites for a in g) == sorted(bench.action_names)
    states = bench.all_states()
    assert len(states) <= 20000, "a small task: every state is checked"
    for s in states:
        legal = set(bench.valid_actions(s))
        for group in sites:
            for verb in ("pick", "place"):
                assert len([a for a in group if a in legal and a.startswith(verb)]) <= 1, \
                    (name, s, group)


def test_a_generated_trace_declares_its_undo_pairs_and_they_hold_on_it(appended):
    trace, _, bench = appended
    pairs = recorded_facts(trace).undo
    assert [(trace.action_names[p], trace.action_names[q]) for p, q in pairs] == \
        list(bench.undo_pairs)
    twin = {**dict(pairs), **{q: p for p, q in pairs}}
    acts, back = trace.actions, 0
    for t in range(len(acts) - 1):
        if acts[t] >= 0 and acts[t + 1] == twin.get(int(acts[t])):
            assert trace.states[t + 2] == trace.states[t]
            back += 1
    assert back, "the walk undoes an action somewhere"


@pytest.mark.parametrize("drop", [("undo",), ("sites",), ("undo", "sites")])
def test_solvers_see_the_undo_pairs_and_sites_so_the_hashes_do(appended, drop):
    trace, _, bench = appended
    facts = recorded_facts(trace)
    assert [tuple(trace.action_names[a] for a in g) for g in facts.sites] == list(bench.sites)
    bare = replace(trace, meta={k: v for k, v in trace.meta.items() if k not in drop})
    assert bool(recorded_facts(bare)) == (len(drop) == 1)
    assert bare.content_hash() != trace.content_hash()
    assert bare.identity_hash() != trace.identity_hash()


@pytest.mark.parametrize("key, value, field, says", [
    ("undo", "pick_red_0", "meta.undo", "is not a list"),
    ("undo", [["place_red_0", "pick_red_0"]], "meta.undo[0]", "expected [pick, place]"),
    ("undo", [["pick_red_0", "place_red_9"]], "meta.undo[0]", "two action names of the trace"),
    ("undo", [["pick_red_0", "place_red_0"], ["pick_red_0", "place_red_1"]], "meta.undo[1]",
     "names 'pick_red_0' again"),
    ("sites", {"a": 1}, "meta.sites", "is not a list"),
    ("sites", [[]], "meta.sites[0]", "expected a list of action names"),
    ("sites", [["pick_red_0", "pick_nothing"]], "meta.sites[0]",
     "expected a list of action names"),
    ("sites", [["pick_red_0"], ["place_red_0", "pick_red_0"]], "meta.sites[1]",
     "names 'pick_red_0' again"),
    ("sites", [["pick_red_0", "pick_red_0"]], "meta.sites[0]", "names 'pick_red_0' again"),
])
def test_a_declaration_that_does_not_fit_is_refused_at_load(appended, tmp_path, key, value,
                                                            field, says):
    trace, _, _ = appended
    path = tmp_path / "bad.npz"
    save_trace(replace(trace, meta={**trace.meta, key: value}), path)
    with pytest.raises(TraceError) as err:
        load_trace(path)
    assert str(err.value).startswith(f"{path}: field '{field}'") and says in str(err.value)


def test_a_trace_without_the_record_states_nothing():
    obs = np.zeros((3, 2, 2, 3), np.uint8)
    from vggc_cp.trace import Trace

    t = Trace(obs, np.array([0, 1]), ("pick_a", "place_b"), None, {"appended": []})
    assert not recorded_facts(t)
    assert NO_FACTS.key() == b""


def test_problems_carry_the_refusals_to_the_merge(appended):
    from vggc_cp.solvers.base import Problem
    from vggc_cp.solvers.coded import CodedProblem
    from vggc_cp.solvers.heldout import subproblem

    _, new, _ = appended
    facts = recorded_facts(new)
    n_pick, n_place = int((new.roles() == 0).sum()), int((new.roles() == 1).sum())
    dense = Problem.from_trace(new, np.zeros((n_pick, n_pick)), np.zeros((n_place, n_place)))
    assert dense.refused == facts.refusals
    codes = (np.zeros(n_pick, np.int64), np.zeros(n_place, np.int64))
    coded = CodedProblem.from_trace(new, codes, (np.zeros((1, 1)), np.zeros((1, 1))))
    assert coded.refused == facts.refusals and coded.dense().refused == facts.refusals
    # a restriction keeps the refusals of the observations it keeps, renumbered
    keep = np.ones(new.n_obs, bool)
    keep[: facts.refusals[0][0]] = False
    sub, idx = subproblem(dense, keep)
    sub_c, _ = coded.restricted(keep)
    want = tuple((int(np.searchsorted(idx, o)), k) for o, k in facts.refusals if keep[o])
    assert sub.refused == want == sub_c.refused and want


def test_solve_says_what_it_read_and_refuses_a_record_that_does_not_fit(appended, tmp_path,
                                                                         capsys):
    from vggc_cp.cli import main

    _, new, _ = appended
    path = tmp_path / "t2.npz"
    save_trace(new, path)
    assert main(["solve", str(path), "-o", str(tmp_path / "s.json"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "recorded       3 reset(s), 4 refused action(s)" in out
    assert "recorded       3 undo pair(s) (meta.undo)" in out
    assert "recorded       3 site(s) (meta.sites)" in out
    meta = copy.deepcopy(new.meta)
    meta["appended"][0]["episodes"][0]["start_observation"] = -1
    bad = tmp_path / "bad.npz"
    save_trace(replace(new, meta=meta), bad)
    assert main(["solve", str(bad), "-o", str(tmp_path / "b.json"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "meta.appended[0].episodes[0].start_observation" in err
    assert "Traceback" not in err and not (tmp_path / "b.json").exists()
