"""CP-SAT with co-determinism and visual cannot-link agrees with brute-force enumeration."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import make_trace

from vggc_cp.solvers import Problem
from vggc_cp.solvers.brute import BruteSolver, CellConstraints, split_colours, violations
from vggc_cp.solvers.cpsat import CpSatSolver

NAMES = ("pick_1", "pick_2", "place_1", "place_2")


def random_problem(rng):
    episodes = []
    for _ in range(2):
        r = int(rng.integers(1, 3))
        ep = [str(r)]
        for _ in range(2):
            ep += [f"pick_{r}", "H" + str(int(rng.integers(0, 2)))]
            r = int(rng.integers(1, 3))
            ep += [f"place_{r}", str(r)]
        episodes.append(ep)
    trace = make_trace(episodes, NAMES)
    roles = trace.roles()
    mats = []
    for role in (0, 1):
        n = int((roles == role).sum())
        d = np.triu(rng.uniform(0, 1, (n, n)), 1)
        mats.append(d + d.T)
    return Problem.from_trace(trace.without_states(), *mats)


CASES = [{"codeterministic": True}, {"cannot_link": 0.6},
         {"deterministic": True, "codeterministic": True, "cannot_link": 0.8}]


@pytest.mark.parametrize("options", CASES)
def test_agrees_with_brute_force(options):
    rng = np.random.default_rng(7)
    verdicts = set()
    for _ in range(8):
        problem = random_problem(rng)
        for kp, kq in ((1, 2), (2, 1), (2, 2), (3, 2)):
            exact = CpSatSolver(params="num_workers:1,random_seed:0", hint="none",
                                **options).solve(problem, kp, kq)
            brute = BruteSolver(**options).solve(problem, kp, kq)
            assert (exact.status == "infeasible") == (brute.status == "infeasible")
            verdicts.add(brute.status)
            if brute.found:
                assert exact.J == pytest.approx(brute.J, abs=0.02)
                pc, qc = split_colours(problem, exact.labels)
                assert not violations(problem, pc, qc, CellConstraints(**options))
    assert verdicts == {"infeasible", "optimal"}  # both verdicts were exercised


def test_violations_name_the_broken_constraint():
    rng = np.random.default_rng(3)
    problem = random_problem(rng)
    one = np.zeros(problem.n_pick, dtype=np.int64), np.zeros(problem.n_place, dtype=np.int64)
    msgs = violations(problem, *one, CellConstraints(cannot_link=0.0))
    assert any("share colour" in m and "> 0.0" in m for m in msgs)
    assert not violations(problem, np.arange(problem.n_pick), np.arange(problem.n_place),
                          CellConstraints(True, None, True, 0.0))
