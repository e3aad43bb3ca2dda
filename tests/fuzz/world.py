"""A tiny valid world (trace, solution, localizer, novel file, image) and the bad inputs made
from it: the raw material of the fuzz corpus (``test_corpus.py``)."""

from __future__ import annotations

import hashlib
import io
import json
import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np
from conftest import TOY_NAMES, make_trace

from vggc_cp.trace import npz_bytes

EP1 = ["L", "pick_L", "H", "place_R", "R", "pick_R", "H", "place_L", "L"]
EP2 = ["R", "pick_R", "H", "place_R", "R", "pick_R", "H", "place_L", "L"]
FAST = ("--sinkhorn-device", "numpy")
SIZE = 16


def sha(path) -> str:
    p = Path(path)
    return hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "-"


def toy_trace(size: int = SIZE, **changes):
    return make_trace([EP1, EP2], TOY_NAMES, size=size, noise=4)


def trace_arrays(trace) -> dict:
    return {"observations": trace.observations, "actions": trace.actions,
            "action_names": np.array(trace.action_names), "states": trace.states,
            "meta": np.array(json.dumps(trace.meta))}


def npy_with_header(shape, dtype="<u1", payload: bytes = b"") -> bytes:
    """An .npy member whose header declares ``shape`` whatever ``payload`` holds."""
    header = repr({"descr": dtype, "fortran_order": False, "shape": tuple(shape)}).encode()
    total = 10 + len(header) + 1
    pad = (64 - total % 64) % 64
    header = header + b" " * pad + b"\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header + payload


