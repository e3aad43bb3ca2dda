"""The fuzz corpus of issue 17: hundreds of bad inputs over every command that reads a file.

Each case runs in-process through :func:`vggc_cp.cli.main` and must end with exit code 2,
exactly one stderr line ``vggc-cp: error: ...`` naming the file (and the field or index where
there is one), no traceback, and every input byte-identical afterwards.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
from pathlib import Path

import numpy as np
import pytest
import torch
from world import (
    FAST,
    bad_solutions,
    bad_traces,
    exactly_one_violation,
    png,
    png_header_only,
    sha,
    toy_trace,
    zip_bomb,
)

from vggc_cp.cli import main
from vggc_cp.sim.novel import save_novel
from vggc_cp.trace import save_trace, trace_to_bytes

VALID_TRACE_BYTES = trace_to_bytes(toy_trace())
BAD_TRACES = bad_traces(VALID_TRACE_BYTES)
_DUMMY = {"format": "vggc-solution/1", "labels": [0, 1, 2], "roles": ["pick", "place", "pick"],
          "edges": [[0, "pick_L", 1], [1, "place_R", 2]], "k_pick": 2, "k_place": 1, "J": 0.5,
          "solver": "greedy", "status": "feasible"}
SOLUTION_CASES = sorted(bad_solutions(_DUMMY, "0" * 64)) + ["exactly-one"]


@pytest.fixture(scope="session")
def world(tmp_path_factory):
    """The valid files every case starts from (made once)."""
    root = tmp_path_factory.mktemp("world")
    cache = root / "cache"
    w = {"root": root, "cache": cache, "trace": root / "t.npz", "solution": root / "s.json",
         "model": root / "m.pt", "novel": root / "t.novel.npz", "image": root / "a.png"}
    w["trace"].write_bytes(VALID_TRACE_BYTES)
    rc = main(["solve", str(w["trace"]), "-o", str(w["solution"]), "--quiet", "--solver",
               "greedy", "--k-pick", "1:3", "--k-place", "1:2", "--cache-dir", str(cache),
               *FAST])
    assert rc == 0
    rc = main(["train-localizer", str(w["trace"]), str(w["solution"]), "-o", str(w["model"]),
               "--epochs", "1", "--lr", "1e-2", "--folds", "2", "--quiet", "--threads", "1"])
    assert rc == 0
    t = toy_trace()
    save_novel(w["novel"], t.observations, t.states)
    w["image"].write_bytes(png(16))
    other = toy_trace()
    other = type(other)(other.observations[::-1].copy(), other.actions, other.action_names,
                        other.states, other.meta)
    w["other_sha"] = other.content_hash()
    w["valid_solution"] = json.loads(w["solution"].read_text())
    bad = root / "bad"
    bad.mkdir()
    w["bad"] = bad
    return w


def expect_refusal(capsys, argv, inputs, must=()):
    """Run ``argv``; assert exit 2, one stderr line naming ``must``, inputs unchanged."""
    capsys.readouterr()
    before = {str(p): sha(p) for p in inputs}
    rc = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    lines = err.splitlines()
    assert rc == 2, (rc, out, err)
    assert len(lines) == 1, err
    assert lines[0].startswith("vggc-cp: error: "), err
    for m in must:
        assert str(m) in lines[0], (m, lines[0])
    assert {str(p): sha(p) for p in inputs} == before
    return lines[0]


def _each_once(cases):
    """Every ``(command, bad input)`` case, id ``command-input``; in the quick run only a case
    that brings a command or a bad input not seen before it (each bad input once, each command
    once), the rest marked slow: the full run takes every case."""
    seen, out = set(), []
    for case in cases:
        new = not set(enumerate(case)) <= seen
        out.append(pytest.param(*case, id="-".join(case),
                                marks=() if new else pytest.mark.slow))
        seen.update(enumerate(case))
    return out


# ------------------------------------------------------------------ bad traces

TRACE_COMMANDS = {
    "inspect": lambda p, w, o: ["inspect", p],
    "solve": lambda p, w, o: ["solve", p, "-o", o / "s.json", "--quiet", "--cache-dir",
                              w["cache"], *FAST],
    "evaluate": lambda p, w, o: ["evaluate", p, w["solution"]],
    "render": lambda p, w, o: ["render", p, "-o", o / "sheet.png"],
    "distances": lambda p, w, o: ["distances", p, "--quiet", "--cache-dir", w["cache"], *FAST],
    "show-attention": lambda p, w, o: ["show-attention", p, "-o", o / "att.png"],
    "baseline": lambda p, w, o: ["baseline", "pca-hdbscan", p, "-o", o / "b.json"],
    "train-localizer": lambda p, w, o: ["train-localizer", p, w["solution"], "-o", o / "m.pt",
                                        "--quiet", "--threads", "1"],
    "compare": lambda p, w, o: ["compare", p, "--quiet", "--cache-dir", w["cache"], *FAST],
    "bench-distance": lambda p, w, o: ["bench", "distance", "--trace", p],
}
# every bad trace through inspect, solve and evaluate; every third through each other command
TRACE_CASES = [(cmd, name) for i, name in enumerate(sorted(BAD_TRACES))
               for j, cmd in enumerate(TRACE_COMMANDS)
               if j < 3 or (i + j) % 3 == 0]


@pytest.mark.parametrize("cmd,name", _each_once(TRACE_CASES))
def test_bad_trace(world, capsys, tmp_path, cmd, name):
    data, must = BAD_TRACES[name]
    path = world["bad"] / f"{name}.npz"
    if not path.exists():
        path.write_bytes(data)
    argv = TRACE_COMMANDS[cmd](path, world, tmp_path)
    expect_refusal(capsys, argv, [path, world["solution"]], (path, *must))
    assert not list(tmp_path.iterdir())  # nothing written


@pytest.mark.parametrize("cmd", ["inspect", "solve", "evaluate", "distances"])
def test_zip_bomb_refused_before_inflating(world, capsys, tmp_path, monkeypatch, cmd):
    # frames above max_bytes are read from the file in chunks (vggc_cp.frames); what bounds
    # them then is max_frame_bytes
    monkeypatch.setenv("VGGC_CP_MAX_BYTES", str(1 << 20))
    monkeypatch.setenv("VGGC_CP_MAX_FRAME_BYTES", str(2 << 20))
    path = tmp_path / "bomb.npz"
    path.write_bytes(zip_bomb(3 << 20))  # a few kB inflating to 3 MB > the 2 MB cap
    assert path.stat().st_size < 100_000
    out = tmp_path / "out"
    out.mkdir()
    expect_refusal(capsys, TRACE_COMMANDS[cmd](path, world, out), [path],
                   (path, "VGGC_CP_MAX_FRAME_BYTES"))


@pytest.mark.parametrize("cmd", ["inspect", "render"])
def test_pixel_cap(world, capsys, tmp_path, monkeypatch, cmd):
    monkeypatch.setenv("VGGC_CP_MAX_PIXELS", "100")
    expect_refusal(capsys, TRACE_COMMANDS[cmd](world["trace"], world, tmp_path),
                   [world["trace"]], (world["trace"], "observations", "VGGC_CP_MAX_PIXELS"))


@pytest.mark.parametrize("cmd", ["solve", "distances", "show-attention"])
def test_images_smaller_than_the_grid(world, capsys, tmp_path, cmd):
    path = tmp_path / "t8.npz"
    save_trace(toy_trace(size=8), path)
    out = tmp_path / "out"
    out.mkdir()
    argv = TRACE_COMMANDS[cmd](path, world, out)
    if cmd == "solve":  # the grid belongs to the attention evidence (footprints need none)
        argv = [*argv, "--evidence", "attention"]
    expect_refusal(capsys, argv, [path], (path, "observations", "grid"))


# ------------------------------------------------------------------ bad solutions

SOLUTION_COMMANDS = {
    "evaluate": lambda s, w, o: ["evaluate", w["trace"], s],
    "plan": lambda s, w, o: ["plan", s, "--start-obs", "0", "--goal-obs", "1"],
    "train-localizer": lambda s, w, o: ["train-localizer", w["trace"], s, "-o", o / "m.pt",
                                        "--quiet", "--threads", "1"],
    "plan-images": lambda s, w, o: ["plan", s, "--model", w["model"], "--start", w["image"],
                                    "--goal", w["image"]],
}
NEEDS_TRACE = {"sha-other-trace"}  # only a trace can tell
SOL_CASES = [(cmd, name) for name in SOLUTION_CASES for cmd in SOLUTION_COMMANDS
             if not (name in NEEDS_TRACE and cmd.startswith("plan"))]


@pytest.mark.parametrize("cmd,name", _each_once(SOL_CASES))
def test_bad_solution(world, capsys, tmp_path, cmd, name):
    if name == "exactly-one":
        data, must = json.dumps(exactly_one_violation(world["valid_solution"])).encode(), ()
    else:
        data, must = bad_solutions(world["valid_solution"], world["other_sha"])[name]
    path = world["bad"] / f"{name}.json"
    if not path.exists():
        path.write_bytes(data)
    line = expect_refusal(capsys, SOLUTION_COMMANDS[cmd](path, world, tmp_path),
                          [path, world["trace"]], (path, *must))
    if name == "sha-other-trace":
        assert str(world["trace"]) in line  # both files named
    assert not list(tmp_path.iterdir())


def test_solve_hint_with_bad_solution(world, capsys, tmp_path):
    path = tmp_path / "hint.json"
    path.write_bytes(b'{"labels": true}')
    expect_refusal(capsys, ["solve", world["trace"], "-o", tmp_path / "o.json", "--solver",
                            "cpsat", "--hint", path, "--quiet", *FAST], [path], (path,))


# ------------------------------------------------------------------ outputs

OUTPUT_COMMANDS = {
    "solve": (lambda w, o: ["solve", w["trace"], "-o", o, "--quiet", "--cache-dir", w["cache"],
                            *FAST]),
    "baseline": lambda w, o: ["baseline", "pca-hdbscan", w["trace"], "-o", o],
    "show-attention": lambda w, o: ["show-attention", w["trace"], "-o", o],
    "render": lambda w, o: ["render", w["trace"], "-o", o],
    "compare-csv": lambda w, o: ["compare", w["trace"], "--csv", o, "--quiet", "--cache-dir",
                                 w["cache"], *FAST],
    "compare-plot": lambda w, o: ["compare", w["trace"], "--plot", o, "--quiet", "--cache-dir",
                                  w["cache"], *FAST],
    "solve-plot": lambda w, o: ["solve", w["trace"], "-o", w["root"] / "unused.json", "--plot", o,
                                "--quiet", "--cache-dir", w["cache"], *FAST],
    "train-localizer": lambda w, o: ["train-localizer", w["trace"], w["solution"], "-o", o,
                                     "--quiet", "--threads", "1"],
}


def _output_target(kind, world, tmp_path):
    if kind == "is-the-trace":
        return world["trace"], "same file"
    if kind == "is-the-solution":
        return world["solution"], "same file"
    if kind == "symlink-to-trace":
        link = tmp_path / "link.npz"
        link.symlink_to(world["trace"])
        return link, "same file"
    if kind == "relative-to-trace":
        return Path(os.path.relpath(world["trace"])), "same file"
    if kind == "directory":
        return tmp_path, "directory"
    if kind == "dev-null":
        return Path("/dev/null"), "not a regular file"
    if kind == "fifo":
        fifo = tmp_path / "fifo.png"
        os.mkfifo(fifo)
        return fifo, "not a regular file"
    if kind == "under-a-file":
        return world["solution"] / "x.png", "not a folder"
    if kind == "name-too-long":
        return tmp_path / ("x" * 300 + ".png"), "255"
    raise AssertionError(kind)


OUTPUT_KINDS = ["is-the-trace", "is-the-solution", "symlink-to-trace", "relative-to-trace",
                "directory", "dev-null", "fifo", "under-a-file", "name-too-long"]
OUT_CASES = [(c, k) for c in OUTPUT_COMMANDS for k in OUTPUT_KINDS
             if k != "is-the-solution" or c == "train-localizer"]  # else not an input


@pytest.mark.parametrize("cmd,kind", _each_once(OUT_CASES))
def test_bad_output(world, capsys, tmp_path, cmd, kind):
    target, why = _output_target(kind, world, tmp_path)
    argv = OUTPUT_COMMANDS[cmd](world, target)
    expect_refusal(capsys, argv, [world["trace"], world["solution"], world["model"]], (why,))


@pytest.mark.parametrize("suffix", ["npz", "json", "txt"])
def test_plot_with_a_non_image_suffix(world, capsys, tmp_path, suffix):
    out = tmp_path / f"x.{suffix}"
    expect_refusal(capsys, OUTPUT_COMMANDS["solve-plot"](world, out), [world["trace"]],
                   (out, "image format"))


def test_hint_is_the_output(world, capsys):
    expect_refusal(capsys, ["solve", world["trace"], "-o", world["solution"], "--solver",
                            "cpsat", "--hint", world["solution"], "--quiet", *FAST],
                   [world["solution"], world["trace"]], (world["solution"], "same file"))


def test_csv_and_plot_the_same_file(world, capsys, tmp_path):
    out = tmp_path / "x.png"
    expect_refusal(capsys, ["compare", world["trace"], "--csv", out, "--plot", out, "--quiet"],
                   [world["trace"]], (out, "same file"))


@pytest.mark.parametrize("cmd", ["solve", "distances"])
def test_cache_dir_is_a_file(world, capsys, tmp_path, cmd):
    argv = TRACE_COMMANDS[cmd](world["trace"], world, tmp_path)
    argv[argv.index("--cache-dir") + 1] = world["solution"]
    expect_refusal(capsys, argv, [world["trace"], world["solution"]],
                   (world["solution"], "--cache-dir"))


# ------------------------------------------------------------------ other inputs

def _missing(tmp_path):
    return tmp_path / "nope.npz"


INPUT_PATHS = {
    "missing": lambda w, t: (t / "nope.npz", "no such file"),
    "directory": lambda w, t: (t, "directory"),
    "fifo": lambda w, t: (_fifo(t), "not a regular file"),
    "name-too-long": lambda w, t: (t / ("y" * 300 + ".npz"), "255"),
}


def _fifo(tmp_path):
    p = tmp_path / "in.fifo"
    os.mkfifo(p)
    return p


IN_CASES = [(c, k) for c in ("inspect", "evaluate", "render", "solve", "baseline")
            for k in INPUT_PATHS]


@pytest.mark.parametrize("cmd,kind", _each_once(IN_CASES))
def test_bad_input_path(world, capsys, tmp_path, cmd, kind):
    path, why = INPUT_PATHS[kind](world, tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    expect_refusal(capsys, TRACE_COMMANDS[cmd](path, world, out), [world["solution"]], (why,))


def _checkpoints(world, tmp):
    payload = torch.load(world["model"], weights_only=True)
    out = {}

    def save(name, p, *must):
        path = tmp / f"{name}.pt"
        torch.save(p, path)
        out[name] = (path, must)

    for name, value in (("nan", float("nan")), ("inf", float("inf"))):
        p = {**payload, "state_dict": dict(payload["state_dict"])}
        k = next(k for k, v in p["state_dict"].items() if v.is_floating_point())
        t = p["state_dict"][k].clone()
        t.view(-1)[0] = value
        p["state_dict"][k] = t
        save(name, p, "NaN")
    meta = json.loads(payload["meta"])
    huge = {**meta, "backbone_config": {**meta["backbone_config"], "width": 1 << 16}}
    save("huge-width", {**payload, "meta": json.dumps(huge)}, "bytes")
    big_input = {**meta, "backbone_config": {**meta["backbone_config"], "input_size": 1 << 16}}
    save("huge-input", {**payload, "meta": json.dumps(big_input)}, "VGGC_CP_MAX_PIXELS")
    save("deep-meta", {**payload, "meta": "[" * 100_000 + "]" * 100_000}, "nested")
    save("meta-list", {**payload, "meta": "[]"})
    save("meta-not-string", {**payload, "meta": 5})
    save("format", {**payload, "format": "other"}, "format")
    save("no-state", {k: v for k, v in payload.items() if k != "state_dict"})
    save("extra-weight", {**payload, "state_dict": {**payload["state_dict"],
                                                    "x": torch.zeros(3)}})
    save("malicious", {**payload, "evil": np.random.default_rng(0)}, "refused")
    for name, data in (("empty", b""), ("random", np.random.default_rng(1).bytes(500)),
                       ("truncated", world["model"].read_bytes()[:2000])):
        path = tmp / f"{name}.pt"
        path.write_bytes(data)
        out[name] = (path, ())
    return out


CKPT_NAMES = ["nan", "inf", "huge-width", "huge-input", "deep-meta", "meta-list",
              "meta-not-string", "format", "no-state", "extra-weight", "malicious", "empty",
              "random", "truncated"]
CKPT_CASES = [(c, n) for c in ("plan", "evaluate") for n in CKPT_NAMES]


@pytest.mark.parametrize("cmd,name", _each_once(CKPT_CASES))
def test_bad_checkpoint(world, capsys, tmp_path, cmd, name):
    path, must = _checkpoints(world, tmp_path)[name]
    argv = (["plan", world["solution"], "--model", path, "--start", world["image"], "--goal",
             world["image"]] if cmd == "plan" else
            ["evaluate", world["trace"], world["solution"], "--model", path, "--novel",
             world["novel"]])
    expect_refusal(capsys, argv, [path, world["solution"], world["trace"], world["novel"]],
                   (path, *must))


def _written(tmp, cases: dict, suffix: str) -> dict:
    """Write every case's bytes to ``tmp/NAME + suffix``: name -> (path, what the error names)."""
    out = {}
    for name, (data, must) in cases.items():
        p = tmp / f"{name}{suffix}"
        p.write_bytes(data)
        out[name] = (p, must)
    return out


