"""Descriptor codes: a problem whose distances are tables of codes, and the threshold grid
read from them (issue 27).

The footprint evidence describes an observation by per-site presence and colour values,
nearly all exactly 0 or 1: renders of one situation share their descriptor to the bit.
Observations of one role with identical descriptors get one *code*; the distance is a
function of the two descriptors, so ``d(o, o') = table[code(o), code(o')]`` exactly, with a
``(G, G)`` table (G codes, a few hundred where the trace has thousands of observations).
:class:`CodedProblem` holds roles, transitions, codes and tables; it answers what the
pipeline asks of a :class:`~vggc_cp.solvers.base.Problem` and builds the dense one on demand
(:meth:`CodedProblem.dense`, for the grid solvers and ``solve --exact``).
:func:`coded_threshold_grid` is :func:`vggc_cp.pipeline.threshold_grid` computed from the
tables, bit for bit, without the ``(n, n)`` matrices. The merge path on candidate pairs of
codes is :mod:`vggc_cp.solvers.pairs`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vggc_cp.graph import TaskGraph
from vggc_cp.recorded import recorded_facts
from vggc_cp.solvers.base import Problem, Readings, kept_refusals, kept_resets, set_role_index
from vggc_cp.trace import PICK, PLACE


@dataclass(frozen=True, eq=False)
class CodedProblem:
    """A :class:`~vggc_cp.solvers.base.Problem` whose distances are tables of codes.

    Attributes
    ----------
    roles : ndarray of int8, shape (N,)
    src, act, dst : ndarray of int64, shape (|D|,)
    action_names : tuple of str
    codes_pick, codes_place : ndarray of int64, shapes (n_pick,), (n_place,)
        Code of every observation of the role (rows in the order of ``pick_obs``,
        ``place_obs``).
    table_pick, table_place : ndarray of float64, shapes (G_pick, G_pick), (G_place, G_place)
        Distance between codes; zero diagonal.
    action_colour : ndarray of int64, shape (A,), or None
        As :attr:`Problem.action_colour`.
    readings : Readings or None
        As :attr:`Problem.readings`.
    refused : tuple of (int, int)
        As :attr:`Problem.refused`.
    resets : tuple of (int, int)
        As :attr:`Problem.resets`.
    """

    roles: np.ndarray
    src: np.ndarray
    act: np.ndarray
    dst: np.ndarray
    action_names: tuple[str, ...]
    codes_pick: np.ndarray
    codes_place: np.ndarray
    table_pick: np.ndarray
    table_place: np.ndarray
    #: what the evidence says about how it ran (e.g. the footprints' working resolution)
    notes: tuple[str, ...] = ()
    action_colour: np.ndarray | None = None
    readings: Readings | None = None
    refused: tuple[tuple[int, int], ...] = ()
    resets: tuple[tuple[int, int], ...] = ()
    pick_obs: np.ndarray = field(init=False)
    place_obs: np.ndarray = field(init=False)
    local: np.ndarray = field(init=False)

    def __post_init__(self):
        pick, place = set_role_index(self)
        for name, codes, table, n in (("pick", self.codes_pick, self.table_pick, len(pick)),
                                      ("place", self.codes_place, self.table_place,
                                       len(place))):
            if np.shape(codes) != (n,):
                raise ValueError(f"codes_{name} has shape {np.shape(codes)}, expected ({n},)")
            g = int(np.max(codes)) + 1 if n else 0
            if np.ndim(table) != 2 or np.shape(table)[0] != np.shape(table)[1] \
                    or np.shape(table)[0] < g:
                raise ValueError(f"table_{name} has shape {np.shape(table)}, expected a square "
                                 f"table of at least {g} codes")

    @classmethod
    def from_trace(cls, trace, codes: tuple[np.ndarray, np.ndarray],
                   tables: tuple[np.ndarray, np.ndarray], notes: tuple[str, ...] = (),
                   action_colour: np.ndarray | None = None, readings: Readings | None = None
                   ) -> CodedProblem:
        """From a trace (its ``states`` are not copied), per-role codes and tables."""
        src, act, dst = trace.transitions()
        facts = recorded_facts(trace)
        return cls(trace.roles(), src, act, dst, trace.action_names,
                   np.asarray(codes[0], dtype=np.int64), np.asarray(codes[1], dtype=np.int64),
                   np.asarray(tables[0], dtype=np.float64),
                   np.asarray(tables[1], dtype=np.float64), tuple(notes), action_colour,
                   readings, facts.refusals, facts.resets)

    n_obs = Problem.n_obs
    n_pick = Problem.n_pick
    n_place = Problem.n_place
    n_actions = Problem.n_actions
    labels_from_colours = Problem.labels_from_colours

    def codes(self, role: int) -> np.ndarray:
        return self.codes_pick if role == PICK else self.codes_place

    def table(self, role: int) -> np.ndarray:
        return self.table_pick if role == PICK else self.table_place

    def graph(self, labels: np.ndarray) -> TaskGraph:
        """The task graph that ``labels`` induces on the transitions."""
        return TaskGraph.from_labels(labels, self.roles, self.src, self.act, self.dst,
                                     self.action_names)

    def visual_score(self, labels: np.ndarray) -> float:
        """The paper's J (:func:`vggc_cp.score.visual_score`) from code counts: equal to the
        dense one up to rounding."""
        labels = np.asarray(labels)
        total = 0.0
        for role in (PICK, PLACE):
            obs = self.pick_obs if role == PICK else self.place_obs
            if len(obs) == 0:
                continue
            codes, table = self.codes(role), self.table(role)
            ids, inv = np.unique(labels[obs], return_inverse=True)
            counts = np.zeros((len(ids), len(table)))
            np.add.at(counts, (inv, codes), 1.0)
            size = counts.sum(axis=1)
            within = ((counts @ table) * counts).sum(axis=1)
            big = size >= 2
            total += float(np.sum(within[big] / (size[big] * (size[big] - 1))))
        return total

    def dense(self) -> Problem:
        """The :class:`Problem` with ``(n, n)`` distance matrices (quadratic memory)."""
        return Problem(self.roles, self.src, self.act, self.dst, self.action_names,
                       self.table_pick[np.ix_(self.codes_pick, self.codes_pick)],
                       self.table_place[np.ix_(self.codes_place, self.codes_place)],
                       self.notes, self.action_colour, self.readings, self.refused,
                       self.resets)

    def restricted(self, keep: np.ndarray) -> tuple[CodedProblem, np.ndarray]:
        """The problem on the observations ``keep`` (bool, shape (N,)): transitions with both
        ends kept, the same tables. Returns it and the kept indices (as
        :func:`vggc_cp.solvers.heldout.subproblem`)."""
        idx = np.flatnonzero(keep)
        new = np.full(self.n_obs, -1, dtype=np.int64)
        new[idx] = np.arange(len(idx))
        tk = keep[self.src] & keep[self.dst]
        roles = self.roles[idx]
        pick, place = idx[roles == PICK], idx[roles == PLACE]
        sub = CodedProblem(roles, new[self.src[tk]], self.act[tk], new[self.dst[tk]],
                           self.action_names, self.codes_pick[self.local[pick]],
                           self.codes_place[self.local[place]], self.table_pick,
                           self.table_place, action_colour=self.action_colour,
                           readings=None if self.readings is None
                           else self.readings.restricted(idx),
                           refused=kept_refusals(self.refused, new),
                           resets=kept_resets(self.resets, new))
        return sub, idx


def coded_values(problem: CodedProblem) -> tuple[np.ndarray, np.ndarray]:
    """Every within-role pair distance as ``(values, counts)``: the distinct entries of the
    tables that some pair of observations takes, and how many pairs take each."""
    vals, counts = [], []
    for role in (PICK, PLACE):
        codes, table = problem.codes(role), problem.table(role)
        size = np.bincount(codes, minlength=len(table)).astype(np.float64)
        gi, hi = np.triu_indices(len(table))
        n = np.where(gi == hi, size[gi] * (size[gi] - 1) / 2, size[gi] * size[hi])
        keep = n > 0
        vals.append(table[gi[keep], hi[keep]])
        counts.append(n[keep])
    v, c = np.concatenate(vals), np.concatenate(counts)
    uniq, inv = np.unique(v, return_inverse=True)
    return uniq, np.bincount(inv, weights=c)


def weighted_quantile(values: np.ndarray, counts: np.ndarray, q: float) -> float:
    """``np.quantile`` (method ``linear``) of the sample holding ``counts[k]`` copies of
    ``values[k]`` (``values`` ascending), computed without building it; bit-identical."""
    total = int(round(float(counts.sum())))
    if total == 0:
        raise ValueError("quantile of an empty sample")
    virtual = (total - 1) * float(q)
    prev = float(np.floor(virtual))
    cum = np.cumsum(counts)

    def at(k: int) -> float:
        return float(values[int(np.searchsorted(cum, k, side="right"))])

    if virtual >= total - 1:
        return at(total - 1)
    a, b, t = at(int(prev)), at(int(prev) + 1), virtual - prev
    diff = b - a
    return b - diff * (1 - t) if t >= 0.5 else a + diff * t


def coded_noise_scale(problem: CodedProblem) -> float:
    """:func:`vggc_cp.solvers.merge.noise_scale` from the tables: an observation's nearest
    neighbour is 0 away when its code has another member, else its code's nearest code."""
    nn = []
    for role in (PICK, PLACE):
        codes, table = problem.codes(role), problem.table(role)
        if len(codes) <= 1:
            continue
        size = np.bincount(codes, minlength=len(table))
        present = size > 0
        masked = np.where(present[None, :], table, np.inf)
        masked = masked + np.diag(np.full(len(table), np.inf))
        nearest = np.where(size >= 2, 0.0, masked.min(axis=1))
        nn.append(nearest[codes])
    return float(np.median(np.concatenate(nn))) if nn else 0.0


def coded_threshold_grid(problem: CodedProblem, steps: int = 24,
                         top_quantile: float = 0.9) -> np.ndarray:
    """:func:`vggc_cp.pipeline.threshold_grid` from the tables (bit-identical)."""
    values, counts = coded_values(problem)
    lo = coded_noise_scale(problem)
    hi = weighted_quantile(values, counts, top_quantile) if counts.sum() > 0 else 0.0
    lo = max(lo, hi / 100) if hi > 0 else (lo if lo > 0 else 1e-3)
    hi = max(hi, lo * 1.01)
    return np.geomspace(lo, hi, int(steps))
