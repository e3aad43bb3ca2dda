"""Hardened file input and output: the one place every command's files pass through.

* :func:`preflight` runs before a command does any work (``vggc_cp.cli.main``). It checks every
  input path of the parsed arguments (exists, a regular file, a sane name) and every output
  path (not an input of the same run, not a directory, device or fifo, a writable folder), so a
  bad path fails in a second, never after minutes of computing, and an input is never replaced.
* :func:`npz_headers` reads the header (shape, dtype) of every member of an ``.npz`` without
  inflating it, so declared sizes are checked against :func:`cap` before any allocation;
  pickled (object) members are refused.
* :func:`loads_json` / :func:`read_json` bound the size and nesting depth of JSON before
  parsing (a ``meta`` nested 100 000 deep never reaches the recursive parser).
* :func:`sweep_stale_temps` removes temporary files of :mod:`vggc_cp.atomic` left behind by a
  killed run.

Caps are module constants, overridable by environment variables (README, "Hardening: caps
and refusals"): :data:`CAPS` maps each name to its default and variable.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import secrets
import stat
import sys
import time
import zipfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from vggc_cp.errors import VggcError

#: name -> (default, environment variable, what it bounds)
CAPS: dict[str, tuple[int, str, str]] = {
    "max_bytes": (1 << 30, "VGGC_CP_MAX_BYTES",
                  "uncompressed bytes of one input file's arrays held in memory (npz members, "
                  "checkpoints)"),
    "max_frame_bytes": (64 << 30, "VGGC_CP_MAX_FRAME_BYTES",
                        "uncompressed bytes of a trace's frames read from the file in chunks "
                        "(vggc_cp.frames), beyond max_bytes"),
    "max_pixels": (4096 * 4096, "VGGC_CP_MAX_PIXELS", "pixels (height x width) of one image"),
    "min_side": (4, "VGGC_CP_MIN_SIDE", "smallest image height or width accepted"),
    "max_json_bytes": (256 << 20, "VGGC_CP_MAX_JSON_BYTES", "bytes of one JSON file or field"),
    "max_json_depth": (64, "VGGC_CP_MAX_JSON_DEPTH", "nesting depth of JSON arrays/objects"),
    "stale_temp_minutes": (60, "VGGC_CP_STALE_TEMP_MINUTES",
                           "age after which a left-over temporary file is swept"),
}

#: attributes of a parsed command line that name files the command reads
INPUT_ATTRS = ("trace", "solution", "hint", "model", "novel", "start", "goal", "weights",
               "notebook")
#: attributes that name files the command writes
OUTPUT_ATTRS = ("output", "csv", "plot")
#: attributes that name folders the command writes into (checked by :func:`check_output_dir`)
OUTPUT_DIR_ATTRS = ("out", "workdir")
#: integer options bounded for every command that has them: attribute -> (lowest, highest);
#: a new command's option of the same name is checked without touching this module
ARG_BOUNDS: dict[str, tuple[int, int]] = {
    "seed": (0, 2**32 - 1),
    "queries": (1, 1_000_000),
    "i2p_queries": (1, 1_000_000),
    "reference_queries": (1, 1_000_000),
    "jobs": (1, 1024),
    "threads": (1, 1024),
    "sinkhorn_threads": (1, 1024),
    "pairs": (1, 10_000_000),
    "naive_pairs": (1, 10_000_000),
    "batch_pairs": (1, 1_000_000),
    "batch_size": (1, 1_000_000),
    "maps": (1, 1_000_000),
}
#: suffixes matplotlib can write (``--plot``)
PLOT_FORMATS = frozenset({"png", "pdf", "svg", "svgz", "jpg", "jpeg", "eps", "ps", "tif",
                          "tiff", "webp", "pgf", "raw", "rgba"})
TEMP_MARK = ".vggctmp-"
PROBE_PREFIX = ".vggc-probe-"
_TEMP_RE = re.compile(r"^(\..+\.vggctmp-|\.vggc-probe-)[A-Za-z0-9_]+(\.[A-Za-z0-9]+)?$")
#: temporary files that may exist now: registered *before* they are created, removed by
#: :func:`cleanup_temps` when a signal ends the run
_LIVE: set[Path] = set()


#: largest value an environment cap may hold (a C ``int64``: numpy and the OS take it)
ENV_INT_MAX = (1 << 63) - 1


def env_int(env: str, default: int, minimum: int = 1) -> int:
    """The integer of environment variable ``env`` (``default`` when unset or blank).

    The one parser of every integer the environment sets: a value that is not a plain decimal
    integer (``1.5``, ``1e9``, ``inf``, ``nan``, ``-3``, ``abc``), below ``minimum`` or above
    :data:`ENV_INT_MAX` is refused with one line naming the variable.
    """
    text = os.environ.get(env)
    if text is None or not text.strip():
        return default
    t = text.strip()
    if not re.fullmatch(r"\+?[0-9]{1,19}", t) or not minimum <= int(t) <= ENV_INT_MAX:
        shown = text if len(text) <= 40 else text[:40] + "..."
        raise VggcError(f"${env} = {shown!r}: expected an integer from {minimum:,} to "
                        f"{ENV_INT_MAX:,} (unset it for the default, {default:,})")
    return int(t)


def cap(name: str) -> int:
    """The cap ``name`` (:data:`CAPS`): its environment variable if set, else the default
    (parsed by :func:`env_int`)."""
    default, env, _ = CAPS[name]
    return env_int(env, default)


def fail(source, msg: str) -> VggcError:
    return VggcError(f"{source}: {msg}")


def _too_big(what: str, value: int, name: str) -> str:
    return (f"{what} ({value:,}) exceeds the cap of {cap(name):,}; raise it with "
            f"{CAPS[name][1]}=... if the file is trusted")


# ------------------------------------------------------------------ paths


def _name_too_long(path: str) -> bool:
    return any(len(os.fsencode(part)) > 255 for part in Path(path).parts)


def check_input(path, what: str = "input") -> os.stat_result:
    """Refuse a missing, unreadable or non-regular input file (a fifo would block reading)."""
    src = str(path)
    if "\x00" in src:
        raise fail(repr(src), "a path holding NUL")
    if _name_too_long(src):
        raise fail(src[:80] + "...", "a path component is longer than 255 bytes")
    try:
        st = os.stat(src)
    except FileNotFoundError:
        raise fail(src, "no such file") from None
    except OSError as exc:
        raise fail(src, f"cannot read the {what} ({exc.strerror or type(exc).__name__})") from None
    if stat.S_ISDIR(st.st_mode):
        raise fail(src, f"the {what} is a directory, not a file")
    if not stat.S_ISREG(st.st_mode):
        raise fail(src, f"the {what} is not a regular file (device, fifo or socket)")
    return st


def _same(a: str, b: str) -> bool:
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_output(path, opt: str, inputs: dict[str, str] = {}) -> None:  # noqa: B006
    """Refuse an output that is an input of the run, not a regular file, or not writable."""
    src = str(path)
    if "\x00" in src:
        raise fail(repr(src), f"{opt}: a path holding NUL")
    if _name_too_long(src):
        raise fail(src[:80] + "...", f"{opt}: a path component is longer than 255 bytes")
    for in_opt, inp in inputs.items():
        if _same(src, inp):
            raise fail(src, f"{opt} is the same file as the input {inp} ({in_opt}); refused, it "
                            f"would overwrite the input")
    try:
        st = os.stat(src)
    except (FileNotFoundError, NotADirectoryError):
        st = None
    except OSError as exc:
        raise fail(src, f"{opt}: cannot use this path ({exc.strerror or type(exc).__name__})"
                   ) from None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise fail(src, f"{opt} is a directory; give a file name")
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise fail(src, f"{opt} is not a regular file (device, fifo or socket); refused")
    parent = Path(os.path.abspath(src)).parent
    probe = parent
    while not (probe.exists() or probe.is_symlink()):
        probe = probe.parent
    if probe.is_symlink() and not probe.exists():
        raise fail(src, f"{opt}: {probe} is a broken link")
    if not probe.is_dir():
        raise fail(src, f"{opt}: {probe} is a file, not a folder")
    if probe == parent:
        try:
            with temp_file(parent, PROBE_PREFIX):
                pass
        except OSError as exc:
            raise fail(src, f"{opt}: cannot write in {parent} "
                            f"({exc.strerror or type(exc).__name__})") from None
    elif not os.access(probe, os.W_OK | os.X_OK):
        raise fail(src, f"{opt}: cannot create folders in {probe} (not writable)")


def check_output_dir(path, opt: str = "--out", folders: tuple[str, ...] = (),
                     files: tuple[str, ...] = (),
                     file_suffixes: tuple[str, ...] = (".json", ".npz", ".pt", ".csv", ".md")
                     ) -> None:
    """Refuse an output *folder* the command could not write into, before any work.

    ``path`` must be a folder (or not exist yet, under a writable existing folder): not a
    file, a fifo, a device, a symbolic-link loop, under ``/proc``/``/sys``, or read-only
    (checked by creating a probe file there). Inside it, each of ``folders`` must be a folder
    where it exists, each of ``files`` a regular file where it exists, and every entry of those
    folders whose name ends in one of ``file_suffixes`` a regular file (a directory or fifo
    named ``cells/x.json`` would fail the run later). Stale temporary files are swept from the
    folder and its ``folders``.
    """
    src = str(path)
    if "\x00" in src:
        raise fail(repr(src), f"{opt}: a path holding NUL")
    if _name_too_long(src):
        raise fail(src[:80] + "...", f"{opt}: a path component is longer than 255 bytes")
    real = os.path.realpath(src)
    if real == "/proc" or real.startswith(("/proc/", "/sys/", "/dev/")) or real == "/sys":
        raise fail(src, f"{opt}: a folder under /proc, /sys or /dev; refused")
    try:
        st = os.stat(src)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise fail(src, f"{opt}: cannot use this path ({oserror_text(exc)})") from None
    if st is not None and not stat.S_ISDIR(st.st_mode):
        kind = "a file" if stat.S_ISREG(st.st_mode) else "a device, fifo or socket"
        raise fail(src, f"{opt} is {kind}, not a folder")
    probe = Path(os.path.abspath(src))
    while not (probe.exists() or probe.is_symlink()):
        probe = probe.parent
    if probe.is_symlink() and not probe.exists():
        raise fail(src, f"{opt}: {probe} is a broken link")
    if not probe.is_dir():
        raise fail(src, f"{opt}: {probe} is a file, not a folder")
    try:
        with temp_file(probe, PROBE_PREFIX):
            pass
    except OSError as exc:
        raise fail(src, f"{opt}: cannot write in {probe} ({oserror_text(exc)})") from None
    if st is None:
        return
    root = Path(src)
    for name in files:
        p = root / name
        if (p.exists() or p.is_symlink()) and not p.is_file():
            raise fail(p, f"{opt}: {name} is not a regular file (a folder, fifo or broken "
                          f"link); refused")
    sweep_stale_temps(root)
    for name in folders:
        sub = root / name
        if not (sub.exists() or sub.is_symlink()):
            continue
        if not sub.is_dir():
            raise fail(sub, f"{opt}: {name} is not a folder")
        try:
            entries = list(os.scandir(sub))
        except OSError as exc:
            raise fail(sub, f"{opt}: cannot read the folder ({oserror_text(exc)})") from None
        for e in entries:
            if e.name.endswith(file_suffixes) and not is_temp_name(e.name) \
                    and not e.is_file(follow_symlinks=True):
                raise fail(e.path, f"{opt}: not a regular file (a folder, fifo or broken "
                                   f"link); refused")
        sweep_stale_temps(sub)


def check_size(value: int | None, option: str, low: int, high: int, cap_text: str) -> None:
    """Refuse a size from the command line outside ``low..high``; ``cap_text`` names the cap
    (``"the cap of 10,000 seeds"``, ``"VGGC_CP_MAX_BYTES"``)."""
    if value is None:
        return
    if value < low:
        raise VggcError(f"{option} {value}: expected at least {low:,}")
    if value > high:
        raise VggcError(f"{option} {value:,}: above {cap_text} ({high:,})")


def check_trace_budget(n: int | None, side: int | tuple[int, int], option: str,
                       name: str = "max_bytes") -> None:
    """Refuse ``n`` transitions (or renders) of ``side`` x ``side`` (or ``(height, width)``)
    RGB images whose arrays would exceed the cap ``name`` (``max_bytes``: the cap of a trace
    read from a file, applied to one the command would generate; ``max_frame_bytes`` where the
    frames go to a file as they are rendered): ``--transitions 1000000000`` is refused, not
    run."""
    if n is None:
        return
    if n < 1:
        raise VggcError(f"{option} {n}: expected at least 1")
    limit = cap(name)
    h, w = (side, side) if isinstance(side, int) else side
    per = 3 * h * w
    if (n + 1) * per > limit:
        raise VggcError(f"{option} {n:,}: {w}x{h} images of {n + 1:,} observations would "
                        f"take {(n + 1) * per:,} bytes, above the cap of {limit:,} "
                        f"({CAPS[name][1]}); at most {limit // per - 1:,}")


def check_numbers(args) -> None:
    """Refuse a NaN in any float option and an integer option of :data:`ARG_BOUNDS` outside
    its bounds (``--seed -1``, ``-Q 100000000000``), naming the option and the cap."""
    for attr, value in sorted(vars(args).items()):
        opt = "--" + attr.replace("_", "-")
        if isinstance(value, float) and value != value:
            raise VggcError(f"{opt} nan: not a number")
        if attr in ARG_BOUNDS and isinstance(value, int) and not isinstance(value, bool):
            lo, hi = ARG_BOUNDS[attr]
            check_size(value, opt, lo, hi, "the cap in safeio.ARG_BOUNDS")


def preflight(args) -> None:
    """Check the environment's caps and the input and output paths of a parsed command line
    before any work."""
    for name in CAPS:
        cap(name)  # a bad $VGGC_CP_* cap fails here, whatever the command reads later
    check_numbers(args)
    inputs: dict[str, str] = {}
    for attr in INPUT_ATTRS:
        value = getattr(args, attr, None)
        if isinstance(value, (str, os.PathLike)):
            value = os.path.expanduser(value) if attr == "weights" else value
            check_input(value, attr)
            inputs[attr] = str(value)
    outputs: dict[str, str] = {}
    for attr in OUTPUT_ATTRS:
        value = getattr(args, attr, None)
        if not isinstance(value, (str, os.PathLike)):
            continue
        opt = "--" + attr
        check_output(value, opt, inputs)
        for other_opt, other in outputs.items():
            if _same(str(value), other):
                raise fail(value, f"{opt} and {other_opt} name the same file")
        if attr == "plot":
            suffix = Path(value).suffix.lstrip(".").lower()
            if suffix and suffix not in PLOT_FORMATS:
                raise fail(value, f"--plot: {suffix!r} is not an image format "
                                  f"({', '.join(sorted(PLOT_FORMATS))})")
        outputs[opt] = str(value)
        sweep_stale_temps(Path(os.path.abspath(value)).parent)
    for attr in OUTPUT_DIR_ATTRS:
        value = getattr(args, attr, None)
        if isinstance(value, (str, os.PathLike)):
            check_output_dir(value, "--" + attr.replace("_", "-"))
    cache = getattr(args, "cache_dir", None)
    if isinstance(cache, str) and not getattr(args, "no_cache", False):
        if os.path.exists(cache) and not os.path.isdir(cache):
            raise fail(cache, "--cache-dir is not a folder")


def check_grid(trace, grid: int) -> None:
    """Refuse a trace whose images are smaller than the attention grid (before any work)."""
    h, w = trace.image_shape
    if min(h, w) < grid:
        raise VggcError(f"{getattr(trace, 'source', None) or 'the trace'}: field 'observations' "
                        f"holds {h}x{w} images, smaller than the {grid}x{grid} attention grid "
                        f"(--grid)")


def check_image_size(height: int, width: int, source: str) -> None:
    """Refuse images below ``min_side`` or above ``max_pixels`` (before decoding them)."""
    lo = cap("min_side")
    if height < lo or width < lo:
        raise VggcError(f"{source}: {height}x{width} images are smaller than the minimum "
                        f"{lo}x{lo} ({CAPS['min_side'][1]})")
    if height * width > cap("max_pixels"):
        raise VggcError(f"{source}: {height}x{width} images: "
                        + _too_big("pixels", height * width, "max_pixels"))


# ------------------------------------------------------------------ npz


def npz_headers(path, source: str | None = None, streamed: tuple[str, ...] = ()
                ) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """``{key: (shape, dtype)}`` of every ``.npy`` member of ``path``, read from the headers.

    Refuses (naming the file and the field) a file that is not a zip, a member that is not an
    array, an object (pickle) member, a declared size above ``max_bytes`` or above what the
    member holds, and a total uncompressed size above ``max_bytes``. Members named in
    ``streamed`` (read in chunks, :mod:`vggc_cp.frames`) are bounded by ``max_frame_bytes``
    instead and left out of the total. Nothing is inflated beyond the few bytes of each header.
    """
    source = str(path) if source is None else source
    limit = cap("max_bytes")
    stream_limit = cap("max_frame_bytes")
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, EOFError, ValueError) as exc:
        raise fail(source, f"not an npz archive ({type(exc).__name__})") from None
    out = {}
    with zf:
        infos = zf.infolist()
        total = sum(i.file_size for i in infos if i.filename.removesuffix(".npy")
                    not in streamed)
        if total > limit:
            raise fail(source, "uncompressed size " + _too_big("bytes", total, "max_bytes"))
        for info in infos:
            key = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
            try:
                with zf.open(info) as f:
                    version = np.lib.format.read_magic(f)
                    if version == (1, 0):
                        shape, fortran, dtype = np.lib.format.read_array_header_1_0(f)
                    elif version in ((2, 0), (3, 0)):
                        shape, fortran, dtype = np.lib.format.read_array_header_2_0(f)
                    else:
                        raise ValueError(f"npy version {version}")
                    header_len = f.tell()
            except Exception as exc:  # noqa: BLE001 - any damage in a header is a refusal
                raise fail(source, f"field {key!r} is not a readable array "
                                   f"({type(exc).__name__})") from None
            if dtype.hasobject:
                raise fail(source, f"field {key!r} holds an object array (pickle); refused")
            n = 1
            for s in shape:
                n *= int(s)
            declared = n * dtype.itemsize
            own, own_name = (stream_limit, "max_frame_bytes") if key in streamed \
                else (limit, "max_bytes")
            if declared > own:
                raise fail(source, f"field {key!r} declares shape {tuple(shape)} of {dtype}: "
                           + _too_big("bytes", declared, own_name))
            if declared > info.file_size - header_len:
                raise fail(source, f"field {key!r} declares shape {tuple(shape)} of {dtype} "
                                   f"({declared:,} bytes) but holds "
                                   f"{max(info.file_size - header_len, 0):,} bytes (truncated)")
            out[key] = (tuple(int(s) for s in shape), dtype)
    return out


# ------------------------------------------------------------------ JSON


class NonFinite(float):
    """A JSON ``NaN``/``Infinity`` read with ``allow_nan=False`` (a float that remembers)."""

    def __new__(cls, text: str):
        obj = super().__new__(cls, float(text.replace("Infinity", "inf")))
        obj.text = text
        return obj


def json_depth(text: str) -> int:
    """Deepest nesting of arrays/objects in ``text`` (brackets inside strings ignored)."""
    if "[" not in text and "{" not in text:
        return 0
    stripped = re.sub(r'"(?:[^"\\]|\\.)*"', '""', text)
    b = np.frombuffer(stripped.encode("utf-8", "surrogatepass"), dtype=np.uint8)
    step = np.zeros(256, dtype=np.int8)
    step[[ord("["), ord("{")]] = 1
    step[[ord("]"), ord("}")]] = -1
    s = step[b]
    if not s.any():
        return 0
    return int(np.cumsum(s, dtype=np.int64).max())


def loads_json(text: str, source: str, *, allow_nan: bool = True):
    """Parse JSON with bounded size and depth; ``allow_nan=False`` returns ``NaN``/``Infinity``
    as :class:`NonFinite` (the caller refuses it naming the field)."""
    if len(text) > cap("max_json_bytes"):
        raise fail(source, "JSON " + _too_big("characters", len(text), "max_json_bytes"))
    depth = json_depth(text)
    if depth > cap("max_json_depth"):
        raise fail(source, "JSON nested " + _too_big("levels", depth, "max_json_depth"))
    try:
        if allow_nan:
            return json.loads(text)
        return json.loads(text, parse_constant=NonFinite)
    except json.JSONDecodeError as exc:
        raise fail(source, f"not JSON ({exc})") from None
    except RecursionError:  # pragma: no cover - the depth check comes first
        raise fail(source, "JSON nested too deeply") from None


def read_json(path, source: str | None = None, *, allow_nan: bool = True):
    """Read a JSON file (size-capped, depth-bounded); errors name the file."""
    source = str(path) if source is None else source
    st = check_input(path, "JSON file")
    if st.st_size > cap("max_json_bytes"):
        raise fail(source, "file " + _too_big("bytes", st.st_size, "max_json_bytes"))
    try:
        with open(path, "rb") as f:
            raw = f.read()
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise fail(source, f"not JSON (not UTF-8: {exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise fail(source, f"cannot read ({exc.strerror or type(exc).__name__})") from None
    return loads_json(text, source, allow_nan=allow_nan)


# ------------------------------------------------------------------ temporary files


def is_temp_name(name: str) -> bool:
    """True for the names :func:`temp_file` gives: ``.NAME.vggctmp-*`` of
    :func:`vggc_cp.atomic.atomic_path` and ``.vggc-probe-*`` of the writability probes."""
    return bool(_TEMP_RE.match(name))


@contextlib.contextmanager
def temp_file(folder, prefix: str, suffix: str = "") -> Iterator[Path]:
    """An empty new file ``folder/<prefix><random><suffix>`` for the ``with`` block.

    The path is registered for :func:`cleanup_temps` *before* the file is created (``O_EXCL``,
    mode ``0666 & ~umask``), so a signal at any moment leaves nothing behind; the file is
    removed on exit unless the block renamed it away.
    """
    folder = Path(folder)
    for _ in range(100):
        path = folder / f"{prefix}{secrets.token_hex(6)}{suffix}"
        _LIVE.add(path)
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0),
                         0o666)
        except FileExistsError:
            _LIVE.discard(path)
            continue
        except BaseException:  # e.g. a signal's exception: the file may exist already
            with contextlib.suppress(OSError):
                path.unlink()
            _LIVE.discard(path)
            raise
        os.close(fd)
        break
    else:  # pragma: no cover - 100 collisions of 48 random bits
        raise FileExistsError(errno.EEXIST, "no free temporary name", str(folder))
    try:
        yield path
    finally:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
        _LIVE.discard(path)


def cleanup_temps() -> None:
    """Remove every temporary file of :func:`temp_file` still in progress (signal handlers)."""
    for tmp in list(_LIVE):
        try:
            tmp.unlink()
        except OSError:
            pass
        _LIVE.discard(tmp)


def sweep_stale_temps(folder, target_name: str | None = None) -> int:
    """Remove the tool's temporary files in ``folder`` (:func:`is_temp_name`: any target's
    ``.NAME.vggctmp-*`` and ``.vggc-probe-*``) older than ``stale_temp_minutes``.

    With ``target_name``, only those of that target (``.<name>.vggctmp-*``). Returns the count.
    """
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return 0
    limit = time.time() - 60 * cap("stale_temp_minutes")
    removed = 0
    for e in entries:
        if not is_temp_name(e.name):
            continue
        if target_name is not None and not e.name.startswith(f".{target_name}{TEMP_MARK}"):
            continue
        try:
            if e.is_file(follow_symlinks=False) and e.stat(follow_symlinks=False).st_mtime < limit:
                os.unlink(e.path)
                removed += 1
        except OSError:
            continue
    return removed


def cache_writable(path) -> bool:
    """True when the cache file ``path`` can be written (its folder made if missing); else a
    warning on stderr and False, so the caller goes on without caching. Sweeps stale
    temporary files of the folder."""
    folder = Path(path).parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with temp_file(folder, PROBE_PREFIX):
            pass
    except OSError as exc:
        warn(f"{folder}: cannot write the distance cache ({oserror_text(exc)}); going on "
             f"without caching")
        return False
    sweep_stale_temps(folder)
    return True


def warn(msg: str) -> None:
    """One warning line on stderr."""
    print(f"vggc-cp: warning: {msg}", file=sys.stderr)


def oserror_text(exc: OSError) -> str:
    return exc.strerror or errno.errorcode.get(exc.errno or 0, type(exc).__name__)
