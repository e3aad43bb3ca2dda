"""Frames read from the trace file as they are needed, not all held in memory (issue 27).

A camera-sized recording does not fit the memory cap: 1,628 frames of 640x480 RGB are 1.5 GB
of uint8 before any float copy. :func:`vggc_cp.trace.load_trace` therefore returns the
``observations`` of a trace whose frames exceed ``max_bytes`` (:data:`vggc_cp.safeio.CAPS`) as
a :class:`StreamedFrames`: an array-like over the ``observations`` member of the ``.npz`` that
inflates the frames an index asks for, in one forward pass of the member (a deflated zip member
is read front to back; a read behind the last one starts again from the front). What a stage
holds is then what it asks for: the footprint evidence reads chunks of frames and keeps only its
working-resolution copy (:func:`vggc_cp.vision.working.normalise_frames`).

A stage that needs every frame at full size at once (``np.asarray(frames)``: training a
localizer, writing the trace again) is refused with the file, the field, the size and the cap,
never left to exhaust memory.

Examples
--------
>>> import numpy as np, tempfile, os
>>> from vggc_cp.trace import npz_bytes
>>> frames = np.arange(5 * 4 * 4 * 3, dtype=np.uint8).reshape(5, 4, 4, 3)
>>> path = os.path.join(tempfile.mkdtemp(), "t.npz")
>>> _ = open(path, "wb").write(npz_bytes({"observations": frames}))
>>> s = StreamedFrames(path, "observations")
>>> s.shape, s.dtype, len(s)
((5, 4, 4, 3), dtype('uint8'), 5)
>>> bool(np.array_equal(s[1:3], frames[1:3])), bool(np.array_equal(s[[4, 0]], frames[[4, 0]]))
(True, True)
>>> s.close()
"""

from __future__ import annotations

import hashlib
import zipfile
from collections.abc import Iterator

import numpy as np

from vggc_cp.errors import TraceError

#: bytes of frames :meth:`StreamedFrames.chunks` yields at once
READ_BYTES = 64 << 20
#: bytes inflated at once while skipping or filling a request: a piece the allocator reuses
#: and the cache still holds when it is checked and copied out (inflating 1.5 GB of 640x480
#: frames took 0.55 s in 1 MiB pieces against 0.9-1.3 s in 64 MiB ones, each a fresh mapping)
PIECE_BYTES = 1 << 20


def _inflater():
    """``(decompressobj, crc32)`` of zlib-ng where installed (inflating and checking run about
    three times faster: 1.4 s against 4.1 s of CPU for 1.5 GB of 640x480 frames here), else
    of the standard zlib; the same bytes either way."""
    try:
        from zlib_ng import zlib_ng as z
    except ImportError:  # pragma: no cover - zlib-ng is a dependency; zlib reads the same
        import zlib as z
    return z.decompressobj, z.crc32


