"""The cell's constraints evaluated directly on a colouring, and exhaustive enumeration.

This module is the ground truth the exact CP-SAT model (:mod:`vggc_cp.solvers.cpsat`) is
tested against, and the solver of last resort for tiny problems.

A *cell colouring* gives every pick observation a colour in ``0..k_pick-1`` and every place
observation a colour in ``0..k_place-1``. It is **valid** when

* **Exactly-One** — for every ordered pair of colours ``(c, c')`` (pick -> place for pick
  transitions, place -> pick for place transitions) the transitions from a ``c``-observation
  to a ``c'``-observation carry one action label only;
* **deterministic** (option) — for every colour ``c`` and action ``a``, the transitions
  ``(o, a, o')`` with ``o`` coloured ``c`` all reach one colour;
* **max_actions = K** (option) — every colour (node) has at most ``K`` distinct action labels
  on its outgoing edges.

Bipartiteness holds by construction (colours are per role). Colourings are enumerated up to
renaming of the colours within each role (restricted growth strings), which is exact because
validity and the visual score J do not depend on the names of the colours.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.score import visual_score_role
from vggc_cp.solvers.base import (
    INFEASIBLE,
    OPTIMAL,
    Problem,
    Solver,
    SolveResult,
    register_solver,
)


@dataclass(frozen=True)
class CellConstraints:
    """Options that restrict the valid colourings of a cell beyond Exactly-One.

    Attributes
    ----------
    deterministic : bool
        One node and one action lead to one node.
    max_actions : int or None
        At most this many distinct action labels on the outgoing edges of every node.
    codeterministic : bool
        One action into a node comes from one node (determinism of the reversed graph; holds
        for pick/place rearrangement: the state before placing into region r is the state
        after, with that object lifted).
    cannot_link : float or None
        Visual evidence: two observations whose visual distance exceeds this never share a
        node.
    """

    deterministic: bool = False
    max_actions: int | None = None
    codeterministic: bool = False
    cannot_link: float | None = None

    def __post_init__(self):
        if self.max_actions is not None and self.max_actions < 1:
            raise VggcError(f"max_actions must be at least 1, got {self.max_actions}")
        if self.cannot_link is not None and not self.cannot_link >= 0:
            raise VggcError(f"cannot_link must be a distance >= 0, got {self.cannot_link}")


def split_colours(problem: Problem, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-role colours ``(pick_colour (n_pick,), place_colour (n_place,))`` from global labels.

    Colours are renumbered ``0..`` within each role in order of first appearance.
    """
    labels = np.asarray(labels, dtype=np.int64)
    return (_first_appearance(labels[problem.pick_obs]),
            _first_appearance(labels[problem.place_obs]))


def _first_appearance(colours: np.ndarray) -> np.ndarray:
    out = np.empty(len(colours), dtype=np.int64)
    seen: dict[int, int] = {}
    for i, c in enumerate(colours.tolist()):
        out[i] = seen.setdefault(c, len(seen))
    return out


def fit_colouring(problem: Problem, labels: np.ndarray, k_pick: int, k_place: int,
                  constraints: CellConstraints = CellConstraints()
                  ) -> tuple[np.ndarray, np.ndarray, int]:
    """Squeeze a colouring into a cell by merging colours: ``(pick, place, n_violations)``.

    While a role has more colours than the cell allows, the two of its colours whose merge
    leaves the fewest violated constraints are merged (greedy, ties: the lowest pair). A valid
    colouring of a larger cell so becomes a near-valid one of a smaller cell -- a start for a
    solver that can repair it, never a proof of anything.

    Parameters
    ----------
    labels : ndarray of int, shape (N,)
        Global labels (any numbering; :func:`split_colours` renumbers them per role).
    """
    cols = list(split_colours(problem, labels))
    for r, k in ((0, max(int(k_pick), 1)), (1, max(int(k_place), 1))):
        while len(np.unique(cols[r])) > k:
            present = np.unique(cols[r]).tolist()
            best = None
            for i, a in enumerate(present):
                for b in present[i + 1:]:
                    trial = list(cols)
                    trial[r] = np.where(cols[r] == b, a, cols[r])
                    n = len(violations(problem, trial[0], trial[1], constraints))
                    if best is None or n < best[0]:
                        best = (n, trial[r])
            cols[r] = _first_appearance(best[1])
    return cols[0], cols[1], len(violations(problem, cols[0], cols[1], constraints))


