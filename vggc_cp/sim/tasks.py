"""Tasks beyond the paper's seven: a procedural family, spec strings, and name resolution.

A rearrangement task is fixed by its colour classes (the task cares which *class* stands
where, never which object), the objects (a class and a shape each), the regions and their
layout, and whether objects stack. :func:`draw_task` draws one from a seed:

* 1-4 colour classes of :data:`CLASS_COLOURS`, 1-3 shapes per class, 2-8 objects;
* 3-12 regions in a ``row`` (3-5), a ``grid`` (2-3 rows of 2-4) or ``scattered`` (3-8
  regions at random places, markers never overlapping);
* stacking allowed (stacks of 2-3 stackable shapes, :data:`STACKABLE`) or not;
* episodes from uniformly drawn states, or from 1-2 home states (a robot reset between
  episodes, shorter episodes);
* drawn again until the reachable state count lies in ``[MIN_STATES, MAX_STATES]``
  (``MAX_STATES_HOME`` with home starts, whose traces stay near home), so that a trace of
  ``|D| = OBS_PER_STATE x |S|`` transitions (``OBS_PER_STATE_HOME`` with home starts; the
  paper's density: 7-20 observations per visited state) visits most states more than once.

A task is named ``random-S`` (drawn from seed ``S``) or by its spec string
(:func:`format_spec`, :func:`parse_spec`)::

    task:regions=6,layout=grid:2x3,height=1,starts=0,episode=4-12,transitions=400,objects=red/apple+red/strawberry+yellow/lemon

:func:`get_spec` and :func:`get_benchmark` resolve every name: the seven benchmarks', ``random-S``
and ``task:...``. A trace of a task records the name in ``meta['benchmark']``, so evaluation
rebuilds the true dynamics from the trace alone.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from functools import cache, lru_cache
from pathlib import Path

import numpy as np

from vggc_cp.errors import VggcError
from vggc_cp.sim.dynamics import Benchmark
from vggc_cp.sim.specs import SPECS, TASK, BenchmarkSpec, paper_spec

#: Colour classes of the task family, in canonical order (their first letters are the state
#: keys' letters, so they differ).
CLASS_COLOURS = ("red", "yellow", "blue", "green")
#: Shapes an object can take (any colour).
SHAPES = ("apple", "strawberry", "tomato", "lemon", "banana", "pear", "cube", "cylinder",
          "brick")
#: Shapes that can carry another object (stacking tasks use only these).
STACKABLE = ("cube", "cylinder", "brick")
#: Region layouts.
LAYOUTS = ("row", "grid", "scattered")
#: Bounds of a drawn task.
CLASSES_RANGE = (1, 4)
SHAPES_PER_CLASS = (1, 3)
OBJECTS_RANGE = (2, 8)
ROW_REGIONS = (3, 5)
GRID_ROWS = (2, 3)
GRID_COLS = (2, 4)
SCATTERED_REGIONS = (3, 8)
STACK_HEIGHT = (2, 3)
#: Probability that a drawn task allows stacking, and that its episodes start at home states.
P_STACKING = 0.3
P_HOME_STARTS = 0.35
#: Reachable state counts (pick and place states) a drawn task may have: with uniform starts
#: (a trace visits nearly all of them), and with home starts (it visits those near home, as
#: multifruit-4x6's trace visits 58 of its 210).
MIN_STATES = 6
MAX_STATES = 150
MAX_STATES_HOME = 400
#: Transitions per reachable state of a task's default ``|D|`` (uniform starts, home starts),
#: and the bounds of it.
OBS_PER_STATE = 10
OBS_PER_STATE_HOME = 2
TRANSITIONS_RANGE = (60, 1500)
TRANSITIONS_HOME = (100, 600)
#: Episode lengths: from uniform starts, from home states.
EPISODES_UNIFORM = (4, 12)
EPISODES_HOME = (2, 8)
#: Centre-to-centre distance of neighbouring regions (m), as in the renderer.
PITCH = 0.16
#: Spread of a scattered layout: regions lie in a square of this many pitches per sqrt(R).
SCATTER_SPREAD = 1.35
#: A fixed salt so that task seeds and trace seeds draw unrelated numbers.
_TASK_SALT = 0x7A5C

#: The task families (``vggc-cp envs``).
FAMILIES = {
    "fruit": "the paper's fruit benchmarks: one object per region, 1-2 classes",
    "blocks": "the paper's blocks benchmarks: one class of cubes stacked on 3 regions",
    "task": "tasks beyond the seven: random-S (drawn from seed S: 1-4 colour classes, 1-3 "
            "shapes per class, 2-8 objects, 3-12 regions in a row, a grid or scattered, "
            "stacking or not) or a spec string task:...",
}

RANDOM_PREFIX = "random-"
SPEC_PREFIX = "task:"


# ------------------------------------------------------------------ state counting
def count_states(classes: tuple[str, ...], object_classes: tuple[str, ...], regions: int,
                 height: int) -> int:
    """The number of arrangements of the objects' classes (pick states) plus those with one
    object held (place states), counted combinatorially (no search).

    A region holds a stack of at most ``height`` objects (bottom to top, order matters);
    objects of one class are interchangeable.

    >>> count_states(("red",), ("red", "red"), 3, 1)   # fruit-2x3: 3 + 3
    6
    >>> count_states(("red",), ("red",) * 3, 3, 3)      # blocks-3 as one class
    16
    """
    counts = tuple(sum(1 for c in object_classes if c == k) for k in classes)

    @cache
    def arrangements(r: int, left: tuple[int, ...]) -> int:
        if r == 0:
            return 1 if not any(left) else 0
        total = 0
        for take in itertools.product(*(range(n + 1) for n in left)):
            size = sum(take)
            if size > height:
                continue
            ways = math.factorial(size)
            for t in take:
                ways //= math.factorial(t)
            total += ways * arrangements(r - 1, tuple(a - b for a, b in zip(left, take)))
        return total

    pick = arrangements(regions, counts)
    place = sum(arrangements(regions, counts[:i] + (counts[i] - 1,) + counts[i + 1:])
                for i in range(len(counts)) if counts[i] > 0)
    return pick + place


# --------------------------------------------------------------------- building
def _grid(layout: str, regions: int) -> tuple[int, int]:
    if layout.startswith("grid:"):
        rows, _, cols = layout[5:].partition("x")
        return int(rows), int(cols)
    return 1, regions


def scattered_centres(regions: int, seed: int) -> tuple[tuple[float, float], ...]:
    """``regions`` centres (m) drawn from ``seed`` in a square around the table's centre, no
    two markers closer than :data:`PITCH` on both axes (so markers never overlap)."""
    rng = np.random.default_rng([_TASK_SALT, 1, int(seed)])
    half = SCATTER_SPREAD * PITCH * math.sqrt(regions) / 2
    for _ in range(1000):
        pts: list[tuple[float, float]] = []
        for _ in range(200 * regions):
            p = rng.uniform(-half, half, 2)
            if all(max(abs(p[0] - q[0]), abs(p[1] - q[1])) >= PITCH for q in pts):
                pts.append((round(float(p[0]), 4), round(float(p[1]), 4)))
                if len(pts) == regions:
                    # back row first, then left to right, as grid regions are numbered
                    pts.sort(key=lambda q: (-q[1], q[0]))
                    return tuple(pts)
        half *= 1.05
    raise VggcError(f"cannot scatter {regions} regions")  # pragma: no cover


def make_spec(name: str, objects: tuple[tuple[str, str], ...], regions: int, layout: str,
              height: int, starts: int, episode: tuple[int, int],
              transitions: int | None = None) -> BenchmarkSpec:
    """A task spec from its parts (validated).

    Parameters
    ----------
    name : str
        The task's name (``random-S`` or its spec string).
    objects : tuple of (class, shape)
        Class of :data:`CLASS_COLOURS` and shape of :data:`SHAPES`, per object.
    regions : int
    layout : str
        ``row``, ``grid:RxC`` (``R * C == regions``) or ``scattered:SEED``.
    height : int
        Tallest stack (1: no stacking).
    starts : int
        0: episodes start at uniformly drawn states; k > 0: at k home states.
    episode : (int, int)
        Episode lengths, drawn uniformly.
    transitions : int, optional
        Default ``|D|``; ``OBS_PER_STATE`` per reachable state (bounded) when None.

    Raises
    ------
    VggcError
        Unknown class, shape or layout, a stacking task with a shape that cannot carry another,
        more objects than places, or sizes out of range.
    """
    if not objects:
        raise VggcError(f"{name}: a task needs at least one object")
    for cls, shape in objects:
        if cls not in CLASS_COLOURS:
            raise VggcError(f"{name}: unknown class {cls!r}; known: {', '.join(CLASS_COLOURS)}")
        if shape not in SHAPES:
            raise VggcError(f"{name}: unknown shape {shape!r}; known: {', '.join(SHAPES)}")
        if height > 1 and shape not in STACKABLE:
            raise VggcError(f"{name}: shape {shape!r} cannot be stacked; a stacking task "
                            f"takes {', '.join(STACKABLE)}")
    if not 1 <= regions <= 32:
        raise VggcError(f"{name}: regions must be in [1, 32], got {regions}")
    if not 1 <= height <= 4:
        raise VggcError(f"{name}: height must be in [1, 4], got {height}")
    if len(objects) > regions * height - 1:
        raise VggcError(f"{name}: {len(objects)} objects leave no free place on {regions} "
                        f"regions of height {height}")
    if starts < 0 or not 1 <= episode[0] <= episode[1]:
        raise VggcError(f"{name}: starts must be >= 0 and episode lengths 1 <= lo <= hi")
    centres = None
    if layout == "row":
        grid = (1, regions)
    elif layout.startswith("grid:"):
        try:
            grid = _grid(layout, regions)
        except ValueError:
            raise VggcError(f"{name}: layout {layout!r} is not grid:ROWSxCOLS") from None
        if grid[0] * grid[1] != regions:
            raise VggcError(f"{name}: layout {layout} does not hold {regions} regions")
    elif layout.startswith("scattered:") and layout[10:].isdigit():
        grid = (1, regions)
        centres = scattered_centres(regions, int(layout[10:]))
    else:
        raise VggcError(f"{name}: unknown layout {layout!r}; known: row, grid:RxC, "
                        "scattered:SEED")
    classes = tuple(c for c in CLASS_COLOURS if any(o[0] == c for o in objects))
    object_classes = tuple(o[0] for o in objects)
    states = count_states(classes, object_classes, regions, height)
    if transitions is None:
        transitions = int(np.clip(OBS_PER_STATE * states, *TRANSITIONS_RANGE) if not starts
                          else np.clip(OBS_PER_STATE_HOME * states, *TRANSITIONS_HOME))
    return BenchmarkSpec(name, TASK, len(objects), len(classes), regions,
                         2 * regions * len(classes) * height, states, int(transitions),
                         classes, tuple(o[1] for o in objects), height, grid,
                         (int(episode[0]), int(episode[1])), int(starts), object_classes,
                         centres, layout)


def layout_of(spec: BenchmarkSpec) -> str:
    """The layout word of a spec (``row``, ``grid:RxC`` or ``scattered:SEED``)."""
    if spec.layout:
        return spec.layout
    return "row" if spec.grid[0] == 1 else f"grid:{spec.grid[0]}x{spec.grid[1]}"


def format_spec(spec: BenchmarkSpec) -> str:
    """The canonical spec string of a task (parsed back by :func:`parse_spec`)."""
    objs = "+".join(f"{c}/{s}" for c, s in zip(spec.object_classes or (), spec.objects))
    lo, hi = spec.episode_length
    return (f"{SPEC_PREFIX}regions={spec.R},layout={layout_of(spec)},height={spec.max_height},"
            f"starts={spec.start_states},episode={lo}-{hi},"
            f"transitions={spec.default_transitions},objects={objs}")


def spec_dict(spec: BenchmarkSpec) -> dict:
    """A task's parameters as a JSON-friendly dict (recorded in a trace's ``meta['task']``)."""
    return {"name": spec.name, "spec": format_spec(spec), "regions": spec.R,
            "layout": layout_of(spec), "height": spec.max_height,
            "classes": list(spec.classes),
            "objects": [[c, s] for c, s in zip(spec.object_classes or (), spec.objects)],
            "start_states": spec.start_states, "episode_length": list(spec.episode_length),
            "transitions": spec.default_transitions, "states": spec.paper_states}


def parse_spec(text: str) -> BenchmarkSpec:
    """Parse a spec string ``task:KEY=VALUE,...`` (keys ``regions``, ``layout``, ``height``,
    ``starts``, ``episode``, ``transitions``, ``objects``; see the module docstring); the
    result is named by its canonical string.

    Raises
    ------
    VggcError
        A malformed string, naming the key.
    """
    if not text.startswith(SPEC_PREFIX):
        raise VggcError(f"a task spec begins with {SPEC_PREFIX!r}, got {text[:40]!r}")
    fields: dict[str, str] = {}
    for part in text[len(SPEC_PREFIX):].split(","):
        key, sep, value = part.partition("=")
        if not sep or not key:
            raise VggcError(f"task spec: {part!r} is not KEY=VALUE")
        if key in fields:
            raise VggcError(f"task spec: {key} given twice")
        fields[key] = value
    known = ("regions", "layout", "height", "starts", "episode", "transitions", "objects")
    for key in fields:
        if key not in known:
            raise VggcError(f"task spec: unknown key {key!r}; known: {', '.join(known)}")
    for key in ("regions", "objects"):
        if key not in fields:
            raise VggcError(f"task spec: {key} is missing")

    def integer(key: str, default: int) -> int:
        v = fields.get(key)
        if v is None:
            return default
        if not v.isdigit() or len(v) > 6:
            raise VggcError(f"task spec: {key}={v!r} is not a non-negative integer")
        return int(v)

    objects = []
    for i, o in enumerate(fields["objects"].split("+")):
        cls, sep, shape = o.partition("/")
        if not sep:
            raise VggcError(f"task spec: objects[{i}] = {o!r} is not CLASS/SHAPE")
        objects.append((cls, shape))
    if len(objects) > 16:
        raise VggcError(f"task spec: {len(objects)} objects; at most 16")
    lo, sep, hi = fields.get("episode", "4-12").partition("-")
    if not (sep and lo.isdigit() and hi.isdigit() and len(lo) < 6 and len(hi) < 6):
        raise VggcError(f"task spec: episode={fields['episode']!r} is not LO-HI")
    regions = integer("regions", 0)
    layout = fields.get("layout", "row")
    transitions = fields.get("transitions")
    provisional = make_spec("task", tuple(objects), regions, layout, integer("height", 1),
                            integer("starts", 0), (int(lo), int(hi)),
                            None if transitions is None else integer("transitions", 0))
    if provisional.paper_states > 100_000:
        raise VggcError(f"task spec: {provisional.paper_states} states; at most 100000")
    if provisional.default_transitions < 1:
        raise VggcError("task spec: transitions must be at least 1")
    return replace(provisional, name=format_spec(provisional))


def draw_task(seed: int) -> BenchmarkSpec:
    """Draw the task ``random-<seed>`` (same seed, same task).

    See the module docstring for the distribution; a draw whose reachable state count lies
    outside ``[MIN_STATES, MAX_STATES]`` (or that search finds differs from the count) is
    drawn again from the same generator.
    """
    seed = int(seed)
    if not 0 <= seed < 2 ** 32:
        raise VggcError(f"a task seed must be in [0, 2^32), got {seed}")
    rng = np.random.default_rng([_TASK_SALT, 0, seed])
    name = f"{RANDOM_PREFIX}{seed}"

    def between(lo_hi: tuple[int, int]) -> int:
        return _between(rng, lo_hi)

    for _ in range(1000):
        # the kind of task first (classes, stacking, layout, starts), then its sizes until
        # the state count fits, so that every kind is drawn about as often as it is set to be
        n_cls = between(CLASSES_RANGE)
        pick = sorted(rng.choice(len(CLASS_COLOURS), size=n_cls, replace=False))
        classes = [CLASS_COLOURS[i] for i in pick]
        stacking = rng.random() < P_STACKING
        layout = LAYOUTS[int(rng.integers(len(LAYOUTS)))]
        home = rng.random() < P_HOME_STARTS
        for _ in range(100):
            spec = _draw_sizes(rng, name, classes, stacking, layout, home)
            if spec is not None:
                return spec
    raise VggcError(f"{name}: no task drawn")  # pragma: no cover


def _between(rng: np.random.Generator, lo_hi: tuple[int, int]) -> int:
    return int(rng.integers(lo_hi[0], lo_hi[1] + 1))


def _draw_sizes(rng: np.random.Generator, name: str, classes: list[str], stacking: bool,
                layout: str, home: bool) -> BenchmarkSpec | None:
    """One draw of a task's sizes and shapes; None when its state count is out of bounds."""
    n_cls = len(classes)
    height = _between(rng, STACK_HEIGHT) if stacking else 1
    if layout == "row":
        regions, word = _between(rng, ROW_REGIONS), "row"
    elif layout == "grid":
        rows, cols = _between(rng, GRID_ROWS), _between(rng, GRID_COLS)
        regions, word = rows * cols, f"grid:{rows}x{cols}"
    else:
        regions = _between(rng, SCATTERED_REGIONS)
        word = f"scattered:{int(rng.integers(2 ** 31))}"
    m = _between(rng, (max(OBJECTS_RANGE[0], n_cls), OBJECTS_RANGE[1]))
    if m > regions * height - (height if stacking else 1):
        return None
    counts = np.ones(n_cls, dtype=int) + rng.multinomial(m - n_cls, [1 / n_cls] * n_cls)
    pool = STACKABLE if stacking else SHAPES
    objects: list[tuple[str, str]] = []
    for cls, count in zip(classes, counts):
        k = min(_between(rng, SHAPES_PER_CLASS), int(count))
        shapes = [pool[int(i)] for i in rng.choice(len(pool), size=k, replace=False)]
        objects += [(cls, shapes[j % k]) for j in range(int(count))]
    starts = _between(rng, (1, 2)) if home else 0
    states = count_states(tuple(classes), tuple(o[0] for o in objects), regions, height)
    if not MIN_STATES <= states <= (MAX_STATES_HOME if home else MAX_STATES):
        return None
    episode = EPISODES_HOME if home else EPISODES_UNIFORM
    spec = make_spec(name, tuple(objects), regions, word, height, starts, episode)
    if len(Benchmark(spec).all_states()) != states:  # unreachable arrangements
        return None
    return spec


