"""Task specs as frozen values: the paper's seven benchmarks, and the task families.

Parameters of the seven follow the paper's table (Ajith & Chamzas, arXiv 2509.14460): ``m``
objects, ``n`` task-distinct classes, ``R`` regions, ``|A|`` actions, ``|V*|`` the number of
states a trace at the paper's ``|D|`` visits, and the default number of transitions ``|D|``.
Tasks beyond the seven (family :data:`TASK`: any number of colour classes, shapes, objects,
regions, a layout and stacking) are drawn or parsed by :mod:`vggc_cp.sim.tasks`, which is also
where every name -- a benchmark's, ``random-S`` or a ``task:...`` spec string -- is resolved.
"""

from __future__ import annotations

from dataclasses import dataclass

from vggc_cp.errors import lookup

FRUIT = "fruit"
BLOCKS = "blocks"
TASK = "task"

#: Attention backend suited to each family (:attr:`BenchmarkSpec.attention`).
FAMILY_ATTENTION = {FRUIT: "keypoints", BLOCKS: "saliency", TASK: "keypoints"}

#: Fruit kinds: name -> task class. Kinds of one class are interchangeable for the task.
FRUIT_CLASS = {"apple": "red", "strawberry": "red", "lemon": "yellow", "banana": "yellow"}


@dataclass(frozen=True)
class BenchmarkSpec:
    """One benchmark's parameters (immutable).

    Attributes
    ----------
    name : str
        Registry name, e.g. ``"fruit-4x6"``.
    family : str
        :data:`FRUIT` (one object per region) or :data:`BLOCKS` (stacks on base regions).
    m : int
        Number of objects.
    n : int
        Number of task-distinct classes.
    R : int
        Number of (base) regions.
    n_actions : int
        ``|A|``: fruit ``2 n R`` (pick/place per class and region), blocks ``2 R h``
        (pick/place per region and level).
    paper_states : int
        ``|V*|`` in the paper: distinct states visited at the paper's ``|D|``.
    default_transitions : int
        The paper's ``|D|``.
    classes : tuple of str
        Task classes (fruit: ``"red"``, ``"yellow"``; blocks: ``"block"``).
    objects : tuple of str
        Kind of every object (fruit kinds of :data:`FRUIT_CLASS`, or ``"cube"``).
    max_height : int
        Highest stack (1 for fruit, one object per region).
    grid : tuple of int
        ``(rows, cols)`` of the regions on the table; ``rows * cols == R``.
    episode_length : tuple of int
        ``(lo, hi)``: exploration draws each episode's number of transitions uniformly in it.
    start_states : int
        Where episodes begin. 0: every episode at a state drawn uniformly from all valid
        states. ``k > 0``: the trace draws ``k`` home states once and every episode begins at
        one of them, like a robot reset to a home scene between episodes. Only
        multifruit-4x6 uses it (``k = 1``, with episodes of 2-8 transitions): its 210 states
        cannot all be visited by 400 transitions, and the paper's trace visits 58 of them, so
        its exploration is local; uniform starts visit about 165, home starts 50-75.
    object_classes : tuple of str, optional
        Family :data:`TASK`: the task class (colour) of every object; its ``objects`` are
        then shapes (:data:`vggc_cp.sim.tasks.SHAPES`). None for the seven benchmarks (the
        class follows from the fruit kind).
    centres : tuple of (float, float), optional
        Region centres (m) for a scattered layout; None: the ``grid``.
    layout : str, optional
        Family :data:`TASK`: the layout word (``row``, ``grid:RxC``, ``scattered:SEED``).
    """

    name: str
    family: str
    m: int
    n: int
    R: int
    n_actions: int
    paper_states: int
    default_transitions: int
    classes: tuple[str, ...]
    objects: tuple[str, ...]
    max_height: int
    grid: tuple[int, int]
    episode_length: tuple[int, int]
    start_states: int = 0
    object_classes: tuple[str, ...] | None = None
    centres: tuple[tuple[float, float], ...] | None = None
    layout: str | None = None

    def __post_init__(self) -> None:
        if self.start_states < 0:
            raise ValueError(f"{self.name}: start_states must be >= 0")
        if len(self.objects) != self.m or len(self.classes) != self.n:
            raise ValueError(f"{self.name}: objects/classes disagree with m={self.m}, n={self.n}")
        if self.grid[0] * self.grid[1] != self.R:
            raise ValueError(f"{self.name}: grid {self.grid} does not hold R={self.R} regions")
        if self.object_classes is not None and len(self.object_classes) != self.m:
            raise ValueError(f"{self.name}: object_classes disagree with m={self.m}")
        if self.centres is not None and len(self.centres) != self.R:
            raise ValueError(f"{self.name}: {len(self.centres)} centres for R={self.R}")
        levels = {BLOCKS: self.max_height, TASK: self.n * self.max_height}.get(self.family,
                                                                              self.n)
        if 2 * self.R * levels != self.n_actions:
            raise ValueError(f"{self.name}: |A|={self.n_actions} disagrees with the action set")

    @property
    def attention(self) -> str:
        """The attention backend suited to the scene (``vggc-cp benchmark --attention auto``):
        separate coloured objects (fruit) ``keypoints``, stacks (blocks) ``saliency`` (a stack
        is one blob to ``keypoints``)."""
        return FAMILY_ATTENTION[self.family]

    def object_class(self, i: int) -> str:
        """Task class of object ``i``."""
        if self.object_classes is not None:
            return self.object_classes[i]
        kind = self.objects[i]
        return FRUIT_CLASS.get(kind, "block")


