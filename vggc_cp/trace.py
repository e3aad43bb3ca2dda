"""Execution traces: the ``trace.npz`` format of ``FORMATS.md``, its validation, and roles.

A trace is a time-ordered list of RGB observations ``o_0 .. o_{N-1}`` and the action
``actions[t]`` taken between ``o_t`` and ``o_{t+1}`` (``-1`` where a new episode starts).
The set of transitions ``D = {(o_t, a_t, o_{t+1}) : a_t >= 0}`` is what every solver sees.

Roles (``FORMATS.md``): an observation followed by a pick, or preceded by a place, is a
*pick* observation (a pick is executed from it); followed by a place or preceded by a pick,
a *place* observation.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from vggc_cp.errors import TraceError, VggcError
from vggc_cp.recorded import recorded_facts

PICK = 0
PLACE = 1
ROLE_NAMES = ("pick", "place")
REQUIRED_KEYS = ("observations", "actions", "action_names")


def action_kind(name: str) -> int | None:
    """Return :data:`PICK`, :data:`PLACE` or ``None`` for an action name by its prefix."""
    if name.startswith("pick"):
        return PICK
    if name.startswith("place"):
        return PLACE
    return None


@dataclass(frozen=True, eq=False)
class Trace:
    """An execution trace (immutable value).

    Attributes
    ----------
    observations : ndarray, uint8, shape (N, H, W, 3)
    actions : ndarray, int64, shape (N-1,)
        Index into ``action_names``, or -1 between episodes.
    action_names : tuple of str, length A
    states : ndarray of str, shape (N,), or None
        Ground-truth state keys; read only by :mod:`vggc_cp.evaluate`.
    meta : dict
        Free-form metadata (benchmark, seed, camera, ...).
    """

    observations: np.ndarray
    actions: np.ndarray
    action_names: tuple[str, ...]
    states: np.ndarray | None = None
    meta: dict = field(default_factory=dict)
    #: the file it was loaded from (error messages name it); not part of its identity
    source: str | None = field(default=None, compare=False, repr=False)

    @property
    def n_obs(self) -> int:
        return int(self.observations.shape[0])

    @property
    def n_actions(self) -> int:
        return len(self.action_names)

    @property
    def image_shape(self) -> tuple[int, int]:
        return int(self.observations.shape[1]), int(self.observations.shape[2])

    def transitions(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(src, act, dst)``, int64 arrays of shape (|D|,), one row per transition."""
        t = np.flatnonzero(self.actions >= 0)
        return t.astype(np.int64), self.actions[t].astype(np.int64), (t + 1).astype(np.int64)

    @property
    def n_transitions(self) -> int:
        return int(np.count_nonzero(self.actions >= 0))

    def episodes(self) -> list[tuple[int, int]]:
        """Return ``[(first, last), ...]``, inclusive observation ranges of each episode."""
        breaks = np.flatnonzero(self.actions < 0)
        starts = np.concatenate([[0], breaks + 1])
        ends = np.concatenate([breaks, [self.n_obs - 1]])
        return [(int(s), int(e)) for s, e in zip(starts, ends)]

    def episode_index(self) -> np.ndarray:
        """Episode of every observation, int64 array of shape (N,) (positions in
        :meth:`episodes`)."""
        out = np.empty(self.n_obs, dtype=np.int64)
        for e, (first, last) in enumerate(self.episodes()):
            out[first:last + 1] = e
        return out

    def roles(self) -> np.ndarray:
        """Role of every observation, int8 array of shape (N,): :data:`PICK` or :data:`PLACE`."""
        return compute_roles(self.actions, self.action_names)

    def action_kinds(self) -> np.ndarray:
        """int8 array of shape (A,): :data:`PICK` or :data:`PLACE` for every action."""
        return np.array([action_kind(a) for a in self.action_names], dtype=np.int8)

    def without_states(self) -> Trace:
        """A copy with the ground truth removed (what a solver is allowed to see)."""
        return replace(self, states=None)

    def content_hash(self) -> str:
        """SHA-256 of what solvers see (observations, actions, action names).

        Ground-truth ``states`` and ``meta`` are excluded, so removing them keeps caches valid;
        but the resets and refusals ``meta["appended"]`` records are seen by solvers
        (:mod:`vggc_cp.recorded`): where there are any, they are hashed last.
        """
        from vggc_cp.frames import StreamedFrames

        obs = self.observations
        prefix = content_prefix(obs.shape)
        if isinstance(obs, StreamedFrames):
            h = obs.hashed(prefix)
        else:
            h = hashlib.sha256(prefix)
            h.update(np.ascontiguousarray(obs).reshape(-1))
        h.update(np.ascontiguousarray(self.actions, dtype=np.int64).tobytes())
        h.update("\x00".join(self.action_names).encode())
        h.update(recorded_facts(self).key())
        return h.hexdigest()

    def identity_hash(self) -> str:
        """SHA-256 of what solvers see, every part prefixed by its length (no two traces share
        it, whatever their action names hold); the distance cache's key."""
        def part(b: bytes) -> None:
            h.update(len(b).to_bytes(8, "little"))
            h.update(b)

        from vggc_cp.frames import StreamedFrames

        obs = self.observations
        shape = repr(tuple(obs.shape)).encode()
        prefix = (b"vggc-trace-identity/1" + len(shape).to_bytes(8, "little") + shape
                  + int(obs.nbytes).to_bytes(8, "little"))  # part() of the frames, in pieces
        if isinstance(obs, StreamedFrames):
            h = obs.hashed(prefix)
        else:
            h = hashlib.sha256(prefix)
            h.update(np.ascontiguousarray(obs).reshape(-1))
        part(np.ascontiguousarray(self.actions, dtype=np.int64).tobytes())
        part(len(self.action_names).to_bytes(8, "little"))
        for name in self.action_names:
            part(name.encode("utf-8", "surrogatepass"))
        facts = recorded_facts(self).key()
        if facts:                      # resets and refusals (vggc_cp.recorded)
            part(facts)
        return h.hexdigest()


