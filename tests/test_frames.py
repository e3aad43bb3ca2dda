"""Frames read from the trace file on demand (issue 27): vggc_cp.frames and load_trace."""

from __future__ import annotations

import hashlib
import pickle
import tracemalloc
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from vggc_cp.errors import TraceError
from vggc_cp.frames import StreamedFrames
from vggc_cp.trace import load_trace, npz_bytes, save_trace

DATA = Path(__file__).resolve().parent.parent / "data" / "fruit-2x3.npz"


@pytest.fixture()
def frames(tmp_path):
    rng = np.random.default_rng(3)
    arr = rng.integers(0, 256, (23, 6, 5, 3), dtype=np.uint8)
    path = tmp_path / "f.npz"
    path.write_bytes(npz_bytes({"observations": arr, "actions": np.zeros(22, np.int64)}))
    s = StreamedFrames(path, "observations")
    yield arr, s
    s.close()


@pytest.mark.parametrize("key", [
    0, 22, -1, np.int64(7), slice(None), slice(3, 9), slice(20, 40), slice(9, 3),
    slice(1, 20, 4), [5, 1, 5, 22, 0], np.array([-2, 3]), (slice(2, 6), slice(1, 4)),
    (4, slice(None), 2), ([9, 2], slice(0, 3), slice(None), 1),
])
def test_indexing_reads_what_memory_holds(frames, key):
    arr, s = frames
    got = s[key]
    assert isinstance(got, np.ndarray) and got.dtype == np.uint8
    assert np.array_equal(got, arr[key])
    got[...] = 0  # an ordinary writable array; the file is untouched
    assert np.array_equal(s[key], arr[key])


def test_boolean_mask_chunks_and_bytes(frames):
    arr, s = frames
    mask = np.arange(23) % 3 == 0
    assert np.array_equal(s[mask], arr[mask])
    assert np.array_equal(np.concatenate(list(s.chunks(s.frame_bytes * 4))), arr)
    s.close()
    s.track(b"p")
    s[:10], s[10:]  # noqa: B018 - a read reached the last frame: the digest started
    assert s.hashed(b"p").hexdigest() == hashlib.sha256(b"p" + arr.tobytes()).hexdigest()
    s[3:5], s[:2], s[5:]  # noqa: B018 - never asked for: hashed when asked
    assert s.hashed(b"q").hexdigest() == hashlib.sha256(b"q" + arr.tobytes()).hexdigest()
    with pytest.raises(IndexError):
        s[[23]]


def test_reads_forward_and_back_and_after_pickling(frames):
    arr, s = frames
    for key in (slice(15, 20), slice(0, 2), 22, 3):
        assert np.array_equal(s[key], arr[key])
    t = pickle.loads(pickle.dumps(s))
    assert t._fh is None and np.array_equal(t[10:12], arr[10:12])
    t.close()


def test_all_frames_at_once_are_refused_above_the_cap(frames, monkeypatch):
    arr, s = frames
    assert np.array_equal(np.asarray(s), arr)
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(arr.nbytes - 1))
    with pytest.raises(TraceError, match=r"f\.npz: field 'observations' holds 2,070 bytes.*"
                                         r"VGGC_CP_MAX_BYTES"):
        np.asarray(s)


