"""``vggc-cp report``: one self-contained HTML page per benchmark trace, naming every node,
holding no network address; the sections a solution's optional fields add."""

from __future__ import annotations

import json
from html.parser import HTMLParser

import pytest

from vggc_cp.cli import main


class Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags, self.srcs, self.ids, self.text = [], [], set(), []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        if "src" in a:
            self.srcs.append(a["src"])
        if "href" in a:
            self.srcs.append(a["href"])
        if "id" in a:
            self.ids.add(a["id"])

    def handle_data(self, data):
        self.text.append(data)


def parse(text: str) -> Collect:
    c = Collect()
    c.feed(text)
    c.close()
    return c


@pytest.mark.parametrize("bench", ["fruit-2x3",
                                   *[pytest.param(b, marks=pytest.mark.slow) for b in (
                                       "multifruit-2x3", "fruit-4x6", "multifruit-4x6",
                                       "fruit-6x8", "blocks-2", "blocks-3", "random-7")]])
def test_report_of_every_benchmark(solved_benchmark, tmp_path, bench):
    solution, trace = solved_benchmark(bench)
    out = tmp_path / "r.html"
    assert main(["report", str(solution), str(trace), "-o", str(out)]) == 0
    text = out.read_text()
    page = parse(text)
    labels = set(json.loads(solution.read_text())["labels"])
    assert {f"node-{u}" for u in labels} <= page.ids
    body = " ".join(page.text)
    assert all(f"node {u}" in body for u in labels)
    assert "http://" not in text and "https://" not in text
    assert "script" not in page.tags and "link" not in page.tags
    assert page.srcs and all(s.startswith("data:image/png;base64,") for s in page.srcs)
    for section in ("Graph", "Confidence", "Threshold path", "Nodes", "Warnings"):
        assert f"<h2>{section}</h2>" in text
    rows = json.loads(solution.read_text())["grid"]
    assert text.count("<tr class=") == len(rows)  # one row per threshold


def test_report_shows_suggestions_doubts_and_warnings(solved_benchmark, tmp_path):
    solution, trace = solved_benchmark("fruit-2x3")
    data = json.loads(solution.read_text())
    data["suggest"] = ["record node 3 from another angle"]
    data["doubts"] = [{"nodes": [0, 1], "why": "look alike"}]
    data["confidence"] = {**data["confidence"], "suspect": True,
                          "reasons": ["plateau of 1 threshold"]}
    edited = tmp_path / "s.json"
    edited.write_text(json.dumps(data))
    out = tmp_path / "r.html"
    assert main(["report", str(edited), str(trace), "-o", str(out)]) == 0
    text = out.read_text()
    assert "<h2>What to record next</h2>" in text
    assert "record node 3 from another angle" in text and "nodes [0, 1]: look alike" in text
    assert '<li class="warn">plateau of 1 threshold</li>' in text


def test_report_shows_a_note_without_warning(solved_benchmark, tmp_path):
    """A chance of change alone is a note: listed under the confidence, not a warning."""
    solution, trace = solved_benchmark("fruit-2x3")
    data = json.loads(solution.read_text())
    note = "the graph changes in 7 of 12 re-runs: nodes 3, 4 rest on few episodes"
    data["confidence"] = {**data["confidence"], "suspect": False, "reasons": [],
                          "notes": [note]}
    edited = tmp_path / "s.json"
    edited.write_text(json.dumps(data))
    out = tmp_path / "r.html"
    assert main(["report", str(edited), str(trace), "-o", str(out)]) == 0
    text = out.read_text()
    assert "Notes (reported, not warnings)" in text and f"<li>{note}</li>" in text
    assert f'<li class="warn">{note}</li>' not in text


def test_report_refuses_a_non_html_output(solved_benchmark, tmp_path, capsys):
    solution, trace = solved_benchmark("fruit-2x3")
    assert main(["report", str(solution), str(trace), "-o", str(tmp_path / "r.png")]) == 2
    assert "a report is an .html file" in capsys.readouterr().err


@pytest.mark.slow
def test_report_and_show_of_a_trace_read_from_its_file(solved_benchmark, tmp_path, monkeypatch):
    """Frames above the memory cap stay in the file (vggc_cp.frames): the pictures read the
    images they show in one pass and come out the same."""
    solution, trace = solved_benchmark("fruit-2x3")
    held = tmp_path / "held.html"
    assert main(["report", str(solution), str(trace), "-o", str(held)]) == 0
    assert main(["show", str(solution), str(trace), "-o", str(tmp_path / "held.svg")]) == 0
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", "200000")  # below the trace's frames
    from vggc_cp.frames import StreamedFrames
    from vggc_cp.trace import load_trace

    assert isinstance(load_trace(trace).observations, StreamedFrames)
    streamed = tmp_path / "streamed.html"
    assert main(["report", str(solution), str(trace), "-o", str(streamed)]) == 0
    assert streamed.read_text() == held.read_text()
    assert main(["show", str(solution), str(trace), "-o", str(tmp_path / "s.svg")]) == 0
    assert (tmp_path / "s.svg").read_bytes() == (tmp_path / "held.svg").read_bytes()