def content_prefix(shape) -> bytes:
    """What :meth:`Trace.content_hash` hashes before the frames' bytes."""
    return repr(tuple(int(v) for v in shape)).encode()


def hand_colours_along(n_obs: int, src: np.ndarray, act: np.ndarray, dst: np.ndarray,
                       lifted: np.ndarray, put: np.ndarray, colour: np.ndarray) -> np.ndarray:
    """Colour of what the hand holds in every observation, int64 shape (N,), -1 for nothing:
    after a transition that lifts an object (``lifted``) the colour of its action, before one
    that puts it down (``put``) likewise; where the two disagree the putting down wins.

    >>> hand_colours_along(4, np.array([0, 1, 2]), np.array([0, 1, 0]), np.array([1, 2, 3]),
    ...                    np.array([True, False, True]), np.array([False, True, False]),
    ...                    np.array([5, 5])).tolist()
    [-1, 5, -1, 5]
    """
    hand = np.full(n_obs, -1, dtype=np.int64)
    colour = np.asarray(colour, dtype=np.int64)
    hand[dst[lifted]] = colour[act[lifted]]
    hand[src[put]] = colour[act[put]]
    return hand


def compute_roles(actions: np.ndarray, action_names) -> np.ndarray:
    """Roles from actions alone (assumes a valid trace). Returns int8 array of shape (N,)."""
    kinds = np.array([action_kind(a) for a in action_names], dtype=np.int8)
    return roles_of(actions, kinds)


def roles_of(actions: np.ndarray, kinds: np.ndarray) -> np.ndarray:
    """:func:`compute_roles` from the actions' kinds (:data:`PICK` / :data:`PLACE` per
    action); -1 for an observation no transition touches."""
    n = len(actions) + 1
    roles = np.full(n, -1, dtype=np.int8)
    valid = actions >= 0
    t = np.flatnonzero(valid)
    k = kinds[actions[t]]
    roles[t] = k  # followed by a pick -> pick, by a place -> place
    roles[t + 1] = 1 - k  # preceded by a pick -> place, by a place -> pick
    return roles


def _fail(source: str, msg: str) -> TraceError:
    return TraceError(f"{source}: {msg}")