def violations(problem: Problem, pick_colour: np.ndarray, place_colour: np.ndarray,
               constraints: CellConstraints = CellConstraints()) -> list[str]:
    """Every violated cell constraint of a per-role colouring (empty list: valid).

    Parameters
    ----------
    pick_colour : ndarray of int, shape (n_pick,)
    place_colour : ndarray of int, shape (n_place,)
    """
    colour = np.empty(problem.n_obs, dtype=np.int64)
    colour[problem.pick_obs] = pick_colour
    colour[problem.place_obs] = place_colour
    pair: dict[tuple, set] = {}
    succ: dict[tuple, set] = {}
    pred: dict[tuple, set] = {}
    out_actions: dict[tuple, set] = {}
    for s, a, d in zip(problem.src.tolist(), problem.act.tolist(), problem.dst.tolist()):
        r = int(problem.roles[s])
        cs, cd = int(colour[s]), int(colour[d])
        pair.setdefault((r, cs, cd), set()).add(a)
        succ.setdefault((r, cs, a), set()).add(cd)
        pred.setdefault((r, cd, a), set()).add(cs)
        out_actions.setdefault((r, cs), set()).add(a)
    role = ("pick", "place")
    out = [f"{role[r]} colour {c} -> colour {c2} carries actions {sorted(acts)}"
           for (r, c, c2), acts in pair.items() if len(acts) > 1]
    if constraints.deterministic:
        out += [f"{role[r]} colour {c} with action {problem.action_names[a]} reaches colours "
                f"{sorted(cs)}" for (r, c, a), cs in succ.items() if len(cs) > 1]
    if constraints.codeterministic:
        out += [f"{role[1 - r]} colour {c} is entered by action {problem.action_names[a]} from "
                f"colours {sorted(cs)}" for (r, c, a), cs in pred.items() if len(cs) > 1]
    if constraints.max_actions is not None:
        out += [f"{role[r]} colour {c} has {len(acts)} distinct actions > {constraints.max_actions}"
                for (r, c), acts in out_actions.items() if len(acts) > constraints.max_actions]
    if constraints.cannot_link is not None:
        sides = ((pick_colour, problem.dist_pick, problem.pick_obs),
                 (place_colour, problem.dist_place, problem.place_obs))
        for r, (cols, dist, obs) in enumerate(sides):
            cols = np.asarray(cols)
            far = (cols[:, None] == cols[None, :]) & (dist > constraints.cannot_link)
            for i, j in zip(*np.nonzero(np.triu(far, 1))):
                out.append(f"{role[r]} observations {int(obs[i])} and {int(obs[j])} share colour "
                           f"{int(cols[i])} at distance {dist[i, j]:.4f} > "
                           f"{constraints.cannot_link}")
    return out


def restricted_growth_strings(n: int, k: int) -> Iterator[tuple[int, ...]]:
    """All colourings of ``n`` items with at most ``k`` colours, one per partition.

    A restricted growth string has ``s[0] = 0`` and ``s[i] <= max(s[:i]) + 1``; there are
    ``sum_{j<=k} S(n, j)`` of them (Stirling numbers of the second kind).
    """
    if n == 0:
        yield ()
        return
    if k < 1:
        return
    s = [0] * n

    def rec(i: int, top: int) -> Iterator[tuple[int, ...]]:
        if i == n:
            yield tuple(s)
            return
        for c in range(min(top + 2, k)):
            s[i] = c
            yield from rec(i + 1, max(top, c))

    yield from rec(1, 0)


