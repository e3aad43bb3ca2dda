"""The task family beyond the seven: drawing, spec strings, dynamics, generation."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from vggc_cp.errors import VggcError
from vggc_cp.sim import draw_task, get_benchmark, get_spec, is_task_name
from vggc_cp.sim.tasks import (
    CLASS_COLOURS,
    MAX_STATES_HOME,
    MIN_STATES,
    count_states,
    format_spec,
    make_spec,
    parse_spec,
    spec_dict,
)


def brute_force_states(spec) -> int:
    """Every arrangement of the objects' class letters on the regions (stacks up to the
    height, order within a stack matters), with nothing or one object held, by listing
    assignments of objects to (region, level) slots -- independent of the search and of the
    counting formula."""
    letters = [spec.object_class(i)[0] for i in range(spec.m)]
    seen = set()
    for held in [None, *range(spec.m)]:
        rest = [i for i in range(spec.m) if i != held]
        for regions in itertools.product(range(spec.R), repeat=len(rest)):
            for order in itertools.permutations(rest):
                stacks = [[] for _ in range(spec.R)]
                for i, r in zip(order, [regions[rest.index(i)] for i in order]):
                    stacks[r].append(letters[i])
                if any(len(s) > spec.max_height for s in stacks):
                    continue
                seen.add((tuple("".join(s) for s in stacks),
                          "-" if held is None else letters[held]))
    return len(seen)


SMALL = [
    "task:regions=3,objects=red/apple+red/lemon",
    "task:regions=3,objects=red/apple+yellow/lemon",
    "task:regions=4,objects=red/apple+yellow/pear+blue/cube",
    "task:regions=3,height=2,objects=red/cube+red/cylinder",
    "task:regions=3,height=2,objects=red/cube+green/brick+blue/cylinder",
    "task:regions=3,height=3,objects=yellow/cube+blue/cube",
]


def test_search_finds_fewer_states_where_a_free_place_is_missing():
    # two stackable objects on two regions: the yellow one can never come to lie under the
    # blue one's region alone, so the search reaches 5 of the 10 arrangements; draw_task
    # rejects such a task (search and count must agree)
    text = "task:regions=2,height=3,objects=yellow/cube+blue/cube"
    assert len(get_benchmark(text).all_states()) == 5
    assert get_spec(text).paper_states == brute_force_states(get_spec(text)) == 10


@pytest.mark.parametrize("text", SMALL)
def test_state_counts_match_enumeration_on_small_specs(text):
    spec = get_spec(text)
    bench = get_benchmark(text)
    n = len(bench.all_states())
    assert n == spec.paper_states == brute_force_states(spec)
    # pick and place states both present, and every key decodes back to itself
    assert any(bench.is_pick_state(s) for s in bench.all_states())
    assert any(not bench.is_pick_state(s) for s in bench.all_states())
    for key in bench.all_states():
        assert bench.encode(bench.decode(key)) == key


def test_count_states_on_the_papers_benchmarks():
    for name, classes in (("fruit-4x6", ("red",)), ("fruit-6x8", ("red",)),
                          ("multifruit-4x6", ("red", "yellow"))):
        spec = get_spec(name)
        objs = tuple(spec.object_class(i) for i in range(spec.m))
        assert count_states(classes, objs, spec.R, 1) == len(get_benchmark(name).all_states())


def test_a_drawn_task_is_the_same_for_the_same_seed_and_varies_across_seeds():
    assert draw_task(7) == draw_task(7) == get_spec("random-7")
    specs = [get_spec(f"random-{s}") for s in range(24)]
    assert len({format_spec(s) for s in specs}) == 24
    # the family's ranges are all drawn
    assert {s.n for s in specs} >= {1, 2, 3}
    assert {s.layout.split(":")[0] for s in specs} == {"row", "grid", "scattered"}
    assert any(s.max_height > 1 for s in specs) and any(s.max_height == 1 for s in specs)
    assert any(s.start_states > 0 for s in specs) and any(s.start_states == 0 for s in specs)
    assert any(len(set(s.objects)) > s.n for s in specs)  # several shapes in a class
    for s in specs:
        assert 1 <= s.n <= 4 and 2 <= s.m <= 8 and 3 <= s.R <= 12
        assert MIN_STATES <= s.paper_states <= MAX_STATES_HOME
        assert set(s.classes) <= set(CLASS_COLOURS)


@pytest.mark.slow
def test_four_classes_are_drawn_somewhere():
    assert any(get_spec(f"random-{s}").n == 4 for s in range(120))


def test_spec_strings_round_trip_and_name_the_task():
    spec = draw_task(3)
    text = format_spec(spec)
    again = parse_spec(text)
    assert again.name == text and is_task_name(text) and is_task_name("random-3")
    assert (again.R, again.objects, again.object_classes, again.max_height, again.centres,
            again.start_states, again.default_transitions) == (
        spec.R, spec.objects, spec.object_classes, spec.max_height, spec.centres,
        spec.start_states, spec.default_transitions)
    d = spec_dict(spec)
    assert json.loads(json.dumps(d))["spec"] == text


def test_scattered_markers_never_overlap():
    for seed in range(24):
        spec = get_spec(f"random-{seed}")
        if spec.centres is None:
            continue
        c = np.array(spec.centres)
        for i, j in itertools.combinations(range(len(c)), 2):
            assert np.abs(c[i] - c[j]).max() >= 0.16 - 1e-9


@pytest.mark.parametrize("text, word", [
    ("task:regions=3,objects=pink/apple", "pink"),
    ("task:regions=3,objects=red/teapot", "teapot"),
    ("task:regions=3,height=2,objects=red/apple+red/cube", "cannot be stacked"),
    ("task:regions=2,objects=red/apple+red/cube", "no free place"),
    ("task:regions=3,layout=grid:2x2,objects=red/apple", "does not hold"),
    ("task:regions=3,layout=spiral,objects=red/apple", "unknown layout"),
    ("task:objects=red/apple", "regions is missing"),
    ("task:regions=3,colour=red,objects=red/apple", "unknown key"),
    ("task:regions=x,objects=red/apple", "regions"),
    ("task:regions=3,objects=red-apple", "objects[0]"),
    ("random-x", "unknown benchmark"),
])
def test_bad_spec_strings_name_what_is_wrong(text, word):
    with pytest.raises(VggcError) as err:
        get_spec(text)
    assert word in str(err.value)


def test_make_spec_counts_actions_and_classes():
    spec = make_spec("t", (("red", "cube"), ("blue", "cube"), ("red", "brick")), 4,
                     "grid:2x2", 2, 0, (4, 12))
    assert spec.classes == ("red", "blue") and spec.n == 2
    bench = get_benchmark(format_spec(spec))
    assert len(bench.action_names) == spec.n_actions == 2 * 4 * 2 * 2
    assert "pick_red_3_1" in bench.action_names and "place_blue_0_0" in bench.action_names


def test_a_generated_random_task_is_deterministic_legal_and_self_describing():
    from vggc_cp.sim.explore import generate

    name = "random-14"
    a = generate(name, 30, seed=2, novel=2)
    b = generate(name, 30, seed=2, novel=2)
    assert np.array_equal(a.trace.observations, b.trace.observations)
    assert np.array_equal(a.novel_observations, b.novel_observations)
    tr = a.trace
    assert tr.meta["benchmark"] == name and tr.meta["family"] == "task"
    assert tr.meta["task"]["spec"] == format_spec(draw_task(14))
    bench = get_benchmark(tr.meta["benchmark"])
    for t, act in enumerate(tr.actions):
        if act >= 0:
            assert bench.step(str(tr.states[t]), tr.action_names[act]) == str(tr.states[t + 1])
    # a place changes the pixels of its region: frames of one episode differ
    assert any(not np.array_equal(tr.observations[t], tr.observations[t + 1])
               for t in range(len(tr.actions)) if tr.actions[t] >= 0)


def test_evaluation_rebuilds_a_random_tasks_dynamics_from_the_trace(tmp_path):
    from vggc_cp.evaluate import GroundTruth, resolve_dynamics
    from vggc_cp.sim.explore import generate

    tr = generate("task:regions=3,height=2,objects=red/cube+blue/cylinder", 40, seed=0).trace
    step, used = resolve_dynamics(tr, GroundTruth.from_trace(tr), "auto")
    assert used == "sim" and step is not None


@pytest.mark.slow
def test_generate_cli_takes_a_task(tmp_path, capsys):
    from vggc_cp.cli import main

    out = tmp_path / "t.npz"
    assert main(["generate", "--task", "random", "--task-seed", "5", "--seed", "1",
                 "--transitions", "20", "-o", str(out), "--quiet"]) == 0
    from vggc_cp.trace import load_trace

    assert load_trace(out).meta["benchmark"] == "random-5"
    spec_file = tmp_path / "spec.json"
    spec_file.write_text(json.dumps({"spec": "task:regions=3,objects=green/pear+red/apple"}))
    assert main(["generate", "--task", str(spec_file), "--transitions", "10", "-o",
                 str(tmp_path / "u.npz"), "--quiet"]) == 0
    for bad in (["generate", "-o", str(tmp_path / "x.npz")],
                ["generate", "fruit-2x3", "--task", "random-1", "-o", str(tmp_path / "x.npz")],
                ["generate", "--task", "random-2", "--task-seed", "3", "-o",
                 str(tmp_path / "x.npz")]):
        assert main(bad) == 2
    assert not (tmp_path / "x.npz").exists()
    capsys.readouterr()
    assert main(["envs", "--tasks", "0:2"]) == 0
    text = capsys.readouterr().out
    assert "random-2:" in text and "task:regions=" in text and "families:" in text