def validate(trace: Trace, source: str = "<trace>") -> None:
    """Check a :class:`Trace` against ``FORMATS.md``; raise :class:`TraceError` on the first problem.

    The message names the source file, the field and the index.
    """
    from vggc_cp.frames import StreamedFrames

    obs, actions, names = trace.observations, trace.actions, trace.action_names
    if not isinstance(obs, (np.ndarray, StreamedFrames)) or obs.dtype != np.uint8:
        dt = getattr(obs, "dtype", type(obs).__name__)
        raise _fail(source, f"field 'observations' has dtype {dt}, expected uint8")
    if obs.ndim != 4 or obs.shape[3] != 3:
        raise _fail(source, f"field 'observations' has shape {obs.shape}, expected [N, H, W, 3]")
    n = obs.shape[0]
    if n == 0 or obs.shape[1] == 0 or obs.shape[2] == 0:
        raise _fail(source, "empty trace: field 'observations' holds no image")
    if not isinstance(actions, np.ndarray) or actions.dtype.kind != "i":
        dt = getattr(actions, "dtype", type(actions).__name__)
        raise _fail(source, f"field 'actions' has dtype {dt}, expected int64")
    if actions.ndim != 1:
        raise _fail(source, f"field 'actions' has rank {actions.ndim}, expected 1")
    if actions.shape[0] != n - 1:
        raise _fail(source, f"field 'actions' has length {actions.shape[0]}, expected N-1 = {n - 1}")
    a = len(names)
    if a == 0:
        raise _fail(source, "field 'action_names' is empty")
    seen: dict[str, int] = {}
    for i, name in enumerate(names):
        if not isinstance(name, str) or not name.isprintable() or name != name.strip() or \
                not name:
            raise _fail(source, f"action_names[{i}] = {name!r} is empty, holds control "
                                f"characters or surrounding spaces")
        if name in seen:
            raise _fail(source, f"action_names[{i}] = {name!r} repeats action_names[{seen[name]}]")
        seen[name] = i
        if action_kind(name) is None:
            raise _fail(source, f"action_names[{i}] = {name!r} begins with neither 'pick' nor 'place'")
    bad = np.flatnonzero((actions < -1) | (actions >= a))
    if bad.size:
        t = int(bad[0])
        raise _fail(source, f"actions[{t}] = {int(actions[t])} is out of range [-1, {a - 1}]")
    if not np.any(actions >= 0):
        raise _fail(source, "empty trace: no transition (every entry of 'actions' is -1)")
    kinds = np.array([action_kind(x) for x in names], dtype=np.int8)
    for t in range(n):
        prev_a = int(actions[t - 1]) if t > 0 else -1
        next_a = int(actions[t]) if t < n - 1 else -1
        if prev_a < 0 and next_a < 0:
            raise _fail(source, f"observations[{t}] has no transition (an episode of length one)")
        if prev_a >= 0 and next_a >= 0 and kinds[prev_a] == kinds[next_a]:
            kind = ROLE_NAMES[kinds[prev_a]]
            raise _fail(
                source,
                f"observations[{t}] gets two roles: preceded by {names[prev_a]!r} (actions[{t - 1}]) "
                f"and followed by {names[next_a]!r} (actions[{t}]): two {kind}s in a row inside an episode",
            )
    if trace.states is not None:
        st = trace.states
        if not isinstance(st, np.ndarray) or st.dtype.kind != "U" or st.ndim != 1:
            raise _fail(source, "field 'states' must be a unicode array of shape [N]")
        if st.shape[0] != n:
            raise _fail(source, f"field 'states' has length {st.shape[0]}, expected N = {n}")


def _read_member(data, key: str, source: str) -> np.ndarray:
    try:
        return data[key]
    except ValueError as exc:
        if "allow_pickle" in str(exc) or "Object arrays" in str(exc):
            raise _fail(source, f"field {key!r} holds an object array (pickle); refused") from None
        raise _fail(source, f"field {key!r} is unreadable: {exc}") from None
    except (zipfile.BadZipFile, OSError, EOFError, KeyError) as exc:
        raise _fail(source, f"field {key!r} is corrupt or truncated ({type(exc).__name__})") from None
    except MemoryError:
        raise _fail(source, f"field {key!r} does not fit in memory") from None
    except Exception as exc:  # zlib.error and friends on damaged members
        raise _fail(source, f"field {key!r} is corrupt or truncated ({type(exc).__name__})") from None


