"""The exact product-graph metrics agree with plan enumeration on random traces."""

from __future__ import annotations

import numpy as np
from conftest import make_trace
from hypothesis import given, settings
from hypothesis import strategies as st

from vggc_cp.evaluate import GroundTruth, execution_probability, validate_dag
from vggc_cp.evaluate.reference import enumerate_outcomes
from vggc_cp.graph import TaskGraph, shortest_path_dag

PICKS = [f"pick_{i}" for i in range(3)]
PLACES = [f"place_{i}" for i in range(3)]


@st.composite
def random_trace_and_labels(draw):
    n_pick_states = draw(st.integers(2, 4))
    n_place_states = draw(st.integers(2, 4))
    episodes = []
    for _ in range(draw(st.integers(1, 4))):
        length = draw(st.integers(1, 6))
        kind = draw(st.sampled_from(["pick", "place"]))
        ep = []
        for _ in range(length + 1):
            if kind == "pick":
                ep.append(f"P{draw(st.integers(0, n_pick_states - 1))}")
                ep.append(draw(st.sampled_from(PICKS)))
                kind = "place"
            else:
                ep.append(f"Q{draw(st.integers(0, n_place_states - 1))}")
                ep.append(draw(st.sampled_from(PLACES)))
                kind = "pick"
        episodes.append(ep[:-1])
    trace = make_trace(episodes, PICKS + PLACES)
    # random labels that respect roles: observations of a role share nodes only within it
    roles = trace.roles()
    labels = np.array([draw(st.integers(0, 2)) * 2 + int(r) for r in roles])
    return trace, labels


@settings(max_examples=120, deadline=None)
@given(random_trace_and_labels())
def test_product_search_equals_enumeration(data):
    trace, labels = data
    gt = GroundTruth.from_trace(trace)
    src, act, dst = trace.transitions()
    graph = TaskGraph.from_labels(labels, trace.roles(), src, act, dst, trace.action_names)
    cons = gt.consistent(labels)
    for s in range(gt.n_states):
        for g in range(gt.n_states):
            if s == g:
                continue
            o_s = int(np.flatnonzero(gt.obs_state == s)[0])
            o_g = int(np.flatnonzero(gt.obs_state == g)[0])
            dag = shortest_path_dag(graph, int(labels[o_s]), int(labels[o_g]))
            any_ref, all_ref, exec_ref = enumerate_outcomes(dag, gt, cons, s, g, gt.observed_step)
            any_ok, all_ok = validate_dag(dag, gt, cons)
            assert (any_ok, all_ok) == (any_ref, all_ref)
            assert abs(execution_probability(dag, s, g, gt.observed_step) - exec_ref) < 1e-12
