"""The default merge path (candidate pairs of footprint codes) gives the dense path's graphs
(issue 27): the same grid, partitions at every threshold, selection, confidence."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vggc_cp.errors import VggcError
from vggc_cp.learned import FOOTPRINTS, LearnConfig
from vggc_cp.pipeline import evidence_problem, run_candidate
from vggc_cp.solvers.coded import CodedProblem
from vggc_cp.trace import load_trace
from vggc_cp.vision.footprints import action_footprints, footprint_codes, footprint_distances

DATA = Path(__file__).resolve().parents[1] / "data" / "fruit-2x3.npz"


def same_candidate(trace):
    dense = run_candidate(trace, FOOTPRINTS, LearnConfig(evidence=FOOTPRINTS,
                                                          candidates="dense"))
    coded = run_candidate(trace, FOOTPRINTS, LearnConfig(evidence=FOOTPRINTS))
    assert isinstance(coded.problem, CodedProblem)
    assert dense.path.thresholds == coded.path.thresholds
    for a, b in zip(dense.path.results, coded.path.results):
        assert np.array_equal(a.labels, b.labels)
    assert dense.path.selected == coded.path.selected
    assert dense.description_lengths == coded.description_lengths
    assert dense.confidence == coded.confidence
    return coded


def test_codes_reproduce_the_footprint_distances_bit_for_bit():
    trace = load_trace(DATA).without_states()
    fp = action_footprints(trace)
    codes, tables = footprint_codes(fp, trace.roles())
    for dense, code, table in zip(footprint_distances(trace), codes, tables):
        assert len(table) < len(code)  # renders of one situation share a code
        assert np.array_equal(table[np.ix_(code, code)], dense)


def test_shipped_trace_same_graphs_on_both_paths():
    coded = same_candidate(load_trace(DATA).without_states())
    assert coded.best.n_nodes > 1


def test_descriptors_that_do_not_repeat_take_the_dense_matrices(monkeypatch):
    from vggc_cp import pipeline

    trace = load_trace(DATA).without_states()
    monkeypatch.setattr(pipeline, "CODES_SHARE", 0.0)
    problem = evidence_problem(trace, FOOTPRINTS, LearnConfig())
    assert not isinstance(problem, CodedProblem)
    for a, b in zip((problem.dist_pick, problem.dist_place), footprint_distances(trace)):
        assert np.array_equal(a, b)


def test_candidates_setting_is_validated():
    with pytest.raises(VggcError, match="codes, dense"):
        LearnConfig(candidates="sparse")
    trace = load_trace(DATA).without_states()
    assert not isinstance(evidence_problem(trace, FOOTPRINTS, LearnConfig(candidates="dense")),
                          CodedProblem)


@pytest.mark.slow
@pytest.mark.parametrize("bench,transitions,look", [
    # sites settled by the actions make exact ties common: here an average linkage equal to
    # the top threshold, summed in another order on each path, fell on either side of it
    # (21 nodes against 23) until the test took a relative tolerance (merge.LINK_RTOL)
    ("fruit-4x6", 400, "clean"),
    ("blocks-2", 300, "clean"), ("multifruit-2x3", 300, "clean"),
    ("fruit-2x3", 300, "randomized"), ("fruit-4x6", 400, "randomized")])
def test_generated_traces_same_graphs_on_both_paths(bench, transitions, look, monkeypatch):
    from vggc_cp import pipeline
    from vggc_cp.sim.explore import generate

    monkeypatch.setattr(pipeline, "CODES_SHARE", 1.0)  # codes even where they barely repeat
    trace = generate(bench, transitions, seed=3, look=look).trace.without_states()
    same_candidate(trace)
