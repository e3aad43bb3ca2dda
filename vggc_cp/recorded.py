"""What a recording states beyond its transitions: resets, refused actions, the actions that
undo each other and the actions that act at one site (beyond the paper).

An episode recorded on request (``vggc-cp suggest`` -> ``generate --episodes --append``,
``docs/FORMATS.md``: ``meta["appended"]``) states two facts no image has to be read for:

* **reset** -- the robot was put in the state of an earlier observation (the request's
  ``start_observation``) before the episode began, so the episode's first observation shows
  that same state;
* **refusal** -- an action the request named could not be taken (``illegal_action``): in the
  state the robot was in then (the episode's last recorded observation, or the start
  observation where nothing was recorded), that action is not legal. A refused pick says the
  place holds nothing the hand can take of that class; a refused place, that the place is taken.

:func:`recorded_facts` reads them, checking ``meta["appended"]`` against the trace (bad input
gets a :class:`~vggc_cp.errors.TraceError` naming the field and index). A trace without that
field states neither; everything else in ``meta`` is ignored, so nothing learned ever reads the
simulator's ground truth.

A recording can also declare what the robot's skills are known to do, whatever the scene:

* **undo pairs** -- ``meta["undo"]``, a list of ``[pick, place]`` action names: the place
  puts back what the pick took (the same class, the same place, the same level), so taking
  one right after the other returns the scene to the state before, either way round. A
  robot's skill library knows this of its own skills (``pick(red, 3)`` and ``place(red, 3)``);
  ``vggc-cp generate`` records it for every task. A graph that takes the pick from node
  ``u`` to ``v`` and the place from ``v`` to ``w != u`` is wrong: ``u`` and ``w`` are one
  state, or ``v`` holds two (:mod:`vggc_cp.solvers.broken_facts`);
* **sites** -- ``meta["sites"]``, a list of lists of action names: the actions that act at one
  site (a region holding one stack: its picks and places of every class and level). A state
  offers at most one pick at a site (of its top object) and at most one place (onto its top,
  of the class the hand holds), so a graph whose node takes two picks, or two places, of
  one site holds two states on that node. ``vggc-cp generate`` records the sites of every
  task; a site where objects lie side by side (a bin) is not one.

Nothing reads the names' spelling: a trace without a field declares nothing of it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from vggc_cp.errors import TraceError


@dataclass(frozen=True)
class RecordedFacts:
    """Resets and refusals of a trace (module docstring).

    Attributes
    ----------
    resets : tuple of (int, int)
        ``(a, b)``: observation ``b`` (an episode's first) shows the state of observation ``a``.
    refusals : tuple of (int, int)
        ``(o, k)``: action ``k`` (an index into ``action_names``) was refused in the state of
        observation ``o``.
    undo : tuple of (int, int)
        ``(p, q)``: pick ``p`` and place ``q`` (indices into ``action_names``) undo each other.
    sites : tuple of tuple of int
        The actions (indices into ``action_names``) that act at one site, per site.
    """

    resets: tuple[tuple[int, int], ...] = ()
    refusals: tuple[tuple[int, int], ...] = ()
    undo: tuple[tuple[int, int], ...] = ()
    sites: tuple[tuple[int, ...], ...] = ()

    def __bool__(self) -> bool:
        return bool(self.resets or self.refusals or self.undo or self.sites)

    @property
    def appended(self) -> bool:
        """Whether the recorded episodes (``meta["appended"]``) state a reset or a refusal."""
        return bool(self.resets or self.refusals)

    def key(self) -> bytes:
        """Canonical bytes of the facts (empty where there are none), for cache keys; the
        undo pairs and the sites join only where there are some (keys of traces without them
        unchanged)."""
        if not self:
            return b""
        parts = [list(map(list, self.resets)), list(map(list, self.refusals))]
        if self.undo or self.sites:
            parts.append(list(map(list, self.undo)))
        if self.sites:
            parts.append(list(map(list, self.sites)))
        return json.dumps(parts).encode()


NO_FACTS = RecordedFacts()


def _bad(src: str, field: str, msg: str) -> TraceError:
    return TraceError(f"{src}: field '{field}' {msg}")


def _int(value, src: str, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _bad(src, field, f"is {value!r}, expected an integer")
    return value


def _declared(trace, key: str, fits, expected: str, again: str) -> tuple[tuple[int, ...], ...]:
    """The lists of action names ``trace.meta[key]`` declares, as tuples of indices into
    ``action_names``; empty where the field is absent. Each list must hold names of the trace
    and pass ``fits``, and no name may appear twice; else a
    :class:`~vggc_cp.errors.TraceError` names ``meta.key[i]``, saying ``expected`` or
    ``again``."""
    value = (trace.meta or {}).get(key)
    if value is None:
        return ()
    src = trace.source or "the trace"
    if not isinstance(value, list):
        raise _bad(src, f"meta.{key}", "is not a list")
    index = {name: k for k, name in enumerate(trace.action_names)}
    out, seen = [], set()
    for i, names in enumerate(value):
        if not (isinstance(names, list) and names and fits(names) and all(
                isinstance(x, str) and x in index for x in names)):
            raise _bad(src, f"meta.{key}[{i}]", f"is {names!r}: expected {expected}")
        twice = [x for k, x in enumerate(names) if x in seen or x in names[:k]]
        if twice:
            raise _bad(src, f"meta.{key}[{i}]", f"names {twice[0]!r} again: {again}")
        seen.update(names)
        out.append(tuple(index[x] for x in names))
    return tuple(out)


def undo_pairs(trace) -> tuple[tuple[int, int], ...]:
    """The undo pairs ``trace.meta["undo"]`` declares (module docstring), as indices into
    ``action_names``; empty where the field is absent. Bad input raises a
    :class:`~vggc_cp.errors.TraceError` naming the field and index.

    >>> import numpy as np
    >>> from vggc_cp.trace import Trace
    >>> names = ("pick_a", "pick_b", "place_a", "place_b")
    >>> t = Trace(np.zeros((2, 2, 2, 3), np.uint8), np.array([0]), names, None,
    ...           {"undo": [["pick_a", "place_a"], ["pick_b", "place_b"]]})
    >>> undo_pairs(t)
    ((0, 2), (1, 3))
    >>> undo_pairs(Trace(t.observations, t.actions, names, None, {"undo": [["place_a", "pick_a"]]}))
    Traceback (most recent call last):
    ...
    vggc_cp.errors.TraceError: the trace: field 'meta.undo[0]' is ['place_a', 'pick_a']: expected [pick, place], two action names of the trace
    """
    # the kinds by the names' prefix, as vggc_cp.trace.action_kind reads them
    return _declared(trace, "undo", lambda p: len(p) == 2 and str(p[0]).startswith("pick")
                     and str(p[1]).startswith("place"),
                     "[pick, place], two action names of the trace",
                     "an action undoes at most one other")


def site_groups(trace) -> tuple[tuple[int, ...], ...]:
    """The sites ``trace.meta["sites"]`` declares (module docstring), as tuples of indices
    into ``action_names``; empty where the field is absent. Bad input raises a
    :class:`~vggc_cp.errors.TraceError` naming the field and index.

    >>> import numpy as np
    >>> from vggc_cp.trace import Trace
    >>> names = ("pick_a_0", "pick_a_1", "place_a_0", "place_a_1")
    >>> t = Trace(np.zeros((2, 2, 2, 3), np.uint8), np.array([0]), names, None,
    ...           {"sites": [["pick_a_0", "place_a_0"], ["pick_a_1", "place_a_1"]]})
    >>> site_groups(t)
    ((0, 2), (1, 3))
    """
    return _declared(trace, "sites", lambda g: True, "a list of action names of the trace",
                     "an action acts at one site")


def recorded_facts(trace) -> RecordedFacts:
    """The resets and refusals ``trace.meta["appended"]`` records, the undo pairs
    ``trace.meta["undo"]`` and the sites ``trace.meta["sites"]`` declare (module docstring,
    :func:`undo_pairs`, :func:`site_groups`).

    Every recorded episode is checked against the trace: it must start a new episode at the
    observation the rounds' layout puts it, and its actions must be the ones recorded.

    >>> import numpy as np
    >>> from vggc_cp.trace import Trace
    >>> obs = np.zeros((5, 2, 2, 3), np.uint8)
    >>> meta = {"appended": [{"observations": 3, "episodes": [
    ...     {"start_observation": 0, "executed": [], "illegal_action": "pick_a"},
    ...     {"start_observation": 1, "executed": ["place_b"], "illegal_at": 1,
    ...      "illegal_action": "pick_a"}]}]}
    >>> t = Trace(obs, np.array([0, 1, -1, 1]), ("pick_a", "place_b"), None, meta)
    >>> f = recorded_facts(t)
    >>> f.resets, f.refusals
    (((1, 3),), ((0, 0), (4, 0)))
    >>> bool(recorded_facts(Trace(obs, np.array([0, 1, -1, 1]), ("pick_a", "place_b"))))
    False
    """
    undo, sites = undo_pairs(trace), site_groups(trace)
    rounds = (trace.meta or {}).get("appended")
    if rounds is None:
        return RecordedFacts(undo=undo, sites=sites) if undo or sites else NO_FACTS
    src = trace.source or "the trace"
    if not isinstance(rounds, list):
        raise _bad(src, "meta.appended", "is not a list")
    index = {name: k for k, name in enumerate(trace.action_names)}
    n, actions = trace.n_obs, np.asarray(trace.actions)
    resets, refusals = [], []
    ends = [r.get("observations") if isinstance(r, dict) else None for r in rounds[1:]] + [n]
    for r, (rnd, end) in enumerate(zip(rounds, ends)):
        where = f"meta.appended[{r}]"
        if not isinstance(rnd, dict) or not isinstance(rnd.get("episodes"), list):
            raise _bad(src, f"{where}.episodes", "is missing or not a list")
        t = _int(rnd.get("observations"), src, f"{where}.observations")
        end = _int(end, src, f"meta.appended[{r + 1}].observations")
        if not 0 < t <= end <= n:
            raise _bad(src, f"{where}.observations", f"is {t}: outside 1 .. {min(end, n)}")
        for e, ep in enumerate(rnd["episodes"]):
            at = f"{where}.episodes[{e}]"
            if not isinstance(ep, dict):
                raise _bad(src, at, "is not an object")
            start = _int(ep.get("start_observation"), src, f"{at}.start_observation")
            if not 0 <= start < t:
                raise _bad(src, f"{at}.start_observation", f"is {start}: outside 0 .. {t - 1}")
            done = ep.get("executed")
            if not isinstance(done, list) or any(a not in index for a in done):
                raise _bad(src, f"{at}.executed", "is not a list of the trace's action names")
            if done:
                if t + len(done) >= end or actions[t - 1] >= 0:
                    raise _bad(src, f"{at}.executed", f"does not fit: its {len(done)} actions "
                               f"do not start a new episode at observation {t}")
                got = [int(k) for k in actions[t:t + len(done)]]
                if got != [index[a] for a in done] or (t + len(done) <= n - 2 and
                                                       actions[t + len(done)] >= 0):
                    raise _bad(src, f"{at}.executed",
                               f"differs from actions[{t}:{t + len(done)}]")
                resets.append((start, t))
                last, t = t + len(done), t + len(done) + 1
            else:
                last = start
            refused = ep.get("illegal_action")
            if refused is not None:
                if refused not in index:
                    raise _bad(src, f"{at}.illegal_action",
                               f"is {refused!r}, not an action of the trace")
                refusals.append((last, index[refused]))
        if t != end:
            raise _bad(src, where, f"does not fit: its episodes record observations up to "
                       f"{t}, but the next round starts at {end}")
    return RecordedFacts(tuple(resets), tuple(refusals), undo, sites)
