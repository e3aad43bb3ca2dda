"""The corpus registry of issue 26: bad inputs for every sub-command, every file option and every
``VGGC_CP_*`` environment variable (run by ``test_corpus.py``; coverage checked against the
parser by ``test_every_subcommand_and_file_option_has_cases``).

Adding a sub-command is one small entry in :data:`CASES`: one line per file option through
:func:`files` (missing / directory / fifo inputs, directory / fifo / under-a-file / the-input
outputs, file / fifo / loop / ``/proc`` folders), plus a :class:`Case` per refused value::

    *files("export", "trace", "in", lambda w, t, p: ["export", p, "-o", t / "x.json"]),
    *files("export", "--output", "out", lambda w, t, p: ["export", w["trace"], "-o", p]),
    Case("export", "format-unknown", lambda w, t: ["export", w["trace"], "--format", "x"],
         must=("--format",)),

A case's ``argv(world, tmp)`` returns the whole command line (the sub-command words first);
``world`` holds the valid files of ``test_corpus.world`` (``trace``, ``solution``, ``model``,
``novel``, ``image``, ``notebook``, ``root``, ``cache``). Every case must end with exit code 2,
one stderr line ``vggc-cp: error: ...`` holding each of ``must``, no traceback, every file of
``world`` byte-identical and nothing written under ``tmp/out``.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from world import FAST


@dataclass(frozen=True)
class Case:
    """One bad command line.

    Attributes
    ----------
    command : str
        The sub-command as the parser names it (``"robustness"``, ``"bench sweep"``).
    name : str
        Unique within the command.
    argv : callable
        ``argv(world, tmp) -> list``: the whole command line; may create files under ``tmp``.
    covers : tuple of str
        The options / positionals whose checks the case exercises (``"--out"``, ``"trace"``).
    must : tuple of str
        Substrings of the error line.
    env : dict
        Environment variables set for the run.
    expect : str
        ``"refusal"`` (exit 2, one error line) or ``"warning"`` (exit 0, a warning line holding
        ``must``: a legitimate fallback, documented in the README).
    """

    command: str
    name: str
    argv: Callable[[dict, Path], list]
    covers: tuple[str, ...] = ()
    must: tuple[str, ...] = ()
    env: dict = field(default_factory=dict)
    expect: str = "refusal"

    @property
    def id(self) -> str:
        return f"{self.command.replace(' ', '-')}-{self.name}"


def _fifo(t: Path, name: str = "fifo") -> Path:
    p = t / name
    if not p.exists():
        os.mkfifo(p)
    return p


def _loop(t: Path) -> Path:
    p = t / "loop"
    if not p.is_symlink():
        p.symlink_to(p.name)
    return p


#: kind -> (maker(world, tmp) -> path, phrase of the error)
BAD_INPUTS = {
    "missing": (lambda w, t: t / "nope.npz", "no such file"),
    "directory": (lambda w, t: t, "directory"),
    "fifo": (lambda w, t: _fifo(t), "not a regular file"),
}
BAD_OUTPUTS = {
    "directory": (lambda w, t: t, "directory"),
    "fifo": (lambda w, t: _fifo(t, "fifo.out"), "not a regular file"),
    "under-a-file": (lambda w, t: w["solution"] / "x.out", "not a folder"),
    "is-the-trace": (lambda w, t: w["trace"], "same file"),
}
BAD_FOLDERS = {
    "file": (lambda w, t: w["solution"], "is a file"),
    "fifo": (lambda w, t: _fifo(t), "fifo"),
    "symlink-loop": (lambda w, t: _loop(t), "symbolic links"),
    "proc": (lambda w, t: Path("/proc/vggc-cp-out"), "/proc"),
}
KINDS = {"in": BAD_INPUTS, "out": BAD_OUTPUTS, "dir": BAD_FOLDERS}


def files(command: str, option: str, kind: str, argv: Callable, skip: tuple[str, ...] = (),
          **kw) -> list[Case]:
    """The cases of one file option: ``argv(world, tmp, bad_path)`` for each bad path of
    ``kind`` (``in``, ``out``, ``dir``) except ``skip``."""
    out = []
    for bad, (make, phrase) in KINDS[kind].items():
        if bad in skip:
            continue
        out.append(Case(command, f"{option.lstrip('-')}-{bad}",
                        (lambda w, t, make=make: argv(w, t, make(w, t))), (option,),
                        (phrase,), **kw))
    return out


def _import_cases(layout: str, positionals: tuple[str, ...], extra: tuple = ()) -> list[Case]:
    """``import LAYOUT``: each positional file, ``--output`` and ``--map`` (the other
    positionals given a readable file; ``extra``: its required options)."""
    cmd = f"import {layout}"

    def argv(w, t, bad=None, which=None, out=None, map_=None):
        files_ = [bad if p == which else w["solution"] for p in positionals]
        return ["import", layout, *files_, *extra, "-o", out or t / "out" / "i.npz",
                *(["--map", map_] if map_ else [])]

    out = []
    for p in positionals:
        out += files(cmd, p, "in", lambda w, t, x, p=p: argv(w, t, bad=x, which=p))
    out += files(cmd, "--output", "out", lambda w, t, x: argv(w, t, out=x),
                 skip=("is-the-trace",))
    out += files(cmd, "--map", "in", lambda w, t, x: argv(w, t, map_=x))
    return out


def _nb(w, t, p):
    return ["notebook", p]


T = "trace"
CASES: list[Case] = [
    # ---------------------------------------------------------------- trace readers
    *files("inspect", T, "in", lambda w, t, p: ["inspect", p]),
    *files("render", T, "in", lambda w, t, p: ["render", p, "-o", t / "out" / "r.png"]),
    *files("render", "--output", "out", lambda w, t, p: ["render", w["trace"], "-o", p]),
    *files("evaluate", T, "in", lambda w, t, p: ["evaluate", p, w["solution"]]),
    *files("evaluate", "solution", "in", lambda w, t, p: ["evaluate", w["trace"], p]),
    *files("evaluate", "--model", "in", lambda w, t, p: ["evaluate", w["trace"], w["solution"],
                                                         "--model", p, "--novel", w["novel"]]),
    *files("evaluate", "--novel", "in", lambda w, t, p: ["evaluate", w["trace"], w["solution"],
                                                         "--model", w["model"], "--novel", p]),
    Case("evaluate", "queries-huge", lambda w, t: ["evaluate", w["trace"], w["solution"], "-Q",
                                                   "1000000000"], must=("--queries", "cap")),
    Case("evaluate", "consistency-without-paper",
         lambda w, t: ["evaluate", w["trace"], w["solution"], "--consistency", "all"],
         must=("--consistency",)),
    *files("distances", T, "in", lambda w, t, p: ["distances", p, "--quiet", "--no-cache"]),
    *files("distances", "--weights", "in", lambda w, t, p: ["distances", w["trace"], "--attention",
                                                            "dinov2", "--weights", p]),
    Case("distances", "cache-dir-a-file", lambda w, t: ["distances", w["trace"], "--cache-dir",
                                                        w["solution"]],
         ("--cache-dir",), ("--cache-dir",)),
    *files("show-attention", T, "in", lambda w, t, p: ["show-attention", p, "-o",
                                                       t / "out" / "a.png"]),
    *files("show-attention", "--output", "out", lambda w, t, p: ["show-attention", w["trace"],
                                                                 "-o", p]),
    *files("show-attention", "--weights", "in",
           lambda w, t, p: ["show-attention", w["trace"], "-o", t / "out" / "a.png",
                            "--attention", "dinov2", "--weights", p]),
    Case("show-attention", "indices-thousands",
         lambda w, t: ["show-attention", w["trace"], "-o", t / "out" / "a.png", "-i",
                       ",".join(["1"] * 5000)], must=("--indices", "cap of 64")),
    Case("show-attention", "indices-huge-integer",
         lambda w, t: ["show-attention", w["trace"], "-o", t / "out" / "a.png", "-i",
                       "9" * 5000], must=("--indices",)),
    # ---------------------------------------------------------------- learners
    *files("solve", T, "in", lambda w, t, p: ["solve", p, "-o", t / "out" / "s.json", "--quiet"]),
    *files("solve", "--output", "out", lambda w, t, p: ["solve", w["trace"], "-o", p, "--quiet"]),
    *files("solve", "--plot", "out", lambda w, t, p: ["solve", w["trace"], "-o",
                                                      t / "out" / "s.json", "--plot", p]),
    *files("solve", "--hint", "in", lambda w, t, p: ["solve", w["trace"], "-o",
                                                     t / "out" / "s.json", "--solver", "cpsat",
                                                     "--hint", p]),
    *files("solve", "--weights", "in", lambda w, t, p: ["solve", w["trace"], "-o",
                                                        t / "out" / "s.json", "--weights", p]),
    Case("solve", "cache-dir-a-file", lambda w, t: ["solve", w["trace"], "-o",
                                                    t / "out" / "s.json", "--cache-dir",
                                                    w["solution"]],
         ("--cache-dir",), ("--cache-dir",)),
    *[Case(cmd, f"{opt.lstrip('-')}-{value}", lambda w, t, cmd=cmd, opt=opt, value=value: [
        cmd, w["trace"], *(["-o", t / "out" / "s.json", "--solver", "greedy"]
                           if cmd == "solve" else []), f"{opt}={value}", "--quiet"],
        must=(opt,))
      for cmd in ("solve", "compare", "distances")
      for opt, value in (("--tau", "nan"), ("--tau", "inf"), ("--k-pick", "1:100000000"),
                         ("--eps", "inf"), ("--eps", "nan"), ("--sinkhorn-tol", "inf"),
                         ("--sinkhorn-threads", "100000"), ("--floor", "nan"))
      if cmd != "distances" or opt not in ("--tau", "--k-pick")],
    *[Case(cmd, f"{opt.lstrip('-')}-{value}", lambda w, t, argv=argv: argv(w, t),
           must=(opt,))
      for cmd, opt, value, argv in (
          ("evaluate", "--seed", "-1", lambda w, t: ["evaluate", w["trace"], w["solution"],
                                                     "--seed=-1"]),
          ("generate", "--seed", "-1", lambda w, t: ["generate", "fruit-2x3", "-o",
                                                     t / "out" / "g.npz", "--seed=-1"]),
          ("train-localizer", "--seed", "-5", lambda w, t: [
              "train-localizer", w["trace"], w["solution"], "-o", t / "out" / "m.pt",
              "--seed=-5"]),
          ("robustness", "--queries", "1e11", lambda w, t: [
              "robustness", "--out", t / "out" / "r", "-Q", "100000000000"]),
          ("bench distance", "--pairs", "-1", lambda w, t: ["bench", "distance", "--pairs=-1"]),
          ("bench solve", "--limit", "nan", lambda w, t: ["bench", "solve", "--limit=nan"]),
          ("bench solve", "--repeats", "0", lambda w, t: ["bench", "solve", "--repeats=0"]),
          ("bench sweep", "--transitions", "1e9", lambda w, t: [
              "bench", "sweep", "--transitions", "1000000000"]),
          ("benchmark", "--novel", "1e8", lambda w, t: [
              "benchmark", "--out", t / "out" / "b", "--i2p", "greedy", "--novel",
              "100000000"]),
          ("solve", "--jobs", "5000", lambda w, t: ["solve", w["trace"], "-o",
                                                    t / "out" / "s.json", "--jobs", "5000"]))],
    *files("compare", T, "in", lambda w, t, p: ["compare", p, "--quiet"]),
    *files("compare", "--csv", "out", lambda w, t, p: ["compare", w["trace"], "--csv", p]),
    *files("compare", "--plot", "out", lambda w, t, p: ["compare", w["trace"], "--plot", p]),
    *files("compare", "--hint", "in", lambda w, t, p: ["compare", w["trace"], "--hint", p]),
    *files("compare", "--weights", "in", lambda w, t, p: ["compare", w["trace"], "--weights", p]),
    Case("compare", "cache-dir-a-file", lambda w, t: ["compare", w["trace"], "--cache-dir",
                                                      w["solution"]],
         ("--cache-dir",), ("--cache-dir",)),
    *files("baseline", T, "in", lambda w, t, p: ["baseline", "pca-hdbscan", p, "-o",
                                                 t / "out" / "b.json"]),
    *files("baseline", "--output", "out", lambda w, t, p: ["baseline", "pca-hdbscan",
                                                           w["trace"], "-o", p]),
    # ---------------------------------------------------------------- planning, localizer
    *files("plan", "solution", "in", lambda w, t, p: ["plan", p, "--start-obs", "0",
                                                      "--goal-obs", "1"]),
    *files("plan", "--model", "in", lambda w, t, p: ["plan", w["solution"], "--model", p,
                                                     "--start", w["image"], "--goal", w["image"]]),
    *files("plan", "--start", "in", lambda w, t, p: ["plan", w["solution"], "--model", w["model"],
                                                     "--start", p, "--goal", w["image"]]),
    *files("plan", "--goal", "in", lambda w, t, p: ["plan", w["solution"], "--model", w["model"],
                                                    "--start", w["image"], "--goal", p]),
    Case("plan", "edge-to-unknown-node", lambda w, t: ["plan", w["unknown_node"], "--start-obs",
                                                       "0", "--goal-obs", "1"],
         must=("unknown_node.json", "edges[", "node without observations")),
    *files("train-localizer", T, "in", lambda w, t, p: ["train-localizer", p, w["solution"], "-o",
                                                        t / "out" / "m.pt"]),
    *files("train-localizer", "solution", "in",
           lambda w, t, p: ["train-localizer", w["trace"], p, "-o", t / "out" / "m.pt"]),
    *files("train-localizer", "--output", "out",
           lambda w, t, p: ["train-localizer", w["trace"], w["solution"], "-o", p]),
    *files("train-localizer", "--weights", "in",
           lambda w, t, p: ["train-localizer", w["trace"], w["solution"], "-o",
                            t / "out" / "m.pt", "--backbone", "dinov2", "--weights", p]),
    *[Case("train-localizer", f"{opt.lstrip('-')}-{value}",
           lambda w, t, opt=opt, value=value: ["train-localizer", w["trace"], w["solution"],
                                               "-o", t / "out" / "m.pt", f"{opt}={value}"],
           must=(opt,))
      for opt, value in (("--lr", "nan"), ("--lr", "inf"), ("--lr", "-1"), ("--gamma", "nan"),
                         ("--gamma", "-inf"), ("--gamma", "0"), ("--folds", "1000"),
                         ("--folds", "10"), ("--folds", "1"), ("--input-size", "100000"),
                         ("--input-size", "1"), ("--epochs", "1000000000"),
                         ("--epochs", ",".join(["1"] * 200)), ("--threads", "0"))],
    *files("demo", "--output", "out", lambda w, t, p: ["demo", "-o", p], skip=("is-the-trace",)),
    *files("demo", "--workdir", "dir", lambda w, t, p: ["demo", "--workdir", p]),
    # ---------------------------------------------------------------- simulator
    *files("generate", "--output", "out", lambda w, t, p: ["generate", "fruit-2x3", "-o", p,
                                                           "--transitions", "2"],
           skip=("is-the-trace",)),
    Case("generate", "transitions-huge", lambda w, t: ["generate", "fruit-2x3", "-o",
                                                       t / "out" / "g.npz", "--transitions",
                                                       "1000000000"],
         must=("--transitions", "VGGC_CP_MAX_FRAME_BYTES")),
    Case("generate", "size-huge", lambda w, t: ["generate", "fruit-2x3", "-o",
                                                t / "out" / "g.npz", "--size", "100000"],
         must=("--size", "VGGC_CP_MAX_PIXELS")),
    Case("envs", "cap-not-a-number", lambda w, t: ["envs"], env={"VGGC_CP_MAX_BYTES": "inf"},
         must=("VGGC_CP_MAX_BYTES",)),
    # ---------------------------------------------------------------- bench
    *files("bench evaluate", "--trace", "in", lambda w, t, p: ["bench", "evaluate", "--trace", p]),
    *files("bench distance", "--trace", "in", lambda w, t, p: ["bench", "distance", "--trace", p]),
    *files("bench solve", "--trace", "in", lambda w, t, p: ["bench", "solve", "--trace", p]),
    Case("bench sweep", "cache-dir-a-file", lambda w, t: ["bench", "sweep", "--cache-dir",
                                                          w["solution"]],
         ("--cache-dir",), ("--cache-dir",)),
    Case("bench generate", "transitions-huge", lambda w, t: ["bench", "generate", "--transitions",
                                                             "1000000000"],
         must=("--transitions", "VGGC_CP_MAX_BYTES")),
    # ---------------------------------------------------------------- studies
    *files("benchmark", "--out", "dir", lambda w, t, p: ["benchmark", "--out", p]),
    Case("benchmark", "seeds-many", lambda w, t: ["benchmark", "--out", t / "out" / "b",
                                                  "--seeds", ",".join(map(str, range(20000)))],
         must=("--seeds", "cap")),
    *files("calibration", "tables", "in", lambda w, t, p: ["calibration", p]),
    *files("calibration", "--output", "out",
           lambda w, t, p: ["calibration", w["solution"], "-o", p], skip=("is-the-trace",)),
    *files("calibration", "--png", "out",
           lambda w, t, p: ["calibration", w["solution"], "--png", p], skip=("is-the-trace",)),
    Case("calibration", "output-is-the-table",
         lambda w, t: ["calibration", w["solution"], "-o", w["solution"]], ("--output",),
         ("same file",)),
    Case("calibration", "not-a-robustness-table", lambda w, t: ["calibration", w["solution"]],
         ("tables",), ("no column",)),
    Case("settle", "out-dir-missing", lambda w, t: ["settle", t / "nope"], ("out_dir",),
         ("robustness.csv", "no such file")),
    Case("settle", "out-dir-is-a-file", lambda w, t: ["settle", w["solution"]], ("out_dir",),
         ("robustness.csv", "no such file")),
    Case("settle", "only-not-column-value",
         lambda w, t: ["settle", _settle_study(t), "--only", "look"], ("--only",),
         ("--only", "COLUMN=VALUE")),
    Case("settle", "only-unknown-column",
         lambda w, t: ["settle", _settle_study(t), "--only", "colour=red"], ("--only",),
         ("--only", "no column")),
    *files("settle", "--output", "out",
           lambda w, t, p: ["settle", _settle_study(t), "-o", p], skip=("is-the-trace",)),
    Case("settle", "output-is-a-csv",
         lambda w, t: ["settle", _settle_study(t), "-o", t / "out" / "s.csv"], ("--output",),
         ("-o names the markdown report",)),
    *files("robustness", "--out", "dir", lambda w, t, p: ["robustness", "--out", p]),
    *[Case("robustness", f"out-{sub.replace('/', '-')}-{what}",
           lambda w, t, sub=sub, what=what: ["robustness", "--out", _study(t, sub, what)],
           ("--out",), (sub.split("/")[0],))
      for sub, what in (("cells/fruit-2x3-clean-s0.json", "dir"), ("robustness.csv", "dir"),
                        ("robustness.md", "dir"), ("traces/fruit-2x3-clean-d10-s0.npz", "dir"),
                        ("solutions", "file"), ("cells", "file"), ("cells/x.json", "fifo"))],
    Case("robustness", "seeds-huge-range", lambda w, t: ["robustness", "--out", t / "out" / "r",
                                                         "--seeds", "0:100000000"],
         must=("--seeds", "cap of 10,000")),
    Case("robustness", "seeds-negative", lambda w, t: ["robustness", "--out", t / "out" / "r",
                                                       "--seeds", "0,-1"], must=("--seeds",)),
    Case("robustness", "transitions-huge", lambda w, t: ["robustness", "--out", t / "out" / "r",
                                                         "--benchmarks", "fruit-2x3",
                                                         "--transitions", "1000000000"],
         must=("--transitions", "VGGC_CP_MAX_BYTES")),
    # ---------------------------------------------------------------- notebook
    *files("notebook", "notebook", "in", _nb),
    *files("notebook", "--output", "out", lambda w, t, p: ["notebook", w["notebook"], "-o", p],
           skip=("is-the-trace",)),
    Case("notebook", "output-is-the-input", lambda w, t: ["notebook", w["notebook"], "-o",
                                                          w["notebook"], "-p", "x=5"],
         ("--output",), ("same file",)),
    *[Case("notebook", f"file-{name}", lambda w, t, name=name: ["notebook", w[f"nb_{name}"]],
           must=(f"nb_{name}",))
      for name in ("random", "empty-object", "nbformat-99", "deep", "no-cells", "list")],
    *[Case("notebook", f"param-{name}", lambda w, t, value=value: ["notebook", w["notebook"],
                                                                   "-p", value],
           must=("--param",))
      for name, value in (("minus-signs", "x=" + "-" * 100_000 + "1"), ("bytes", "x=b'\\xff'"),
                          ("inf", "x=1e999"), ("nan-in-list", "x=[1e999]"),
                          ("complex", "x=1j"), ("set", "x={1}"), ("no-equals", "x"),
                          ("escape", "x=\x1b[31m"))],
    *[Case("notebook", f"timeout-{v}", lambda w, t, v=v: ["notebook", w["notebook"],
                                                          "--timeout", v],
           must=("--timeout",))
      for v in ("0", "-1", "100000000")],
    # ---------------------------------------------------------------- schedulers
    *[Case(cmd, f"scheduler-{i}", lambda w, t, cmd=cmd, value=value: [
        cmd, w["trace"],
        *(["-o", t / "out" / "s.json", "--solver", "greedy"] if cmd == "solve" else []),
        "--backend", "dask", "--scheduler", value, "--quiet"], must=("--scheduler",))
      for cmd in ("compare", "solve", "distances")
      for i, value in enumerate(("garbage!!", "tcp://[::1", "http://", "udp://x:1", "://",
                                 "inproc://x", "tcp://h:0", "tcp://h:99999", "tcp://a b:1",
                                 "tcp://h:1/path", "x" * 400))],
]


# ---------------------------------------------------------------- commands of other branches
# (show, report, export, import, generate --task, bench startup): run where the checkout has
# them, skipped elsewhere
OUT = lambda t, name: t / "out" / name  # noqa: E731
CASES += [
    *files("show", "solution", "in", lambda w, t, p: ["show", p, w["trace"], "-o",
                                                      OUT(t, "g.png")]),
    *files("show", T, "in", lambda w, t, p: ["show", w["solution"], p, "-o", OUT(t, "g.png")]),
    *files("show", "--output", "out", lambda w, t, p: ["show", w["solution"], w["trace"],
                                                       "-o", p]),
    *files("doubts", "solution", "in", lambda w, t, p: ["doubts", p, w["trace"], "-o",
                                                        OUT(t, "d.png")]),
    *files("doubts", T, "in", lambda w, t, p: ["doubts", w["solution"], p, "-o",
                                               OUT(t, "d.png")]),
    *files("doubts", "--output", "out", lambda w, t, p: ["doubts", w["solution"], w["trace"],
                                                         "-o", p]),
    *files("suggest", "solution", "in", lambda w, t, p: ["suggest", p, w["trace"], "-o",
                                                         OUT(t, "n.json")]),
    *files("suggest", T, "in", lambda w, t, p: ["suggest", w["solution"], p, "-o",
                                                OUT(t, "n.json")]),
    *files("suggest", "--output", "out", lambda w, t, p: ["suggest", w["solution"], w["trace"],
                                                          "-o", p]),
    *files("generate", "--episodes", "in", lambda w, t, p: ["generate", "--episodes", p,
                                                            "--append", w["trace"], "-o",
                                                            OUT(t, "a.npz")]),
    *files("generate", "--append", "in", lambda w, t, p: ["generate", "--episodes",
                                                          w["solution"], "--append", p, "-o",
                                                          OUT(t, "a.npz")]),
    *files("report", "solution", "in", lambda w, t, p: ["report", p, w["trace"], "-o",
                                                        OUT(t, "r.html")]),
    *files("report", T, "in", lambda w, t, p: ["report", w["solution"], p, "-o",
                                               OUT(t, "r.html")]),
    *files("report", "--output", "out", lambda w, t, p: ["report", w["solution"], w["trace"],
                                                         "-o", p]),
    *files("export", "solution", "in", lambda w, t, p: ["export", p, "--to", "dot", "-o",
                                                        OUT(t, "g.dot")]),
    *files("export", "--output", "out", lambda w, t, p: ["export", w["solution"], "--to", "dot",
                                                         "-o", p], skip=("is-the-trace",)),
    Case("export", "output-is-the-solution", lambda w, t: ["export", w["solution"], "--to",
                                                           "dot", "-o", w["solution"]],
         ("--output",), ("same file",)),
    *[c for layout, positionals, extra in (
        ("images", ("log",), ()), ("video", ("video", "log"), ()),
        ("robomimic", ("file",), ("--camera", "c", "--labels", "l")))
      for c in _import_cases(layout, positionals, extra)],
    *[Case("import lerobot", f"folder-{bad}",
           lambda w, t, make=make: ["import", "lerobot", make(w, t), "--camera", "c",
                                    "--labels", "l", "-o", OUT(t, "i.npz")],
           ("folder",), (phrase,))
      for bad, make, phrase in (("missing", lambda w, t: t / "nope", "not a folder"),
                                ("a-file", lambda w, t: w["solution"], "not a folder"),
                                ("no-meta", lambda w, t: t, "meta/info.json"))],
    *files("import lerobot", "--output", "out",
           lambda w, t, p: ["import", "lerobot", t, "--camera", "c", "--labels", "l", "-o", p],
           skip=("is-the-trace",)),
    *files("import lerobot", "--map", "in",
           lambda w, t, p: ["import", "lerobot", t, "--camera", "c", "--labels", "l", "-o",
                            OUT(t, "i.npz"), "--map", p]),
    *files("generate", "--task", "in", lambda w, t, p: ["generate", "--task", f"{p}.json", "-o",
                                                        OUT(t, "g.npz")],
           skip=("directory", "fifo")),
    Case("generate", "task-json-without-spec", lambda w, t: ["generate", "--task",
                                                             w["solution"], "-o",
                                                             OUT(t, "g.npz")],
         ("--task",), ("spec",)),
    Case("bench startup", "limit-nan", lambda w, t: ["bench", "startup", "--limit=nan"],
         must=("--limit",)),
    Case("bench scale", "cache-dir-a-file", lambda w, t: ["bench", "scale", "--cache-dir",
                                                          w["solution"], "--sizes", "20",
                                                          "--camera", "none"],
         ("--cache-dir",), ("--cache-dir",)),
    *files("bench scale", "--csv", "out", lambda w, t, p: ["bench", "scale", "--csv", p,
                                                           "--sizes", "20", "--camera", "none"],
           skip=("is-the-trace",)),
    Case("bench scale", "sizes-not-numbers", lambda w, t: ["bench", "scale", "--sizes", "a,b"],
         must=("--sizes",)),
    Case("solve", "backend-ray-missing", lambda w, t: ["solve", w["trace"], "-o",
                                                       OUT(t, "s.json"), "--backend", "ray",
                                                       "--quiet"],
         ("--backend",), ("ray",)),
]


def _settle_study(t: Path) -> Path:
    """A robustness folder whose table has one passing, quiet row (no case to settle)."""
    root = t / "settle-study"
    root.mkdir(exist_ok=True)
    (root / "robustness.csv").write_text(
        "benchmark,look,seed,split,transitions,true_states,nodes,exec,opt_path,any_path,"
        "passed,suspect\nfruit-2x3,clean,0,tuning,50,6,6,1.0,1.0,1.0,True,False\n")
    return root


def _study(t: Path, sub: str, what: str) -> Path:
    """A robustness folder whose ``sub`` is a directory, a file or a fifo."""
    root = t / "study"
    p = root / sub
    p.parent.mkdir(parents=True, exist_ok=True)
    if what == "dir":
        p.mkdir(exist_ok=True)
    elif what == "file":
        p.write_text("x")
    else:
        _fifo(p.parent, p.name)
    return root


def _env_cases() -> list[Case]:
    caps = ("VGGC_CP_MAX_BYTES", "VGGC_CP_MAX_FRAME_BYTES", "VGGC_CP_MAX_PIXELS", "VGGC_CP_MIN_SIDE",
            "VGGC_CP_MAX_JSON_BYTES", "VGGC_CP_MAX_JSON_DEPTH", "VGGC_CP_STALE_TEMP_MINUTES")
    out = [Case("inspect", f"env-{var}-{i}", lambda w, t: ["inspect", w["trace"]], (),
                (var,), {var: value})
           for var in caps
           for i, value in enumerate(("inf", "1e400", "-inf", "nan", "-1", "0", "1.5", "abc",
                                      "9" * 30, "0x10", "1_0_"))]
    out += [Case("compare", f"env-scheduler-{i}", lambda w, t: [
        "compare", w["trace"], "--backend", "dask", "--quiet"], (), ("$VGGC_CP_SCHEDULER",),
        {"VGGC_CP_SCHEDULER": value})
        for i, value in enumerate(("garbage!!", "tcp://[::1", "http://", "udp://x:1", "://",
                                   "inproc://x", "tcp://h:0"))]
    out += [Case("distances", f"env-dinov2-{bad}",
                 lambda w, t, make=make: ["distances", w["trace"], "--attention", "dinov2",
                                          "--no-cache", "--quiet"],
                 (), ("VGGC_CP_DINOV2_WEIGHTS", phrase),
                 {"VGGC_CP_DINOV2_WEIGHTS": ("@tmp", make)})
            for bad, (make, phrase) in BAD_INPUTS.items()]
    out += [Case("distances", "env-cache-a-file", lambda w, t: ["distances", w["trace"],
                                                                "--quiet", *FAST],
                 (), ("cannot write the distance cache",),
                 {"VGGC_CP_CACHE": ("@tmp", lambda w, t: w["solution"])}, expect="warning")]
    return out


ENV_CASES = _env_cases()
ALL_CASES = CASES + ENV_CASES

#: destinations of options that name files or folders (and any option whose help says so)
FILE_HELP = re.compile(r"\.(npz|json|pt|png|ipynb|csv|jpe?g)\b|\bfile\b|\bfolder\b|"
                       r"\bdirector(y|ies)\b|\bPATH\b", re.I)


def env_variables(package_root: Path) -> set[str]:
    """Every ``VGGC_CP_*`` variable the package's source names."""
    names = set()
    for p in package_root.rglob("*.py"):
        names |= set(re.findall(r"VGGC_CP_[A-Z0-9_]*[A-Z0-9]", p.read_text(encoding="utf-8")))
    return names
