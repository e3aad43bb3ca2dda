"""Discrete dynamics of the benchmarks: canonical state keys, valid actions, transitions.

State keys are strings in which interchangeable objects are equal:

* fruit: one character per region, the class letter of the fruit on it (``r`` red,
  ``y`` yellow) or ``-`` when free, then ``|`` and the held class letter or ``-``;
  e.g. ``"r-r|-"`` (two fruits on regions 0 and 2, nothing held) or ``"r--|r"``.
* blocks: one digit per base region, its stack height, then ``|`` and ``b`` when a block is
  held or ``-``; e.g. ``"200|-"`` or ``"100|b"``.
* task (the family beyond the seven, :mod:`vggc_cp.sim.tasks`): per region its stack's class
  letters bottom to top (``r`` red, ``y`` yellow, ``b`` blue, ``g`` green) or ``-``, regions
  separated by ``.``, then ``|`` and the held letter or ``-``; e.g. ``"ry.-.g|-"`` or
  ``"r.-.g|y"``.

A state with nothing held is a *pick* state (the next action is a pick), one with an object
held a *place* state. Action names: fruit ``pick_<class>_<region>`` / ``place_<class>_<region>``;
blocks ``pick_<region>_<level>`` / ``place_<region>_<level>`` (level 0 is the table), where a
pick takes the top block at that level and a place puts the held block at that level; task
``pick_<class>_<region>`` (no stacking) or ``pick_<class>_<region>_<level>`` (stacking).
"""

from __future__ import annotations

import itertools
from collections import deque
from dataclasses import dataclass, field

from vggc_cp.errors import VggcError
from vggc_cp.sim.specs import BLOCKS, TASK, BenchmarkSpec

EMPTY = "-"
HELD_BLOCK = "b"


@dataclass(frozen=True)
class Action:
    """A decoded action name.

    Attributes
    ----------
    name : str
    pick : bool
        True for a pick, False for a place.
    region : int
    cls : str
        Class letter (fruit) or ``"b"`` (blocks).
    level : int
        Stack level the action acts at (0 for fruit).
    """

    name: str
    pick: bool
    region: int
    cls: str
    level: int


@dataclass(frozen=True)
class State:
    """A decoded state: per-region stacks of class letters (bottom first) and the held letter.

    Attributes
    ----------
    stacks : tuple of str
        ``stacks[r]`` lists the class letters on region ``r``, bottom to top.
    held : str
        Class letter of the held object, or ``"-"``.
    """

    stacks: tuple[str, ...]
    held: str

    @property
    def holding(self) -> bool:
        return self.held != EMPTY