class _Member:
    """One stored or deflated zip member read front to back (``read``, ``readinto``), its
    CRC-32 checked at its end, inflated by :func:`_inflater`."""

    def __init__(self, path: str, info: zipfile.ZipInfo):
        import struct

        if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            raise ValueError(f"compression method {info.compress_type}")
        self._f = open(path, "rb")  # noqa: SIM115 - closed by close()
        self._f.seek(info.header_offset)
        head = self._f.read(30)
        if len(head) != 30 or head[:4] != b"PK\x03\x04":
            raise zipfile.BadZipFile("bad local file header")
        name_len, extra_len = struct.unpack("<HH", head[26:30])
        self._f.seek(info.header_offset + 30 + name_len + extra_len)
        self._raw_left = info.compress_size
        self._out_left = info.file_size
        self._want_crc = info.CRC
        decompressobj, self._crc32 = _inflater()
        self._z = decompressobj(-15) if info.compress_type == zipfile.ZIP_DEFLATED else None
        self._crc = 0
        self._buf = memoryview(b"")

    def _more(self, n: int) -> memoryview | bytes:
        """Up to ``n`` more bytes of the member (at least one unless it ended), a view into
        what was inflated (no copy)."""
        while True:
            if self._buf:
                out, self._buf = self._buf[:n], self._buf[n:]
                break
            if self._out_left <= 0:
                return b""
            if self._z is None:
                out = self._f.read(min(n, self._raw_left, self._out_left))
                self._raw_left -= len(out)
                if not out:
                    raise EOFError
                break
            if self._z.unconsumed_tail:
                self._buf = memoryview(self._z.decompress(self._z.unconsumed_tail,
                                                          max(n, 1 << 16)))
            elif self._raw_left:
                chunk = self._f.read(min(1 << 20, self._raw_left))
                if not chunk:
                    raise EOFError
                self._raw_left -= len(chunk)
                self._buf = memoryview(self._z.decompress(chunk, max(n, 1 << 16)))
            else:  # all input given: what the inflater still holds
                self._buf = memoryview(self._z.flush())
                if not self._buf:
                    raise EOFError
        self._out_left -= len(out)
        if self._out_left < 0:
            raise zipfile.BadZipFile("member longer than its size")
        self._crc = self._crc32(out, self._crc)
        if self._out_left == 0 and self._crc != self._want_crc:
            raise zipfile.BadZipFile("CRC-32 mismatch")
        return out

    def read(self, n: int) -> bytes:
        parts, got = [], 0
        while got < n:
            b = self._more(n - got)
            if not b:
                break
            parts.append(b)
            got += len(b)
        return b"".join(parts)

    def readinto(self, view: memoryview) -> int:
        b = self._more(len(view))
        view[:len(b)] = b
        return len(b)

    def close(self) -> None:
        self._f.close()


