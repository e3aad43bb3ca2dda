"""Action footprints: where the trace's actions change the scene, and the distance they give."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import shuffled_within_roles

from vggc_cp.errors import VggcError
from vggc_cp.trace import PICK, PLACE, Trace, load_trace
from vggc_cp.vision.footprints import (
    FootprintParams,
    action_footprints,
    footprint_distances,
    normalise_frames,
)

DATA = Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz"


@pytest.fixture(scope="module")
def shipped():
    return load_trace(DATA)


def _per_role(trace, dists):
    roles = trace.roles()
    return [(trace.states[roles == r], d) for r, d in zip((PICK, PLACE), dists)]


def test_footprints_of_one_region_overlap_and_of_two_regions_do_not(shipped):
    fp = action_footprints(shipped.without_states())
    names = list(shipped.action_names)
    maps = fp.maps.reshape(len(names), -1)
    assert np.allclose(maps[fp.taken].sum(axis=1), 1.0)
    cos = (maps @ maps.T) / np.outer(np.linalg.norm(maps, axis=1), np.linalg.norm(maps, axis=1))
    same = cos[names.index("pick_red_0"), names.index("place_red_0")]
    other = cos[names.index("pick_red_0"), names.index("place_red_2")]
    assert same > 0.5 and other < 0.1
    assert fp.presence.min() >= 0 and fp.presence.max() <= 1


def test_footprint_distances_put_every_observation_next_to_its_own_state(shipped):
    dists = footprint_distances(shipped.without_states())
    for states, d in _per_role(shipped, dists):
        assert np.allclose(d, d.T) and np.all(np.diag(d) == 0) and d.max() <= 1
        same = states[:, None] == states[None, :]
        off = ~np.eye(len(d), dtype=bool)
        assert d[same & off].max() < d[~same].min()


def test_a_per_frame_lighting_gain_and_tint_cancel(shipped):
    rng = np.random.default_rng(0)
    # gains below 1 (nothing clips), a different one per frame and channel
    gain = rng.uniform(0.8, 1.0, size=(shipped.n_obs, 1, 1, 3))
    lit = np.clip(shipped.observations * gain, 0, 255).astype(np.uint8)
    x0, x1 = normalise_frames(shipped.observations), normalise_frames(lit)
    assert np.abs(x0 - x1).mean() < 0.02
    other = Trace(lit, shipped.actions, shipped.action_names, None, shipped.meta)
    d0, d1 = footprint_distances(shipped), footprint_distances(other)
    for a, b in zip(d0, d1):
        assert np.abs(a - b).max() < 0.1


def test_shuffled_images_destroy_the_evidence(shipped):
    """The distance depends on what the images show where the actions act: shuffling the
    observations within each role breaks the separation."""
    shuffled = shuffled_within_roles(shipped, 1)
    dists = footprint_distances(shuffled)
    separated = [d[(s[:, None] == s[None, :]) & ~np.eye(len(d), dtype=bool)].max()
                 < d[s[:, None] != s[None, :]].min() for s, d in _per_role(shuffled, dists)]
    assert not all(separated)


def test_bad_parameters_and_an_empty_trace_are_refused(shipped):
    with pytest.raises(VggcError):
        FootprintParams(gripper=1.5)
    with pytest.raises(VggcError):
        FootprintParams(chroma=0)
    one = Trace(shipped.observations[:1], np.zeros(0, dtype=np.int64), shipped.action_names)
    with pytest.raises(VggcError):
        action_footprints(one)
