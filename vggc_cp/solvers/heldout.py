"""Held-out prediction: does a graph learned without some episodes predict their transitions?

The episodes are split into ``folds`` parts (episode ``e`` in part ``e % folds``). For each
part the merge runs at the chosen threshold on the rest of the trace (:func:`subproblem`, or
:meth:`~vggc_cp.solvers.coded.CodedProblem.restricted`); every left-out observation is
placed in the node (of its role) of least mean distance to the node's members, and every
left-out transition ``(o, a, o')`` is *predicted* when the edge ``(node(o), a)`` exists and
leads to ``node(o')``, *contradicted* when it exists and leads elsewhere, *unseen* when it
does not exist (:func:`heldout_prediction`, :func:`fold_prediction`). The contradicted ones
name chosen nodes that might be one state (:func:`disputed_pairs`, :class:`HeldOut`'s
``disputed``). :mod:`vggc_cp.solvers.confidence` runs it in its fold re-runs and judges
its shares among the fixed checks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vggc_cp.solvers.base import Problem, kept_refusals, kept_resets
from vggc_cp.solvers.coded import CodedProblem
from vggc_cp.solvers.merge import congruence_merge
from vggc_cp.solvers.pairs import coded_merge
from vggc_cp.trace import PICK, PLACE


@dataclass(frozen=True)
class HeldOut:
    """Held-out prediction over ``folds`` parts of the episodes (shares of transitions).

    ``disputed`` lists, for the contradicted transitions ``(o, a, o')``, the chosen node the
    fold's graph predicted ``o'`` in (through the node holding most of that graph's node)
    and the chosen node ``o'`` is in, when they differ, with how many transitions say so:
    ``(predicted, observed, count)``, most often first. Those are nodes that might be one
    state (:func:`~vggc_cp.solvers.doubts.disputed_doubts`)."""

    predicted: float
    contradicted: float
    unseen: float
    transitions: int
    folds: int
    disputed: tuple[tuple[int, int, int], ...] = ()


def subproblem(problem: Problem, keep: np.ndarray) -> tuple[Problem, np.ndarray]:
    """The problem restricted to the observations ``keep`` (bool, shape (N,)): transitions with
    both ends kept, distances of the kept observations. Returns it and the kept indices."""
    idx = np.flatnonzero(keep)
    new = np.full(problem.n_obs, -1, dtype=np.int64)
    new[idx] = np.arange(len(idx))
    tk = keep[problem.src] & keep[problem.dst]
    roles = problem.roles[idx]
    pick = idx[roles == PICK]
    place = idx[roles == PLACE]
    lp, lq = problem.local[pick], problem.local[place]
    sub = Problem(roles, new[problem.src[tk]], problem.act[tk], new[problem.dst[tk]],
                  problem.action_names, problem.dist_pick[np.ix_(lp, lp)],
                  problem.dist_place[np.ix_(lq, lq)], action_colour=problem.action_colour,
                  readings=None if problem.readings is None else problem.readings.restricted(idx),
                  refused=kept_refusals(problem.refused, new),
                  resets=kept_resets(problem.resets, new))
    return sub, idx


def heldout_prediction(problem: Problem, threshold: float, episode_of: np.ndarray,
                       folds: int = 5) -> HeldOut | None:
    """Held-out prediction of the merge graph at ``threshold`` (module docstring).

    Parameters
    ----------
    problem : Problem or CodedProblem
        A :class:`~vggc_cp.solvers.coded.CodedProblem` is merged on its candidate pairs.
    threshold : float
    episode_of : ndarray of int, shape (N,)
        Episode of every observation; episode ``e`` is held out in fold ``e % folds``.
    folds : int

    Returns None when the trace has fewer than two episodes.
    """
    episode_of = np.asarray(episode_of, dtype=np.int64)
    n_ep = int(episode_of.max()) + 1 if len(episode_of) else 0
    folds = min(int(folds), n_ep)
    if folds < 2:
        return None
    fold_of = episode_of % folds
    counts = np.zeros(3, dtype=np.int64)
    coded = isinstance(problem, CodedProblem)
    for f in range(folds):
        train = fold_of != f
        sub, kept = problem.restricted(train) if coded else subproblem(problem, train)
        if len(sub.act) == 0:
            continue
        labels, _ = (coded_merge if coded else congruence_merge)(sub, threshold)
        # (a transition lies in one episode, so in one fold)
        counts += fold_prediction(problem, kept, labels, sub, train)
    predicted, contradicted, total = (int(c) for c in counts)
    if total == 0:
        return None
    return HeldOut(predicted / total, contradicted / total,
                   (total - predicted - contradicted) / total, total, folds)


def _localize(problem: Problem, kept: np.ndarray, labels: np.ndarray,
              held: np.ndarray) -> dict[int, int]:
    """Node of every held-out observation: the node (of its role) of least mean distance."""
    out: dict[int, int] = {}
    kept_roles = problem.roles[kept]
    coded = isinstance(problem, CodedProblem)
    for role in (PICK, PLACE):
        members = kept[kept_roles == role]
        queries = np.flatnonzero(held & (problem.roles == role))
        if len(members) == 0 or len(queries) == 0:
            continue
        node = labels[kept_roles == role]
        ids, inv = np.unique(node, return_inverse=True)
        if coded:  # the members' code counts per node: no (queries, members) block
            codes, table = problem.codes(role), problem.table(role)
            counts = np.zeros((len(table), len(ids)))
            np.add.at(counts, (codes[problem.local[members]], inv), 1.0)
            mean = table[codes[problem.local[queries]]] @ counts
            mean /= counts.sum(axis=0)
        else:
            dist = problem.dist_pick if role == PICK else problem.dist_place
            onehot = np.zeros((len(members), len(ids)))
            onehot[np.arange(len(members)), inv] = 1.0
            mean = dist[np.ix_(problem.local[queries], problem.local[members])] @ onehot
            mean /= onehot.sum(axis=0)
        for q, k in zip(queries, np.argmin(mean, axis=1)):
            out[int(q)] = int(ids[k])
    return out


def fold_prediction(problem: Problem, kept: np.ndarray, lab: np.ndarray, sub: Problem,
             train: np.ndarray, wrong: list | None = None) -> np.ndarray:
    """Predicted, contradicted and total left-out transitions of one fold re-run; with
    ``wrong``, each contradicted one's predicted node (of ``lab``) and ``o'`` are appended."""
    edges = {(int(u), int(a)): int(v) for u, a, v in zip(lab[sub.src], sub.act, lab[sub.dst])}
    node_of = _localize(problem, kept, lab, ~train)
    held = ~train[problem.src] & ~train[problem.dst]  # both ends left out (a block's edge)
    predicted = contradicted = total = 0
    for s, a, d in zip(problem.src[held], problem.act[held], problem.dst[held]):
        total += 1
        v = edges.get((node_of[s], int(a)))
        if v is None:
            continue
        if v == node_of[d]:
            predicted += 1
        else:
            contradicted += 1
            if wrong is not None:
                wrong.append((v, int(d)))
    return np.array([predicted, contradicted, total], dtype=np.int64)


def disputed_pairs(labels: np.ndarray, kept: np.ndarray, lab: np.ndarray,
                   wrong: list) -> list[tuple[int, int]]:
    """Chosen-node pairs ``(predicted, observed)`` of one fold's contradicted transitions
    (:class:`HeldOut`): the fold's node ``v`` stands for the chosen node most of its kept
    observations are in."""
    out = []
    for v, d in wrong:
        members = labels[kept[lab == v]]
        if not len(members):
            continue
        ids, n = np.unique(members, return_counts=True)
        x, y = int(ids[np.argmax(n)]), int(labels[d])
        if x != y:
            out.append((x, y))
    return out
