"""The package's face: the few entry points a notebook needs (``import vggc_cp as vg``).

``vg.load_trace`` reads a ``trace.npz``, ``vg.learn_graph`` runs the default pipeline of
``vggc-cp solve`` (:mod:`vggc_cp.pipeline`) and returns a :class:`Learned`, ``vg.plan`` plans
on it, ``vg.evaluate`` scores it against the trace's ground truth. The package loads this
module (and numpy, the solvers, ...) only when one of these names is first used.

Examples
--------
>>> import vggc_cp as vg
>>> trace = vg.load_trace("data/fruit-2x3.npz")
>>> learned = vg.learn_graph(trace)                 # what `vggc-cp solve` does
>>> learned.graph.n_nodes, learned.confidence.suspect
(6, False)
>>> g = learned.to_networkx()                       # a networkx MultiDiGraph
>>> sorted(g.nodes[0])
['medoid', 'role', 'size']
>>> sorted({role for _, role in g.nodes(data="role")})
['pick', 'place']
>>> plan = vg.plan(learned, start_obs=0, goal_obs=4)
>>> [action for _, action, _ in plan]
['pick_red_1', 'place_red_2']
>>> import os, tempfile
>>> learned.save(os.path.join(tempfile.mkdtemp(), "s.json"))   # the bytes of `solve -o`
>>> vg.evaluate(trace, learned).exec
1.0

Settings are keyword arguments or a :class:`LearnConfig`; a wrong name lists the choices:

>>> vg.learn_graph(trace, rule="MDL")
Traceback (most recent call last):
...
vggc_cp.errors.UnknownNameError: unknown path selection rule 'MDL'; known: cascade, fewest, mdl
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.graph import TaskGraph, shortest_plan
from vggc_cp.learned import LearnConfig, Learned
from vggc_cp.pipeline import learn_graph as _learn_graph
from vggc_cp.solution import Solution, read_solution, verify_standalone
from vggc_cp.trace import Trace, load_trace

__all__ = ["LearnConfig", "Learned", "Solution", "Trace", "evaluate", "learn_graph",
           "load_solution", "load_trace", "plan"]


def load_solution(path: str | Path) -> Solution:
    """Read a solution JSON (``vggc-cp solve -o``) and check it stands alone (known actions,
    roles, one successor per node and action)."""
    solution = read_solution(path)
    verify_standalone(solution, str(path))
    return solution


def learn_graph(trace: Trace | str | Path, config: LearnConfig | None = None, *,
                progress: bool = False, **settings) -> Learned:
    """Learn the task graph of ``trace`` with the default pipeline of ``vggc-cp solve``.

    Parameters
    ----------
    trace : Trace or path
        A trace (:func:`load_trace`) or the path of a ``trace.npz``; only its observations
        and actions are read.
    config : LearnConfig, optional
        Every setting (default: :class:`LearnConfig` ``()``).
    progress : bool
        Progress bars on stderr.
    **settings
        Fields of :class:`LearnConfig` to replace (``evidence="keypoints"``, ``rule="cascade"``,
        ``steps=12``, ...); an unknown one names the known ones.

    Returns
    -------
    Learned
        ``.graph`` (:class:`~vggc_cp.graph.TaskGraph`), ``.labels`` (node of every observation,
        shape (N,)), ``.confidence``, ``.to_networkx()``, ``.save(path)``.

    Raises
    ------
    VggcError
        A wrong setting (naming the field or the choices), a trace with no transition, or no
        evidence that applies to it.
    """
    if not isinstance(trace, Trace):
        trace = load_trace(trace)
    return _learn_graph(trace, LearnConfig.from_settings(config, **settings), progress=progress)


def _graph_and_labels(learned: Learned | Solution) -> tuple[TaskGraph, np.ndarray]:
    if isinstance(learned, Learned):
        return learned.graph, learned.labels
    if isinstance(learned, Solution):
        return learned.edge_graph(), learned.labels
    raise VggcError(f"expected a Learned or a Solution, got {type(learned).__name__}")


def plan(learned: Learned | Solution, start_obs: int, goal_obs: int
         ) -> list[tuple[int, str, int]] | None:
    """A shortest plan between the nodes of two observations of the learned trace
    (``vggc-cp plan --start-obs I --goal-obs J``).

    Parameters
    ----------
    learned : Learned or Solution
    start_obs, goal_obs : int
        Observation indices, ``0 <= i < N``.

    Returns
    -------
    list of (node, action name, node), or None
        ``[]`` when both observations lie in one node; None when the goal is unreachable.
    """
    graph, labels = _graph_and_labels(learned)
    n = len(labels)
    for name, i in (("start_obs", start_obs), ("goal_obs", goal_obs)):
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < n:
            raise VggcError(f"{name} {i!r} is out of range: the graph labels {n} observations "
                            f"(0..{n - 1})")
    steps = shortest_plan(graph, int(labels[start_obs]), int(labels[goal_obs]))
    if steps is None:
        return None
    return [(int(u), graph.action_names[a], int(v)) for u, a, v in steps]


def evaluate(trace: Trace, learned: Learned | Solution, *, n_queries: int = 1500,
             seed: int = 0, dynamics: str = "auto"):
    """Score a learned graph against ``trace``'s ground-truth ``states`` (``vggc-cp
    evaluate``).

    Returns
    -------
    Metrics
        ``trans_prec``, ``trans_cov``, ``opt_path``, ``any_path``, ``exec`` (fractions in
        [0, 1]), ``nodes``, ``edges``, ``true_states``, ...

    Raises
    ------
    VggcError
        When the trace holds no states, or labels another number of observations.
    """
    from vggc_cp.evaluate import evaluate_trace

    if trace.states is None:
        raise VggcError(f"{trace.source or 'the trace'}: no field 'states': nothing to "
                        f"evaluate against")
    labels = learned.labels
    if len(labels) != trace.n_obs:
        raise VggcError(f"the graph labels {len(labels)} observations, the trace has "
                        f"{trace.n_obs}")
    graph = learned.graph if isinstance(learned, Learned) else learned.graph(trace)
    metrics, _ = evaluate_trace(trace, graph, labels, n_queries=n_queries, seed=seed,
                                dynamics=dynamics)
    return metrics
