"""Baselines (PCA-HDBSCAN roadmap, Latent Space Roadmap) on a small hand-made trace.

Six states with well-separated noisy images: pick states A, B, C and place states X, Y, Z.
Any merge of two states of one role puts two action labels on one node pair, so the true
partition is the unique Exactly-One-free graph with fewest nodes.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import make_trace

from vggc_cp.baselines import (
    BASELINES,
    LsrConfig,
    PcaHdbscanConfig,
    baseline_solution,
    get_baseline,
    graph_stats,
)
from vggc_cp.baselines.base import induced_graph, labels_from_roles
from vggc_cp.baselines.lsr import action_pairs, epsilon_components
from vggc_cp.baselines.pca_hdbscan import assign_noise
from vggc_cp.cli import main
from vggc_cp.errors import UnknownNameError, VggcError
from vggc_cp.graph import check
from vggc_cp.solution import read_solution, verify_solution, write_solution
from vggc_cp.trace import save_trace

NAMES = ("pick_a", "pick_b", "pick_c", "place_a", "place_b", "place_c")
GRAPH = {  # state -> [(action, next state)]
    "A": [("pick_a", "X"), ("pick_b", "Y")],
    "B": [("pick_a", "Y"), ("pick_c", "Z")],
    "C": [("pick_c", "Z"), ("pick_b", "X")],
    "X": [("place_a", "B"), ("place_b", "C")],
    "Y": [("place_a", "C"), ("place_c", "A")],
    "Z": [("place_a", "A"), ("place_b", "B")],
}


def toy_trace(n_episodes: int = 12, noise: int = 12, seed: int = 0):
    rng = np.random.default_rng(seed)
    episodes = []
    for _ in range(n_episodes):
        state = "ABC"[rng.integers(3)]
        ep = [state]
        for _ in range(int(rng.integers(4, 9))):
            action, state = GRAPH[state][rng.integers(2)]
            ep += [action, state]
        episodes.append(ep)
    return make_trace(episodes, NAMES, size=8, noise=noise, seed=seed)


def same_partition(labels: np.ndarray, states: np.ndarray) -> bool:
    pairs = set(zip(labels.tolist(), states.tolist()))
    return len(pairs) == len(set(labels.tolist())) == len(set(states.tolist()))


FAST_LSR = LsrConfig(image_size=8, latent_dim=6, steps=150, batch=16, d_m=(6.0,), shift=0,
                     cut_candidates=20)


@pytest.mark.parametrize("name, options", [
    ("pca-hdbscan", {}),
    pytest.param("lsr", {"config": FAST_LSR}, marks=pytest.mark.slow),  # trains a VAE
])
def test_baseline_recovers_states_and_evaluates(tmp_path, capsys, name, options):
    trace = toy_trace()
    result = get_baseline(name, **options).fit(trace)
    assert result.status == "feasible" and result.solver == name
    assert same_partition(result.labels, trace.states)
    assert (result.k_pick, result.k_place) == (3, 3)
    graph = induced_graph(trace, result.labels)
    assert check(graph).ok
    assert result.stats["violations"]["exactly_one"] == 0
    assert len(result.stats["grid"]) >= 2
    for row in result.stats["grid"]:
        assert {"k_pick", "k_place", "status", "J", "seconds"} <= set(row)

    save_trace(trace, tmp_path / "t.npz")
    write_solution(tmp_path / "s.json", baseline_solution(trace, result))
    assert main(["evaluate", str(tmp_path / "t.npz"), str(tmp_path / "s.json"), "--json",
                 "-Q", "200"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["solver"] == name
    assert out["opt_path"] == out["any_path"] == out["exec"] == 1.0
    assert out["exactly_one_violations"] == 0


def test_baselines_never_read_states():
    trace = toy_trace()
    a = get_baseline("pca-hdbscan").fit(trace)
    b = get_baseline("pca-hdbscan").fit(trace.without_states())
    assert np.array_equal(a.labels, b.labels)


@pytest.mark.slow
def test_lsr_is_deterministic():
    trace = toy_trace(n_episodes=4)
    cfg = LsrConfig(image_size=8, latent_dim=4, steps=20, batch=8, d_m=(4.0,),
                    clusterings=("epsilon",))
    a = get_baseline("lsr", config=cfg).fit(trace)
    b = get_baseline("lsr", config=cfg).fit(trace)
    assert np.array_equal(a.labels, b.labels)
    assert a.stats["grid"][0]["final_loss"] == b.stats["grid"][0]["final_loss"]


def test_violating_baseline_solution_is_evaluated_not_refused(tmp_path, capsys):
    trace = toy_trace(n_episodes=6)
    roles = trace.roles()
    one_per_role = labels_from_roles(roles, np.zeros(np.sum(roles == 0)),
                                     np.zeros(np.sum(roles == 1)))
    stats = graph_stats(induced_graph(trace, one_per_role))
    assert stats.nodes == 2 and stats.exactly_one > 0
    assert stats.exactly_one_transitions == trace.n_transitions
    from vggc_cp.solution import labels_solution

    data = labels_solution(trace, one_per_role, solver="pca-hdbscan")
    save_trace(trace, tmp_path / "t.npz")
    write_solution(tmp_path / "strict.json", data)
    with pytest.raises(VggcError, match="exactly_one"):
        verify_solution(read_solution(tmp_path / "strict.json"), trace)
    write_solution(tmp_path / "none.json", data | {"constraints": "none"})
    verify_solution(read_solution(tmp_path / "none.json"), trace)
    assert main(["evaluate", str(tmp_path / "t.npz"), str(tmp_path / "none.json"),
                 "-Q", "50"]) == 0
    assert "Exactly-One violations" in capsys.readouterr().out


def test_registry_and_options():
    assert {"pca-hdbscan", "lsr"} <= set(BASELINES)
    with pytest.raises(UnknownNameError, match="known: .*lsr.*pca-hdbscan"):
        get_baseline("kmeans")
    with pytest.raises(VggcError, match="noise"):
        PcaHdbscanConfig(noise="drop")
    with pytest.raises(VggcError, match="clustering"):
        LsrConfig(clusterings=("ward",))


def test_noise_handling():
    feats = np.array([[0.0], [0.1], [5.0], [5.1], [0.3], [4.8]])
    clusters = np.array([0, 0, 1, 1, -1, -1])
    assert assign_noise(feats, clusters, "nearest").tolist() == [0, 0, 1, 1, 0, 1]
    assert assign_noise(feats, clusters, "own").tolist() == [0, 0, 1, 1, 2, 3]
    assert assign_noise(feats, np.full(6, -1), "nearest").tolist() == [0] * 6


def test_epsilon_components_and_action_pairs():
    z = np.array([[0.0, 0.0], [0.3, 0.0], [0.6, 0.1], [3.0, 3.0]])
    assert epsilon_components(z, 0.45).tolist() == [0, 0, 0, 1]
    trace = toy_trace(n_episodes=2)
    src, dst = action_pairs(trace, two_step=True)
    assert np.all((dst - src == 1) | (dst - src == 2))
    assert np.all(trace.roles()[src[dst - src == 2]] == trace.roles()[dst[dst - src == 2]])


def test_baseline_cli(tmp_path, capsys):
    trace = toy_trace()
    save_trace(trace, tmp_path / "t.npz")
    out = tmp_path / "s.json"
    assert main(["baseline", "pca-hdbscan", str(tmp_path / "t.npz"), "-o", str(out),
                 "--param", "min_cluster_size=3,5", "--param", "noise=own"]) == 0
    text = capsys.readouterr().out
    assert "pca-hdbscan" in text and "nodes" in text
    sol = read_solution(out)
    assert sol.extra["constraints"] == "none"
    assert {row["min_cluster_size"] for row in sol.extra["grid"]} == {3, 5}
    assert sol.extra["params"]["noise"] == "own"
    assert main(["baseline", "pca-hdbscan", str(tmp_path / "t.npz"), "-o", str(out),
                 "--param", "bogus=1"]) == 2
    assert "bogus" in capsys.readouterr().err


def test_baseline_progress_bar_has_its_total_and_quiet_hides_it(tmp_path, capsys):
    from dataclasses import replace

    trace = toy_trace()
    get_baseline("lsr", config=replace(FAST_LSR, steps=5, d_m=(4.0, 6.0))).fit(trace,
                                                                              progress=True)
    assert "lsr:   0%|          | 0/10 [" in capsys.readouterr().err  # steps x d_m
    save_trace(trace, tmp_path / "t.npz")
    argv = ["baseline", "pca-hdbscan", str(tmp_path / "t.npz"), "-o", str(tmp_path / "s.json"),
            "--param", "min_cluster_size=3,4,5", "--param", "n_components=8", "--param",
            "min_samples=1,none"]
    assert main(argv) == 0
    assert "pca-hdbscan:   0%|          | 0/6 [" in capsys.readouterr().err
    assert main(argv + ["--quiet"]) == 0
    assert capsys.readouterr().err == ""