def _images(tmp):
    cases = {"empty": (b"", ()), "random": (np.random.default_rng(2).bytes(200), ()),
             "1x1": (png(1), ("1x1",)), "3x3": (png(3), ("3x3",)),
             "header-40000": (png_header_only(40000, 40000), ("VGGC_CP_MAX_PIXELS",)),
             "header-0": (png_header_only(0, 0), ()),
             "truncated": (png(16)[:40], ()), "json": (b"{}", ())}
    return _written(tmp, cases, ".png")


@pytest.mark.parametrize("name", ["empty", "random", "1x1", "3x3", "header-40000", "header-0",
                                  "truncated", "json"])
@pytest.mark.parametrize("which", ["--start", "--goal"])
def test_bad_image(world, capsys, tmp_path, name, which):
    path, must = _images(tmp_path)[name]
    argv = ["plan", world["solution"], "--model", world["model"], "--start", world["image"],
            "--goal", world["image"]]
    argv[argv.index(which) + 1] = path
    expect_refusal(capsys, argv, [path, world["solution"], world["model"]], (path, *must))


def _novels(world, tmp):
    t = toy_trace()
    base = {"observations": t.observations, "states": t.states}
    from world import npy, npy_with_header, zip_members

    def members(**change):
        d = {f"{k}.npy": npy(v) for k, v in base.items()}
        d.update({f"{k}.npy": v for k, v in change.items()})
        return zip_members(d)

    cases = {
        "empty": (b"", ()),
        "truncated": (world["novel"].read_bytes()[:300], ()),
        "pickled": (members(states=npy(np.array([None], dtype=object), allow_pickle=True)),
                    ("pickle",)),
        "float-obs": (members(observations=npy(t.observations.astype(np.float32))),
                      ("observations",)),
        "huge": (members(observations=npy_with_header((10**6, 512, 512, 3), "|u1")),
                 ("observations",)),
        "unvisited": (members(states=npy(np.array(["Z"] * len(t.states)))), ("visited",)),
        "no-images": (members(observations=npy(t.observations[:0]),
                              states=npy(t.states[:0])), ()),
        "no-states": (zip_members({"observations.npy": npy(t.observations)}), ("states",)),
        "1x1": (members(observations=npy(t.observations[:, :1, :1])), ("1x1",)),
    }
    return _written(tmp, cases, ".novel.npz")


