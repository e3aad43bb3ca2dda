"""Trace format: round trip, roles, and every refused input (exit 2, one line)."""

from __future__ import annotations

import io
import json
import subprocess
import sys
import zipfile

import numpy as np
import pytest
from conftest import TOY_NAMES, make_trace

from vggc_cp.cli import main
from vggc_cp.errors import TraceError
from vggc_cp.trace import PICK, PLACE, load_trace, save_trace, summarize, trace_to_bytes


def write_npz(path, **arrays):
    np.savez_compressed(path, **arrays)
    return path


def arrays_of(trace):
    return {"observations": trace.observations, "actions": trace.actions,
            "action_names": np.array(trace.action_names), "states": trace.states}


def run_cli(capsys, *argv):
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_refused(capsys, path, *needles):
    code, out, err = run_cli(capsys, "inspect", str(path))
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert str(path) in lines[0]
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def test_round_trip_and_same_bytes(tmp_path, toy_trace):
    p1, p2 = tmp_path / "a.npz", tmp_path / "b.npz"
    save_trace(toy_trace, p1)
    save_trace(toy_trace, p2)
    assert p1.read_bytes() == p2.read_bytes()
    back = load_trace(p1)
    assert np.array_equal(back.observations, toy_trace.observations)
    assert np.array_equal(back.actions, toy_trace.actions)
    assert back.action_names == toy_trace.action_names
    assert list(back.states) == list(toy_trace.states)
    assert back.meta == {"benchmark": "handmade"}
    assert back.content_hash() == toy_trace.content_hash()
    assert back.without_states().content_hash() == toy_trace.content_hash()


def test_roles_and_summary(toy_trace):
    roles = toy_trace.roles()
    # L H R H L | R H R : pick place pick place pick | pick place pick
    assert roles.tolist() == [PICK, PLACE, PICK, PLACE, PICK, PICK, PLACE, PICK]
    info = summarize(toy_trace)
    assert info["transitions"] == 6
    assert info["episodes"] == 2
    assert info["pick_observations"] == 5 and info["place_observations"] == 3
    assert info["distinct_states"] == 3
    assert info["action_counts"] == {"pick_L": 1, "pick_R": 2, "place_L": 1, "place_R": 2}


def test_inspect_prints_facts(tmp_path, toy_trace, capsys):
    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    code, out, _ = run_cli(capsys, "inspect", str(path))
    assert code == 0
    assert "N = 8" in out and "|D| = 6" in out and "|A| = 4" in out
    assert "pick 5, place 3" in out and "3 distinct" in out and "8x8" in out
    code, out, _ = run_cli(capsys, "inspect", str(path), "--json")
    assert json.loads(out)["episodes"] == 2


def test_missing_key(tmp_path, toy_trace, capsys):
    arrays = arrays_of(toy_trace)
    del arrays["actions"]
    assert_refused(capsys, write_npz(tmp_path / "t.npz", **arrays), "missing field 'actions'")


@pytest.mark.parametrize("field,value,needle", [
    ("actions", lambda t: t.actions.astype(np.float64), "'actions' has dtype float64"),
    ("actions", lambda t: t.actions.reshape(1, -1), "'actions' has rank 2"),
    ("observations", lambda t: t.observations.astype(np.float32), "'observations' has dtype float32"),
    ("observations", lambda t: t.observations[..., 0], "'observations' has shape"),
    ("observations", lambda t: np.concatenate([t.observations] * 2, axis=3)[..., :4], "expected [N, H, W, 3]"),
    ("action_names", lambda t: np.arange(4), "'action_names' has dtype"),
])
def test_wrong_dtype_or_rank(tmp_path, toy_trace, capsys, field, value, needle):
    arrays = arrays_of(toy_trace)
    arrays[field] = value(toy_trace)
    assert_refused(capsys, write_npz(tmp_path / "t.npz", **arrays), needle)


def test_action_index_out_of_range(tmp_path, toy_trace, capsys):
    arrays = arrays_of(toy_trace)
    arrays["actions"] = arrays["actions"].copy()
    arrays["actions"][3] = 7
    assert_refused(capsys, write_npz(tmp_path / "t.npz", **arrays), "actions[3] = 7", "out of range")


def test_bad_action_name(tmp_path, toy_trace, capsys):
    arrays = arrays_of(toy_trace)
    arrays["action_names"] = np.array(["pick_L", "pick_R", "push_L", "place_R"])
    assert_refused(capsys, write_npz(tmp_path / "t.npz", **arrays), "action_names[2]", "'push_L'")


@pytest.mark.parametrize("episode,needle", [
    (["A", "pick_L", "B", "pick_R", "C"], "two picks in a row"),
    (["A", "place_L", "B", "place_R", "C"], "two places in a row"),
])
def test_two_in_a_row(tmp_path, capsys, episode, needle):
    trace = make_trace([episode], TOY_NAMES)
    path = write_npz(tmp_path / "t.npz", **arrays_of(trace))
    line = assert_refused(capsys, path, "observations[1]", needle)
    assert "actions[0]" in line and "actions[1]" in line


def test_observation_with_two_roles(tmp_path, capsys):
    # o_2 follows a pick (-> place role) and precedes a pick (-> pick role)
    trace = make_trace([["A", "place_L", "B", "pick_L", "C", "pick_R", "D"]], TOY_NAMES)
    path = write_npz(tmp_path / "t.npz", **arrays_of(trace))
    assert_refused(capsys, path, "observations[2] gets two roles")


