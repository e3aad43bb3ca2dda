"""What learning takes and gives (vggc_cp.learned): settings validated when built, naming the
field or the known names; a result that writes its solution only with its trace."""

from __future__ import annotations

from pathlib import Path

import pytest

from vggc_cp.errors import UnknownNameError, VggcError
from vggc_cp.learned import FALLBACKS, LearnConfig, Learned, evidence_choices

DATA = Path(__file__).resolve().parents[1] / "data" / "fruit-2x3.npz"


@pytest.mark.parametrize("field, value, known", [
    ("evidence", "footprint", "footprints"),
    ("rule", "MDL", "mdl"),
    ("fallback", "sometimes", "suspect"),
    ("candidates", "sparse", "codes"),
])
def test_an_unknown_name_lists_the_known_ones(field, value, known):
    with pytest.raises(UnknownNameError, match=known):
        LearnConfig(**{field: value})


@pytest.mark.parametrize("settings, says", [
    ({"thresholds": (0.1, -1.0)}, r"'thresholds'\[1\]"),
    ({"thresholds": ()}, "non-empty"),
    ({"steps": 0}, "'steps'"),
    ({"steps": True}, "'steps'"),
    ({"folds": 1}, "'folds'"),
    ({"warning": "strict"}, "'warning' must be a WarningRule"),
    ({"evidence": 3}, "'evidence' must be a name"),
])
def test_a_value_out_of_range_names_its_field(settings, says):
    with pytest.raises(VggcError, match=says):
        LearnConfig(**settings)


def test_settings_are_normalised_and_replaced_by_name():
    cfg = LearnConfig(thresholds=[1, 2.5])
    assert cfg.thresholds == (1.0, 2.5) and isinstance(cfg.thresholds[0], float)
    assert LearnConfig(evidence="attention").evidence == cfg.distance.backend
    assert LearnConfig.from_settings(cfg, steps=8).steps == 8
    assert LearnConfig.from_settings(cfg) is cfg
    with pytest.raises(UnknownNameError, match="steps"):
        LearnConfig.from_settings(cfg, step=8)
    with pytest.raises(VggcError, match="expected a LearnConfig"):
        LearnConfig.from_settings({"steps": 8})


def test_the_choices_cover_auto_attention_and_every_fallback_policy():
    choices = evidence_choices()
    assert choices[:2] == ("auto", "attention") and "footprints" in choices
    assert set(FALLBACKS) == {"refused", "suspect", "never"}


def test_a_result_without_its_trace_refuses_to_write_a_solution(tmp_path):
    from vggc_cp.api import learn_graph, load_trace

    learned = learn_graph(load_trace(DATA).without_states())
    bare = Learned(learned.chosen, learned.candidates, learned.seconds)
    with pytest.raises(VggcError, match="no trace or settings"):
        bare.save(tmp_path / "s.json")
    assert not (tmp_path / "s.json").exists()
    learned.save(tmp_path / "s.json")
    assert (tmp_path / "s.json").stat().st_size > 0