def load_trace(path: str | Path, validate_trace: bool = True) -> Trace:
    """Load and validate ``trace.npz`` (never unpickles).

    Frames of more than ``max_bytes`` (:data:`vggc_cp.safeio.CAPS`) are not loaded: the
    trace's ``observations`` is then a :class:`vggc_cp.frames.StreamedFrames` that reads them
    from the file as a stage asks for them (bounded by ``max_frame_bytes``); every other field
    is held in memory as before.

    Raises
    ------
    TraceError
        Naming the file, the field and the index of the first problem.
    """
    from vggc_cp.frames import StreamedFrames
    from vggc_cp.safeio import cap, check_image_size, check_input, loads_json, npz_headers

    path = Path(path)
    source = str(path)
    try:
        check_input(path, "trace")
        headers = npz_headers(path, source, streamed=("observations",))
        obs_shape, obs_dtype = headers.get("observations", ((), None))
        if len(obs_shape) == 4:
            check_image_size(obs_shape[1], obs_shape[2], f"{source}: field 'observations'")
        stream = obs_dtype is not None and \
            int(np.prod(obs_shape)) * obs_dtype.itemsize > cap("max_bytes")
    except TraceError:
        raise
    except VggcError as exc:
        raise TraceError(str(exc)) from None
    try:
        data = np.load(path, allow_pickle=False)
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as exc:
        raise _fail(source, f"not an npz archive ({type(exc).__name__})") from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise _fail(source, "not an npz archive (a single .npy array)")
    with data:
        keys = set(data.files)
        for key in REQUIRED_KEYS:
            if key not in keys:
                raise _fail(source, f"missing field {key!r}")
        if stream:
            obs = StreamedFrames(path, "observations", source)
            obs.track(content_prefix(obs.shape))  # the solution's trace_sha256, meanwhile
        else:
            obs = _read_member(data, "observations", source)
        actions = _read_member(data, "actions", source)
        names_arr = _read_member(data, "action_names", source)
        states = _read_member(data, "states", source) if "states" in keys else None
        meta_arr = _read_member(data, "meta", source) if "meta" in keys else None
        # read every other member too, so pickles or corruption anywhere are refused
        for key in keys - set(REQUIRED_KEYS) - {"states", "meta"}:  # (frames: read later)
            _read_member(data, key, source)
    if names_arr.dtype.kind != "U" or names_arr.ndim != 1:
        raise _fail(source, f"field 'action_names' has dtype {names_arr.dtype} and rank "
                            f"{names_arr.ndim}, expected unicode [A]")
    meta: dict = {}
    if meta_arr is not None:
        if meta_arr.dtype.kind != "U" or meta_arr.ndim != 0:
            raise _fail(source, "field 'meta' must be a unicode scalar holding a JSON object")
        try:
            meta = loads_json(str(meta_arr), f"{source}: field 'meta'")
        except VggcError as exc:
            raise TraceError(str(exc)) from None
        if not isinstance(meta, dict):
            raise _fail(source, "field 'meta' is JSON but not an object")
    if actions.dtype.kind == "i":
        actions = actions.astype(np.int64, copy=False)
    trace = Trace(obs, actions, tuple(str(x) for x in names_arr), states, meta, source)
    if validate_trace:
        validate(trace, source)
        recorded_facts(trace)          # meta.appended, where present, fits the trace
    return trace


#: bytes of a member written to the zip at once
WRITE_BYTES = 64 << 20


def _npy_header(shape, dtype) -> bytes:
    """The ``.npy`` header :func:`numpy.lib.format.write_array` writes for a C-ordered array
    of ``shape`` and ``dtype`` (version 1.0, or 2.0 where 1.0 cannot hold it)."""
    d = {"descr": np.lib.format.dtype_to_descr(np.dtype(dtype)), "fortran_order": False,
         "shape": tuple(int(v) for v in shape)}
    head = io.BytesIO()
    try:
        np.lib.format.write_array_header_1_0(head, d)
    except ValueError:
        head = io.BytesIO()
        np.lib.format.write_array_header_2_0(head, d)
    return head.getvalue()