# ---------------------------------------------------------------- name resolution
def is_task_name(name: str) -> bool:
    """True for ``random-S`` and ``task:...`` names (tasks beyond the seven)."""
    return name.startswith(SPEC_PREFIX) or (name.startswith(RANDOM_PREFIX)
                                            and name[len(RANDOM_PREFIX):].isdigit())


def get_spec(name: str) -> BenchmarkSpec:
    """The spec of any task name: one of the seven benchmarks, ``random-S``, or a spec string.

    Raises
    ------
    VggcError
        Unknown benchmark (listing the seven and the task forms) or a malformed spec.
    """
    name = str(name)
    if name.startswith(RANDOM_PREFIX) and name[len(RANDOM_PREFIX):].isdigit():
        return _drawn(int(name[len(RANDOM_PREFIX):]))
    if name.startswith(SPEC_PREFIX):
        return parse_spec(name)
    if name in SPECS:
        return paper_spec(name)
    raise VggcError(f"unknown benchmark {name!r}; known: {', '.join(SPECS)}, "
                    f"{RANDOM_PREFIX}S (a task drawn from seed S) or a spec string "
                    f"{SPEC_PREFIX}... (vggc-cp envs)")


@lru_cache(maxsize=256)
def _drawn(seed: int) -> BenchmarkSpec:
    return draw_task(seed)


