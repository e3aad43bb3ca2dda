"""No solver or selection rule reads ``states``: a trace with ``states`` removed solves the same.

Every (solver, selection rule) pair the CLI offers is run twice through ``vggc-cp solve`` — on
a trace that carries ground-truth ``states`` and on the same file without them — and the two
solution files must agree on every learned field (the baselines: tests/baselines). The rule lists come from the registries, so
a rule added later is covered without editing this file.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import fruit_episode, make_trace

from vggc_cp.cli import main
from vggc_cp.solvers.merge import PATH_SELECTIONS
from vggc_cp.solvers.sweep import SELECTIONS
from vggc_cp.trace import save_trace

NAMES = ("pick_1", "pick_2", "pick_3", "place_1", "place_2", "place_3")
FIELDS = ("labels", "edges", "k_pick", "k_place", "J", "status", "nodes")


def _episodes(seed: int, n: int = 4, length: int = 3):
    rng = np.random.default_rng(seed)
    return [fruit_episode(rng, length) for _ in range(n)]


@pytest.fixture(scope="module")
def traces(tmp_path_factory):
    folder = tmp_path_factory.mktemp("blind")
    trace = make_trace(_episodes(3), NAMES, size=16, noise=4)
    full, bare = folder / "full.npz", folder / "bare.npz"
    save_trace(trace, full)
    save_trace(trace.without_states(), bare)
    return folder, full, bare, trace


#: The grid solvers' cases compute Sinkhorn distances and sweep the grid (about a minute on
#: two cores): slow, run by the full CI. Their quick counterparts are
#: tests/solvers/test_greedy.py::test_states_removed_gives_the_identical_solution and
#: tests/test_cli_solve.py::test_states_removed_solves_identically; the default (merge) stays quick.
_SLOW = pytest.mark.slow
CASES = ([pytest.param("greedy", rule, marks=_SLOW) for rule in sorted(SELECTIONS)]
         + [pytest.param("cpsat", rule, marks=_SLOW) for rule in sorted(SELECTIONS)]
         + [("merge", rule) for rule in sorted(PATH_SELECTIONS)])


@pytest.mark.parametrize("solver,rule", CASES)
def test_solution_does_not_depend_on_states(traces, solver, rule, monkeypatch):
    folder, full, bare, trace = traces
    monkeypatch.setenv("VGGC_CP_CACHE", str(folder / "cache"))
    outs = []
    for src in (full, bare):
        out = folder / f"{solver}-{rule}-{src.stem}.json"
        args = ["solve", str(src), "-o", str(out), "--quiet", "--solver", solver,
                "--select", rule, "--sinkhorn-device", "numpy"]
        if solver != "merge":
            args += ["--k-pick", "1:4", "--k-place", "1:2"]
        if solver == "cpsat":
            args += ["--cpsat-params", "max_time_in_seconds:20,num_workers:1,random_seed:0"]
        assert main(args) == 0
        outs.append(json.loads(out.read_text()))
    a, b = outs
    assert len(a["labels"]) == trace.n_obs
    for key in FIELDS:
        if key in a or key in b:
            assert a.get(key) == b.get(key), key

