"""The evidence registry: built-in members, and a toy evidence that takes a registration and
nothing else to be learned on, from the library and from ``vggc-cp solve``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vggc_cp.errors import EvidenceNotApplicable, UnknownNameError
from vggc_cp.learned import LearnConfig, evidence_choices
from vggc_cp.pipeline import learn_graph
from vggc_cp.trace import Trace, load_trace
from vggc_cp.vision import evidence as ev

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "data" / "fruit-2x3.npz"


def test_the_built_in_evidences_are_registered():
    assert ev.evidence_names()[0] == "footprints"
    assert {"footprints", "saliency", "keypoints", "dinov2"} <= set(ev.evidence_names())
    assert set(evidence_choices()) == {"auto", "attention", *ev.evidence_names()}
    with pytest.raises(UnknownNameError, match="known: dinov2, footprints"):
        ev.get_evidence("footprint")
    opts = LearnConfig()
    assert ev.get_evidence("footprints").settings(opts) is opts.footprint
    assert ev.get_evidence("keypoints").settings(opts).backend == "keypoints"


def test_an_attention_evidence_refuses_images_below_its_grid():
    small = Trace(np.zeros((3, 8, 8, 3), np.uint8), np.array([0, 1]), ("pick_a", "place_a"))
    with pytest.raises(EvidenceNotApplicable, match="smaller than the 16x16 attention grid"):
        ev.get_evidence("saliency").distances(small, LearnConfig())


@pytest.fixture
def toy(monkeypatch):
    """A toy evidence: Euclidean distance between 8x8 block means of the images."""
    registry = dict(ev.EVIDENCE_REGISTRY)
    monkeypatch.setattr(ev, "EVIDENCE_REGISTRY", registry)

    @ev.register_evidence("blocks", settings=lambda options: options.distance)
    def blocks(trace, options, progress=False):
        n, h, w, _ = trace.observations.shape
        x = trace.observations[:, :h // 8 * 8, :w // 8 * 8].astype(np.float64) / 255
        f = x.reshape(n, h // 8, 8, w // 8, 8, 3).mean(axis=(2, 4)).reshape(n, -1)
        roles = trace.roles()
        return tuple(np.linalg.norm(f[roles == r][:, None] - f[roles == r][None], axis=-1)
                     for r in (0, 1))
    return "blocks"


def test_a_registered_evidence_is_learned_on_from_the_library_and_the_cli(toy, tmp_path):
    trace = load_trace(DATA)
    learned = learn_graph(trace.without_states(), LearnConfig(evidence=toy))
    assert learned.chosen.evidence == "blocks" and learned.graph.n_nodes >= 2
    from vggc_cp.cli import main

    out = tmp_path / "s.json"
    assert main(["solve", str(DATA), "-o", str(out), "--evidence", "blocks", "--quiet"]) == 0
    data = json.loads(out.read_text())
    assert data["evidence"] == "blocks" and data["labels"] == [int(x) for x in learned.labels]