def _fruit(name, m, n, R, paper, d, objects, grid, episode, starts=0) -> BenchmarkSpec:
    classes = tuple(c for c in ("red", "yellow") if any(FRUIT_CLASS[o] == c for o in objects))
    return BenchmarkSpec(name, FRUIT, m, n, R, 2 * n * R, paper, d, classes, tuple(objects), 1,
                         grid, episode, starts)


def _blocks(name, m, paper, d, episode) -> BenchmarkSpec:
    return BenchmarkSpec(name, BLOCKS, m, 1, 3, 2 * 3 * m, paper, d, ("block",), ("cube",) * m,
                         m, (1, 3), episode)


SPECS: dict[str, BenchmarkSpec] = {
    s.name: s
    for s in (
        _fruit("fruit-2x3", 2, 1, 3, 6, 50, ["apple"] * 2, (1, 3), (4, 12)),
        _fruit("multifruit-2x3", 2, 2, 3, 12, 95, ["apple", "banana"], (1, 3), (4, 12)),
        _fruit("fruit-4x6", 4, 1, 6, 35, 700, ["apple"] * 4, (2, 3), (4, 16)),
        _fruit("multifruit-4x6", 4, 2, 6, 58, 400, ["strawberry", "apple", "lemon", "banana"],
               (2, 3), (2, 8), starts=1),
        _fruit("fruit-6x8", 6, 1, 8, 84, 1500, ["apple"] * 6, (2, 4), (4, 20)),
        _blocks("blocks-2", 2, 9, 95, (4, 12)),
        _blocks("blocks-3", 3, 16, 200, (4, 12)),
    )
}


def benchmark_names() -> tuple[str, ...]:
    """Names of the registered benchmarks, in the paper's order."""
    return tuple(SPECS)


def paper_spec(name: str) -> BenchmarkSpec:
    """Return the spec of the paper's benchmark called ``name`` (any name, a drawn or parsed
    task's too: :func:`vggc_cp.sim.tasks.get_spec`).

    Raises
    ------
    UnknownNameError
        (a :class:`~vggc_cp.errors.VggcError`) listing the known names.
    """
    return lookup(SPECS, name, "benchmark")
