"""Parts of a learned graph that no transition joins, moved onto the rest (beyond the paper).

A learned graph may fall into **parts**: sets of nodes that no transition of the recording
joins to the others (the connected components of its transitions, undirected). A recording
whose episodes start in regions of the task that never meet gives a right graph of several
parts (random-14 clean: two starts, a part of 21 nodes that the other part never reaches).
But a few episodes whose images all read alike and unlike the others' -- a randomized look
that drew them another light, an arm over the same sites in each -- make parts of their own,
parallel to nodes the rest of the graph has (random-1255 randomized, draw 54: two episodes on
three nodes of their own, 48 nodes for 45, a silent miss).

The actions tell the two apart without reading an image. The dynamics are deterministic, so
a part that is a copy of states the rest has must map onto the rest's nodes by its own
actions: an **embedding** sends each of its nodes to a node of the rest so that every
transition ``u -a-> v`` of the part lands on an edge ``f(u) -a-> f(v)`` of the rest
(:func:`part_embeddings`; the propagation follows the edges both ways from the part's first
node, and a step that could go two ways is no embedding). Such a move makes no edge the rest
does not have, so the graph stays bipartite and Exactly-One. A separate region of the task
rarely has one: over the tuning split, draws 47-54 and multifruit-4x6 robot s350-383 (1,435
runs, the graphs learned before this step) every part of a right graph had none (the right
graphs of several parts were random-14, -1180, -1235 and -1255, parts of 13 or 21 nodes),
while the parts that had one (six, of five runs) all belonged to wrong graphs.

:func:`move_lone_parts` moves every part with fewer observations than the largest onto its
embedding of least description length (:func:`~vggc_cp.solvers.mdl.description_length`,
the criterion that chooses the graph) where that is shorter than the graph as it is; a part
with no embedding, or whose move the code does not favour, stays, and so does a part as
large as the largest (which of the two would be the copy, nothing says). Only the problem's transitions and the
description length are read, never ground-truth states.
"""

from __future__ import annotations

import numpy as np

from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.mdl import description_length

#: Most embeddings of one part that :func:`move_lone_parts` weighs (a part of a few pick /
#: place nodes may fit many places of a large graph; the first found are kept).
MAX_EMBEDDINGS = 32


def graph_parts(problem: Problem, labels: np.ndarray) -> list[np.ndarray]:
    """The node sets of the parts of the graph ``labels`` induces (module docstring), the
    largest first (ties: the one with the lowest node first); nodes with no transition are
    in no part.

    >>> from vggc_cp.solvers.base import Problem
    >>> src = np.array([0, 1, 3]); dst = src + 1; act = np.array([0, 1, 0])
    >>> p = Problem(np.array([0, 1, 0, 0, 1]), src, act, dst, ("pick", "place"),
    ...             np.zeros((3, 3)), np.zeros((2, 2)))
    >>> [part.tolist() for part in graph_parts(p, np.array([0, 1, 2, 3, 4]))]
    [[0, 1, 2], [3, 4]]
    """
    from vggc_cp.vision.resets import components  # scipy: not at the CLI's start

    labels = np.asarray(labels, dtype=np.int64)
    s, d = labels[problem.src], labels[problem.dst]
    if not s.size:
        return []
    comp = components(int(labels.max()) + 1, zip(s.tolist(), d.tolist()))
    touched = np.unique(np.concatenate([s, d]))
    parts = [touched[comp[touched] == c] for c in np.unique(comp[touched])]
    return sorted(parts, key=lambda g: (-len(g), int(g[0])))


