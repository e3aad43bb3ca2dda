"""Our traces written out in the four recording layouts ``vggc-cp import`` reads, by code, so
the tests can import them back (the writers are the tests' own, not part of the package)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from vggc_cp.trace import Trace

SHIPPED = Path(__file__).resolve().parents[2] / "data" / "fruit-2x3.npz"
FPS = 10
CAMERA = "observation.images.top"


def after(trace: Trace) -> list[str]:
    """The action taken after each frame ("" on an episode's last frame)."""
    acts = [trace.action_names[a] if a >= 0 else "" for a in trace.actions.tolist()]
    return acts + [""]


def episode_ids(trace: Trace) -> list[int]:
    return trace.episode_index().tolist()


def write_png(path: Path, image: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(image).save(path, format="PNG")


def encode_video(path: Path, frames: np.ndarray, fps: int = FPS, gop: int | None = None,
                 av1: bool = False) -> None:
    """A lossless H.264 (RGB, crf 0) video of ``frames``, which decodes back bit-exact; or with
    ``av1`` a lossy AV1 one (yuv420p, crf 30) as LeRobot writes by default."""
    import av

    h, w = frames.shape[1:3]
    with av.open(str(path), "w") as c:
        s = c.add_stream("libsvtav1" if av1 else "libx264rgb", rate=fps)
        s.width, s.height, s.pix_fmt = w, h, "yuv420p" if av1 else "rgb24"
        s.options = {"crf": "30" if av1 else "0", **({"g": str(gop)} if gop else {})}
        for image in frames:
            for packet in s.encode(av.VideoFrame.from_ndarray(image, format="rgb24")):
                c.mux(packet)
        for packet in s.encode():
            c.mux(packet)


def write_images_layout(trace: Trace, folder: Path, jsonl: bool = False,
                        states: bool = False) -> Path:
    """``folder/frames/000000.png ...`` and ``folder/log.csv`` (or ``log.jsonl``)."""
    (folder / "frames").mkdir(parents=True, exist_ok=True)
    rows = []
    for t, (image, act, ep) in enumerate(zip(trace.observations, after(trace),
                                             episode_ids(trace))):
        name = f"frames/{t:06d}.png"
        write_png(folder / name, image)
        row = {"frame": name, "action": act, "episode": f"ep{ep}"}
        if states:
            row["state"] = str(trace.states[t])
        rows.append(row)
    return write_log(folder / ("log.jsonl" if jsonl else "log.csv"), rows)


def write_log(path: Path, rows: list[dict]) -> Path:
    if path.suffix == ".jsonl":
        path.write_text("".join(json.dumps(r) + "\n" for r in rows), encoding="utf-8")
    else:
        with open(path, "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return path


def write_video_layout(trace: Trace, folder: Path, by: str = "frame",
                       padding: int = 2) -> tuple[Path, Path]:
    """``folder/run.mp4`` holding the trace's frames with ``padding`` extra frames (a blank
    frame) before each episode, and ``folder/log.csv`` naming the trace's frames by index or
    time."""
    folder.mkdir(parents=True, exist_ok=True)
    blank = np.zeros_like(trace.observations[0])
    frames, rows = [], []
    for (first, last) in trace.episodes():
        frames += [blank] * padding
        for t in range(first, last + 1):
            k = len(frames)
            frames.append(trace.observations[t])
            where = {"frame": k} if by == "frame" else {"time": f"{k / FPS:.4f}"}
            rows.append({**where, "action": after(trace)[t], "episode": f"ep{first}"})
    video = folder / "run.mp4"
    encode_video(video, np.stack(frames))
    return video, write_log(folder / "log.csv", rows)


def write_robomimic(trace: Trace, path: Path, int_labels: bool = False) -> Path:
    """An HDF5 file in robomimic's layout: ``data/demo_K/obs/agentview_image`` and labels
    ``data/demo_K/action_labels``; demos numbered 1, 2, 4, 8, ... so that their natural order
    differs from the order of their names."""
    import h5py

    with h5py.File(path, "w") as f:
        data = f.create_group("data")
        data.attrs["env_args"] = json.dumps({"env_name": "fruit-2x3"})
        for e, (first, last) in enumerate(trace.episodes()):
            demo = data.create_group(f"demo_{2 ** e}")
            demo.create_dataset("obs/agentview_image",
                                data=trace.observations[first:last + 1], compression="gzip")
            demo.create_dataset("actions", data=np.zeros((last - first + 1, 7), np.float32))
            acts = after(trace)[first:last + 1]
            if int_labels:
                names = list(trace.action_names)
                idx = [names.index(a) for a in acts[:-1]]  # T - 1 labels, one per transition
                ds = demo.create_dataset("action_labels", data=np.array(idx, dtype=np.int64))
                ds.attrs["names"] = names
            else:
                demo.create_dataset("action_labels", data=np.array(acts, dtype=object),
                                    dtype=h5py.string_dtype())
        data.create_group("mask")  # robomimic's filter keys: not a demo, ignored
    return path


def write_lerobot(trace: Trace, folder: Path, version: str = "v3.0",
                  label_column: str = "action_label", av1: bool = False) -> Path:
    """A LeRobot dataset folder holding ``trace``: v3.0 (one parquet and one mp4 for every
    episode, located through ``meta/episodes``) or v2.1 (one parquet and one mp4 per
    episode)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    h, w = trace.image_shape
    eps = trace.episodes()
    acts = after(trace)
    features = {
        CAMERA: {"dtype": "video", "shape": [h, w, 3], "names": ["height", "width", "channel"]},
        "action": {"dtype": "float32", "shape": [2], "names": ["x", "y"]},
        label_column: {"dtype": "string", "shape": [1], "names": None},
        "timestamp": {"dtype": "float32", "shape": [1], "names": None},
        "frame_index": {"dtype": "int64", "shape": [1], "names": None},
        "episode_index": {"dtype": "int64", "shape": [1], "names": None},
        "index": {"dtype": "int64", "shape": [1], "names": None},
        "task_index": {"dtype": "int64", "shape": [1], "names": None},
    }

    def table(episodes):
        cols = {k: [] for k in ("action", label_column, "timestamp", "frame_index",
                                "episode_index", "index", "task_index")}
        for e, (first, last) in episodes:
            for k, t in enumerate(range(first, last + 1)):
                cols["action"].append([0.0, 0.0])
                cols[label_column].append(acts[t])
                cols["timestamp"].append(np.float32(k / FPS))
                cols["frame_index"].append(k)
                cols["episode_index"].append(e)
                cols["index"].append(t)
                cols["task_index"].append(0)
        return pa.table({
            "action": pa.array(cols["action"], pa.list_(pa.float32())),
            label_column: pa.array(cols[label_column], pa.string()),
            "timestamp": pa.array(cols["timestamp"], pa.float32()),
            **{k: pa.array(cols[k], pa.int64())
               for k in ("frame_index", "episode_index", "index", "task_index")},
        })

    (folder / "meta").mkdir(parents=True, exist_ok=True)
    info = {"codebase_version": version, "robot_type": "fruit-2x3-sim", "fps": FPS,
            "total_episodes": len(eps), "total_frames": trace.n_obs, "chunks_size": 1000,
            "features": features, "splits": {"train": f"0:{len(eps)}"}}
    if version.startswith("v2"):
        info["data_path"] = "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet"
        info["video_path"] = ("videos/chunk-{episode_chunk:03d}/{video_key}/"
                              "episode_{episode_index:06d}.mp4")
        for e, (first, last) in enumerate(eps):
            p = folder / info["data_path"].format(episode_chunk=0, episode_index=e)
            p.parent.mkdir(parents=True, exist_ok=True)
            pq.write_table(table([(e, (first, last))]), p)
            v = folder / info["video_path"].format(episode_chunk=0, episode_index=e,
                                                   video_key=CAMERA)
            v.parent.mkdir(parents=True, exist_ok=True)
            encode_video(v, trace.observations[first:last + 1])
    else:
        info["data_path"] = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
        info["video_path"] = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
        p = folder / info["data_path"].format(chunk_index=0, file_index=0)
        p.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(table(list(enumerate(eps))), p)
        v = folder / info["video_path"].format(chunk_index=0, file_index=0, video_key=CAMERA)
        v.parent.mkdir(parents=True, exist_ok=True)
        encode_video(v, trace.observations, gop=8, av1=av1)  # key frames to seek to
        rows = {"episode_index": [], "length": [], "dataset_from_index": [],
                "dataset_to_index": [], "data/chunk_index": [], "data/file_index": [],
                f"videos/{CAMERA}/chunk_index": [], f"videos/{CAMERA}/file_index": [],
                f"videos/{CAMERA}/from_timestamp": [], f"videos/{CAMERA}/to_timestamp": []}
        for e, (first, last) in enumerate(eps):
            for key, value in (("episode_index", e), ("length", last - first + 1),
                               ("dataset_from_index", first), ("dataset_to_index", last + 1),
                               ("data/chunk_index", 0), ("data/file_index", 0),
                               (f"videos/{CAMERA}/chunk_index", 0),
                               (f"videos/{CAMERA}/file_index", 0),
                               (f"videos/{CAMERA}/from_timestamp", first / FPS),
                               (f"videos/{CAMERA}/to_timestamp", (last + 1) / FPS)):
                rows[key].append(value)
        m = folder / "meta" / "episodes" / "chunk-000" / "file-000.parquet"
        m.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(pa.table(rows), m)
    (folder / "meta" / "info.json").write_text(json.dumps(info, indent=2), encoding="utf-8")
    return folder


def assert_same_trace(got: Trace, want: Trace, states: bool = False) -> None:
    """Frames bit-exact, the same actions, action names and episodes."""
    np.testing.assert_array_equal(got.observations, want.observations)
    assert got.observations.dtype == np.uint8
    assert got.action_names == want.action_names
    np.testing.assert_array_equal(got.actions, want.actions)
    assert got.episodes() == want.episodes()
    if states:
        np.testing.assert_array_equal(got.states, want.states)


def solved_graph(trace_path: Path, out: Path) -> dict:
    """The graph the default ``solve`` writes for ``trace_path``: labels, edges and the choice."""
    from vggc_cp.cli import main

    assert main(["solve", str(trace_path), "-o", str(out), "--quiet", "--no-cache"]) == 0
    sol = json.loads(out.read_text(encoding="utf-8"))
    return {k: sol[k] for k in ("labels", "roles", "edges", "k_pick", "k_place", "J",
                                "threshold", "evidence")}


def run(capsys, *argv):
    """``vggc-cp import ARGV``: ``(exit code, stdout, stderr)``."""
    from vggc_cp.cli import main

    rc = main(["import", *map(str, argv)])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def refused(capsys, out, *argv) -> str:
    """Run ``import ARGV -o out`` and check it is refused with one line and writes nothing;
    returns the line."""
    rc, _, err = run(capsys, *argv, "-o", out)
    lines = err.strip().splitlines()
    assert rc == 2 and len(lines) == 1 and lines[0].startswith("vggc-cp: error: "), err
    assert "Traceback" not in err and not out.exists()
    return lines[0]