def get_benchmark(name: str) -> Benchmark:
    """The dynamics of task ``name`` (any name :func:`get_spec` takes)."""
    return Benchmark(get_spec(name))


def read_task_argument(value: str) -> str:
    """The task name of ``generate --task VALUE``: ``random-S``, a spec string, or a JSON file
    holding ``{"spec": "task:..."}`` (as ``meta['task']`` records it)."""
    if is_task_name(value) or value in SPECS:
        return get_spec(value).name  # a spec string's canonical form
    path = Path(value)
    if path.suffix == ".json":
        from vggc_cp.safeio import read_json

        data = read_json(path)
        spec = data.get("spec") if isinstance(data, dict) else None
        if not isinstance(spec, str):
            raise VggcError(f"{path}: field 'spec' (a string task:...) is missing")
        try:
            return get_spec(spec).name
        except VggcError as exc:
            raise VggcError(f"{path}: spec: {exc}") from None
    raise VggcError(f"--task {value!r}: not random-S, a spec string task:... or a .json file")


def describe(spec: BenchmarkSpec) -> str:
    """One line describing a task (for ``vggc-cp envs`` and tables)."""
    shapes = sorted(set(spec.objects))
    stack = f", stacks of {spec.max_height}" if spec.max_height > 1 else ""
    starts = f", {spec.start_states} home state(s)" if spec.start_states else ""
    return (f"{spec.n} class{'es' if spec.n != 1 else ''}, {spec.m} objects ({', '.join(shapes)}), {spec.R} regions "
            f"({layout_of(spec).split(':')[0]}){stack}{starts}")
