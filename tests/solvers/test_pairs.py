"""The candidate-pair merge path on descriptor codes equals the dense path (issue 27)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import fruit_episode, make_trace

from vggc_cp.solvers.coded import (
    CodedProblem,
    coded_noise_scale,
    coded_threshold_grid,
    weighted_quantile,
)
from vggc_cp.solvers.heldout import heldout_prediction
from vggc_cp.solvers.merge import congruence_merge, noise_scale, threshold_path
from vggc_cp.solvers.pairs import coded_merge, coded_threshold_path

NAMES = ("pick_1", "pick_2", "pick_3", "place_1", "place_2", "place_3")


def coded_problem(trace, n_codes, levels, seed):
    """Codes drawn per state (a few codes per state, so renders of one state mostly share
    one) and a random symmetric table whose values are on ``levels`` steps (ties, as the
    footprint distances have) or continuous (``levels`` 0)."""
    rng = np.random.default_rng(seed)
    roles = trace.roles()
    codes, tables = [], []
    for role in (0, 1):
        st = trace.states[roles == role]
        _, state_id = np.unique(st, return_inverse=True)
        code = state_id * n_codes + rng.integers(0, n_codes, len(st))
        _, code = np.unique(code, return_inverse=True)
        g = int(code.max()) + 1
        t = rng.uniform(0, 1, (g, g))
        if levels:
            t = np.round(t * levels) / levels
        # codes of one state are near each other
        rep = np.zeros(g, dtype=np.int64)
        for c, s in zip(code, state_id):
            rep[c] = s
        t = np.where(rep[:, None] == rep[None, :], t * 0.1, t)
        t = np.triu(t, 1)
        codes.append(code)
        tables.append(t + t.T)
    return CodedProblem.from_trace(trace.without_states(), tuple(codes), tuple(tables))


@pytest.mark.parametrize("seed,levels", [(0, 0), (2, 16),
                                         pytest.param(1, 8, marks=pytest.mark.slow),
                                         pytest.param(3, 0, marks=pytest.mark.slow),
                                         pytest.param(4, 4, marks=pytest.mark.slow)])
def test_coded_path_equals_dense_path(seed, levels):
    rng = np.random.default_rng(seed)
    trace = make_trace([fruit_episode(rng, 8) for _ in range(6)], NAMES)
    coded = coded_problem(trace, 3, levels, seed)
    dense = coded.dense()
    ts = np.geomspace(0.01, 0.9, 12)
    a = threshold_path(dense, ts, "mdl")
    b = coded_threshold_path(coded, ts, "mdl")
    for x, y in zip(a.results, b.results):
        assert np.array_equal(x.labels, y.labels)
        assert x.J == pytest.approx(y.J, abs=1e-12)
    assert a.selected == b.selected
    # one threshold alone, and the held-out prediction, agree too
    t = float(ts[5])
    assert np.array_equal(congruence_merge(dense, t)[0], coded_merge(coded, t)[0])
    episodes = trace.episode_index()
    assert heldout_prediction(dense, t, episodes, 3) == heldout_prediction(coded, t, episodes, 3)


def test_small_batches_split_levels_and_give_the_same_path(monkeypatch):
    """Batches of 40 pairs: levels are split by ranges of first ids, many batches per pass."""
    from vggc_cp.solvers import pairs

    rng = np.random.default_rng(5)
    trace = make_trace([fruit_episode(rng, 8) for _ in range(6)], NAMES)
    coded = coded_problem(trace, 2, 4, 5)
    ts = np.geomspace(0.01, 0.9, 10)
    whole = coded_threshold_path(coded, ts, "mdl")
    monkeypatch.setattr(pairs, "BATCH", 40)
    stream = pairs._PairStream(coded, float(ts[-1]))
    assert any(i0 > 0 for _, _, i0, _ in stream.bounds)  # a level was split
    got = [stream.pairs(k) for k in range(len(stream.bounds))]
    d, i, j = (np.concatenate(x) for x in zip(*got))
    order = np.lexsort((j, i, d))
    assert np.array_equal(order, np.arange(len(d)))  # batches in the dense order
    dense = coded.dense()
    n_pairs = sum(int((m[np.triu_indices(len(m), 1)] <= ts[-1]).sum())
                  for m in (dense.dist_pick, dense.dist_place))
    assert len(d) == n_pairs
    split = coded_threshold_path(coded, ts, "mdl")
    for x, y in zip(whole.results, split.results):
        assert np.array_equal(x.labels, y.labels)


def test_grid_statistics_equal_the_dense_ones():
    rng = np.random.default_rng(7)
    trace = make_trace([fruit_episode(rng, 6) for _ in range(5)], NAMES)
    coded = coded_problem(trace, 2, 16, 7)
    dense = coded.dense()
    assert coded_noise_scale(coded) == noise_scale(dense)
    ups = np.concatenate([d[np.triu_indices(len(d), 1)] for d in (dense.dist_pick,
                                                                   dense.dist_place)])
    from vggc_cp.pipeline import threshold_grid

    assert np.array_equal(coded_threshold_grid(coded), threshold_grid(dense))
    values, counts = np.unique(ups, return_counts=True)
    for q in (0.0, 0.1, 0.5, 0.9, 0.97, 1.0):
        assert weighted_quantile(values, counts, q) == np.quantile(ups, q)


def test_visual_score_and_restriction():
    rng = np.random.default_rng(3)
    trace = make_trace([fruit_episode(rng, 6) for _ in range(4)], NAMES)
    coded = coded_problem(trace, 2, 0, 3)
    dense = coded.dense()
    labels = coded_merge(coded, 0.3)[0]
    assert coded.visual_score(labels) == pytest.approx(dense.visual_score(labels), abs=1e-12)
    keep = trace.episode_index() % 2 == 0
    sub, kept = coded.restricted(keep)
    assert sub.n_obs == int(keep.sum())
    assert np.array_equal(sub.dense().dist_pick,
                          dense.dist_pick[np.ix_(dense.local[kept[sub.roles == 0]],
                                                 dense.local[kept[sub.roles == 0]])])


@pytest.mark.parametrize("seed,levels,n_codes,batch", [
    (0, 0, 3, None), (6, 4, 1, 40),
    *(pytest.param(*p, marks=pytest.mark.slow) for p in (
        (0, 0, 3, 40), (6, 4, 1, None), (2, 16, 3, None), (2, 16, 3, 40), (1, 8, 2, None),
        (4, 4, 3, 40)))])
def test_pairs_of_clusters_give_the_dense_path(monkeypatch, seed, levels, n_codes, batch):
    """Batches scanned from their pairs of clusters (one pair per two clusters, regenerated
    after every accepted merge) always, never, or by the default rule: the dense partitions
    at every threshold, in one threshold alone too."""
    from vggc_cp.solvers import pairs

    rng = np.random.default_rng(seed)
    trace = make_trace([fruit_episode(rng, 8) for _ in range(6)], NAMES)
    coded = coded_problem(trace, n_codes, levels, seed)
    ts = np.geomspace(0.01, 0.9, 12)
    want = threshold_path(coded.dense(), ts, "mdl")
    if batch:
        monkeypatch.setattr(pairs, "BATCH", batch)
    compressed = []
    real = pairs._PairStream.compressed

    def spy(self, *a):
        out = real(self, *a)
        compressed.append(out is not None)
        return out

    monkeypatch.setattr(pairs._PairStream, "compressed", spy)
    for share, regens in ((1e9, 10**9), (0.0, 0), (pairs.COMPRESS_SHARE, pairs.COMPRESS_REGENS)):
        monkeypatch.setattr(pairs, "COMPRESS_SHARE", share)
        monkeypatch.setattr(pairs, "COMPRESS_REGENS", regens)
        compressed.clear()
        got = coded_threshold_path(coded, ts, "mdl")
        for x, y in zip(want.results, got.results):
            assert np.array_equal(x.labels, y.labels)
        assert want.selected == got.selected
        if share > 1:
            assert compressed and all(compressed)
        if regens == 0:
            assert not any(compressed)
        t = float(ts[6])
        assert np.array_equal(congruence_merge(coded.dense(), t)[0], coded_merge(coded, t)[0])


def test_the_hand_constraint_is_the_same_on_codes_and_kept_by_restriction():
    rng = np.random.default_rng(5)
    trace = make_trace([fruit_episode(rng, 8) for _ in range(6)], NAMES)
    base = coded_problem(trace, 3, 8, 5)
    colour = np.array([0, 1, 0, 0, 1, 0])          # region 2's fruit is another colour
    coded = CodedProblem(base.roles, base.src, base.act, base.dst, base.action_names,
                         base.codes_pick, base.codes_place, base.table_pick, base.table_place,
                         action_colour=colour)
    assert np.array_equal(coded.dense().action_colour, colour)
    assert np.array_equal(coded.restricted(np.ones(coded.n_obs, bool))[0].action_colour, colour)
    t = 0.95                                        # everything within reach of the distances
    a, sa = congruence_merge(coded.dense(), t)
    b, sb = coded_merge(coded, t)
    assert np.array_equal(a, b) and sa.vetoed_hand >= 1 and sb.vetoed_hand >= 1
    from vggc_cp.solvers.base import hand_colours
    hand = hand_colours(coded)
    for node in np.unique(a[coded.place_obs]):
        held = set(hand[(a == node) & (hand >= 0)].tolist())
        assert len(held) <= 1
