"""How sure a learned graph is, without ground truth, and when to say it is suspect.

Three things the trace itself can tell about a chosen graph:

* **margin** — how much better (in nats per transition) the chosen graph's description length
  is than that of the best candidate with another node count
  (:func:`vggc_cp.solvers.mdl.description_length`). A small margin means the criterion could
  as well have chosen a graph of another size.
* **plateau** — how many thresholds in a row of the merge path give exactly the chosen
  partition. When states separate cleanly, one partition survives a wide range of thresholds;
  a graph that exists at one threshold only is an accident of that threshold.
* **held-out prediction** — episodes are split in ``folds`` parts; the graph is learned again
  (same evidence, same threshold) without each part, the held-out observations are placed in
  the node of least mean distance (their own role), and every held-out transition
  ``(o, a, o')`` is checked against the graph: *predicted* when the edge ``(node(o), a)``
  exists and leads to ``node(o')``, *contradicted* when it exists and leads elsewhere.
  Contradictions mean that the visual evidence places renders of one situation in different
  nodes (or different situations in one).

:func:`assess` turns them into a :class:`Confidence` with a ``suspect`` flag and the reasons.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.merge import congruence_merge
from vggc_cp.solvers.pairs import CodedProblem, coded_merge
from vggc_cp.trace import PICK, PLACE


@dataclass(frozen=True)
class WarningRule:
    """When a graph is flagged as suspect (any one condition suffices).

    Attributes
    ----------
    min_plateau : int
        Fewer thresholds in a row giving the chosen partition.
    max_contradicted : float
        More held-out transitions contradicted by the graph.
    min_predicted : float
        Fewer held-out transitions predicted.
    min_obs_per_node : float
        Fewer observations per node (too few renders of each situation to tell them apart).
    min_margin : float
        A smaller description-length margin (nats per transition) to a graph of another size.
    """

    min_plateau: int = 3
    max_contradicted: float = 0.05
    min_predicted: float = 0.6
    min_obs_per_node: float = 2.0
    min_margin: float = 0.01


@dataclass(frozen=True)
class HeldOut:
    """Held-out prediction over ``folds`` parts of the episodes (shares of transitions)."""

    predicted: float
    contradicted: float
    unseen: float
    transitions: int
    folds: int


@dataclass(frozen=True)
class Confidence:
    """What the model-selection criterion saw, and the verdict.

    Attributes
    ----------
    criterion : str
        The selection criterion (``mdl``: least description length).
    margin : float
        Nats per transition to the best candidate with another node count (``inf`` if none).
    plateau : int
        Thresholds in a row (the chosen one included) that give the chosen partition.
    heldout : HeldOut or None
    obs_per_node : float
    suspect : bool
    reasons : tuple of str
        One phrase per failed condition of the :class:`WarningRule`.
    """

    criterion: str
    margin: float
    plateau: int
    heldout: HeldOut | None
    obs_per_node: float
    suspect: bool
    reasons: tuple[str, ...]

    def as_dict(self) -> dict:
        d = asdict(self)
        d["reasons"] = list(self.reasons)
        if not np.isfinite(self.margin):
            d["margin"] = None
        else:
            d["margin"] = round(float(self.margin), 6)
        return d

    def summary(self) -> str:
        """One line: the figures and the verdict."""
        ho = self.heldout
        held = ("" if ho is None else
                f", held-out predicted {100 * ho.predicted:.1f} % / contradicted "
                f"{100 * ho.contradicted:.1f} %")
        margin = "n/a" if not np.isfinite(self.margin) else f"{self.margin:.3f}"
        verdict = "SUSPECT: " + "; ".join(self.reasons) if self.suspect else "no warning"
        return (f"margin {margin} nats/transition, plateau {self.plateau}{held}, "
                f"{self.obs_per_node:.1f} obs/node -> {verdict}")


def plateau_length(labelings: list[np.ndarray | None], index: int) -> int:
    """Thresholds in a row around ``index`` whose labels equal those at ``index``.

    Labels of one partition are identical arrays (:meth:`Problem.labels_from_colours`
    numbers nodes in order of first appearance), so equality is exact comparison.
    """
    ref = labelings[index]
    if ref is None:
        return 0
    same = [lab is not None and np.array_equal(lab, ref) for lab in labelings]
    lo = index
    while lo > 0 and same[lo - 1]:
        lo -= 1
    hi = index
    while hi + 1 < len(same) and same[hi + 1]:
        hi += 1
    return hi - lo + 1


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
                  problem.dist_place[np.ix_(lq, lq)])
    return sub, idx


def heldout_prediction(problem: Problem, threshold: float, episode_of: np.ndarray,
                       folds: int = 5) -> HeldOut | None:
    """Held-out prediction of the merge graph at ``threshold`` (module docstring).

    Parameters
    ----------
    problem : Problem or CodedProblem
        A :class:`~vggc_cp.solvers.pairs.CodedProblem` is merged on its candidate pairs.
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
    predicted = contradicted = total = 0
    coded = isinstance(problem, CodedProblem)
    for f in range(folds):
        train = fold_of != f
        sub, kept = problem.restricted(train) if coded else subproblem(problem, train)
        if len(sub.act) == 0:
            continue
        labels, _ = (coded_merge if coded else congruence_merge)(sub, threshold)
        edges = {(int(u), int(a)): int(v)
                 for u, a, v in zip(labels[sub.src], sub.act, labels[sub.dst])}
        node_of = _localize(problem, kept, labels, ~train)
        held = ~train[problem.src]
        for s, a, d in zip(problem.src[held], problem.act[held], problem.dst[held]):
            total += 1
            v = edges.get((node_of[s], int(a)))
            if v is None:
                continue
            if v == node_of[d]:
                predicted += 1
            else:
                contradicted += 1
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


def assess(margin: float, plateau: int, heldout: HeldOut | None, obs_per_node: float,
           rule: WarningRule | None = None, criterion: str = "mdl") -> Confidence:
    """Apply the warning ``rule`` to the figures; returns the :class:`Confidence`."""
    rule = rule or WarningRule()
    reasons = []
    if plateau < rule.min_plateau:
        reasons.append(f"the chosen graph holds for {plateau} threshold(s) only "
                       f"(< {rule.min_plateau}): no stable partition")
    if np.isfinite(margin) and margin < rule.min_margin:
        reasons.append(f"description-length margin {margin:.3f} nats/transition "
                       f"(< {rule.min_margin}): a graph of another size explains the trace "
                       f"almost as well")
    if heldout is not None:
        if heldout.contradicted > rule.max_contradicted:
            reasons.append(f"{100 * heldout.contradicted:.1f} % of held-out transitions "
                           f"contradict the graph (> {100 * rule.max_contradicted:.0f} %): the "
                           f"visual evidence does not place renders of one situation together")
        if heldout.predicted < rule.min_predicted:
            reasons.append(f"only {100 * heldout.predicted:.1f} % of held-out transitions are "
                           f"predicted (< {100 * rule.min_predicted:.0f} %)")
    if obs_per_node < rule.min_obs_per_node:
        reasons.append(f"{obs_per_node:.1f} observations per node (< "
                       f"{rule.min_obs_per_node:g}): too few renders of each situation")
    return Confidence(criterion, float(margin), int(plateau), heldout, float(obs_per_node),
                      bool(reasons), tuple(reasons))
