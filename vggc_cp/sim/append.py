"""Record requested episodes in the simulator and append them to a generated trace.

The episodes file (``vggc-episodes/1``, written by ``vggc-cp suggest``, see
``docs/FORMATS.md``) names, per episode, an observation of the trace to start from and the
actions to take. :func:`append_episodes` plays them in the world that made the trace:

* each episode starts in the **true state** of its start observation (the trace's
  ground-truth ``states``: here the simulator is the world, not the learner), in a fresh
  arrangement of it;
* the actions run under the benchmark's dynamics (:meth:`~vggc_cp.sim.dynamics.Benchmark.step`);
  an action that is illegal there ends the episode, is reported, and is not recorded (an
  episode whose first action is illegal records nothing);
* frames are rendered with the trace's look, rebuilt from ``meta['seed']`` as
  :func:`~vggc_cp.sim.explore.generate` built it (checked against ``meta['look_params']``),
  at frame indices that continue the trace's (the robot look's lighting drift goes on);
  the placement noise and the per-frame effects come from two streams of
  ``SeedSequence([seed, APPEND_SALT, n_obs])`` (``n_obs``: the input trace's observation
  count, so every round draws afresh): the same inputs give the same bytes.

The output holds the input's observations, actions and states unchanged, then the recorded
episodes; ``meta['appended']`` lists every round (the observation count before it, and per
requested episode what was recorded and why it stopped).
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vggc_cp.errors import VggcError

#: The episodes file's format tag.
EPISODES_FORMAT = "vggc-episodes/1"
#: Mixed into the seed of the appended episodes' streams.
APPEND_SALT = 0xA99E


@dataclass(frozen=True)
class EpisodeRequest:
    """One episode to record: start at observation ``start_observation``, take ``actions``.

    ``doubt`` and ``why`` are carried for the record (``suggest``'s reasons)."""

    start_observation: int
    actions: tuple[str, ...]
    doubt: int | None = None
    why: str = ""


@dataclass(frozen=True)
class RecordedEpisode:
    """What became of one request: the actions executed and, if it stopped early, the action
    that was illegal (its position and name) in the state reached."""

    request: EpisodeRequest
    executed: tuple[str, ...]
    illegal_at: int | None
    illegal_action: str | None
    state: str

    def as_dict(self) -> dict:
        return {"start_observation": self.request.start_observation,
                "requested": list(self.request.actions), "executed": list(self.executed),
                "illegal_at": self.illegal_at, "illegal_action": self.illegal_action,
                "doubt": self.request.doubt}


def read_episodes(path: str | Path, trace, source: str | None = None
                  ) -> tuple[list[EpisodeRequest], str]:
    """Read and check an episodes file against ``trace``; returns the requests and the
    file's SHA-256.

    Raises
    ------
    VggcError
        Not JSON, another format, a ``trace_sha256`` other than the trace's, a start
        observation out of range, an unknown action name (names the field and index).
    """
    from vggc_cp.safeio import loads_json

    src = source or str(path)
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise VggcError(f"{src}: cannot read ({exc.strerror or type(exc).__name__})") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise VggcError(f"{src}: not UTF-8 text") from None
    data = loads_json(text, src, allow_nan=False)
    if not isinstance(data, dict):
        raise VggcError(f"{src}: expected a JSON object")
    if data.get("format") != EPISODES_FORMAT:
        raise VggcError(f"{src}: field 'format' is {data.get('format')!r}, expected "
                        f"{EPISODES_FORMAT!r}")
    sha = data.get("trace_sha256")
    if sha is not None:
        if not (isinstance(sha, str) and re.fullmatch(r"[0-9a-f]{64}", sha)):
            raise VggcError(f"{src}: field 'trace_sha256' must be 64 hexadecimal digits")
        if sha != trace.content_hash():
            raise VggcError(f"{src}: field 'trace_sha256' names another trace "
                            f"({sha[:12]}... differs from {trace.content_hash()[:12]}...)")
    episodes = data.get("episodes")
    if not isinstance(episodes, list):
        raise VggcError(f"{src}: field 'episodes' must be a list")
    names = set(trace.action_names)
    out = []
    for k, ep in enumerate(episodes):
        where = f"episodes[{k}]"
        if not isinstance(ep, dict):
            raise VggcError(f"{src}: field {where!r} must be an object")
        start = ep.get("start_observation")
        if not (isinstance(start, int) and not isinstance(start, bool)
                and 0 <= start < trace.n_obs):
            raise VggcError(f"{src}: field '{where}.start_observation' is {start!r}, expected "
                            f"an observation index in [0, {trace.n_obs - 1}]")
        acts = ep.get("actions")
        if not isinstance(acts, list) or not all(isinstance(a, str) for a in acts):
            raise VggcError(f"{src}: field '{where}.actions' must be a list of action names")
        for i, a in enumerate(acts):
            if a not in names:
                raise VggcError(f"{src}: field '{where}.actions[{i}]' is {a!r}, not an action "
                                f"of the trace")
        doubt = ep.get("doubt")
        if doubt is not None and not (isinstance(doubt, int) and not isinstance(doubt, bool)):
            raise VggcError(f"{src}: field '{where}.doubt' must be an integer or null")
        why = ep.get("why", "")
        out.append(EpisodeRequest(int(start), tuple(acts), doubt,
                                  why if isinstance(why, str) else ""))
    return out, hashlib.sha256(raw).hexdigest()


@dataclass(frozen=True, eq=False)
class Appended:
    """What :func:`append_episodes` returns: the new trace and one record per request."""

    trace: object
    recorded: tuple[RecordedEpisode, ...]

    @property
    def added_transitions(self) -> int:
        return sum(len(r.executed) for r in self.recorded)


def _rebuild_look(trace, bench):
    """The trace's look, drawn again from its seed as :func:`generate` drew it."""
    from vggc_cp.sim.explore import look_streams
    from vggc_cp.sim.looks import check_look, make_look

    meta = trace.meta
    name = check_look(meta.get("look", "clean"))
    rounds = meta.get("appended") or []
    base = int(rounds[0]["observations"]) if rounds else trace.n_obs
    look = make_look(name, bench, look_streams(int(meta["seed"]))[0], base)
    if not look.is_clean:
        have = meta.get("look_params", {})
        for key, value in look.as_meta().items():
            if have.get(key) != value:
                raise VggcError(f"{trace.source or 'the trace'}: field 'meta.look_params."
                                f"{key}' differs from the look its seed draws: cannot render "
                                f"in the trace's look")
    return look


def append_episodes(trace, requests: list[EpisodeRequest], *, episodes_sha256: str = "",
                    progress=None) -> Appended:
    """Record ``requests`` in the simulator and append them to ``trace`` (module docstring).

    Parameters
    ----------
    trace : Trace
        A trace written by ``vggc-cp generate`` (with ``states`` and ``meta['benchmark']``,
        ``meta['seed']``, ``meta['image_size']``).
    requests : list of EpisodeRequest
    episodes_sha256 : str
        The episodes file's SHA-256, recorded in ``meta['appended']``.
    progress : callable, optional
        Called once per rendered frame.

    Returns
    -------
    Appended

    Raises
    ------
    VggcError
        A trace without ground truth or without the generator's meta.
    """
    from vggc_cp.sim.arrange import arrangement_after, fresh_arrangement
    from vggc_cp.sim.looks import finish_frame
    from vggc_cp.sim.tasks import get_benchmark
    from vggc_cp.trace import Trace

    src = trace.source or "the trace"
    meta = dict(trace.meta or {})
    for key in ("benchmark", "seed"):
        if key not in meta:
            raise VggcError(f"{src}: field 'meta.{key}' is missing: only a trace written by "
                            f"`vggc-cp generate` can be extended in the simulator")
    if trace.states is None:
        raise VggcError(f"{src}: field 'states' is missing: the simulator needs the true "
                        f"state of every start observation")
    bench = get_benchmark(str(meta["benchmark"]))
    if tuple(bench.action_names) != tuple(trace.action_names):
        raise VggcError(f"{src}: field 'action_names' differs from benchmark "
                        f"{meta['benchmark']!r}'s")
    look = _rebuild_look(trace, bench)
    jitter = look.placement_jitter
    arm = look.arm is not None
    n0 = trace.n_obs
    size = int(trace.observations.shape[1])
    noise_seq, frame_seq = np.random.SeedSequence(
        [int(meta["seed"]), APPEND_SALT, n0]).spawn(2)
    noise_rng, frame_rng = np.random.default_rng(noise_seq), np.random.default_rng(frame_seq)
    index = {a: i for i, a in enumerate(bench.action_names)}

    # the discrete episodes first (what is legal), then the renders
    plans: list[tuple[str, list[str], list[str]]] = []  # (start state, actions, states after)
    recorded = []
    for req in requests:
        state = str(trace.states[req.start_observation])
        cur, done, after = state, [], []
        illegal_at = illegal = None
        for i, a in enumerate(req.actions):
            nxt = bench.step(cur, a)
            if nxt is None:
                illegal_at, illegal = i, a
                break
            done.append(a)
            after.append(nxt)
            cur = nxt
        recorded.append(RecordedEpisode(req, tuple(done), illegal_at, illegal, cur))
        if done:
            plans.append((state, done, after))
    frames, actions, states = [], [], []
    from vggc_cp.sim.render import Scene

    t = n0
    with Scene(bench, size, look) as scene:
        first = True
        for state, acts, after in plans:
            actions.append(-1)
            arr = fresh_arrangement(bench, state, noise_rng, jitter, arm=arm)
            for k in range(len(acts) + 1):
                if k > 0:
                    arr = arrangement_after(bench, arr, acts[k - 1], noise_rng, jitter)
                    actions.append(index[acts[k - 1]])
                scene.distractor_step(frame_rng, first=first)
                first = False
                frames.append(finish_frame(scene.render(arr), look, frame_rng, t))
                states.append(state if k == 0 else after[k - 1])
                t += 1
                if progress is not None:
                    progress()
    rounds = list(meta.get("appended") or [])
    rounds.append({"observations": n0, "episodes_sha256": episodes_sha256,
                   "transitions": sum(len(p[1]) for p in plans),
                   "episodes": [r.as_dict() for r in recorded]})
    meta["appended"] = rounds
    if not frames:
        new = Trace(trace.observations, trace.actions, trace.action_names, trace.states, meta)
    else:
        obs = np.concatenate([trace.observations, np.stack(frames)])
        acts = np.concatenate([trace.actions, np.array(actions, dtype=np.int64)])
        sts = np.concatenate([np.asarray(trace.states, dtype=str), np.array(states, dtype=str)])
        new = Trace(obs, acts, trace.action_names, sts, meta)
    return Appended(new, tuple(recorded))
