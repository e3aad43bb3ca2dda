"""``vggc-cp bench solve`` and ``vggc-cp bench startup``: each against a baseline, in one run.

``bench startup`` times ``python -m vggc_cp --help`` (and ``plan --help``) against
``python -c pass`` and lists the modules the command loads (``sys.modules`` once it has run):
a command imports what it needs when it runs, so no help imports :data:`HEAVY_MODULES`.

The previous default (before the pipeline) was the paper's saliency attention with batched
Sinkhorn divergences and congruence-closure merging with the ``cascade`` threshold rule; the
current one is :func:`vggc_cp.pipeline.learn_graph`. Both run on the same trace in the same
process, neither reads a distance cache, and the ratio of their wall times is printed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from vggc_cp.pipeline import learn_graph
from vggc_cp.solvers.base import Problem
from vggc_cp.solvers.merge import threshold_path
from vggc_cp.trace import Trace
from vggc_cp.vision.distances import DistanceConfig, compute_distances


@dataclass(frozen=True)
class SolveTiming:
    """Seconds and node counts of both defaults on one trace.

    ``default_seconds`` and ``footprints_seconds`` are the fastest of ``repeats`` runs each.
    """

    default_seconds: float
    default_nodes: int
    default_evidence: str
    default_suspect: bool
    previous_seconds: float
    previous_nodes: int
    footprints_seconds: float = float("nan")
    footprints_nodes: int = 0
    repeats: int = 1

    @property
    def ratio(self) -> float:
        return self.default_seconds / self.previous_seconds

    @property
    def footprints_ratio(self) -> float:
        """The default's time over the footprint evidence's alone (``--evidence footprints``):
        what the default's fallback costs beyond it."""
        return self.default_seconds / self.footprints_seconds


def time_previous_default(trace: Trace, threads: int | None = None) -> tuple[float, int]:
    """Seconds and nodes of saliency Sinkhorn distances (uncached) + merge with ``cascade``."""
    t0 = time.perf_counter()
    cfg = DistanceConfig(use_cache=False, threads=threads)
    dp, dq = compute_distances(trace, cfg, progress=False)
    path = threshold_path(Problem.from_trace(trace, dp, dq), None, "cascade")
    return time.perf_counter() - t0, path.best.n_nodes


def bench_solve(trace: Trace, threads: int | None = None, repeats: int = 3) -> SolveTiming:
    """Time the current default (:func:`learn_graph`, its keypoint fallback uncached where it
    runs), the footprint evidence alone and the previous default on ``trace``.

    The default and the footprint evidence alone run ``repeats`` times each, alternately, and
    each keeps its fastest run (as ``bench startup`` and ``bench scale`` do): one run of a few
    seconds on a shared machine varies by a fifth, which their ratio would inherit. The
    previous default, tens of times slower, runs once.
    """
    from dataclasses import replace

    from vggc_cp.learned import LearnConfig

    if repeats < 1:
        raise ValueError(f"repeats must be at least 1, got {repeats}")
    options = LearnConfig()
    options = replace(options, distance=replace(options.distance, use_cache=False,
                                                threads=threads))
    seconds = fp_seconds = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        learned = learn_graph(trace, options)
        seconds = min(seconds, time.perf_counter() - t0)
        t0 = time.perf_counter()
        alone = learn_graph(trace, replace(options, evidence="footprints"))
        fp_seconds = min(fp_seconds, time.perf_counter() - t0)
    prev_s, prev_n = time_previous_default(trace, threads)
    return SolveTiming(seconds, learned.graph.n_nodes, learned.chosen.evidence,
                       learned.confidence.suspect, prev_s, prev_n, fp_seconds,
                       alone.graph.n_nodes, repeats)


# ---------------------------------------------------------------- bench startup

#: Packages that building the command line must not import: each command imports the ones it
#: needs when it runs, so ``vggc-cp --help`` and every sub-command's ``--help`` start fast.
HEAVY_MODULES = ("torch", "ortools", "pybullet", "matplotlib", "pandas", "ot", "scipy",
                 "sklearn", "dask", "pyarrow", "h5py", "av")
#: The commands ``bench startup`` times.
STARTUP_COMMANDS = (("--help",), ("plan", "--help"))


@dataclass(frozen=True)
class StartupTiming:
    """One command's start: the fastest wall time, the interpreter's, and what it imported.

    Attributes
    ----------
    argv : tuple of str
        Arguments of ``python -m vggc_cp``.
    seconds : float
        Fastest wall-clock seconds of the command over the repeats.
    cpu_seconds : float
        CPU seconds (user + system) of that command's fastest run: near its wall time on an
        idle machine, and unlike it not stretched by other processes.
    baseline_seconds : float
        Fastest wall-clock seconds of ``python -c pass``, measured in the same run.
    modules : int
        Modules the command imports (the interpreter's own start-up included).
    heavy : tuple of str
        The :data:`HEAVY_MODULES` among them (should be empty).
    """

    argv: tuple[str, ...]
    seconds: float
    cpu_seconds: float
    baseline_seconds: float
    modules: int
    heavy: tuple[str, ...]

    @property
    def ratio(self) -> float:
        return self.seconds / self.baseline_seconds


def run_python(args: list[str]) -> subprocess.CompletedProcess:
    """Run this interpreter on ``args`` with this checkout's package first on the path."""
    root = str(Path(__file__).resolve().parents[2])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [root, *filter(None, [os.environ.get("PYTHONPATH")])]))
    return subprocess.run([sys.executable, *args], cwd=root, env=env, capture_output=True,
                          text=True, check=False)


#: Runs the command line on ``sys.argv[1:]`` and prints the modules loaded, as the last line.
_MODULES_AFTER = """
import json, sys
from vggc_cp.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print("\\n" + json.dumps(sorted(sys.modules)))
"""


def imported_modules(argv: tuple[str, ...]) -> list[str]:
    """The modules loaded once ``vggc-cp *argv`` has run in a fresh interpreter (sorted; the
    interpreter's own start-up included)."""
    res = run_python(["-c", _MODULES_AFTER, *argv])
    lines = res.stdout.strip().splitlines()
    if res.returncode != 0 or not lines:
        raise RuntimeError(f"vggc-cp {' '.join(argv)} failed: {res.stderr.strip()[-400:]}")
    return json.loads(lines[-1])


def heavy_among(modules) -> tuple[str, ...]:
    """The :data:`HEAVY_MODULES` whose package is among ``modules``, sorted."""
    tops = {m.split(".")[0] for m in modules}
    return tuple(sorted(tops & set(HEAVY_MODULES)))


def _children_cpu() -> float:
    import resource

    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _fastest(args: list[str], repeats: int) -> tuple[float, float]:
    """Wall and CPU seconds of the fastest of ``repeats`` runs of ``python *args``."""
    best = (float("inf"), float("inf"))
    for _ in range(max(1, repeats)):
        c0, t0 = _children_cpu(), time.perf_counter()
        run_python(args)
        best = min(best, (time.perf_counter() - t0, _children_cpu() - c0))
    return best


def time_startup(argv: tuple[str, ...], repeats: int = 5) -> StartupTiming:
    """Time ``python -m vggc_cp *argv`` against ``python -c pass`` (the fastest of
    ``repeats`` runs each, interleaved in one run) and list its imports."""
    seconds, cpu = _fastest(["-m", "vggc_cp", *argv], repeats)
    base, _ = _fastest(["-c", "pass"], repeats)
    modules = imported_modules(argv)
    return StartupTiming(tuple(argv), seconds, cpu, base, len(modules), heavy_among(modules))