def test_a_damaged_member_names_the_file_field_and_frame(tmp_path):
    arr = np.arange(40 * 8 * 8 * 3, dtype=np.uint8).reshape(40, 8, 8, 3)
    good = tmp_path / "g.npz"
    good.write_bytes(npz_bytes({"observations": arr}))
    bad = tmp_path / "b.npz"
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(bad, "w") as dst:
        info = src.getinfo("observations.npy")
        raw = src.read(info)
        dst.writestr(info, raw[: len(raw) // 2])  # a member cut in half, header intact
    # the zip's own size field now says half: the frames past it are missing
    s = StreamedFrames(bad, "observations")
    assert np.array_equal(s[:3], arr[:3])
    with pytest.raises(TraceError, match=r"b\.npz: field 'observations' is corrupt or "
                                         r"truncated near frame 30"):
        s[30:32]
    with pytest.raises(TraceError, match="Fortran order"):
        f = tmp_path / "f.npz"
        np.savez(f, observations=np.asfortranarray(arr))
        StreamedFrames(f, "observations")


def test_load_trace_streams_frames_above_the_cap(monkeypatch):
    held = load_trace(DATA)
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(held.observations.nbytes // 2))
    streamed = load_trace(DATA)
    assert isinstance(streamed.observations, StreamedFrames)
    assert streamed.observations.shape == held.observations.shape
    assert np.array_equal(streamed.actions, held.actions)
    assert np.array_equal(streamed.states, held.states)
    assert streamed.content_hash() == held.content_hash()
    assert streamed.identity_hash() == held.identity_hash()
    monkeypatch.setenv("VGGC_CP_MAX_FRAME_BYTES", str(held.observations.nbytes - 1))
    with pytest.raises(TraceError, match="VGGC_CP_MAX_FRAME_BYTES"):
        load_trace(DATA)


def test_streamed_frames_give_the_same_distances_holding_a_fraction(tmp_path, monkeypatch):
    """The footprints of a trace streamed from its file equal those of the trace in memory,
    and converting its frames holds a fraction of them: this fails if every frame were
    inflated (or converted to float) at once."""
    from vggc_cp.vision.footprints import footprint_distances
    from vggc_cp.vision.working import normalise_frames

    small = load_trace(DATA).without_states()
    big = replace(small, observations=small.observations.repeat(4, axis=1).repeat(4, axis=2))
    path = tmp_path / "big.npz"
    save_trace(big, path)
    frames_bytes = big.observations.nbytes
    want = footprint_distances(big)
    want_x = normalise_frames(big.observations, 4)
    want_hash = big.content_hash()
    del big
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(frames_bytes // 4))
    trace = load_trace(path)
    assert isinstance(trace.observations, StreamedFrames)
    for a, b in zip(footprint_distances(trace), want):
        assert np.array_equal(a, b)
    # the footprints' pass hashed the frames on the way: the content hash reads nothing more
    opened = []
    monkeypatch.setattr(StreamedFrames, "_open", lambda self: opened.append(1))
    assert trace.content_hash() == want_hash
    assert not opened
    monkeypatch.undo()
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(frames_bytes // 4))
    tracemalloc.start()
    try:
        x = normalise_frames(trace.observations, 4, chunk_bytes=1 << 20)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert np.array_equal(x, want_x)
    assert peak < frames_bytes / 2, (peak, frames_bytes)  # the working copy is a quarter


def test_the_working_copy_is_what_the_cap_bounds(monkeypatch):
    from vggc_cp.vision.footprints import footprint_distances

    trace = load_trace(DATA).without_states()
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(trace.observations.nbytes))  # < float copy
    with pytest.raises(TraceError, match=r"fruit-2x3\.npz: field 'observations': 56 frames of "
                                         r"64x64 hold 2,752,512 bytes at the footprints' "
                                         r"working resolution.*VGGC_CP_MAX_BYTES"):
        footprint_distances(load_trace(DATA))


def test_saving_a_streamed_trace_writes_the_same_bytes_in_pieces(tmp_path, monkeypatch):
    from vggc_cp import trace as trace_module

    held = load_trace(DATA)
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(held.observations.nbytes // 2))
    monkeypatch.setattr(trace_module, "WRITE_BYTES", 50_000)  # many pieces per member
    streamed = load_trace(DATA)
    assert isinstance(streamed.observations, StreamedFrames)
    save_trace(streamed, tmp_path / "again.npz")
    assert (tmp_path / "again.npz").read_bytes() == DATA.read_bytes()
    with pytest.raises(TraceError, match="VGGC_CP_MAX_BYTES"):  # all at once: refused
        np.ascontiguousarray(streamed.observations)


def test_the_digest_runs_beside_the_learning_after_the_pass_and_stops_on_close(frames):
    """``track`` asks for a digest; it starts in a thread of its own when a read reaches the
    last frame (the footprints' pass ended), is kept once finished, and is stopped by
    ``close`` while unfinished (computed again when asked)."""
    arr, s = frames
    want = hashlib.sha256(b"p" + arr.tobytes()).hexdigest()
    s.track(b"p")
    s[:10]  # noqa: B018
    assert not s._jobs  # the pass has not ended
    s[10:]  # noqa: B018
    job = s._jobs[b"p"]
    assert s.hashed(b"p").hexdigest() == want
    assert job.finished and not job.stopped
    s.close()  # a finished digest survives closing
    assert s.hashed(b"p").hexdigest() == want
    s.track(b"r")
    s[:]  # noqa: B018
    running = s._jobs[b"r"]
    running.stop()  # as close() does to an unfinished one (it may have finished already)
    s.close()
    assert b"r" not in s._jobs
    assert s.hashed(b"r").hexdigest() == hashlib.sha256(b"r" + arr.tobytes()).hexdigest()
    h = s.hashed(b"r")
    h.update(b"x")  # a copy: the kept digest is unchanged
    assert s.hashed(b"r").hexdigest() != h.hexdigest()


def test_a_damaged_member_fails_the_digest_naming_the_field(tmp_path):
    arr = np.random.default_rng(2).integers(0, 256, (12, 8, 8, 3), dtype=np.uint8)
    path = tmp_path / "s.npz"
    np.savez(path, observations=arr)  # stored: a byte changed in the file reaches the frames
    raw = bytearray(path.read_bytes())
    raw[raw.index(arr[11].tobytes()) + 3] ^= 0xFF
    bad = tmp_path / "b.npz"
    bad.write_bytes(bytes(raw))
    for started in (False, True):  # asked for when needed, or running in its thread
        s = StreamedFrames(bad, "observations")
        s.track(b"p")
        if started:
            s._start_digests()
        with pytest.raises(TraceError, match=r"b\.npz: field 'observations' is corrupt"):
            s.hashed(b"p")
        s.close()


def test_stored_members_and_a_changed_byte(tmp_path):
    """An uncompressed member (np.savez) is read as well; a byte changed in the frames is
    caught by the member's CRC-32 when the pass reaches its end."""
    arr = np.random.default_rng(1).integers(0, 256, (12, 8, 8, 3), dtype=np.uint8)
    path = tmp_path / "s.npz"
    np.savez(path, observations=arr)
    s = StreamedFrames(path, "observations")
    assert np.array_equal(s[:], arr) and np.array_equal(s[[11, 2]], arr[[11, 2]])
    s.close()
    raw = bytearray(path.read_bytes())
    at = raw.index(arr[5].tobytes())
    raw[at + 7] ^= 0xFF
    bad = tmp_path / "bad.npz"
    bad.write_bytes(bytes(raw))
    s = StreamedFrames(bad, "observations")
    assert np.array_equal(s[:3], arr[:3])  # before the end nothing can tell
    with pytest.raises(TraceError, match=r"bad\.npz: field 'observations' is corrupt"):
        s[3:]


def test_slices_in_order_read_the_next_frames_ahead_and_scattered_reads_do_not(frames):
    arr, s = frames
    got = s[0:5]
    assert s._ahead is not None and s._ahead[1:] == (5, 10)  # inflating in the thread
    assert np.array_equal(got, arr[0:5]) and np.array_equal(s[5:10], arr[5:10])
    assert s._ahead[1:] == (10, 15)
    assert np.array_equal(s[[2, 20]], arr[[2, 20]])
    assert s._ahead is None
