"""``vggc-cp demo``: the whole pipeline on fruit-2x3, from pixels to an executed plan.

generate (PyBullet) -> the default pipeline of `vggc-cp solve` -> solution JSON ->
train the localizer -> pick two novel renders (start, goal) -> localize + plan ->
execute the plan with the simulator's dynamics, rendering every step -> the panels of a
picture strip (:class:`Strip`; the command line draws it with
:func:`vggc_cp.plots.plot_image_strip`).

The true states of the novel images are used only to choose a start/goal pair whose goal is
a few actions away and to simulate the execution (the simulator is the robot); localization
and planning see pixels only.
"""

from __future__ import annotations

import tempfile
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.localize.localizer import load_localizer, save_localizer, write_image
from vggc_cp.localize.planning import ImagePlan, plan_images
from vggc_cp.localize.train import TrainConfig, train_localizer

BENCHMARK = "fruit-2x3"
NOVEL = 12


@dataclass(frozen=True, eq=False)
class Strip:
    """The panels of the demo's picture strip: start image, executed steps, goal image.

    Attributes
    ----------
    images : tuple of ndarray
        uint8 RGB images, each (H, W, 3).
    titles : tuple of str
        One per image.
    outlines : tuple of str or None
        Frame colour per image (None: no frame).
    suptitle : str
    """

    images: tuple
    titles: tuple[str, ...]
    outlines: tuple
    suptitle: str


@dataclass(frozen=True)
class DemoResult:
    """What the demo did.

    Attributes
    ----------
    plan : ImagePlan
        Localized nodes and the plan between them.
    start_state, goal_state : str
        True states of the two novel images.
    visited : tuple of str
        True states along the execution, the start state first.
    success : bool
        Whether the execution ended in the goal state.
    strip : Strip
        The panels of the picture strip.
    files : dict
        Paths of the intermediate files (trace, novel images, solution, model, PNGs).
    """

    plan: ImagePlan
    start_state: str
    goal_state: str
    visited: tuple[str, ...]
    success: bool
    strip: Strip
    files: dict


def _true_distance(bench, start: str, goal: str) -> int:
    """Hop distance between two states under the simulator's dynamics (-1: unreachable)."""
    dist = {start: 0}
    queue = deque([start])
    while queue:
        s = queue.popleft()
        if s == goal:
            return dist[s]
        for a in bench.valid_actions(s):
            t = bench.step(s, a)
            if t not in dist:
                dist[t] = dist[s] + 1
                queue.append(t)
    return -1


def choose_pair(bench, states: np.ndarray, rng: np.random.Generator) -> tuple[int, int]:
    """Indices of a start and a goal novel image: distinct pick states (nothing held), the
    goal reachable, preferring the farthest pairs (so the plan has several steps)."""
    idx = [i for i, s in enumerate(states) if bench.is_pick_state(str(s))]
    pairs = [(i, j, _true_distance(bench, str(states[i]), str(states[j])))
             for i in idx for j in idx if states[i] != states[j]]
    pairs = [p for p in pairs if p[2] > 0]
    if not pairs:
        raise VggcError("demo: no two novel images of distinct, connected states")
    far = max(p[2] for p in pairs)
    best = [p for p in pairs if p[2] == far]
    i, j, _ = best[int(rng.integers(len(best)))]
    return i, j


def compute_solution(trace, *, cache_dir: str | Path | None = None,
                     progress: bool = False) -> dict:
    """The default of ``vggc-cp solve`` (:func:`vggc_cp.pipeline.learn_graph`); the solution
    JSON object (what ``vggc-cp solve`` writes with default options). Attention distances of
    the fallback, if any, are cached in ``cache_dir`` (default: the vision package's)."""
    from dataclasses import replace

    from vggc_cp.learned import LearnConfig, solution_record
    from vggc_cp.pipeline import learn_graph

    options = LearnConfig()
    options = replace(options, distance=replace(options.distance, cache_dir=cache_dir))
    learned = learn_graph(trace.without_states(), options, progress=progress)
    return solution_record(learned.problem, learned.chosen.best, **learned.solution_fields())


def execute(bench, start_state: str, actions, size: int, rng: np.random.Generator
            ) -> tuple[list[str], list[np.ndarray]]:
    """Execute ``actions`` from ``start_state`` with the simulator's dynamics and render each
    resulting state (a fresh arrangement of the start state, then only moved bodies change).

    Stops at the first impossible action. Returns the visited states (start first) and one
    frame per executed action.
    """
    from vggc_cp.sim.arrange import arrangement_after, fresh_arrangement
    from vggc_cp.sim.render import Scene

    states, frames = [start_state], []
    arr = fresh_arrangement(bench, start_state, rng)
    with Scene(bench, size) as scene:
        for a in actions:
            nxt = bench.step(states[-1], a)
            if nxt is None:
                break
            arr = arrangement_after(bench, arr, a, rng)
            states.append(nxt)
            frames.append(scene.render(arr))
    return states, frames