@pytest.mark.parametrize("name", ["empty", "truncated", "pickled", "float-obs", "huge",
                                  "unvisited", "no-images", "no-states", "1x1"])
def test_bad_novel(world, capsys, tmp_path, name):
    path, must = _novels(world, tmp_path)[name]
    expect_refusal(capsys, ["evaluate", world["trace"], world["solution"], "--model",
                            world["model"], "--novel", path],
                   [path, world["trace"], world["solution"], world["model"]], (path, *must))


def test_benchmark_cell_files_damaged_are_ignored(tmp_path, capsys):
    from vggc_cp.experiments.table1 import _cached

    for i, data in enumerate((b"[" * 100_000, b"[1]", b"\xff\xfe", b'{"key": 1, "row": 5}',
                              b'{"key": {"a": 1}, "row": []}')):
        p = tmp_path / f"cell{i}.json"
        p.write_bytes(data)
        assert _cached(p, {"a": 1}, "row") is None
        assert "Traceback" not in capsys.readouterr().err


def test_corpus_size():
    """Issue 17 asks for at least 200 bad inputs."""
    n = (len(TRACE_CASES) + len(SOL_CASES) + len(OUT_CASES) + len(IN_CASES) + len(CKPT_CASES)
         + 16 + 9 + 4 + 2 + 3 + 3 + 3 + 2)
    assert n >= 200


