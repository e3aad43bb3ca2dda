"""Benchmark specs and registry."""

from __future__ import annotations

import pytest

from vggc_cp.errors import VggcError
from vggc_cp.sim import SPECS, benchmark_names, get_benchmark, get_spec

PAPER = {  # name: (m, n, R, |A|, |V*|, |D|)
    "fruit-2x3": (2, 1, 3, 6, 6, 50),
    "multifruit-2x3": (2, 2, 3, 12, 12, 95),
    "fruit-4x6": (4, 1, 6, 12, 35, 700),
    "multifruit-4x6": (4, 2, 6, 24, 58, 400),
    "fruit-6x8": (6, 1, 8, 16, 84, 1500),
    "blocks-2": (2, 1, 3, 12, 9, 95),
    "blocks-3": (3, 1, 3, 18, 16, 200),
}


def test_registry_holds_the_papers_seven_in_order():
    assert benchmark_names() == tuple(PAPER)
    assert set(SPECS) == set(PAPER)


@pytest.mark.parametrize("name", list(PAPER))
def test_spec_matches_the_paper_table(name):
    s = get_spec(name)
    assert (s.m, s.n, s.R, s.n_actions, s.paper_states, s.default_transitions) == PAPER[name]
    assert len(get_benchmark(name).action_names) == s.n_actions
    assert len(s.objects) == s.m and len(s.classes) == s.n


def test_multifruit_4x6_has_four_fruits_in_two_classes():
    s = get_spec("multifruit-4x6")
    assert sorted(s.objects) == ["apple", "banana", "lemon", "strawberry"]
    assert sorted(s.object_class(i) for i in range(4)) == ["red", "red", "yellow", "yellow"]


def test_unknown_name_lists_the_known_ones():
    with pytest.raises(VggcError) as err:
        get_benchmark("fruit-9x9")
    for name in PAPER:
        assert name in str(err.value)