def test_episode_of_length_one(tmp_path, capsys):
    trace = make_trace([["A", "pick_L", "B"], ["C"], ["D", "pick_R", "E"]], TOY_NAMES)
    path = write_npz(tmp_path / "t.npz", **arrays_of(trace))
    assert_refused(capsys, path, "observations[2] has no transition")


def test_object_array_is_refused_never_unpickled(tmp_path, toy_trace, capsys):
    class Boom:
        def __reduce__(self):
            return (exec, ("raise SystemExit('unpickled!')",))

    arrays = arrays_of(toy_trace)
    arrays["action_names"] = np.array([Boom()] * 4, dtype=object)
    path = tmp_path / "t.npz"
    np.savez(path, **arrays)  # allow_pickle defaults to True when saving
    assert_refused(capsys, path, "'action_names' holds an object array (pickle)")


def test_object_array_in_extra_field_is_refused(tmp_path, toy_trace, capsys):
    arrays = arrays_of(toy_trace)
    arrays["extra"] = np.array([{"a": 1}], dtype=object)
    path = tmp_path / "t.npz"
    np.savez(path, **arrays)
    assert_refused(capsys, path, "'extra' holds an object array")


def test_empty_trace(tmp_path, capsys):
    arrays = {"observations": np.zeros((0, 8, 8, 3), np.uint8), "actions": np.zeros(0, np.int64),
              "action_names": np.array(["pick_a", "place_a"])}
    assert_refused(capsys, write_npz(tmp_path / "t.npz", **arrays), "empty trace")
    arrays = {"observations": np.zeros((2, 8, 8, 3), np.uint8), "actions": np.array([-1]),
              "action_names": np.array(["pick_a", "place_a"])}
    assert_refused(capsys, write_npz(tmp_path / "u.npz", **arrays), "empty trace")


def test_truncated_file(tmp_path, toy_trace, capsys):
    data = trace_to_bytes(toy_trace)
    path = tmp_path / "t.npz"
    path.write_bytes(data[: len(data) // 2])
    assert_refused(capsys, path, "not an npz archive")


def test_corrupt_member(tmp_path, toy_trace, capsys):
    # a valid zip directory whose compressed observations are damaged
    buf = io.BytesIO(trace_to_bytes(toy_trace))
    with zipfile.ZipFile(buf) as zf:
        info = zf.getinfo("observations.npy")
        offset = info.header_offset + 30 + len(info.filename) + len(info.extra)
    data = bytearray(buf.getvalue())
    for i in range(offset + 20, offset + 60):
        data[i] ^= 0xFF
    path = tmp_path / "t.npz"
    path.write_bytes(bytes(data))
    assert_refused(capsys, path, "'observations'", "corrupt")


def test_not_an_npz(tmp_path, capsys):
    path = tmp_path / "t.npz"
    path.write_text("hello, I am text\n")
    assert_refused(capsys, path, "not an npz archive")
    npy = tmp_path / "a.npz"
    with open(npy, "wb") as f:
        np.save(f, np.zeros(3))
    assert_refused(capsys, npy, "not an npz archive")


def test_missing_file(tmp_path, capsys):
    assert_refused(capsys, tmp_path / "nope.npz", "no such file")


def test_save_refuses_invalid_and_writes_nothing(tmp_path, toy_trace):
    bad = make_trace([["A", "pick_L", "B", "pick_R", "C"]], TOY_NAMES)
    path = tmp_path / "t.npz"
    with pytest.raises(TraceError):
        save_trace(bad, path)
    assert not path.exists() and list(tmp_path.iterdir()) == []


def test_console_script_has_no_traceback(tmp_path):
    path = tmp_path / "t.npz"
    path.write_text("garbage")
    proc = subprocess.run([sys.executable, "-m", "vggc_cp", "inspect", str(path)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr


def test_a_reader_that_goes_away_stops_the_command_quietly(tmp_path, toy_trace):
    """`vggc-cp inspect T | head -1` with the reader gone before the command writes: exit
    141 (128 + SIGPIPE) and no traceback (before: "Exception ignored ... BrokenPipeError",
    exit 120)."""
    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    proc = subprocess.Popen([sys.executable, "-m", "vggc_cp", "inspect", str(path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # long before the interpreter has started
    err = proc.stderr.read().decode()
    proc.stderr.close()
    assert proc.wait(timeout=120) == 141, err
    assert "Traceback" not in err and "BrokenPipe" not in err, err


class _ClosedPipe(io.StringIO):
    def write(self, text):
        raise BrokenPipeError(32, "Broken pipe")


def test_a_pipe_that_closes_while_printing_is_exit_141(tmp_path, toy_trace, monkeypatch):
    """The same inside a command's printing (a long listing fills the pipe first)."""
    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    monkeypatch.setattr(sys, "stdout", _ClosedPipe())
    assert main(["inspect", str(path)]) == 141


def test_written_files_get_the_usual_mode(tmp_path, toy_trace):
    import os

    path = tmp_path / "t.npz"
    save_trace(toy_trace, path)
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask


def test_episode_index_numbers_the_episodes_of_every_observation():
    trace = make_trace([["A", "pick_L", "B", "place_R", "C"], ["D", "pick_R", "E"]], TOY_NAMES)
    assert trace.episodes() == [(0, 2), (3, 4)]
    assert trace.episode_index().tolist() == [0, 0, 0, 1, 1]