class StreamedFrames:
    """The uint8 frames of one ``.npz`` member, read on demand (module docstring).

    Parameters
    ----------
    path : str or path-like
        The ``.npz`` file.
    key : str
        The member's name without ``.npy`` (``"observations"``).
    source : str, optional
        How error messages name the file (default: ``path``).

    Attributes
    ----------
    shape : tuple of int, (N, H, W, C)
    dtype : numpy.dtype (uint8)
    ndim, size, nbytes : int

    Notes
    -----
    Indexing takes an integer, a slice of step 1, a sequence or array of integers (one forward
    pass over the sorted indices, the result in the order asked) or a tuple whose first item is
    one of those and whose other items index every frame (``frames[a:b, :h, :w]``). The result
    is an ordinary writable ``ndarray``. Pickling keeps the path, not an open file: a worker
    process reads the frames it is sent for itself.
    """

    def __init__(self, path, key: str = "observations", source: str | None = None):
        self.path = str(path)
        self.key = key
        self.source = self.path if source is None else str(source)
        self._fh = None
        self._pos = 0
        self._wanted: list[bytes] = []      # prefixes of the digests to compute (:meth:`track`)
        self._jobs: dict = {}               # digests being computed, by prefix
        self._digests: dict = {}            # finished hashers, by prefix
        self._pool = None                   # the read-ahead thread
        self._ahead = None                  # (future, first, end) of the frames read ahead
        with zipfile.ZipFile(self.path) as zf:
            self._member = self._find(zf)
        try:
            head = _Member(self.path, self._member)
        except (ValueError, OSError, zipfile.BadZipFile) as exc:
            raise TraceError(f"{self._where()} is not a readable array "
                             f"({type(exc).__name__}: {exc})") from None
        try:
            shape, fortran, dtype = _read_header(head, self._where())
        finally:
            head.close()
        if fortran or dtype != np.uint8 or len(shape) != 4:
            raise TraceError(f"{self._where()} holds {dtype} of shape {tuple(shape)}"
                             f"{' in Fortran order' if fortran else ''}; frames are read "
                             f"from the file only as C-ordered uint8 [N, H, W, 3]")
        self.shape = tuple(int(s) for s in shape)
        self.dtype = np.dtype(np.uint8)
        self.ndim = 4
        self.frame_bytes = int(np.prod(self.shape[1:]))
        self.size = int(np.prod(self.shape))
        self.nbytes = self.size

    # ------------------------------------------------------------------ reading

    def _where(self) -> str:
        return f"{self.source}: field {self.key!r}"

    def _find(self, zf: zipfile.ZipFile) -> zipfile.ZipInfo:
        try:
            return zf.getinfo(self.key + ".npy")
        except KeyError:
            raise TraceError(f"{self.source}: missing field {self.key!r}") from None

    def _open(self) -> None:
        if self._fh is not None:
            self._fh.close()
        self._fh = _Member(self.path, self._member)
        _read_header(self._fh, self._where())
        self._pos = 0

    def _fill(self, a: int, b: int) -> np.ndarray:
        """Frames ``a:b`` inflated from the member, reading forward (the read-ahead thread
        runs this too, never at the same time as another call)."""
        out = np.empty((b - a, *self.shape[1:]), dtype=np.uint8)
        try:
            if self._fh is None or a < self._pos:
                self._open()
            skip = (a - self._pos) * self.frame_bytes
            while skip > 0:
                got = len(self._fh.read(min(skip, PIECE_BYTES)))
                if got == 0:
                    raise EOFError
                skip -= got
            self._pos = a
            view = memoryview(out.reshape(-1))
            done = 0
            while done < len(view):
                got = self._fh.readinto(view[done:done + PIECE_BYTES])
                if not got:
                    raise EOFError
                done += got
        except Exception as exc:  # noqa: BLE001 - EOF, OSError, BadZipFile, zlib.error
            if self._fh is not None:
                self._fh.close()
            self._fh = None
            self._pos = 0
            raise TraceError(f"{self._where()} is corrupt or truncated near frame {a} "
                             f"({type(exc).__name__})") from None
        self._pos = b
        return out

    def _read(self, a: int, b: int, ahead: bool = True) -> np.ndarray:
        """Frames ``a:b``; with ``ahead`` the next as many are inflated meanwhile in a thread
        (a pass in order costs the larger of inflating and using the frames, not their sum;
        scattered reads go without, or the frames read ahead would overshoot the next ones
        and send the next read back to the start)."""
        pending, self._ahead = self._ahead, None
        out = None
        if pending is not None:
            done, pa, pb = pending
            got = done.result()  # a damaged member raises here, naming the frame
            if (pa, pb) == (a, b):
                out = got
        if out is None:
            out = self._fill(a, b)
        if b == self.shape[0] and self._wanted:
            self._start_digests()
        if ahead and self.shape[0] > b > a:
            nb = min(self.shape[0], b + (b - a))
            if self._pool is None:
                from concurrent.futures import ThreadPoolExecutor

                self._pool = ThreadPoolExecutor(1, thread_name_prefix="vggc-frames")
            self._ahead = (self._pool.submit(self._fill, b, nb), b, nb)
        return out

    # ------------------------------------------------------------------ digests

    def track(self, prefix: bytes) -> None:
        """Compute the SHA-256 of ``prefix`` followed by every frame's bytes in a background
        thread that reads the member on its own (:class:`_Digest`), started when a read
        reaches the last frame (the end of the footprints' pass): on two cores it then runs
        beside the learning after the pass, which leaves one core mostly idle, instead of
        competing with the pass's two threads (inflating, converting)."""
        if prefix not in self._wanted:
            self._wanted.append(prefix)

    def _start_digests(self) -> None:
        for prefix in self._wanted:
            if prefix not in self._digests and prefix not in self._jobs:
                self._jobs[prefix] = _Digest(self.path, self._member, prefix, self._where())

    def hashed(self, prefix: bytes):
        """A ``hashlib`` SHA-256 object that has consumed ``prefix`` and the C-order bytes of
        all frames (a copy: update it further): the one :meth:`track` asked for, once it
        finishes, else computed here.

        Raises
        ------
        TraceError
            When the member is corrupt or truncated.
        """
        if prefix not in self._digests:
            job = self._jobs.pop(prefix, None)
            if job is None or job.stopped:
                job = _Digest(self.path, self._member, prefix, self._where(), start=False)
            self._digests[prefix] = job.result()
        return self._digests[prefix].copy()

    def take(self, indices) -> np.ndarray:
        """The frames ``indices`` (ints, any order, repeats allowed) in one forward pass."""
        idx = np.asarray(indices)
        if idx.dtype == bool:
            if idx.shape != (self.shape[0],):
                raise IndexError(f"boolean index of shape {idx.shape} for {self.shape[0]} frames")
            idx = np.flatnonzero(idx)
        idx = idx.astype(np.int64).reshape(-1)
        n = self.shape[0]
        if idx.size and (idx.min() < -n or idx.max() >= n):
            raise IndexError(f"frame index out of range for {n} frames")
        idx = np.where(idx < 0, idx + n, idx)
        want, inverse = np.unique(idx, return_inverse=True)
        got = np.empty((len(want), *self.shape[1:]), dtype=np.uint8)
        k = 0
        while k < len(want):  # runs of consecutive frames, read in one go each
            e = k + 1
            while e < len(want) and want[e] == want[e - 1] + 1:
                e += 1
            got[k:e] = self._read(int(want[k]), int(want[e - 1]) + 1, ahead=False)
            k = e
        return got[inverse.reshape(-1)]

    def __getitem__(self, key):
        rest = ()
        if isinstance(key, tuple):
            key, rest = key[0], key[1:]
        if isinstance(key, (int, np.integer)):
            out = self.take([int(key)])[0]
        elif isinstance(key, slice):
            start, stop, step = key.indices(self.shape[0])
            if step == 1:
                out = self._read(start, stop) if stop > start else \
                    np.empty((0, *self.shape[1:]), dtype=np.uint8)
            else:
                out = self.take(np.arange(start, stop, step))
        else:
            out = self.take(key)
        if not rest:
            return out
        return out[rest] if isinstance(key, (int, np.integer)) else out[(slice(None), *rest)]

    def chunks(self, chunk_bytes: int = READ_BYTES) -> Iterator[np.ndarray]:
        """The frames in order, about ``chunk_bytes`` at a time (one pass over the member)."""
        step = max(1, int(chunk_bytes) // self.frame_bytes)
        for s in range(0, self.shape[0], step):
            yield self[s:s + step]

    def __len__(self) -> int:
        return self.shape[0]

    def __array__(self, dtype=None, copy=None):
        from vggc_cp.safeio import CAPS, cap

        limit = cap("max_bytes")
        if self.nbytes > limit:
            raise TraceError(f"{self._where()} holds {self.nbytes:,} bytes of frames; this "
                             f"step needs all of them in memory at once, above the cap of "
                             f"{limit:,} ({CAPS['max_bytes'][1]}): raise it if the machine "
                             f"has the memory, or record at a smaller size")
        out = self[:]
        return out if dtype is None else out.astype(dtype, copy=False)

    # ------------------------------------------------------------------ lifetime

    def close(self) -> None:
        """Close the open member and file (reopened by the next read), after any frames
        being read ahead."""
        ahead, self._ahead = self._ahead, None
        if ahead is not None:
            ahead[0].cancel()
            try:
                ahead[0].result()
            except Exception:  # noqa: BLE001 - frames nobody asked for yet
                pass
        if self._fh is not None:
            self._fh.close()
        self._fh = None
        self._pos = 0
        for prefix, job in self._jobs.items():  # a finished digest is kept, the others stop
            if job.finished:
                try:
                    self._digests[prefix] = job.result()
                except TraceError:  # raised again by the next hashed()
                    continue
            job.stop()
        self._jobs = {}
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __getstate__(self):
        state = dict(self.__dict__)
        state.update(_fh=None, _pos=0, _jobs={}, _digests={}, _pool=None, _ahead=None)
        return state

    def __del__(self):
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass

    def __repr__(self) -> str:
        return f"StreamedFrames({self.source!r}, shape={self.shape})"


class _Digest:
    """The SHA-256 of ``prefix`` and the bytes of one ``.npy`` member after its header,
    computed by a daemon thread (``start``) or in :meth:`result`, reading the member on its
    own, :data:`PIECE_BYTES` at a time; :meth:`stop` ends it within a piece (Ctrl-C, or the
    frames closed)."""

    def __init__(self, path: str, info: zipfile.ZipInfo, prefix: bytes, where: str,
                 start: bool = True):
        import threading

        self._args = (path, info, where)
        self._hash = hashlib.sha256(prefix)
        self._error: BaseException | None = None
        self._stop = threading.Event()
        self._complete = False
        self._thread = None
        if start:
            self._thread = threading.Thread(target=self._run, name="vggc-frames-digest",
                                            daemon=True)
            self._thread.start()

    @property
    def stopped(self) -> bool:
        """Stopped before it read the whole member."""
        return self._stop.is_set() and not self._complete

    @property
    def finished(self) -> bool:
        """Read the whole member (:meth:`result` returns at once)."""
        return self._complete or self._error is not None

    def stop(self) -> None:
        self._stop.set()

    def _run(self) -> None:
        path, info, where = self._args
        member = None
        try:
            member = _Member(path, info)
            _read_header(member, where)
            while not self._stop.is_set():
                piece = member._more(PIECE_BYTES)
                if not piece:
                    self._complete = True
                    break
                self._hash.update(piece)
        except TraceError as exc:
            self._error = exc
        except Exception as exc:  # noqa: BLE001 - EOF, OSError, BadZipFile, zlib.error
            self._error = TraceError(f"{where} is corrupt or truncated "
                                     f"({type(exc).__name__})")
        finally:
            if member is not None:
                member.close()

    def result(self):
        """The finished hasher (waits for the thread; runs here if none was started)."""
        if self._thread is None:
            self._run()
        else:
            while self._thread.is_alive():  # in slices: Ctrl-C reaches the waiting thread
                self._thread.join(0.1)
        if self._error is not None:
            raise self._error
        return self._hash


def _read_header(fh, where: str) -> tuple[tuple[int, ...], bool, np.dtype]:
    try:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            return np.lib.format.read_array_header_1_0(fh)
        if version in ((2, 0), (3, 0)):
            return np.lib.format.read_array_header_2_0(fh)
        raise ValueError(f"npy version {version}")
    except Exception as exc:  # noqa: BLE001 - any damage in a header is a refusal
        raise TraceError(f"{where} is not a readable array ({type(exc).__name__})") from None


def gather(frames, indices, group: int = 64) -> dict[int, np.ndarray]:
    """``{index: frame}`` of ``frames`` (an ndarray or :class:`StreamedFrames`) at
    ``indices``, read in ascending groups of ``group``: one forward pass over a file, holding
    only the frames asked for (a picture's medoids and thumbnails)."""
    want = np.unique(np.asarray(list(indices), dtype=np.int64))
    out: dict[int, np.ndarray] = {}
    for s in range(0, len(want), group):
        idx = want[s:s + group]
        for i, frame in zip(idx.tolist(), frames[idx]):
            out[i] = frame
    return out


class FrameSpool:
    """Frames of one size appended one by one (an importer reading a recording), held in
    memory up to ``max_bytes`` and, past it, in the file ``path`` (raw bytes, then mapped
    read-only: :meth:`array` is an ``np.memmap``), so a camera-sized recording is imported
    without holding it. Without ``path`` nothing spills: :attr:`spills` is False and the
    caller refuses what exceeds the cap.

    Parameters
    ----------
    path : str or path-like, optional
        The file the frames spill into (created or truncated on the first spill).
    """

    def __init__(self, path=None):
        self.path = None if path is None else str(path)
        self._held: list[np.ndarray] = []
        self._file = None
        self._n = 0
        self._shape: tuple[int, ...] | None = None

    @property
    def spills(self) -> bool:
        return self.path is not None

    def append(self, frame: np.ndarray, held_bytes: int) -> None:
        """Add ``frame`` (uint8, (H, W, 3)); ``held_bytes``: the frames' bytes so far, with it."""
        from vggc_cp.safeio import cap

        frame = np.ascontiguousarray(frame, dtype=np.uint8)
        self._shape = frame.shape
        if self._file is None and self.spills and held_bytes > cap("max_bytes"):
            self._file = open(self.path, "wb")  # noqa: SIM115 - closed by array()
            for f in self._held:
                self._file.write(f.tobytes())
            self._held = []
        if self._file is not None:
            self._file.write(frame.tobytes())
        else:
            self._held.append(frame)
        self._n += 1

    def __len__(self) -> int:
        return self._n

    def array(self) -> np.ndarray:
        """All frames, shape (N, H, W, 3): stacked in memory, or mapped from the file (no
        frame may be appended after)."""
        if self._file is None:
            return np.stack(self._held)
        if not self._file.closed:
            self._file.close()
        return np.memmap(self.path, dtype=np.uint8, mode="r", shape=(self._n, *self._shape))