# ------------------------------------------------------------------ the registry (issue 26)

from cases import ALL_CASES, FILE_HELP, env_variables  # noqa: E402

from vggc_cp.cli import build_parser, iter_parsers  # noqa: E402
from vggc_cp.safeio import INPUT_ATTRS, OUTPUT_ATTRS, OUTPUT_DIR_ATTRS  # noqa: E402

FILE_DESTS = {*INPUT_ATTRS, *OUTPUT_ATTRS, *OUTPUT_DIR_ATTRS, "cache_dir"}
NOTEBOOK = {"nbformat": 4, "nbformat_minor": 5, "metadata": {}, "cells": [
    {"cell_type": "code", "id": "p", "metadata": {"tags": ["parameters"]}, "source": "x = 1",
     "outputs": [], "execution_count": None}]}


@pytest.fixture(scope="session")
def corpus_world(world):
    """The world plus the files the registry's cases read (a notebook, damaged notebooks, a
    solution with an edge to a node no observation has)."""
    root = world["root"]
    if "notebook" not in world:
        world["notebook"] = root / "n.ipynb"
        world["notebook"].write_text(json.dumps(NOTEBOOK))
        bad = {"random": np.random.default_rng(3).bytes(400), "empty-object": b"{}",
               "nbformat-99": json.dumps({**NOTEBOOK, "nbformat": 99}).encode(),
               "deep": b"[" * 100_000 + b"]" * 100_000,
               "no-cells": json.dumps({k: v for k, v in NOTEBOOK.items() if k != "cells"}
                                      ).encode(),
               "list": b"[]"}
        for name, data in bad.items():
            world[f"nb_{name}"] = root / f"nb_{name}.ipynb"
            world[f"nb_{name}"].write_bytes(data)
        d = json.loads(json.dumps(world["valid_solution"]))
        u, a, _v = d["edges"][0]
        d["edges"].append([u, a, 999])
        world["unknown_node"] = root / "unknown_node.json"
        world["unknown_node"].write_text(json.dumps(d))
    return world