def run_demo(*, seed: int = 0, workdir: str | Path | None = None,
             log: Callable[[str], None] = lambda _m: None) -> DemoResult:
    """Run the whole pipeline; see the module docstring. The intermediate files stay in
    ``workdir`` when given (else a temporary folder)."""
    if workdir is None:
        with tempfile.TemporaryDirectory(prefix="vggc-demo-") as tmp:
            return _run(seed, Path(tmp), log, keep=False)
    return _run(seed, Path(workdir), log, keep=True)


def _run(seed: int, work: Path, log, keep: bool) -> DemoResult:
    from vggc_cp.sim import get_benchmark
    from vggc_cp.sim.explore import generate
    from vggc_cp.sim.novel import save_novel
    from vggc_cp.solution import read_solution, verify_solution, write_solution
    from vggc_cp.trace import save_trace

    work.mkdir(parents=True, exist_ok=True)
    files = {k: work / v for k, v in (("trace", f"{BENCHMARK}.npz"),
                                      ("novel", f"{BENCHMARK}.novel.npz"),
                                      ("solution", "solution.json"), ("model", "localizer.pt"),
                                      ("start", "start.png"), ("goal", "goal.png"))}
    log(f"[1/6] generate {BENCHMARK} (seed {seed}) with {NOVEL} novel renders")
    gen = generate(BENCHMARK, seed=seed, novel=NOVEL)
    trace = gen.trace
    save_trace(trace, files["trace"])
    save_novel(files["novel"], gen.novel_observations, gen.novel_states)
    log("[2/6] the default solve (evidence, merge, description length)")
    write_solution(files["solution"], compute_solution(trace.without_states(),
                                                       cache_dir=work / "cache"))
    solution = read_solution(files["solution"])
    verify_solution(solution, trace, str(files["solution"]))
    log(f"      {solution.k_pick} pick + {solution.k_place} place nodes, J = {solution.J:.4g}")
    log("[3/6] train the localizer")
    config = TrainConfig(learning_rates=(3e-3,), epoch_grid=(10, 20, 30), folds=2, seed=seed)
    localizer, report = train_localizer(trace.without_states(), solution, config,
                                        trace_path=files["trace"],
                                        solution_path=files["solution"])
    save_localizer(files["model"], localizer)
    log(f"      lr {report.learning_rate:g}, {report.epochs} epochs, train accuracy "
        f"{100 * report.train_accuracy:.1f} %")
    bench = get_benchmark(BENCHMARK)
    rng = np.random.default_rng(seed)
    i, j = choose_pair(bench, gen.novel_states, rng)
    start_img, goal_img = gen.novel_observations[i], gen.novel_observations[j]
    write_image(files["start"], start_img)
    write_image(files["goal"], goal_img)
    start_state, goal_state = str(gen.novel_states[i]), str(gen.novel_states[j])
    log(f"[4/6] two novel images: {files['start'].name} ({start_state}), "
        f"{files['goal'].name} ({goal_state})")
    log("[5/6] localize and plan")
    result = plan_images(load_localizer(files["model"]), solution, start_img, goal_img,
                         start_source=str(files["start"]), goal_source=str(files["goal"]),
                         solution_source=str(files["solution"]))
    if not result.found:
        visited, frames = [start_state], []
    else:
        log(f"      plan: {' -> '.join(result.actions) or '(empty)'}")
        log("[6/6] execute in the simulator")
        visited, frames = execute(bench, start_state, result.actions, trace.image_shape[0], rng)
    success = result.found and len(visited) == len(result.actions) + 1 \
        and visited[-1] == goal_state
    images = [start_img] + frames + [goal_img]
    titles = [f"start image\nnode {result.start} ({result.start_confidence:.2f})\n{start_state}"]
    titles += [f"{k}. {a}\n{s}" for k, (a, s) in
               enumerate(zip(result.actions, visited[1:]), 1)]
    titles += [f"goal image\nnode {result.goal} ({result.goal_confidence:.2f})\n{goal_state}"]
    outlines = [None] * (len(images) - 2) + ["green" if success else "red", None]
    if not frames:
        outlines = [None, None]
    verdict = "reached the goal" if success else "did NOT reach the goal"
    strip = Strip(tuple(images), tuple(titles), tuple(outlines),
                  f"vggc-cp demo ({BENCHMARK}, seed {seed}): plan of {len(result.actions)} "
                  f"actions executed in the simulator, {verdict}")
    return DemoResult(result, start_state, goal_state, tuple(visited), bool(success), strip,
                      {k: str(v) for k, v in files.items()} if keep else {})
