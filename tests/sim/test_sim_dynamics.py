"""Discrete dynamics: state keys, valid actions, transitions, full state counts."""

from __future__ import annotations

from math import comb, factorial

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vggc_cp.errors import VggcError
from vggc_cp.sim import benchmark_names, get_benchmark
from vggc_cp.sim.arrange import arrangement_after, arrangement_state, fresh_arrangement


def bounded_compositions(total: int, parts: int, cap: int) -> int:
    """Ways to write ``total`` as ``parts`` ordered heights in ``[0, cap]`` (inclusion-exclusion)."""
    return sum((-1) ** j * comb(parts, j) * comb(total - j * (cap + 1) + parts - 1, parts - 1)
               for j in range(parts + 1) if total - j * (cap + 1) >= 0)


def multinomial(*ks: int) -> int:
    out = factorial(sum(ks))
    for k in ks:
        out //= factorial(k)
    return out


def analytic_count(name: str) -> int:
    """Full state count worked out by hand: pick states (nothing held) + place states."""
    b = get_benchmark(name)
    s = b.spec
    if s.family == "blocks":
        return (bounded_compositions(s.m, s.R, s.max_height)
                + bounded_compositions(s.m - 1, s.R, s.max_height))
    per_class = [sum(1 for i in range(s.m) if s.object_class(i) == c) for c in s.classes]
    pick = multinomial(*per_class, s.R - s.m)
    place = 0
    for c in range(len(per_class)):
        held = list(per_class)
        held[c] -= 1
        place += multinomial(*held, s.R - s.m + 1)
    return pick + place


HAND = {"fruit-2x3": 3 + 3, "multifruit-2x3": 6 + 6, "fruit-4x6": comb(6, 4) + comb(6, 3),
        "multifruit-4x6": 90 + 120, "fruit-6x8": comb(8, 6) + comb(8, 5),
        "blocks-2": 6 + 3, "blocks-3": 10 + 6}


@pytest.mark.parametrize("name", benchmark_names())
def test_full_state_count_is_the_analytic_one(name):
    states = get_benchmark(name).all_states()
    assert len(states) == len(set(states)) == analytic_count(name) == HAND[name]


@pytest.mark.parametrize("name", benchmark_names())
def test_state_space_is_closed_and_alternates(name):
    b = get_benchmark(name)
    space = set(b.all_states())
    for s in space:
        valid = b.valid_actions(s)
        assert valid, f"dead end at {s}"
        kind = "pick" if b.is_pick_state(s) else "place"
        assert all(a.startswith(kind + "_") for a in valid)
        for a in valid:
            nxt = b.step(s, a)
            assert nxt in space
            assert b.is_pick_state(nxt) != b.is_pick_state(s)
        for a in set(b.action_names) - set(valid):
            assert b.step(s, a) is None


def test_fruit_steps():
    b = get_benchmark("fruit-2x3")
    assert b.step("r-r|-", "pick_red_0") == "--r|r"
    assert b.step("r-r|-", "pick_red_1") is None  # empty region
    assert b.step("--r|r", "place_red_2") is None  # occupied region
    assert b.step("--r|r", "pick_red_2") is None  # already holding
    assert b.step("r-r|-", "place_red_1") is None  # nothing held
    assert b.step("--r|r", "place_red_1") == "-rr|-"


def test_multifruit_classes_are_distinct():
    b = get_benchmark("multifruit-2x3")
    assert b.step("ry-|-", "pick_yellow_0") is None
    assert b.step("ry-|-", "pick_red_0") == "-y-|r"
    assert b.step("-y-|r", "place_yellow_0") is None
    assert b.step("-y-|r", "place_red_2") == "-yr|-"


def test_blocks_steps():
    b = get_benchmark("blocks-3")
    assert b.step("210|-", "pick_0_1") == "110|b"
    assert b.step("210|-", "pick_0_0") is None  # not the top block
    assert b.step("210|-", "pick_2_0") is None  # empty base
    assert b.step("110|b", "place_0_1") == "210|-"
    assert b.step("110|b", "place_0_2") is None  # would float
    assert b.step("200|b", "place_0_2") == "300|-"
    b2 = get_benchmark("blocks-2")
    assert "place_0_2" not in b2.action_names  # height 2 at most
    assert b2.step("100|b", "place_0_1") == "200|-"


def test_apply_reports_validity_and_states():
    b = get_benchmark("fruit-2x3")
    valid, states = b.apply("rr-|-", ["pick_red_0", "place_red_0", "pick_red_2", "pick_red_1",
                                      "place_red_2"])
    assert valid == [True, True, False, True, True]
    assert states == ["-r-|r", "rr-|-", "rr-|-", "r--|r", "r-r|-"]


def test_bad_keys_and_actions_raise():
    b = get_benchmark("fruit-2x3")
    for key in ("rr|-", "rrr|-", "r--|-", "ry-|-", "rr-"):
        with pytest.raises(VggcError):
            b.step(key, "pick_red_0")
    with pytest.raises(VggcError):
        b.step("rr-|-", "pick_blue_0")
    with pytest.raises(VggcError):
        get_benchmark("blocks-2").step("300|-", "pick_0_2")


@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(benchmark_names()), seed=st.integers(0, 2**31),
       steps=st.integers(1, 25))
def test_arrangements_follow_the_dynamics(name, seed, steps):
    b = get_benchmark(name)
    rng = np.random.default_rng(seed)
    space = b.all_states()
    state = space[int(rng.integers(len(space)))]
    arr = fresh_arrangement(b, state, rng)
    assert arrangement_state(b, arr) == state
    for _ in range(steps):
        valid = b.valid_actions(state)
        a = valid[int(rng.integers(len(valid)))]
        moved = arr.held if a.startswith("place") else None
        new = arrangement_after(b, arr, a, rng)
        state = b.step(state, a)
        assert arrangement_state(b, new) == state
        # only the moved body changes its offset
        changed = [i for i in range(b.spec.m) if new.offsets[i] != arr.offsets[i]]
        assert len(changed) <= 1
        if moved is not None:
            assert changed in ([moved], [])
        arr = new