def _leaf_parsers():
    for name, p in iter_parsers(build_parser()):
        if not any(isinstance(a, argparse._SubParsersAction) for a in p._actions):
            yield name.removeprefix("vggc-cp "), p


@functools.lru_cache(maxsize=1)
def _leaf_commands() -> dict[str, set[str]]:
    """command -> its option strings and positional names."""
    return {cmd: {s for a in p._actions for s in (a.option_strings or [a.dest])}
            for cmd, p in _leaf_parsers()}


def _file_options(parser) -> list[str]:
    out = []
    for a in parser._actions:
        if isinstance(a, argparse._HelpAction) or a.nargs == 0 or a.type in (int, float):
            continue
        if a.dest in FILE_DESTS or FILE_HELP.search(f"{a.help or ''} {a.metavar or ''}"):
            out.append(a.option_strings[-1] if a.option_strings else a.dest)
    return out


def test_every_subcommand_and_file_option_has_cases():
    """A new sub-command, or a new option taking a file or folder, fails here until
    tests/fuzz/cases.py holds its cases (see that module's docstring for the one-entry way)."""
    missing = []
    for cmd, parser in _leaf_parsers():
        cases = [c for c in ALL_CASES if c.command == cmd]
        if not cases:
            missing.append(f"{cmd}: no case at all")
        covered = {o for c in cases for o in c.covers}
        missing += [f"{cmd} {opt}" for opt in _file_options(parser) if opt not in covered]
    assert not missing, "no corpus case in tests/fuzz/cases.py for:\n  " + "\n  ".join(missing)
    ids = [c.id for c in ALL_CASES]
    assert len(ids) == len(set(ids)), "two cases share an id"


