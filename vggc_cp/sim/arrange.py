"""Continuous arrangements: which object body sits where, with placement noise.

A discrete state says *what* is on each region; an :class:`Arrangement` also says *which*
body (objects of one class are interchangeable but may look different) and its continuous
offset and yaw inside the region. Within an episode an arrangement persists: an action moves
one body, the others stay where they were. Nothing here needs PyBullet.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vggc_cp.sim.dynamics import EMPTY, HELD_BLOCK, Benchmark, State

#: Half-range (m) of a fruit's position noise inside its region, per axis.
FRUIT_JITTER = 0.025
#: Half-range (m) of a base block's position noise inside its region, per axis.
BLOCK_JITTER = 0.015
#: Half-range (m) of a stacked block's offset from the block below, per axis.
STACK_JITTER = 0.005
#: Half-range (rad) of a block's yaw (cubes repeat every pi/2).
BLOCK_YAW = np.pi / 4
#: Half-range (m) and (rad) of the held object's jitter in the gripper.
HELD_JITTER = 0.004
HELD_YAW = 0.25


@dataclass(frozen=True)
class Arrangement:
    """Where every body is (immutable).

    Attributes
    ----------
    stacks : tuple of tuple of int
        ``stacks[r]``: body indices on region ``r``, bottom to top.
    held : int
        Index of the held body, or -1.
    offsets : tuple of (float, float, float)
        Per body ``(dx, dy, yaw)``: metres from its region centre (table) or from the
        gripper's centre (held), and the yaw in radians (held: relative to the grip axis).
    last_region : int
        The region the robot last acted on (an arm rests above it; the robot look), or -1
        (not known: looks without an arm ignore it).
    """

    stacks: tuple[tuple[int, ...], ...]
    held: int
    offsets: tuple[tuple[float, float, float], ...]
    last_region: int = -1


def body_letters(bench: Benchmark) -> tuple[str, ...]:
    """Class letter of every body (``b`` for blocks)."""
    spec = bench.spec
    if bench.blocks:
        return (HELD_BLOCK,) * spec.m
    return tuple(spec.object_class(i)[0] for i in range(spec.m))


def _table_offset(bench: Benchmark, below: tuple[float, float, float] | None,
                  rng: np.random.Generator, jitter: float | None = None
                  ) -> tuple[float, float, float]:
    """Noise of a body put on the table; ``jitter`` replaces the position half-range of a
    fruit or a base block (None: :data:`FRUIT_JITTER` / :data:`BLOCK_JITTER`)."""
    if not bench.stacking:
        j = FRUIT_JITTER if jitter is None else jitter
        dx, dy = rng.uniform(-j, j, 2)
        return float(dx), float(dy), float(rng.uniform(0.0, 2 * np.pi))
    if below is None:
        j = BLOCK_JITTER if jitter is None else jitter
        dx, dy = rng.uniform(-j, j, 2)
    else:
        dx, dy = np.array(below[:2]) + rng.uniform(-STACK_JITTER, STACK_JITTER, 2)
    return float(dx), float(dy), float(rng.uniform(-BLOCK_YAW, BLOCK_YAW))


def _held_offset(rng: np.random.Generator) -> tuple[float, float, float]:
    dx, dy = rng.uniform(-HELD_JITTER, HELD_JITTER, 2)
    return float(dx), float(dy), float(rng.uniform(-HELD_YAW, HELD_YAW))


def fresh_arrangement(bench: Benchmark, state: str, rng: np.random.Generator,
                      jitter: tuple[float, ...] | None = None,
                      arm: bool = False) -> Arrangement:
    """A random arrangement of ``state``: bodies of each class shuffled over its places,
    every body with fresh noise.

    ``jitter``: per body, the half-range (m) of its table position noise (a look's
    :attr:`~vggc_cp.sim.looks.Look.placement_jitter`); None: the module's constants.
    ``arm``: also draw the region the arm last acted on (uniform, after every other draw;
    without it ``last_region`` is -1 and ``rng`` draws exactly what it drew before).
    """
    st: State = bench.decode(state)
    letters = body_letters(bench)
    pools: dict[str, list[int]] = {}
    for letter in sorted(set(letters)):
        idx = [i for i, ch in enumerate(letters) if ch == letter]
        pools[letter] = [idx[j] for j in rng.permutation(len(idx))]
    offsets: list[tuple[float, float, float] | None] = [None] * len(letters)
    stacks = []
    for stack in st.stacks:
        bodies = []
        below = None
        for ch in stack:
            b = pools[ch].pop()
            below = offsets[b] = _table_offset(bench, below, rng,
                                               None if jitter is None else jitter[b])
            bodies.append(b)
        stacks.append(tuple(bodies))
    held = -1
    if st.held != EMPTY:
        held = pools[st.held].pop()
        offsets[held] = _held_offset(rng)
    last = int(rng.integers(len(st.stacks))) if arm else -1
    return Arrangement(tuple(stacks), held, tuple(offsets), last)  # type: ignore[arg-type]


def arrangement_after(bench: Benchmark, arr: Arrangement, action: str,
                      rng: np.random.Generator,
                      jitter: tuple[float, ...] | None = None) -> Arrangement:
    """The arrangement after ``action`` (assumed valid): only the moved body changes, and
    ``last_region`` becomes the action's region.

    A pick moves the top body of the region into the gripper; a place puts the held body on
    top of the region with fresh noise (``jitter`` as in :func:`fresh_arrangement`).
    """
    act = bench.action(action)
    stacks = list(arr.stacks)
    offsets = list(arr.offsets)
    if act.pick:
        body = stacks[act.region][-1]
        stacks[act.region] = stacks[act.region][:-1]
        offsets[body] = _held_offset(rng)
        held = body
    else:
        body = arr.held
        below = offsets[stacks[act.region][-1]] if stacks[act.region] else None
        offsets[body] = _table_offset(bench, below, rng,
                                      None if jitter is None else jitter[body])
        stacks[act.region] = stacks[act.region] + (body,)
        held = -1
    return Arrangement(tuple(stacks), held, tuple(offsets), act.region)


def arrangement_state(bench: Benchmark, arr: Arrangement) -> str:
    """The discrete state key an arrangement shows."""
    letters = body_letters(bench)
    stacks = tuple("".join(letters[b] for b in stack) for stack in arr.stacks)
    return bench.encode(State(stacks, letters[arr.held] if arr.held >= 0 else EMPTY))