@dataclass(frozen=True)
class Benchmark:
    """A benchmark's discrete dynamics (what :func:`get_benchmark` returns).

    Attributes
    ----------
    spec : BenchmarkSpec
    action_names : tuple of str
        Every action, picks first; the order used by generated traces.
    """

    spec: BenchmarkSpec
    action_names: tuple[str, ...] = field(init=False)
    _actions: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        s = self.spec
        acts = []
        for pick in (True, False):
            verb = "pick" if pick else "place"
            if s.family == BLOCKS:
                for r, lvl in itertools.product(range(s.R), range(s.max_height)):
                    acts.append(Action(f"{verb}_{r}_{lvl}", pick, r, HELD_BLOCK, lvl))
            elif s.family == TASK:
                for c, r, lvl in itertools.product(s.classes, range(s.R), range(s.max_height)):
                    name = f"{verb}_{c}_{r}" if s.max_height == 1 else f"{verb}_{c}_{r}_{lvl}"
                    acts.append(Action(name, pick, r, c[0], lvl))
            else:
                for c, r in itertools.product(s.classes, range(s.R)):
                    acts.append(Action(f"{verb}_{c}_{r}", pick, r, c[0], 0))
        object.__setattr__(self, "action_names", tuple(a.name for a in acts))
        object.__setattr__(self, "_actions", {a.name: a for a in acts})

    @property
    def undo_pairs(self) -> tuple[tuple[str, str], ...]:
        """Every ``(pick, place)`` pair of action names that undo each other: one class, one
        region, one level (:meth:`step`: the place puts back what the pick took, and the pick
        takes what the place put down). Recorded in a generated trace's ``meta["undo"]``
        (:func:`vggc_cp.recorded.undo_pairs`).

        >>> from vggc_cp.sim.tasks import get_benchmark
        >>> get_benchmark("fruit-2x3").undo_pairs[:2]
        (('pick_red_0', 'place_red_0'), ('pick_red_1', 'place_red_1'))
        """
        acts = self._actions.values()
        places = {(a.cls, a.region, a.level): a.name for a in acts if not a.pick}
        return tuple((a.name, places[(a.cls, a.region, a.level)]) for a in acts
                     if a.pick and (a.cls, a.region, a.level) in places)

    @property
    def sites(self) -> tuple[tuple[str, ...], ...]:
        """The action names that act at each region, region by region (picks then places, in
        :attr:`action_names` order): a state offers at most one pick there (its top object)
        and one place (onto its top, of the held class). Recorded in a generated trace's
        ``meta["sites"]`` (:func:`vggc_cp.recorded.site_groups`).

        >>> from vggc_cp.sim.tasks import get_benchmark
        >>> get_benchmark("blocks-2").sites[0]
        ('pick_0_0', 'pick_0_1', 'place_0_0', 'place_0_1')
        """
        return tuple(tuple(n for n, a in self._actions.items() if a.region == r)
                     for r in range(self.spec.R))

    # ------------------------------------------------------------------ keys
    @property
    def blocks(self) -> bool:
        return self.spec.family == BLOCKS

    @property
    def stacking(self) -> bool:
        """True when objects stack (blocks, and tasks of height > 1)."""
        return self.spec.max_height > 1

    def decode(self, key: str) -> State:
        """Parse a state key; raise :class:`VggcError` when it is malformed or impossible."""
        s = self.spec
        body, sep, held = key.partition("|")
        if s.family == TASK:
            parts = body.split(".")
            if not sep or len(parts) != s.R or len(held) != 1 or any(
                    not p or (p != EMPTY and EMPTY in p) for p in parts):
                raise VggcError(f"{s.name}: malformed state key {key!r}")
            body = ""
        if not sep or (s.family != TASK and len(body) != s.R) or len(held) != 1:
            raise VggcError(f"{s.name}: malformed state key {key!r}")
        if s.family == TASK:
            stacks = tuple("" if p == EMPTY else p for p in parts)
        elif self.blocks:
            if not body.isdigit() or held not in (EMPTY, HELD_BLOCK):
                raise VggcError(f"{s.name}: malformed state key {key!r}")
            stacks = tuple(HELD_BLOCK * int(h) for h in body)
        else:
            stacks = tuple("" if ch == EMPTY else ch for ch in body)
        state = State(stacks, held)
        if self._counts(state) != self._object_counts() or any(
                len(st) > s.max_height for st in stacks):
            raise VggcError(f"{s.name}: state key {key!r} is not a state of this benchmark")
        return state

    def encode(self, state: State) -> str:
        """The canonical key of a decoded state."""
        if self.blocks:
            body = "".join(str(len(st)) for st in state.stacks)
        elif self.spec.family == TASK:
            body = ".".join(st if st else EMPTY for st in state.stacks)
        else:
            body = "".join(st if st else EMPTY for st in state.stacks)
        return f"{body}|{state.held}"

    def _object_counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for i in range(self.spec.m):
            letter = HELD_BLOCK if self.blocks else self.spec.object_class(i)[0]
            out[letter] = out.get(letter, 0) + 1
        return out

    @staticmethod
    def _counts(state: State) -> dict[str, int]:
        out: dict[str, int] = {}
        for ch in "".join(state.stacks) + (state.held if state.holding else ""):
            out[ch] = out.get(ch, 0) + 1
        return out

    def action(self, name: str) -> Action:
        """Decode an action name; raise :class:`VggcError` for a name not in :attr:`action_names`."""
        try:
            return self._actions[name]
        except KeyError:
            raise VggcError(f"{self.spec.name}: unknown action {name!r}") from None

    # -------------------------------------------------------------- dynamics
    def _step(self, state: State, act: Action) -> State | None:
        stack = state.stacks[act.region]
        if act.pick:
            if state.holding or len(stack) != act.level + 1 or stack[-1] != act.cls:
                return None
            new_stack, held = stack[:-1], act.cls
        else:
            if state.held != act.cls or len(stack) != act.level or len(stack) >= self.spec.max_height:
                return None
            new_stack, held = stack + act.cls, EMPTY
        stacks = state.stacks[:act.region] + (new_stack,) + state.stacks[act.region + 1:]
        return State(stacks, held)

    def step(self, state: str, action: str) -> str | None:
        """The state after ``action`` in ``state``, or ``None`` when the action is invalid there.

        Parameters
        ----------
        state : str
            A state key (as stored in a trace's ``states``).
        action : str
            An action name of :attr:`action_names`.
        """
        nxt = self._step(self.decode(state), self.action(action))
        return None if nxt is None else self.encode(nxt)

    def apply(self, state: str, actions) -> tuple[list[bool], list[str]]:
        """Execute an action sequence from ``state``.

        Returns
        -------
        valid : list of bool, one per action
            Whether each action was valid where it was executed.
        states : list of str, one per action
            The state after each action; an invalid action leaves the state unchanged (and
            the rest of the sequence goes on from there).
        """
        valid, states = [], []
        cur = state
        self.decode(cur)
        for a in actions:
            nxt = self.step(cur, a)
            valid.append(nxt is not None)
            cur = cur if nxt is None else nxt
            states.append(cur)
        return valid, states

    def valid_actions(self, state: str) -> tuple[str, ...]:
        """Names of the actions valid in ``state``, in :attr:`action_names` order."""
        st = self.decode(state)
        return tuple(n for n, a in self._actions.items() if self._step(st, a) is not None)

    def is_pick_state(self, state: str) -> bool:
        """True when nothing is held (the next action is a pick)."""
        return not self.decode(state).holding

    def initial_states(self) -> tuple[str, ...]:
        """Every valid start state: all reachable states, sorted (pick and place states)."""
        return self.all_states()

    def all_states(self) -> tuple[str, ...]:
        """The full reachable state set (pick and place states), sorted.

        Found by breadth-first search from the state with the objects on the first regions
        (fruit: classes in object order; blocks: all on region 0).
        """
        s = self.spec
        if self.blocks:
            start = State((HELD_BLOCK * s.m,) + ("",) * (s.R - 1), EMPTY)
        elif s.family == TASK:
            letters = "".join(s.object_class(i)[0] for i in range(s.m))
            h = s.max_height
            stacks = [letters[i:i + h] for i in range(0, len(letters), h)]
            start = State(tuple(stacks) + ("",) * (s.R - len(stacks)), EMPTY)
        else:
            letters = [s.object_class(i)[0] for i in range(s.m)]
            start = State(tuple(letters) + ("",) * (s.R - s.m), EMPTY)
        seen = {self.encode(start)}
        queue = deque([start])
        acts = tuple(self._actions.values())
        while queue:
            cur = queue.popleft()
            for a in acts:
                nxt = self._step(cur, a)
                if nxt is not None:
                    key = self.encode(nxt)
                    if key not in seen:
                        seen.add(key)
                        queue.append(nxt)
        return tuple(sorted(seen))