def test_every_environment_variable_has_cases():
    import vggc_cp

    names = env_variables(Path(vggc_cp.__file__).parent)
    covered = {k for c in ALL_CASES for k in c.env}
    assert names and names <= covered, f"no corpus case sets: {sorted(names - covered)}"


def _resolve_env(case, w, t) -> dict:
    return {k: str(v[1](w, t)) if isinstance(v, tuple) else v for k, v in case.env.items()}


def _quick_first(cases) -> list:
    """Every case; in the quick run only the first of each command and of each environment
    variable (the rest are marked slow: the full run takes every case, the quick run stays
    within its budget and still runs every command once)."""
    seen, out = set(), []
    for c in cases:
        key = tuple(sorted(c.env)) if c.env else c.command
        out.append(pytest.param(c, id=c.id, marks=() if key not in seen else pytest.mark.slow))
        seen.add(key)
    return out


@pytest.mark.parametrize("case", _quick_first(ALL_CASES))
def test_registry_case(corpus_world, capsys, tmp_path, monkeypatch, case):
    if case.command not in _leaf_commands():
        pytest.skip(f"vggc-cp {case.command}: not a command of this checkout")
    if not set(case.covers) <= _leaf_commands()[case.command]:
        pytest.skip(f"vggc-cp {case.command}: no {', '.join(case.covers)} in this checkout")
    w = corpus_world
    (tmp_path / "out").mkdir()
    for k in [k for k in os.environ if k.startswith("VGGC_CP_")]:
        monkeypatch.delenv(k)
    monkeypatch.setenv("VGGC_CP_CACHE", str(w["cache"]))
    for k, v in _resolve_env(case, w, tmp_path).items():
        monkeypatch.setenv(k, v)
    argv = case.argv(w, tmp_path)
    files = [p for p in w.values() if isinstance(p, Path) and p.is_file()]
    if case.expect == "refusal":
        expect_refusal(capsys, argv, files, case.must)
    else:
        before = {str(p): sha(p) for p in files}
        rc = main([str(a) for a in argv])
        out, err = capsys.readouterr()
        assert rc == 0 and "Traceback" not in out + err, err
        assert any(all(m in line for m in case.must) for line in err.splitlines()
                   if line.startswith("vggc-cp: warning: ")), err
        assert {str(p): sha(p) for p in files} == before
    assert not list((tmp_path / "out").iterdir())  # nothing written