def part_embeddings(problem: Problem, labels: np.ndarray, part: np.ndarray,
                    limit: int = MAX_EMBEDDINGS) -> list[dict[int, int]]:
    """The embeddings of ``part`` (its nodes) into the rest of the graph ``labels`` induces
    (module docstring): maps from each of its nodes to a node outside it, in the order of
    the image of its first node; at most ``limit``.

    >>> from vggc_cp.solvers.base import Problem
    >>> src = np.array([0, 1, 3, 4]); dst = src + 1; act = np.array([0, 1, 0, 1])
    >>> roles = np.array([0, 1, 0, 0, 1, 0])
    >>> p = Problem(roles, src, act, dst, ("pick", "place"), np.zeros((4, 4)), np.zeros((2, 2)))
    >>> part_embeddings(p, np.array([0, 1, 2, 3, 4, 5]), np.array([3, 4, 5]))
    [{3: 0, 4: 1, 5: 2}]
    """
    labels = np.asarray(labels, dtype=np.int64)
    mine = set(part.tolist())
    s, a, d = labels[problem.src], np.asarray(problem.act), labels[problem.dst]
    inside = np.isin(s, part)
    ahead: dict[tuple[int, int], set[int]] = {}
    behind: dict[tuple[int, int], set[int]] = {}
    for u, k, v in zip(s[~inside].tolist(), a[~inside].tolist(), d[~inside].tolist()):
        ahead.setdefault((u, k), set()).add(v)
        behind.setdefault((v, k), set()).add(u)
    steps: dict[int, list[tuple[int, int, bool]]] = {}
    for u, k, v in zip(s[inside].tolist(), a[inside].tolist(), d[inside].tolist()):
        steps.setdefault(u, []).append((k, v, True))
        steps.setdefault(v, []).append((k, u, False))
    first = int(part[0])
    role = np.full(int(labels.max()) + 1, -1)
    role[labels] = np.asarray(problem.roles)
    out = []
    for start in np.flatnonzero(role == role[first]).tolist():
        if start in mine:
            continue
        f = {first: start}
        todo = [first]
        ok = True
        while todo and ok:
            u = todo.pop()
            for k, v, forward in steps.get(u, ()):
                there = (ahead if forward else behind).get((f[u], k), set())
                if v in f:
                    ok = f[v] in there
                elif len(there) == 1:
                    f[v] = next(iter(there))
                    todo.append(v)
                else:
                    ok = False
                if not ok:
                    break
        if ok and len(f) == len(mine):
            out.append(f)
            if len(out) >= limit:
                break
    return out


def move_lone_parts(problem: Problem, labels: np.ndarray) -> tuple[np.ndarray, int]:
    """``labels`` with every part smaller than the largest (in observations) moved onto its
    embedding of least description length where that is shorter than the graph as it is
    (module docstring), each in turn (the smallest first), and how many were moved. A part
    as large as the largest stays: which of the two would be the copy, nothing says. Node
    numbers are kept (a moved part's nodes are left empty).

    Examples
    --------
    Three episodes through nodes 0-1-2 and a fourth, the same actions, through nodes 3-4-5
    that no transition joins to them: moved onto 0-1-2, the code is shorter by three nodes.

    >>> from vggc_cp.solvers.base import Problem
    >>> src = np.array([0, 1, 3, 4, 6, 7, 9, 10]); dst = src + 1
    >>> act = np.array([0, 1] * 4)
    >>> p = Problem(np.array([0, 1, 0] * 4), src, act, dst, ("pick", "place"),
    ...             np.zeros((8, 8)), np.zeros((4, 4)))
    >>> labels, moved = move_lone_parts(p, np.array([0, 1, 2] * 3 + [3, 4, 5]))
    >>> labels.tolist()[-3:], moved
    ([0, 1, 2], 1)
    """
    labels = np.asarray(labels, dtype=np.int64)
    parts = graph_parts(problem, labels)
    if len(parts) < 2:
        return labels, 0
    # a part's size: the observations on its nodes; one as large as the largest may be the
    # original as well as the copy, and is left as it is
    seen = np.bincount(labels, minlength=int(labels.max()) + 1)
    size = [int(seen[g].sum()) for g in parts]
    largest = max(size)
    now = description_length(problem, labels)
    moved = 0
    for _, part in sorted(((n, g) for n, g in zip(size, parts) if n < largest),
                          key=lambda x: (x[0], int(x[1][0]))):
        best = None
        for f in part_embeddings(problem, labels, part):
            lut = np.arange(int(labels.max()) + 1)
            lut[list(f)] = list(f.values())
            flipped = lut[labels]
            length = description_length(problem, flipped)
            if length < now and (best is None or length < best[0]):
                best = (length, flipped)
        if best is not None:
            now, labels = best
            moved += 1
    return labels, moved
