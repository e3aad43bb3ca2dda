"""Image-to-plan evaluation (I2P) of a localizer on novel renders.

* **Localization accuracy** — a novel image's predicted node is right when the majority of
  that node's trace observations are of the image's true state.
* **I2P** (the paper's image-to-plan success) — over Q start/goal pairs of novel images (true
  states ``s != g``, ``g`` reachable from ``s`` in G*): both images are localized correctly
  and the plan found between their nodes (the shortest plan that ``vggc-cp plan`` prints)
  validates in G*, i.e. there are states ``s_i in C(u_i)`` with ``(s_{i-1}, a_i, s_i)`` in E*.
* **Exec-I2P** — the same plan executed action by action with the true dynamics (the
  benchmark simulator's) from the start image's true state; success iff it ends in the goal
  image's true state. Localization need not be right for this; the robot only cares whether
  it arrives.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.evaluate.groundtruth import GroundTruth, StepFn
from vggc_cp.graph import Plan, TaskGraph, shortest_plan


@dataclass(frozen=True)
class I2PMetrics:
    """Image-to-plan figures; rates are fractions in [0, 1].

    Attributes
    ----------
    localization : float
        Accuracy over all novel images.
    i2p, exec_i2p : float
        Over the ``queries`` start/goal pairs.
    plan_found : float
        Share of queries where the localized goal node is reachable from the start node.
    images, queries : int
    dynamics : str
        ``sim`` or ``trace``: the transitions Exec-I2P executed on.
    """

    localization: float
    i2p: float
    exec_i2p: float
    plan_found: float
    images: int
    queries: int
    dynamics: str

    def as_dict(self) -> dict:
        return asdict(self)


def majority_states(gt: GroundTruth, labels: np.ndarray) -> dict[int, int]:
    """The state most of each node's observations show (ties: the smaller state id)."""
    out: dict[int, int] = {}
    labels = np.asarray(labels, dtype=np.int64)
    for u in np.unique(labels):
        counts = np.bincount(gt.obs_state[labels == u], minlength=gt.n_states)
        out[int(u)] = int(np.argmax(counts))
    return out


def state_ids(gt: GroundTruth, states) -> np.ndarray:
    """Ids of state keys in G*, -1 for a state the trace never visited."""
    index = {s: i for i, s in enumerate(gt.state_names)}
    return np.array([index.get(str(s), -1) for s in states], dtype=np.int64)


def sample_image_queries(gt: GroundTruth, image_states: np.ndarray, n_queries: int,
                         seed: int) -> np.ndarray:
    """Start/goal queries on novel images, int64 ``(Q, 4)``: (start state, goal state, start
    image, goal image).

    A pair of distinct states that both have novel images, the goal reachable from the start
    in G*, is drawn uniformly, then one image of each uniformly.
    """
    have = sorted(set(int(s) for s in image_states if s >= 0))
    have_set = set(have)
    pairs = np.array([(s, g) for s in have for g in sorted(gt.reachable_from(s))
                      if g != s and g in have_set], dtype=np.int64).reshape(-1, 2)
    if len(pairs) == 0 or n_queries < 1:
        return np.zeros((0, 4), dtype=np.int64)
    rng = np.random.default_rng(seed)
    by_state = {s: np.flatnonzero(image_states == s) for s in have}
    chosen = pairs[rng.integers(0, len(pairs), size=n_queries)]
    out = np.empty((n_queries, 4), dtype=np.int64)
    out[:, :2] = chosen
    for q, (s, g) in enumerate(chosen.tolist()):
        out[q, 2] = by_state[s][rng.integers(len(by_state[s]))]
        out[q, 3] = by_state[g][rng.integers(len(by_state[g]))]
    return out


def plan_validates(plan: Plan, gt: GroundTruth, cons: dict[int, frozenset]) -> bool:
    """Whether one plan ``[(u, a, v), ...]`` is realised in G* by states consistent with its
    nodes (the paper's validation). The empty plan validates."""
    if not plan:
        return True
    reach = set(cons.get(plan[0][0], frozenset()))
    for _, a, v in plan:
        target = cons.get(v, frozenset())
        nxt: set[int] = set()
        for s in reach:
            nxt |= gt.succ.get((s, a), frozenset()) & target
        if not nxt:
            return False
        reach = nxt
    return True


def execute_plan(plan: Plan, start_state: int, step: StepFn) -> int | None:
    """The true state after executing the plan's actions from ``start_state`` (None as soon
    as an action is impossible)."""
    s: int | None = start_state
    for _, a, _ in plan:
        s = step(s, a)
        if s is None:
            return None
    return s


