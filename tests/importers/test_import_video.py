"""``vggc-cp import video``: fruit-2x3 encoded losslessly (H.264 RGB, crf 0) with blank frames
between the episodes, imported back by frame index and by time; seeking gives the frames that
decoding from the start gives; malformed logs refused naming the row."""

from __future__ import annotations

import numpy as np
import pytest
from recordings import (
    SHIPPED,
    assert_same_trace,
    encode_video,
    refused,
    run,
    solved_graph,
    write_log,
    write_video_layout,
)

from vggc_cp.importers.decode import frames_by_index, frames_by_time
from vggc_cp.trace import load_trace


@pytest.mark.parametrize("by", ["frame", pytest.param("time", marks=pytest.mark.slow)])
def test_round_trip_is_bit_exact(original, tmp_path, capsys, by):
    video, log = write_video_layout(original, tmp_path / "rec", by=by)
    out = tmp_path / "t.npz"
    rc, text, _ = run(capsys, "video", video, log, "-o", out)
    assert rc == 0 and "N = 56" in text
    got = load_trace(out)
    assert_same_trace(got, original)
    assert got.meta["source"] == {"format": "video", "file": "run.mp4", "log": "log.csv",
                                  "by": by, "frames": 56, "episodes": 6}
    if by == "time":
        assert solved_graph(out, tmp_path / "b.json") == solved_graph(SHIPPED,
                                                                      tmp_path / "a.json")


def test_seeking_gives_the_frames_decoding_gives(tmp_path):
    rng = np.random.default_rng(0)
    frames = rng.integers(0, 256, size=(120, 16, 16, 3), dtype=np.uint8)
    video = tmp_path / "v.mp4"
    encode_video(video, frames, fps=10, gop=7)
    wanted = [0, 1, 40, 41, 42, 90, 119]  # jumps of 4 s and 5 s: reached by seeking
    places = [f"row {k}" for k in range(len(wanted))]
    by_time = list(frames_by_time(video, [k / 10 for k in wanted], places))
    by_index = list(frames_by_index(video, wanted, places))
    np.testing.assert_array_equal(np.stack(by_time), frames[wanted])
    np.testing.assert_array_equal(np.stack(by_index), frames[wanted])
    near = list(frames_by_time(video, [0.02, 4.04, 11.86], places[:3]))  # nearest frame
    np.testing.assert_array_equal(np.stack(near), frames[[0, 40, 119]])


def test_frame_indices_in_a_variable_rate_video_and_a_stream_without_time_stamps(tmp_path):
    """Indices count frames in display order: the time stamps (read from the packets) may be
    irregular, and a raw H.264 stream without any is decoded from the start."""
    from fractions import Fraction

    import av

    from vggc_cp.importers.decode import _display_pts

    frames = np.random.default_rng(1).integers(0, 256, size=(60, 16, 16, 3), dtype=np.uint8)
    vfr = tmp_path / "vfr.mkv"
    with av.open(str(vfr), "w") as c:
        s = c.add_stream("ffv1", rate=10)
        s.width = s.height = 16
        s.pix_fmt = "bgr0"
        s.codec_context.time_base = Fraction(1, 1000)
        t = 0
        for k, image in enumerate(frames):
            f = av.VideoFrame.from_ndarray(image, format="rgb24")
            f.pts, f.time_base = t, Fraction(1, 1000)
            t += 50 if k % 3 else 2500  # gaps of 2.5 s: reached by seeking
            for packet in s.encode(f):
                c.mux(packet)
        for packet in s.encode():
            c.mux(packet)
    raw = tmp_path / "raw.h264"
    with av.open(str(raw), "w", format="h264") as c:
        s = c.add_stream("libx264rgb", rate=10)
        s.width, s.height, s.pix_fmt, s.options = 16, 16, "rgb24", {"crf": "0"}
        for image in frames:
            for packet in s.encode(av.VideoFrame.from_ndarray(image, format="rgb24")):
                c.mux(packet)
        for packet in s.encode():
            c.mux(packet)
    assert _display_pts(vfr)[:4] == [0, 2500, 2550, 2600] and _display_pts(raw) is None
    wanted = [0, 1, 2, 3, 20, 40, 59]
    for video in (vfr, raw):
        got = np.stack(list(frames_by_index(video, wanted, [str(k) for k in wanted])))
        np.testing.assert_array_equal(got, frames[wanted])


@pytest.fixture
def small(original, tmp_path):
    """The first two episodes in a video, frame k of the video = frame k of the trace."""
    last = original.episodes()[1][1]
    video = tmp_path / "v.mp4"
    encode_video(video, original.observations[:last + 1])
    acts = [original.action_names[a] if a >= 0 else "" for a in original.actions[:last]] + [""]
    eps = original.episode_index()[:last + 1]
    rows = [{"frame": k, "action": acts[k], "episode": int(eps[k])} for k in range(last + 1)]
    return video, rows


def log_of(small, change, tmp_path, name="log.csv"):
    rows = [dict(r) for r in small[1]]
    change(rows)
    return write_log(tmp_path / name, rows)


def test_frames_out_of_order(small, tmp_path, capsys):
    log = log_of(small, lambda rows: rows[4].update(frame=2), tmp_path)
    line = refused(capsys, tmp_path / "t.npz", "video", small[0], log)
    assert f"{log}: row 5: frame 2 is not after frame 3 ({log}: row 4)" in line


def test_frame_past_the_end(small, tmp_path, capsys):
    n = len(small[1])
    log = log_of(small, lambda rows: rows[-1].update(frame=n + 5), tmp_path)
    line = refused(capsys, tmp_path / "t.npz", "video", small[0], log)
    assert f"{log}: row {n}: frame {n + 5} is past the end" in line and f"({n} frames)" in line


def test_time_beyond_the_end_and_not_a_number(small, tmp_path, capsys):
    def by_time(rows, last=None):
        for r in rows:
            r["time"] = r.pop("frame") / 10
        rows[-1]["time"] = last
    n = len(small[1])
    log = log_of(small, lambda rows: by_time(rows, 60.0), tmp_path)
    line = refused(capsys, tmp_path / "t.npz", "video", small[0], log)
    assert f"{log}: row {n}: no frame of {small[0]} at time 60 s" in line
    log = log_of(small, lambda rows: by_time(rows, "soon"), tmp_path)
    line = refused(capsys, tmp_path / "t.npz", "video", small[0], log)
    assert f"{log}: row {n}: time 'soon' is not a time in seconds" in line


def test_log_without_frame_or_time(small, tmp_path, capsys):
    log = log_of(small, lambda rows: [r.pop("frame") for r in rows], tmp_path)
    line = refused(capsys, tmp_path / "t.npz", "video", small[0], log)
    assert f"{log}: no column 'frame'" in line and "'time'" in line


def test_not_a_video(small, tmp_path, capsys):
    log = log_of(small, lambda rows: None, tmp_path)
    fake = tmp_path / "fake.mp4"
    fake.write_bytes(b"\x00" * 1000)
    line = refused(capsys, tmp_path / "t.npz", "video", fake, log)
    assert f"{fake}: not a readable video" in line
