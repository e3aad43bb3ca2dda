"""``vggc-cp show``: the learned graph as PNG, SVG (one element per node) and HTML, on the
shipped trace and on a generated trace of every other benchmark and of a drawn task; plan and
doubts drawn."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from dataclasses import replace
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from vggc_cp.cli import main
from vggc_cp.graph import TaskGraph
from vggc_cp.graph_plots import band_layout, doubt_pairs, pixel_medoids

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data" / "fruit-2x3.npz"


#: the shipped trace in the quick run; every other benchmark and a drawn task in the full run
BENCHMARKS = ["fruit-2x3", *[pytest.param(b, marks=pytest.mark.slow) for b in (
    "multifruit-2x3", "fruit-4x6", "multifruit-4x6", "fruit-6x8", "blocks-2", "blocks-3",
    "random-7")]]


def node_ids(svg: Path) -> set[int]:
    root = ET.parse(svg).getroot()
    ids = {el.get("id") for el in root.iter() if el.get("id")}
    return {int(i.split("-")[1]) for i in ids if i.startswith("node-")}


@pytest.mark.parametrize("bench", BENCHMARKS)
def test_show_draws_every_benchmark(solved_benchmark, tmp_path, bench):
    solution, trace = solved_benchmark(bench)
    labels = set(json.loads(solution.read_text())["labels"])
    png, svg, page = tmp_path / "g.png", tmp_path / "g.svg", tmp_path / "g.html"
    for out in (png, svg, page):
        assert main(["show", str(solution), str(trace), "-o", str(out)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert node_ids(svg) == labels
    text = page.read_text()
    HTMLParser().feed(text)
    assert all(f'id="row-node-{u}"' in text for u in labels)
    assert "http://" not in text and "https://" not in text


def test_show_highlights_a_plan_and_marks_doubts(solved_benchmark, tmp_path):
    solution, trace = solved_benchmark("fruit-2x3")
    data = json.loads(solution.read_text())
    a, b = data["labels"][0], data["labels"][2 * 7]
    doubted = tmp_path / "doubts.json"
    doubted.write_text(json.dumps({**data, "doubts": [{"nodes": [a, b], "why": "test"},
                                                      {"nodes": "junk"}]}))
    svg = tmp_path / "g.svg"
    assert main(["show", str(doubted), str(trace), "-o", str(svg), "--plan-from", "0",
                 "--plan-to", "4"]) == 0
    text = svg.read_text()
    assert f'id="doubt-{a}-{b}"' in text
    assert "#d62728" in text  # the plan's colour


@pytest.mark.parametrize("argv, message", [
    (["-o", "{tmp}/g.jpg"], "'jpg' is not one of png, svg, html"),
    (["-o", "{tmp}/g.png", "--plan-from", "0"], "--plan-from and --plan-to go together"),
    (["-o", "{tmp}/g.png", "--plan-from", "0", "--plan-to", "999"], "--plan-to 999 is out of range"),
])
def test_bad_show_fails_with_one_line(solved_benchmark, tmp_path, capsys, argv, message):
    solution, trace = solved_benchmark("fruit-2x3")
    argv = [x.format(tmp=tmp_path) for x in argv]
    assert main(["show", str(solution), str(trace), *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vggc-cp: error: ") and message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []


def test_show_refuses_a_solution_of_another_trace(solved_benchmark, tmp_path, capsys):
    from vggc_cp.trace import load_trace, save_trace

    solution, trace = solved_benchmark("fruit-2x3")
    t = load_trace(trace)
    other = tmp_path / "flipped.npz"
    save_trace(replace(t, observations=t.observations[:, ::-1].copy()), other)
    assert main(["show", str(solution), str(other), "-o", str(tmp_path / "g.png")]) == 2
    assert capsys.readouterr().err.startswith(f"vggc-cp: error: {solution}: ")


def test_layout_puts_pick_above_place_and_scales():
    rng = np.random.default_rng(0)
    n = 300  # a few hundred nodes: bands wrap, no two nodes share a place
    roles = np.arange(n) % 2
    src = np.arange(0, n - 1)
    dst = src + 1
    graph = TaskGraph.from_labels(np.arange(n), roles, src, np.zeros(n - 1, np.int64), dst,
                                  ("pick_a",))
    pos = band_layout(graph)
    assert len(set(pos.values())) == n
    assert min(pos[u][1] for u in range(0, n, 2)) > max(pos[u][1] for u in range(1, n, 2))
    obs = rng.integers(0, 255, (n, 8, 8, 3), dtype=np.uint8)
    med = pixel_medoids(obs, {0: np.array([3, 4, 5])})
    assert med[0] in (3, 4, 5)


def test_pixel_medoid_is_the_typical_member():
    obs = np.zeros((4, 8, 8, 3), np.uint8)
    obs[0] = 255  # an outlier
    obs[2, 0, 0] = 40  # nearest to the others
    assert pixel_medoids(obs, {7: np.arange(4)})[7] in (1, 2, 3)
    assert pixel_medoids(obs, {7: np.arange(4)})[7] != 0


def test_doubt_pairs_are_robust_to_their_absence():
    graph = TaskGraph.from_labels(np.array([0, 1]), np.array([0, 1]), np.array([0]),
                                  np.array([0]), np.array([1]), ("pick_a",))
    assert doubt_pairs({}, graph) == []
    assert doubt_pairs({"doubts": "x"}, graph) == []
    assert doubt_pairs({"doubts": [{"nodes": [0, 1]}, {"nodes": [0, 9]}, 3]}, graph) == [(0, 1)]