def evaluate_i2p(graph: TaskGraph, labels: np.ndarray, gt: GroundTruth, predicted: np.ndarray,
                 image_states, *, n_queries: int = 150, seed: int = 0,
                 step: StepFn | None = None, dynamics: str = "trace") -> I2PMetrics:
    """Localization accuracy, I2P and Exec-I2P.

    Parameters
    ----------
    graph : TaskGraph
        The learned graph (nodes are the values of ``labels``).
    labels : ndarray of int, shape (N,)
        The solution's node of every trace observation (defines ``C(u)`` and majorities).
    gt : GroundTruth
        G* of the trace.
    predicted : ndarray of int, shape (M,)
        The localizer's node for every novel image.
    image_states : sequence of str, length M
        True state key of every novel image.
    n_queries : int
        Q (the paper uses 150).
    step : callable, optional
        True dynamics on state ids; default the transitions observed in the trace.
    dynamics : str
        Name of ``step``'s source, reported as is.
    """
    predicted = np.asarray(predicted, dtype=np.int64)
    ids = state_ids(gt, image_states)
    if len(ids) != len(predicted):
        raise VggcError(f"{len(predicted)} predictions for {len(ids)} novel images")
    major = majority_states(gt, labels)
    correct = np.array([ids[i] >= 0 and major.get(int(u), -2) == ids[i]
                        for i, u in enumerate(predicted)], dtype=bool)
    cons = gt.consistent(labels)
    step = step or gt.observed_step
    queries = sample_image_queries(gt, ids, n_queries, seed)
    plans: dict[tuple[int, int], Plan | None] = {}
    n_i2p = n_exec = n_found = 0
    for s, g, i, j in queries.tolist():
        u, v = int(predicted[i]), int(predicted[j])
        if (u, v) not in plans:
            plans[(u, v)] = shortest_plan(graph, u, v)
        plan = plans[(u, v)]
        if plan is None:
            continue
        n_found += 1
        if correct[i] and correct[j] and plan_validates(plan, gt, cons):
            n_i2p += 1
        if execute_plan(plan, s, step) == g:
            n_exec += 1
    q = len(queries)
    rate = (lambda x: x / q) if q else (lambda x: 0.0)
    acc = float(np.mean(correct)) if len(correct) else 0.0
    return I2PMetrics(acc, rate(n_i2p), rate(n_exec), rate(n_found), len(predicted), q, dynamics)


def evaluate_localizer(trace, solution, localizer, novel_observations: np.ndarray,
                       novel_states, *, n_queries: int = 150, seed: int = 0,
                       dynamics: str = "auto") -> I2PMetrics:
    """Localize every novel image with ``localizer`` and compute :func:`evaluate_i2p`.

    ``dynamics`` as in :func:`vggc_cp.evaluate.evaluate_trace`: ``auto`` executes on the
    benchmark simulator when the trace names one, else on the trace's observed transitions.
    """
    from vggc_cp.evaluate import resolve_dynamics
    from vggc_cp.solution import verify_solution

    graph = verify_solution(solution, trace)
    gt = GroundTruth.from_trace(trace)
    step, used = resolve_dynamics(trace, gt, dynamics)
    novel_observations = np.asarray(novel_observations)
    if novel_observations.shape[1:3] != tuple(localizer.image_shape):
        h, w = localizer.image_shape
        raise VggcError(f"novel images are {novel_observations.shape[2]}x"
                        f"{novel_observations.shape[1]} pixels, the localizer expects {w}x{h}")
    predicted = localizer.predict(novel_observations).nodes
    return evaluate_i2p(graph, solution.labels, gt, predicted, novel_states,
                        n_queries=n_queries, seed=seed, step=step, dynamics=used)


def train_and_measure(trace, trace_path, solution_path, model_path, novel_path, *,
                      n_queries: int, seed: int, threads: int) -> tuple[I2PMetrics, float]:
    """Train a localizer on a solution's labels, save it, and measure it on novel renders.

    The localizer is trained with the default :class:`vggc_cp.localize.TrainConfig` (seeded
    by ``seed``) on ``trace`` and the solution at ``solution_path``, saved to ``model_path``,
    and evaluated with :func:`evaluate_localizer` on the novel images at ``novel_path`` over
    ``n_queries`` start/goal pairs. Returns the metrics and the training seconds.
    """
    import torch

    from vggc_cp.localize import TrainConfig, save_localizer, train_localizer
    from vggc_cp.sim.novel import load_novel
    from vggc_cp.solution import read_solution

    torch.set_num_threads(threads)
    solution = read_solution(solution_path)
    localizer, report = train_localizer(trace, solution, TrainConfig(seed=seed),
                                        trace_path=trace_path, solution_path=solution_path)
    save_localizer(model_path, localizer)
    obs, states = load_novel(novel_path)
    metrics = evaluate_localizer(trace, solution, localizer, obs, states, n_queries=n_queries,
                                 seed=0)
    return metrics, report.seconds


def load_checkpoint(trace, solution, model_path, novel_path, trace_source: str = "") -> tuple:
    """The localizer at ``model_path`` and the novel renders at ``novel_path`` (``(localizer,
    observations, states)``), checked before any measuring: the model was trained on
    ``solution``'s nodes and the renders show states the trace visited (``trace_source`` names
    the trace in the message)."""
    from vggc_cp.localize import check_model_matches, load_localizer
    from vggc_cp.sim.novel import load_novel

    localizer = load_localizer(model_path)
    check_model_matches(localizer, solution, model_path)
    obs, states = load_novel(novel_path)
    if trace.states is not None and not set(states.tolist()) & set(trace.states.tolist()):
        raise VggcError(f"{novel_path}: none of its {len(states)} images shows a state that "
                        f"the trace {trace_source} visited (another benchmark or seed?)")
    return localizer, obs, states


def measure_checkpoint(trace, solution, model_path, novel_path, *, n_queries: int = 150,
                       seed: int = 0, dynamics: str = "auto", trace_source: str = "",
                       loaded: tuple | None = None) -> I2PMetrics:
    """:func:`evaluate_localizer` of a saved localizer (``model_path``) on saved novel renders
    (``novel_path``), read and checked by :func:`load_checkpoint` (or given as ``loaded``,
    what it returned)."""
    localizer, obs, states = loaded or load_checkpoint(trace, solution, model_path, novel_path,
                                                       trace_source)
    return evaluate_localizer(trace, solution, localizer, obs, states, n_queries=n_queries,
                              seed=seed, dynamics=dynamics)