def count_partitions(n: int, k: int) -> int:
    """``sum_{j<=k} S(n, j)``: how many colourings :func:`restricted_growth_strings` yields."""
    row = [1] + [0] * k  # S(0, j)
    for _ in range(n):
        new = [0] * (k + 1)
        for j in range(1, k + 1):
            new[j] = j * row[j] + row[j - 1]
        row = new
    return sum(row) if n else 1


@dataclass(frozen=True)
class BruteOutcome:
    """Result of :func:`enumerate_cell`: the best valid colouring, if any, and counts."""

    pick_colour: np.ndarray | None
    place_colour: np.ndarray | None
    J: float
    n_valid: int
    n_checked: int

    @property
    def feasible(self) -> bool:
        return self.pick_colour is not None


def enumerate_cell(problem: Problem, k_pick: int, k_place: int,
                   constraints: CellConstraints = CellConstraints(),
                   max_colourings: int = 2_000_000) -> BruteOutcome:
    """Enumerate every colouring of the cell (up to renaming) and keep the lowest J.

    Raises
    ------
    VggcError
        When the number of colourings exceeds ``max_colourings``.
    """
    n_pp = count_partitions(problem.n_pick, k_pick)
    n_pl = count_partitions(problem.n_place, k_place)
    if n_pp * n_pl > max_colourings:
        raise VggcError(f"brute force: {n_pp} x {n_pl} colourings exceed the limit "
                        f"{max_colourings}")
    pick_sets = [np.array(s, dtype=np.int64)
                 for s in restricted_growth_strings(problem.n_pick, k_pick)]
    place_sets = [np.array(s, dtype=np.int64)
                  for s in restricted_growth_strings(problem.n_place, k_place)]
    j_pick = [visual_score_role(problem.dist_pick, s) for s in pick_sets]
    j_place = [visual_score_role(problem.dist_place, s) for s in place_sets]
    best = (math.inf, None, None)
    n_valid = 0
    for pi, ps in enumerate(pick_sets):
        for qi, qs in enumerate(place_sets):
            if violations(problem, ps, qs, constraints):
                continue
            n_valid += 1
            J = j_pick[pi] + j_place[qi]
            if J < best[0]:
                best = (J, ps, qs)
    return BruteOutcome(best[1], best[2], best[0] if best[1] is not None else math.nan,
                        n_valid, len(pick_sets) * len(place_sets))


@register_solver
class BruteSolver(Solver):
    """Exhaustive enumeration of a cell: exact, for tiny problems only.

    Parameters
    ----------
    deterministic, max_actions, codeterministic, cannot_link :
        See :class:`CellConstraints`.
    max_colourings : int
        Refuse (:class:`VggcError`) cells with more colourings than this.
    """

    name = "brute"

    def __init__(self, deterministic: bool = False, max_actions: int | None = None,
                 max_colourings: int = 2_000_000, codeterministic: bool = False,
                 cannot_link: float | None = None):
        self.constraints = CellConstraints(deterministic, max_actions, codeterministic,
                                           cannot_link)
        self.max_colourings = max_colourings

    def _solve(self, problem: Problem, k_pick: int, k_place: int) -> SolveResult:
        out = enumerate_cell(problem, k_pick, k_place, self.constraints, self.max_colourings)
        stats = {"valid_colourings": out.n_valid, "colourings": out.n_checked}
        if not out.feasible:
            return SolveResult(None, k_pick, k_place, math.nan, INFEASIBLE, self.name,
                               stats=stats)
        labels = problem.labels_from_colours(out.pick_colour, out.place_colour)
        return SolveResult(labels, k_pick, k_place, problem.visual_score(labels), OPTIMAL,
                           self.name, bound=out.J, stats=stats)


__all__ = ["BruteOutcome", "BruteSolver", "CellConstraints", "count_partitions",
           "enumerate_cell", "restricted_growth_strings", "split_colours", "violations"]