def zip_members(members: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
    return buf.getvalue()


def npy(arr, allow_pickle: bool = False) -> bytes:
    b = io.BytesIO()
    np.lib.format.write_array(b, arr, allow_pickle=allow_pickle)
    return b.getvalue()


def bad_traces(valid: bytes) -> dict[str, tuple[bytes, tuple[str, ...]]]:
    """name -> (file bytes, substrings the error must hold besides the file name)."""
    t = toy_trace()
    base = trace_arrays(t)
    out: dict[str, tuple[bytes, tuple[str, ...]]] = {}

    def with_(what, **fields):
        arrays = dict(base)
        for k, v in fields.items():
            if v is None:
                arrays.pop(k)
            else:
                arrays[k] = v
        out[what[0]] = (npz_bytes(arrays), what[1:])

    out["empty-file"] = (b"", ())
    out["random-bytes"] = (np.random.default_rng(0).bytes(300), ())
    out["json-not-npz"] = (b'{"format": "vggc-solution/1"}', ())
    out["single-npy"] = (npy(t.observations), ())
    for cut in (10, 30, 100, len(valid) // 3, len(valid) // 2, len(valid) - 30, len(valid) - 1):
        out[f"truncated-{cut}"] = (valid[:cut], ())
    flipped = bytearray(valid)
    flipped[len(valid) // 2] ^= 0xFF
    out["flipped-byte"] = (bytes(flipped), ())
    for key in ("observations", "actions", "action_names"):
        with_((f"missing-{key}", key), **{key: None})
    obs = t.observations
    with_(("obs-float32", "observations"), observations=obs.astype(np.float32))
    with_(("obs-int64", "observations"), observations=obs.astype(np.int64))
    with_(("obs-rank3", "observations"), observations=obs[..., 0])
    with_(("obs-4-channels", "observations"),
          observations=np.concatenate([obs, obs[..., :1]], axis=3))
    with_(("obs-empty", "observations"), observations=obs[:0])
    with_(("obs-1x1", "observations", "1x1"), observations=obs[:, :1, :1])
    with_(("obs-3x3", "observations", "3x3"), observations=obs[:, :3, :3])
    with_(("obs-1x16", "observations"), observations=obs[:, :1, :])
    with_(("actions-float", "actions"), actions=t.actions.astype(float))
    with_(("actions-rank2", "actions"), actions=t.actions[:, None])
    with_(("actions-short", "actions"), actions=t.actions[:-1])
    with_(("actions-out-of-range", "actions[0]"), actions=np.r_[99, t.actions[1:]])
    with_(("actions-minus-two", "actions[1]"), actions=np.r_[t.actions[0], -2, t.actions[2:]])
    with_(("actions-all-minus-one", "actions"), actions=np.full_like(t.actions, -1))
    swapped = t.actions.copy()
    swapped[1] = swapped[0]
    with_(("two-picks-in-a-row", "observations[1]"), actions=swapped)
    lone = t.actions.copy()
    lone[0] = -1
    with_(("episode-of-one", "observations[0]"), actions=lone)
    names = list(t.action_names)
    for what, bad in (("name-dup", [names[0], names[0], *names[2:]]),
                      ("name-nul", [names[0] + "\x00x", *names[1:]]),
                      ("name-newline", [names[0] + "\nx", *names[1:]]),
                      ("name-tab", ["pick\tL", *names[1:]]),
                      ("name-escape", ["pick\x1b[31mL", *names[1:]]),
                      ("name-space", [" " + names[0], *names[1:]]),
                      ("name-fly", ["fly_away", *names[1:]]),
                      ("name-empty", ["", *names[1:]])):
        with_((what, "action_names"), action_names=np.array(bad))
    with_(("names-int", "action_names"), action_names=np.arange(4))
    with_(("names-2d", "action_names"), action_names=np.array([names]))
    with_(("names-none", "action_names"), action_names=np.array([], dtype=str))
    with_(("states-int", "states"), states=np.arange(len(t.states)))
    with_(("states-short", "states"), states=t.states[:-1])
    with_(("meta-not-json", "meta"), meta=np.array("{nope"))
    with_(("meta-list", "meta"), meta=np.array("[1, 2]"))
    with_(("meta-bytes", "meta"), meta=np.array(b"{}"))
    with_(("meta-deep", "meta", "nested"), meta=np.array("[" * 100_000 + "]" * 100_000))
    with_(("meta-deep-object", "meta", "nested"),
          meta=np.array('{"a":' * 5000 + "1" + "}" * 5000))
    for key in ("observations", "actions", "action_names", "states", "meta", "extra"):
        members = {f"{k}.npy": npy(v) for k, v in base.items()}
        members[f"{key}.npy"] = npy(np.array([{"x": 1}, None], dtype=object), allow_pickle=True)
        out[f"pickled-{key}"] = (zip_members(members), (key, "pickle"))
    for what, shape in (("huge-shape", (10**6, 4096, 4096, 3)),
                        ("huge-images", (2, 100_000, 100_000, 3)),
                        ("shape-vs-data", (50, SIZE, SIZE, 3))):
        members = {f"{k}.npy": npy(v) for k, v in base.items()}
        members["observations.npy"] = npy_with_header(shape, "|u1", obs.tobytes()[:1000])
        out[what] = (zip_members(members), ("observations",))
    members = {f"{k}.npy": npy(v) for k, v in base.items()}
    members["observations.npy"] = b"\x93NUMPY\x01\x00\xff\xffgarbage"
    out["bad-npy-header"] = (zip_members(members), ("observations",))
    members = {f"{k}.npy": npy(v) for k, v in base.items()}
    members["observations.npy"] = npy_with_header((9, SIZE, SIZE, 3), "<f8",
                                                  np.zeros(9 * SIZE * SIZE * 3).tobytes())
    out["obs-f8-declared"] = (zip_members(members), ("observations",))
    return out


def zip_bomb(n_bytes: int) -> bytes:
    """A valid-looking trace whose observations inflate to ``n_bytes`` (a small file)."""
    t = toy_trace()
    base = trace_arrays(t)
    side = int((n_bytes / (len(t.observations) * 3)) ** 0.5) + 1
    members = {f"{k}.npy": npy(v) for k, v in base.items()}
    members["observations.npy"] = npy(np.zeros((len(t.observations), side, side, 3), np.uint8))
    return zip_members(members)


def png_header_only(width: int, height: int) -> bytes:
    """A PNG whose IHDR declares ``width`` x ``height`` (one tiny, wrong IDAT)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64))
            + chunk(b"IEND", b""))


def png(size: int) -> bytes:
    from PIL import Image

    b = io.BytesIO()
    Image.fromarray(np.full((size, size, 3), 120, np.uint8)).save(b, format="PNG")
    return b.getvalue()


def bad_solutions(valid: dict, other_sha: str) -> dict[str, tuple[bytes, tuple[str, ...]]]:
    """name -> (file bytes, substrings the error must hold besides the file name)."""
    out: dict[str, tuple[bytes, tuple[str, ...]]] = {}

    def put(name, data, *must):
        out[name] = (json.dumps(data).encode() if not isinstance(data, bytes) else data, must)

    def field(name, key, value, *must):
        d = json.loads(json.dumps(valid))
        d[key] = value
        put(name, d, *(must or (key,)))

    text = json.dumps(valid)
    put("empty", b"")
    put("not-json", b"{nope")
    put("truncated", text[: len(text) // 2].encode())
    put("latin1", b'{"format": "\xff"}')
    put("top-list", [valid])
    put("top-null", None)
    put("deep-array", ("[" * 100_000 + "]" * 100_000).encode(), "nested")
    put("deep-in-field", text[:-1].encode() + b', "x": ' + b"[" * 100_000 + b"]" * 100_000
        + b"}", "nested")
    for key in ("format", "labels", "roles", "edges", "k_pick", "k_place", "J", "solver",
                "status"):
        d = dict(valid)
        d.pop(key)
        put(f"missing-{key}", d, key)
    field("J-string", "J", "abc")
    field("J-bool", "J", True)
    field("J-list", "J", [1.0])
    put("J-infinity", text.replace(f'"J": {json.dumps(valid["J"])}', '"J": Infinity').encode(),
        "J", "Infinity")
    put("J-nan", text.replace(f'"J": {json.dumps(valid["J"])}', '"J": NaN').encode(), "J")
    put("J-minus-inf", text.replace(f'"J": {json.dumps(valid["J"])}', '"J": -Infinity'
                                    ).encode(), "J")
    field("k_pick-list", "k_pick", [1])
    field("k_pick-string", "k_pick", "2")
    field("k_pick-negative", "k_pick", -1)
    field("k_place-float", "k_place", 1.5)
    field("k_place-bool", "k_place", True)
    field("edges-int", "edges", 5)
    field("edges-null", "edges", None)
    field("edges-short", "edges", [[0, "pick_L"]], "edges[0]")
    field("edges-bool-node", "edges", [[True, "pick_L", 2]], "edges[0]")
    field("edges-huge-node", "edges", [[2**70, "pick_L", 2]], "edges[0]")
    field("labels-huge", "labels", [2**70] + valid["labels"][1:], "labels[0]")
    field("labels-true", "labels", [True] + valid["labels"][1:], "labels[0]")
    field("labels-negative", "labels", valid["labels"][:2] + [-1] + valid["labels"][3:],
          "labels[2]")
    field("labels-string", "labels", "0,1,2")
    field("labels-float", "labels", [0.5] + valid["labels"][1:], "labels[0]")
    field("labels-empty", "labels", [])
    field("roles-short", "roles", valid["roles"][:-1])
    field("roles-unknown", "roles", ["hold"] + valid["roles"][1:], "roles[0]")
    field("status-int", "status", 12345)
    field("solver-null", "solver", None)
    field("format-other", "format", "vggc-solution/2")
    field("sha-not-hex", "trace_sha256", "zz")
    field("sha-other-trace", "trace_sha256", other_sha, "trace_sha256")
    d = json.loads(text)
    d["edges"] = [*d["edges"], [d["edges"][0][0], "fly_away", d["edges"][0][2]]]
    put("edge-fly-away", d, "edge")
    d = json.loads(text)
    d["roles"] = ["place" if r == "pick" else "pick" for r in d["roles"]]
    put("roles-swapped", d, "roles")
    return out


def exactly_one_violation(valid: dict) -> dict:
    """The valid solution plus a second action between one ordered pair of nodes."""
    d = json.loads(json.dumps(valid))
    u, a, v = d["edges"][0]
    other = next(x for _, x, _ in d["edges"] if x != a and x.split("_")[0] == a.split("_")[0])
    d["edges"].append([u, other, v])
    return d
