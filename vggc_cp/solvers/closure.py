"""Closing the join of two nodes of a committed partition, with no threshold.

The doubts (:mod:`vggc_cp.solvers.doubts`, :mod:`vggc_cp.solvers.read_doubts`) ask of a
learned graph what the merge (:mod:`vggc_cp.solvers.merge`) would have to do to make two of
its nodes one: which other nodes the congruence closure (determinism and co-determinism,
transitively) would join with them, or that Exactly-One, the hand's colour or the work cap
forbids it. :class:`PartitionClosure` answers with the merge's own clusters and closure.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.merge import _Clusters, _try_merge


class PartitionClosure:
    """The congruence closure of joining two nodes of a given partition, with no threshold.

    The partition ``labels`` is committed once (as :func:`congruence_merge` would have built
    it); :meth:`join` then closes the merge of two of its nodes exactly as the merge does
    (determinism, co-determinism, transitively) and says which nodes would have to become
    one, or that Exactly-One (or the work cap) forbids it. Nothing is committed by
    :meth:`join`: queries are independent.

    Parameters
    ----------
    problem : Problem
    labels : ndarray of int, shape (N,)
        A partition in which every node holds one role.
    max_work : int
        Cap on forced merges examined per query (a larger closure is refused as ``work``).
    """

    def __init__(self, problem: Problem, labels: np.ndarray, max_work: int = 2_000):
        self.labels = np.asarray(labels, dtype=np.int64)
        self.max_work = int(max_work)
        self._cl = _Clusters(problem)
        groups: dict[int, list[int]] = {}
        first: dict[int, int] = {}
        for x, u in enumerate(self.labels.tolist()):
            h = first.setdefault(u, x)
            if h != x:
                groups.setdefault(h, []).append(x)
        self._cl.commit(groups)
        self.first = first  # node -> an observation of it (its root)

    def join(self, a: int, b: int) -> tuple[list[list[int]] | None, str]:
        """Close the merge of nodes ``a`` and ``b`` (node ids of ``labels``).

        Returns
        -------
        groups : list of list of int, or None
            The node groups that become one node (each sorted, ``[a, b, ...]``'s group
            first), or None when the merge is forbidden.
        reason : str
            ``""``, or why it is forbidden: ``exactly_one``, ``distance`` (two roles),
            ``hand`` (the hands hold different colours) or ``work``.
        """
        res, why = _try_merge(self._cl, self.first[int(a)], self.first[int(b)], float("inf"),
                              self.max_work)
        if res is None:
            return None, why
        lab = self.labels
        groups = [sorted({int(lab[h]), *(int(lab[r]) for r in rs)}) for h, rs in res.items()]
        groups.sort(key=lambda g: (int(a) not in g, g))
        return groups, ""