def write_npz(fileobj, arrays: dict) -> None:
    """Write deterministic ``.npz`` bytes of ``arrays`` to ``fileobj`` (fixed zip timestamps,
    no pickles), each member in pieces of :data:`WRITE_BYTES`: frames held in a memory map or
    read from another file (:class:`vggc_cp.frames.StreamedFrames`) are never all in memory.
    The bytes are those of one ``writestr`` per member (the zip entry sized up front)."""
    with zipfile.ZipFile(fileobj, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for key, arr in arrays.items():
            if isinstance(arr, np.ndarray):
                if arr.dtype.hasobject:
                    raise ValueError(f"field {key!r} holds objects; refused")
                arr = np.require(arr, requirements="C")  # (keeps a 0-d array 0-d)
            head = _npy_header(arr.shape, arr.dtype)
            nbytes = int(np.prod(arr.shape)) * np.dtype(arr.dtype).itemsize
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.file_size = len(head) + nbytes
            with zf.open(info, "w") as dest:
                dest.write(head)
                if len(arr.shape) == 0 or arr.shape[0] == 0:
                    dest.write(np.asarray(arr).tobytes())
                    continue
                row = max(1, nbytes // arr.shape[0])
                step = max(1, WRITE_BYTES // row)
                for s in range(0, arr.shape[0], step):
                    dest.write(np.ascontiguousarray(arr[s:s + step]).tobytes())


def npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """Deterministic ``.npz`` bytes of ``arrays`` (:func:`write_npz`)."""
    buf = io.BytesIO()
    write_npz(buf, arrays)
    return buf.getvalue()


def trace_arrays(trace: Trace) -> dict:
    """The members of the trace's ``.npz`` (frames as they are held: an array, a memory map
    or frames read from a file)."""
    from vggc_cp.frames import StreamedFrames

    obs = trace.observations
    arrays = {
        "observations": obs if isinstance(obs, (StreamedFrames, np.memmap))
        else np.ascontiguousarray(obs, dtype=np.uint8),
        "actions": np.ascontiguousarray(trace.actions, dtype=np.int64),
        "action_names": np.array(trace.action_names, dtype=str),
    }
    if trace.states is not None:
        arrays["states"] = np.asarray(trace.states, dtype=str)
    if trace.meta:
        arrays["meta"] = np.array(json.dumps(trace.meta, sort_keys=True))
    return arrays


def trace_to_bytes(trace: Trace) -> bytes:
    """Serialize a trace to the npz format (deterministic bytes for a given trace)."""
    return npz_bytes(trace_arrays(trace))


def save_trace(trace: Trace, path: str | Path) -> None:
    """Validate, then atomically write ``trace`` to ``path`` (same trace, same bytes), its
    frames in pieces (:func:`write_npz`)."""
    from vggc_cp.atomic import atomic_path

    validate(trace, str(path))
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        write_npz(f, trace_arrays(trace))


def summarize(trace: Trace) -> dict:
    """Facts ``vggc-cp inspect`` prints: sizes, actions, counts per role, states if present."""
    roles = trace.roles()
    _, act, _ = trace.transitions()
    counts = np.bincount(act, minlength=trace.n_actions)
    out = {
        "observations": trace.n_obs,
        "transitions": trace.n_transitions,
        "episodes": len(trace.episodes()),
        "actions": trace.n_actions,
        "action_names": list(trace.action_names),
        "action_counts": {n: int(c) for n, c in zip(trace.action_names, counts)},
        "pick_observations": int(np.count_nonzero(roles == PICK)),
        "place_observations": int(np.count_nonzero(roles == PLACE)),
        "image_size": list(trace.image_shape),
    }
    if trace.states is not None:
        out["distinct_states"] = int(len(np.unique(trace.states)))
    if trace.meta:
        out["meta"] = trace.meta
    return out
