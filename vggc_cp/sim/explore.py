"""Exploration: random valid pick/place episodes from random valid starts (or home states),
rendered to a trace.

One seed drives everything through :class:`numpy.random.SeedSequence` children: the
discrete walk, the continuous placement noise of the trace, and that of the novel renders
(children 0-2), and the look (child 3: the per-trace look, then the per-frame effects of the
trace and of the novel renders -- in the robot look also the distractor's moves, drawn
before each frame's render; the clean look draws nothing). The robot look's arm rests above
a region drawn from the noise stream at every episode start (and every novel render). The
same seed gives the same bytes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.sim.arrange import arrangement_after, fresh_arrangement
from vggc_cp.sim.dynamics import Benchmark
from vggc_cp.sim.looks import CLEAN, check_look, finish_frame, make_look
from vggc_cp.sim.tasks import get_benchmark, spec_dict
from vggc_cp.trace import Trace
from vggc_cp.version import __version__

#: Smallest and largest image side accepted by :func:`generate` (pixels).
MIN_SIZE = 16
MAX_SIZE = 1024

#: How to read a state key, stored in a trace's ``meta``.
STATE_KEY_DOC = {
    "fruit": "per region the class letter on it or '-', then '|' and the held class or '-'",
    "blocks": "per base region its stack height, then '|' and 'b' if a block is held or '-'",
    "task": "per region its stack's class letters bottom to top or '-', regions separated by "
            "'.', then '|' and the held class letter or '-'",
}


@dataclass(frozen=True)
class Walk:
    """A discrete exploration: ground-truth states and action indices, no images.

    Attributes
    ----------
    states : tuple of str, length N
        State key of every observation.
    actions : ndarray, int64, shape (N-1,)
        Index into the benchmark's ``action_names``; -1 where a new episode starts.
    """

    states: tuple[str, ...]
    actions: np.ndarray

    @property
    def n_transitions(self) -> int:
        return int(np.count_nonzero(self.actions >= 0))

    def distinct_states(self) -> int:
        """``|V*|``: the number of distinct states visited."""
        return len(set(self.states))


def seed_streams(seed: int) -> tuple[np.random.Generator, np.random.Generator,
                                     np.random.Generator]:
    """Three independent generators from one seed: ``(walk, trace noise, novel noise)``."""
    children = np.random.SeedSequence(int(seed)).spawn(3)
    return tuple(np.random.default_rng(c) for c in children)  # type: ignore[return-value]


def look_streams(seed: int) -> tuple[np.random.Generator, np.random.Generator,
                                     np.random.Generator]:
    """Three generators for the look, from the seed's fourth child (children are keyed by
    index, so :func:`seed_streams` is unchanged): ``(per-trace look, per-frame effects of the
    trace, per-frame effects of the novel renders)``."""
    look_seq = np.random.SeedSequence(int(seed)).spawn(4)[3]
    return tuple(np.random.default_rng(c) for c in look_seq.spawn(3))  # type: ignore[return-value]


def random_walk(bench: Benchmark, n_transitions: int, rng: np.random.Generator) -> Walk:
    """Random valid pick/place episodes with exactly ``n_transitions`` transitions.

    Each episode starts from a state drawn uniformly from :meth:`Benchmark.all_states`
    (pick or place state) -- or, where ``spec.start_states = k > 0``, from ``k`` home states
    drawn once (without replacement) before the first episode -- has a length drawn uniformly
    from ``spec.episode_length`` (the last one is cut to fit), and takes a uniformly random
    valid action at every step; picks and places alternate by construction.
    """
    if n_transitions < 1:
        raise ValueError("n_transitions must be >= 1")
    starts = bench.all_states()
    k = bench.spec.start_states
    if k > 0:
        home = rng.choice(len(starts), size=min(k, len(starts)), replace=False)
        starts = tuple(starts[int(i)] for i in sorted(home))
    index = {name: i for i, name in enumerate(bench.action_names)}
    lo, hi = bench.spec.episode_length
    states: list[str] = []
    actions: list[int] = []
    remaining = n_transitions
    while remaining > 0:
        length = min(int(rng.integers(lo, hi + 1)), remaining)
        if states:
            actions.append(-1)
        cur = starts[int(rng.integers(len(starts)))]
        states.append(cur)
        for _ in range(length):
            valid = bench.valid_actions(cur)
            name = valid[int(rng.integers(len(valid)))]
            cur = bench.step(cur, name)
            actions.append(index[name])
            states.append(cur)
        remaining -= length
    return Walk(tuple(states), np.array(actions, dtype=np.int64))


@dataclass(frozen=True, eq=False)
class Generated:
    """What :func:`generate` returns.

    Attributes
    ----------
    trace : Trace
        Observations, actions, action names, ground-truth ``states`` and ``meta``.
    novel_observations : ndarray, uint8, shape (K, H, W, 3)
        Fresh renders of visited states (K may be 0).
    novel_states : ndarray of str, shape (K,)
    """

    trace: Trace
    novel_observations: np.ndarray
    novel_states: np.ndarray


def novel_order(states: tuple[str, ...], k: int, rng: np.random.Generator) -> list[str]:
    """``k`` states to render afresh: the distinct visited states in random order, again and
    again, so that every visited state appears before any appears twice."""
    distinct = sorted(set(states))
    out: list[str] = []
    while len(out) < k:
        out += [distinct[i] for i in rng.permutation(len(distinct))]
    return out[:k]


def parse_image_size(text: str, option: str = "--size") -> tuple[int, int]:
    """``(height, width)`` of ``option``'s value: one side (``64``) or ``WIDTHxHEIGHT``
    (``640x480``, as cameras are named)."""
    parts = str(text).lower().split("x")
    try:
        if len(parts) == 1:
            side = int(parts[0])
            return side, side
        if len(parts) == 2:
            return int(parts[1]), int(parts[0])
    except ValueError:
        pass
    raise VggcError(f"{option} {text!r}: expected a side in pixels (64) or WIDTHxHEIGHT "
                    f"(640x480)")


def generate(name: str, n_transitions: int | None = None, seed: int = 0,
             size: int | tuple[int, int] = 64,
             novel: int = 0, on_frame: Callable[[int], None] | None = None,
             look: str = CLEAN, frames_file=None) -> Generated:
    """Explore benchmark ``name`` and render the trace (and ``novel`` fresh renders).

    Parameters
    ----------
    name : str
        A benchmark name (:func:`vggc_cp.sim.benchmark_names`).
    n_transitions : int, optional
        ``|D|``; the paper's value when None.
    seed : int
        Drives the walk and all noise (same seed, same observations).
    size : int or (int, int)
        Image side in pixels, or ``(height, width)``.
    novel : int
        Number of novel renders ``K``.
    on_frame : callable, optional
        Called once after every rendered frame with the number of frames in all (the trace's
        observations, one more per episode than transitions, plus the novel renders), which
        is known once the walk is drawn: a progress bar's total.
    look : str
        ``"clean"`` (the renderer the defaults were tuned on), ``"randomized"`` (table,
        camera, light and objects drawn per trace, gain, tint and noise per frame) or
        ``"robot"`` (randomized plus an arm resting above the region it last acted on, a
        lighting drift, a camera shake and a distractor that moves between some frames) or
        ``"armless"`` (the robot look with its arm hidden: the same trace but the arm);
        see :mod:`vggc_cp.sim.looks`. The novel renders share the trace's look and draw
        their own per-frame effects (each: the arm above a random region, the distractor
        on a fresh spot, the drift at its index among the novel renders).
    frames_file : path, optional
        Render the trace's frames into this file (a memory map the trace then holds: a
        camera-sized trace is generated without holding its frames in memory); the same
        frames as without it.

    Raises
    ------
    VggcError
        Unknown benchmark or look, a size outside ``[MIN_SIZE, MAX_SIZE]``,
        ``n_transitions < 1`` or ``novel < 0``.
    """
    bench = get_benchmark(name)
    spec = bench.spec
    d = spec.default_transitions if n_transitions is None else int(n_transitions)
    if d < 1:
        raise VggcError(f"--transitions must be at least 1, got {d}")
    from vggc_cp.sim.render import image_shape

    height, width = image_shape(size)
    if not (MIN_SIZE <= height <= MAX_SIZE and MIN_SIZE <= width <= MAX_SIZE):
        raise VggcError(f"--size must be between {MIN_SIZE} and {MAX_SIZE} pixels, got {size}")
    if novel < 0:
        raise VggcError(f"--novel must be at least 0, got {novel}")
    check_look(look)
    walk_rng, noise_rng, novel_rng = seed_streams(seed)
    look_rng, frame_rng, novel_frame_rng = look_streams(seed)
    walk = random_walk(bench, d, walk_rng)
    the_look = make_look(look, bench, look_rng, len(walk.states))
    jitter = the_look.placement_jitter
    arm = the_look.arm is not None
    n_frames = len(walk.states) + novel

    def tick() -> None:
        if on_frame is not None:
            on_frame(n_frames)

    from vggc_cp.sim.render import Scene

    shape = (len(walk.states), height, width, 3)
    frames = np.empty(shape, dtype=np.uint8) if frames_file is None else \
        np.memmap(frames_file, dtype=np.uint8, mode="w+", shape=shape)
    moves: list[list[float]] = []  # the distractor's spots: [frame, x, y, yaw]
    starts: list[list[int]] = []  # [frame, region the arm rests above] at episode starts
    with Scene(bench, size, the_look) as scene:
        arr = None
        for t, state in enumerate(walk.states):
            if t == 0 or walk.actions[t - 1] < 0:
                arr = fresh_arrangement(bench, state, noise_rng, jitter, arm=arm)
                starts.append([t, arr.last_region])
            else:
                arr = arrangement_after(bench, arr, bench.action_names[walk.actions[t - 1]],
                                        noise_rng, jitter)
            if scene.distractor_step(frame_rng, first=t == 0):
                moves.append([t, *(round(v, 4) for v in scene.distractor_spot)])
            frames[t] = finish_frame(scene.render(arr), the_look, frame_rng, t)
            tick()
        novel_states = novel_order(walk.states, novel, novel_rng)
        novel_frames = np.empty((novel, height, width, 3), dtype=np.uint8)
        for k, state in enumerate(novel_states):
            scene.distractor_step(novel_frame_rng, first=True)
            novel_frames[k] = finish_frame(
                scene.render(fresh_arrangement(bench, state, novel_rng, jitter, arm=arm)),
                the_look, novel_frame_rng, k)
            tick()
        camera = scene.camera.as_dict()
    meta = {
        "benchmark": spec.name,
        "family": spec.family,
        "m": spec.m,
        "n": spec.n,
        "R": spec.R,
        "n_actions": spec.n_actions,
        "classes": list(spec.classes),
        "objects": list(spec.objects),
        "max_height": spec.max_height,
        "transitions": d,
        "episode_length": list(spec.episode_length),
        "start_states": spec.start_states,
        "seed": int(seed),
        "image_size": [height, width],
        "renderer": "pybullet ER_TINY_RENDERER (DIRECT)",
        "camera": camera,
        "look": the_look.name,
        "state_key": STATE_KEY_DOC[spec.family],
        "undo": [list(pair) for pair in bench.undo_pairs],
        "sites": [list(group) for group in bench.sites],
        "generator": f"vggc-cp {__version__}",
    }
    if spec.object_classes is not None:
        meta["task"] = spec_dict(spec)
    if not the_look.is_clean:
        meta["look_params"] = the_look.as_meta()
    if arm:
        meta["look_params"]["arm_start_regions"] = starts
    if the_look.distractor is not None:
        meta["look_params"]["distractor_spots"] = moves
    trace = Trace(frames, walk.actions.copy(), bench.action_names,
                  np.array(walk.states, dtype=str), meta)
    return Generated(trace, novel_frames, np.array(novel_states, dtype=str).reshape(-1))
