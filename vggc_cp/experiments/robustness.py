"""The robustness study: the default ``vggc-cp solve`` on every benchmark, seed and look.

One **cell** per (benchmark, look, seed):

1. the trace, generated once by :func:`vggc_cp.sim.explore.generate` at the paper's |D| (or
   ``transitions``) and cached at ``OUT/traces/<bench>-<look>-d<D>-s<seed>.npz`` (with the novel
   renders of the I2P phase beside it, ``...novel<K>.npz``);
2. :func:`vggc_cp.pipeline.learn_graph` with its defaults (what ``vggc-cp solve trace.npz`` runs),
   on the trace without its ground-truth states;
3. :func:`vggc_cp.evaluate.evaluate_trace` with Q queries (Exec on the simulator's dynamics);
4. optionally (``i2p`` and the seed among ``i2p_seeds``): a localizer trained on the learned
   labels and localization / I2P / Exec-I2P on fresh renders
   (:func:`vggc_cp.evaluate.i2p.evaluate_localizer`);
5. the row, cached atomically as ``OUT/cells/<bench>-<look>-s<seed>.json`` with the settings it
   was made under (the key). A rerun with the same settings reuses it (the study resumes where it
   stopped); a changed setting -- or changed pipeline code -- recomputes it.

Besides the seven benchmarks the study runs **tasks beyond them** (``random-S``, drawn by
:func:`vggc_cp.sim.tasks.draw_task`; ``tasks``): the default draws ten tuning tasks (task
seeds ``0-9``) and twenty held-out tasks (task seeds ``100-119``) at trace seed 0.

The **held-out** split holds every cell whose trace seed is ``>= HELDOUT_FROM_SEED`` (or in
``heldout_seeds``) and every cell of a task drawn from a task seed ``>= HELDOUT_TASK_FROM``:
tasks and seeds never looked at while the method was chosen. Keep them out of any tuning and
read their table separately. :func:`passes` is the acceptance rule of a run,
:func:`calibration` counts how the ground-truth-free warning (``Confidence.suspect``) matched it,
and :func:`vggc_cp.experiments.robustness_tables.write_tables` writes ``robustness.csv`` and
``robustness.md``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from vggc_cp.atomic import write_text
from vggc_cp.errors import VggcError, lookup
from vggc_cp.evaluate.metrics import MIN_EXEC
from vggc_cp.experiments.cells import file_sha256, read_cell
from vggc_cp.experiments.table1 import (
    BACKENDS,
    _cached,
    _spread,
    exploration_of,
    split_cached,
    trace_is_current,
)
from vggc_cp.sim import benchmark_names, get_spec
from vggc_cp.sim.looks import LOOKS
from vggc_cp.solution import jsonable

CELL_FORMAT = "vggc-robustness-cell/1"
#: The acceptance rule of one run (fractions; nodes as a multiple of |V*|); the Exec bar is
#: :data:`vggc_cp.evaluate.metrics.MIN_EXEC`.
NODES_LOW = 0.9
NODES_HIGH = 1.1
MIN_OPT_PATH = 0.95
MIN_ANY_PATH = 1.0
MIN_I2P = 0.90
#: Slack of every comparison of :func:`failures` (floating-point rates).
TOLERANCE = 1e-9
#: Seeds from this one on are the held-out split by default.
HELDOUT_FROM_SEED = 3
#: Tasks drawn from task seeds from this one on are held out (whatever the trace seed).
HELDOUT_TASK_FROM = 100
#: The random tasks of the default study (task seeds): ten for tuning, twenty held out.
DEFAULT_TASKS = tuple(range(10)) + tuple(range(HELDOUT_TASK_FROM, HELDOUT_TASK_FROM + 20))
#: Trace seeds of the random tasks in the default study.
DEFAULT_TASK_SEEDS = (0,)
TUNING, HELDOUT = "tuning", "held-out"
SPLITS = (TUNING, HELDOUT)
CLEAN, RANDOMIZED, ROBOT = "clean", "randomized", "robot"
DEFAULT_SEEDS = (0, 1, 2, 3, 4)
#: Runs with fewer observations per true state than this are marked sparse in the tables.
MIN_OBS_PER_STATE = 2.0
#: Modules and packages whose source is part of a cell's key (changed code recomputes the
#: cells); a package stands for every module under it, so a module split out of another, or
#: a new one, is covered without being listed.
CODE_MODULES = ("vggc_cp.pipeline", "vggc_cp.learned", "vggc_cp.trace", "vggc_cp.solvers",
                "vggc_cp.vision", "vggc_cp.evaluate.metrics")
#: Columns of ``robustness.csv``, in order (measured I2P columns follow when present).
ROW_FIELDS = ("benchmark", "family", "look", "seed", "split", "transitions", "observations",
              "true_states", "nodes", "nodes_ratio", "exec", "opt_path", "any_path",
              "trans_prec", "trans_cov", "passed", "evidence", "threshold", "suspect", "reasons",
              "p_change", "runs", "changed", "doubts", "margin", "plateau",
              "heldout_predicted", "heldout_contradicted", "obs_per_node", "obs_per_state",
              "seconds_learn", "seconds_evaluate", "dynamics")
I2P_FIELDS = ("localization", "i2p", "exec_i2p", "seconds_localizer")


def suite_looks() -> tuple[str, ...]:
    """The looks of the default study, those this checkout's renderer has: clean, randomized
    and robot (``armless``, the robot look with its arm hidden, is an ablation asked for by
    name)."""
    return tuple(look for look in (CLEAN, RANDOMIZED, ROBOT) if look in looks_available())


def looks_available() -> tuple[str, ...]:
    """The looks this checkout's renderer knows (:data:`vggc_cp.sim.looks.LOOKS`)."""
    return tuple(LOOKS)


# ---------------------------------------------------------------- configuration


@dataclass(frozen=True)
class RobustnessConfig:
    """One robustness study.

    Attributes
    ----------
    out : Path
        Folder of traces, cached cells, solutions, localizers and tables.
    benchmarks : tuple of str
        Task names :func:`vggc_cp.sim.get_spec` takes (default the seven benchmarks).
    seeds : tuple of int
        Trace seeds of ``benchmarks`` (default 0..4).
    looks : tuple of str
        Looks of :func:`vggc_cp.sim.explore.generate` (default clean and randomized).
    transitions : int or None
        |D| of every trace; the paper's per benchmark when None.
    size : int
        Image side in pixels.
    n_queries : int
        Q of the evaluation.
    jobs : int
        Worker processes (cells in parallel).
    heldout_seeds : tuple of int or None
        Seeds of the held-out split; None: every seed ``>= HELDOUT_FROM_SEED``.
    i2p : bool
        Also train a localizer and measure localization / I2P / Exec-I2P on the cells whose seed
        is in ``i2p_seeds``.
    i2p_seeds : tuple of int
    novel : int
        Fresh renders per trace for the I2P phase.
    i2p_queries : int
        Start/goal image pairs of the I2P phase (the paper's 150).
    force : bool
        Recompute cached cells.
    backend, scheduler : str, str or None
        Parallel backend as in :class:`vggc_cp.evaluate.benchmark.BenchmarkConfig`.
    tasks : tuple of int
        Task seeds of random tasks ``random-S`` run besides ``benchmarks`` (default
        :data:`DEFAULT_TASKS`; empty: none).
    task_seeds : tuple of int
        Trace seeds of the random tasks (default :data:`DEFAULT_TASK_SEEDS`).
    """

    out: Path
    benchmarks: tuple[str, ...] = field(default_factory=lambda: tuple(benchmark_names()))
    seeds: tuple[int, ...] = DEFAULT_SEEDS
    looks: tuple[str, ...] = field(default_factory=lambda: suite_looks())
    transitions: int | None = None
    size: int = 64
    n_queries: int = 1500
    jobs: int = 1
    heldout_seeds: tuple[int, ...] | None = None
    i2p: bool = False
    i2p_seeds: tuple[int, ...] = (0,)
    novel: int = 150
    i2p_queries: int = 150
    force: bool = False
    backend: str = "local"
    scheduler: str | None = None
    tasks: tuple[int, ...] = DEFAULT_TASKS
    task_seeds: tuple[int, ...] = DEFAULT_TASK_SEEDS

    def __post_init__(self) -> None:
        for b in self.benchmarks:
            get_spec(b)
        if not (self.benchmarks or self.tasks) or not self.seeds or not self.looks:
            raise VggcError("robustness needs at least one benchmark or task, seed and look")
        for opt, seeds in (("--seeds", self.seeds), ("--tasks", self.tasks),
                           ("--task-seeds", self.task_seeds)):
            if len(set(seeds)) != len(seeds) or any(s < 0 for s in seeds):
                raise VggcError(f"{opt} must be distinct non-negative integers, got "
                                f"{list(seeds)}")
        if self.tasks and not self.task_seeds:
            raise VggcError("--task-seeds: random tasks need at least one trace seed")
        known = looks_available()
        for look in self.looks:
            if look not in known:
                hint = ("" if look not in (CLEAN, RANDOMIZED, ROBOT) else
                        " (this checkout's renderer has no such look yet)")
                raise VggcError(f"unknown look {look!r}; known: {', '.join(known)}{hint}")
        if self.jobs < 1:
            raise VggcError(f"--jobs must be at least 1, got {self.jobs}")
        if self.n_queries < 1:
            raise VggcError(f"--queries must be positive, got {self.n_queries}")
        if self.transitions is not None and self.transitions < 1:
            raise VggcError(f"--transitions must be at least 1, got {self.transitions}")
        if self.i2p and (self.novel < 2 or self.i2p_queries < 1):
            raise VggcError(f"--novel must be at least 2 and --i2p-queries positive, got "
                            f"{self.novel} and {self.i2p_queries}")
        lookup({b: b for b in BACKENDS}, self.backend, "backend")

    def n_transitions(self, benchmark: str) -> int:
        return self.transitions or get_spec(benchmark).default_transitions

    def cells(self) -> list[tuple[str, int]]:
        """Every (task name, trace seed) of the study: the benchmarks at ``seeds``, then the
        random tasks at ``task_seeds``."""
        out = [(b, int(s)) for b in self.benchmarks for s in self.seeds]
        return out + [(f"random-{t}", int(s)) for t in self.tasks for s in self.task_seeds]

    def split(self, seed: int, benchmark: str | None = None) -> str:
        """``tuning`` or ``held-out``: held out by the trace seed, or by the task (a random
        task drawn from a seed ``>= HELDOUT_TASK_FROM``)."""
        if benchmark is not None and task_seed(benchmark) is not None \
                and task_seed(benchmark) >= HELDOUT_TASK_FROM:
            return HELDOUT
        if self.heldout_seeds is not None:
            return HELDOUT if seed in self.heldout_seeds else TUNING
        return HELDOUT if seed >= HELDOUT_FROM_SEED else TUNING

    def trace_path(self, benchmark: str, look: str, seed: int) -> Path:
        d = self.n_transitions(benchmark)
        return Path(self.out) / "traces" / f"{slug(benchmark)}-{look}-d{d}-s{seed}.npz"

    def novel_path(self, benchmark: str, look: str, seed: int) -> Path:
        return self.trace_path(benchmark, look, seed).with_suffix(f".novel{self.novel}.npz")

    def cell_name(self, benchmark: str, look: str, seed: int) -> str:
        return f"{slug(benchmark)}-{look}-s{seed}"


def task_seed(benchmark: str) -> int | None:
    """The task seed of a ``random-S`` name, else None."""
    head, _, tail = benchmark.partition("random-")
    return int(tail) if not head and tail.isdigit() else None


def slug(benchmark: str) -> str:
    """A file-name-safe name of a task: itself, or ``task-<sha256 prefix>`` for a spec
    string (which holds ``:``, ``/`` and ``,``)."""
    if all(c.isalnum() or c in "-_." for c in benchmark):
        return benchmark
    return "task-" + hashlib.sha256(benchmark.encode()).hexdigest()[:12]


@dataclass(frozen=True)
class RobustCell:
    """Everything a worker needs for one (benchmark, look, seed) cell (picklable)."""

    benchmark: str
    look: str
    seed: int
    split: str
    transitions: int
    size: int
    queries: int
    trace_path: Path
    cell_path: Path
    solution_path: Path
    i2p: bool
    novel: int
    novel_path: Path
    model_path: Path
    i2p_queries: int
    threads: int
    key: dict
    i2p_key: dict | None = None


def i2p_key(cfg: RobustnessConfig) -> dict:
    """The settings of a cell's I2P figures (novel renders, queries, localizer training)."""
    from vggc_cp.localize import TrainConfig

    return jsonable({"novel": cfg.novel, "queries": cfg.i2p_queries,
                     "train": TrainConfig().as_dict()})


def code_files() -> list[Path]:
    """The source files of :data:`CODE_MODULES` (read, not imported), sorted within a
    package."""
    root = Path(__file__).parents[1]
    out = []
    for name in CODE_MODULES:
        path = root.joinpath(*name.split(".")[1:])
        out += sorted(path.rglob("*.py")) if path.is_dir() else [path.with_suffix(".py")]
    return out


def code_digest() -> str:
    """SHA-256 (12 hex digits) of the source of :data:`CODE_MODULES`."""
    h = hashlib.sha256()
    root = Path(__file__).parents[1]
    for path in code_files():
        h.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:12]


def learn_key() -> dict:
    """The default :class:`vggc_cp.learned.LearnConfig` as JSON values (part of a cell's key)."""
    from vggc_cp.learned import LearnConfig

    opts = LearnConfig()
    out = {k: v for k, v in asdict(opts).items() if k != "distance"}
    out["distance"] = opts.distance.key()
    return jsonable(out)


def cell_jobs(cfg: RobustnessConfig) -> list[RobustCell]:
    """Every cell of the study, task-major (the benchmarks, then the random tasks), then look,
    then seed."""
    out = Path(cfg.out)
    base = {"format": CELL_FORMAT, "size": cfg.size, "queries": cfg.n_queries,
            "learn": learn_key(), "code": code_digest()}
    threads = max(1, (os.cpu_count() or 1) // max(1, cfg.jobs))
    jobs = []
    by_task: dict[str, list[int]] = {}
    for bench, seed in cfg.cells():
        by_task.setdefault(bench, []).append(seed)
    for bench, seeds in by_task.items():
        d = cfg.n_transitions(bench)
        for look in cfg.looks:
            for seed in seeds:
                measured = bool(cfg.i2p and seed in cfg.i2p_seeds)
                name = cfg.cell_name(bench, look, seed)
                key = base | {"benchmark": bench, "look": look, "seed": int(seed),
                              "transitions": d, "exploration": exploration_of(bench)}
                jobs.append(RobustCell(bench, look, int(seed), cfg.split(seed, bench), d,
                                       cfg.size,
                                       cfg.n_queries, cfg.trace_path(bench, look, seed),
                                       out / "cells" / f"{name}.json",
                                       out / "solutions" / f"{name}.json", measured, cfg.novel,
                                       cfg.novel_path(bench, look, seed),
                                       out / "models" / f"{name}.pt", cfg.i2p_queries, threads,
                                       key, i2p_key(cfg) if measured else None))
    return jobs


def cached_row(job: RobustCell) -> dict | None:
    """The cached row of ``job`` when it was made with the same settings (and, when the cell
    measures I2P, holds I2P figures made with the same I2P settings), else None. A row with
    I2P figures also serves a run that does not measure them."""
    row = read_cell(job.cell_path, job.key, job.trace_path)  # validated, tied to its trace
    if row is None or not job.i2p:
        return row
    return row if _cached(job.cell_path, job.key, "i2p_key") == job.i2p_key else None


# ---------------------------------------------------------------- one cell


def _generate(job: RobustCell, novel: int):
    from vggc_cp.sim.explore import generate

    kwargs = {} if job.look == CLEAN else {"look": job.look}
    return generate(job.benchmark, job.transitions, job.seed, size=job.size, novel=novel,
                    **kwargs)


def _trace_fits(job: RobustCell) -> bool:
    from vggc_cp.trace import load_trace

    if not trace_is_current(job.trace_path, job.benchmark):
        return False
    meta = load_trace(job.trace_path, validate_trace=False).meta or {}
    return (meta.get("look", CLEAN) == job.look and meta.get("transitions") == job.transitions
            and list(meta.get("image_size", [])) == [job.size, job.size])


def ensure_trace(job: RobustCell):
    """The cell's trace, generated (with its novel renders when the cell measures I2P) or read
    from the cache."""
    from vggc_cp.sim.novel import save_novel
    from vggc_cp.trace import load_trace, save_trace

    need_novel = job.i2p and not job.novel_path.is_file()
    if _trace_fits(job):
        trace = load_trace(job.trace_path)
        if need_novel:
            g = _generate(job, job.novel)
            save_novel(job.novel_path, g.novel_observations, g.novel_states)
        return trace
    for stale in job.trace_path.parent.glob(f"{job.trace_path.stem}.novel*.npz"):
        stale.unlink()
    g = _generate(job, job.novel if job.i2p else 0)
    save_trace(g.trace, job.trace_path)
    if job.i2p:
        save_novel(job.novel_path, g.novel_observations, g.novel_states)
    return g.trace


def _finite(x):
    return None if x is None or not math.isfinite(float(x)) else float(x)


def run_cell(job: RobustCell) -> dict:
    """Generate or read the trace, learn with the default pipeline, evaluate, cache the row."""
    import numpy as np

    from vggc_cp.evaluate import evaluate_trace
    from vggc_cp.learned import LearnConfig
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.solution import labels_solution, write_solution

    trace = ensure_trace(job)
    learned = learn_graph(trace.without_states(), LearnConfig(), progress=False)
    t0 = time.perf_counter()
    metrics, dynamics = evaluate_trace(trace, learned.graph, learned.labels,
                                       n_queries=job.queries, seed=0)
    conf = learned.confidence
    held = conf.heldout
    true_states = int(len(np.unique(trace.states)))
    row = {"benchmark": job.benchmark, "family": get_spec(job.benchmark).family,
           "look": job.look, "seed": job.seed, "split": job.split,
           "transitions": trace.n_transitions, "observations": trace.n_obs,
           "true_states": int(metrics.true_states), "nodes": int(metrics.nodes),
           "nodes_ratio": metrics.nodes / max(int(metrics.true_states), 1),
           "exec": metrics.exec, "opt_path": metrics.opt_path, "any_path": metrics.any_path,
           "trans_prec": metrics.trans_prec, "trans_cov": metrics.trans_cov,
           "evidence": learned.chosen.evidence, "threshold": _finite(learned.threshold),
           "suspect": bool(conf.suspect), "reasons": "; ".join(conf.reasons),
           "p_change": conf.p_change, "runs": int(conf.runs), "changed": int(conf.changed),
           "doubts": len(learned.doubts), "margin": _finite(conf.margin), "plateau": int(conf.plateau),
           "heldout_predicted": None if held is None else held.predicted,
           "heldout_contradicted": None if held is None else held.contradicted,
           "obs_per_node": _finite(conf.obs_per_node),
           "obs_per_state": trace.n_obs / max(true_states, 1),
           "seconds_learn": round(learned.seconds, 3), "dynamics": dynamics}
    row["seconds_evaluate"] = round(time.perf_counter() - t0, 3)
    write_solution(job.solution_path,
                   labels_solution(trace, learned.labels, solver="learn_graph",
                                   status="feasible", evidence=learned.chosen.evidence,
                                   threshold=_finite(learned.threshold),
                                   confidence=jsonable(conf.as_dict()),
                                   doubts=jsonable([d.as_dict() for d in learned.doubts])))
    if job.i2p:
        row |= run_i2p(job, trace)
    row = jsonable(row)
    record = ({"key": job.key, "trace_sha256": file_sha256(job.trace_path), "row": row} | ({"i2p_key": job.i2p_key} if job.i2p else {}))
    write_text(job.cell_path, json.dumps(record, indent=1) + "\n")
    return row


def run_i2p(job: RobustCell, trace) -> dict:
    """Train a localizer on the cell's learned labels (its solution file) and measure
    localization, I2P and Exec-I2P on the novel renders."""
    from vggc_cp.evaluate.i2p import train_and_measure

    m, seconds = train_and_measure(trace, job.trace_path, job.solution_path, job.model_path,
                                   job.novel_path, n_queries=job.i2p_queries, seed=job.seed,
                                   threads=job.threads)
    return {"localization": m.localization, "i2p": m.i2p, "exec_i2p": m.exec_i2p,
            "seconds_localizer": round(seconds, 3)}


# ---------------------------------------------------------------- the study


@dataclass(frozen=True)
class RobustnessRun:
    """What :func:`run_robustness` did: the rows (cell order), counts and wall time."""

    rows: list[dict]
    computed: int
    reused: int
    seconds: float


def _with_split(row: dict | None, job) -> dict | None:
    """A cached row with the job's current split (the split is not part of the cache)."""
    return None if row is None else row | {"split": job.split}


def run_robustness(cfg: RobustnessConfig, progress: bool = True) -> RobustnessRun:
    """Run every cell of ``cfg`` that has no cached row made under the same settings."""
    t0 = time.perf_counter()
    jobs = cell_jobs(cfg)
    rows, todo = split_cached(jobs, lambda j: _with_split(cached_row(j), j),
                              lambda j: (j.benchmark, j.look, j.seed), cfg.force)
    for row in _spread(run_cell, todo, cfg, "robustness cells", progress):
        rows[(row["benchmark"], row["look"], row["seed"])] = row
    ordered = [rows[(j.benchmark, j.look, j.seed)] for j in jobs]
    return RobustnessRun(ordered, len(todo), len(jobs) - len(todo), time.perf_counter() - t0)


# ---------------------------------------------------------------- pass rule and calibration


def measured(x) -> bool:
    """Whether a metric was measured (not None, not NaN)."""
    return x is not None and not (isinstance(x, float) and math.isnan(x))


def percent(x) -> str:
    """A share as a percentage with one decimal, ``–`` where not measured."""
    return "–" if not measured(x) else f"{100 * float(x):.1f}"


def failures(row: dict) -> list[str]:
    """Each condition of the pass rule that ``row`` misses, as a short phrase (empty: passed)."""
    out = []
    ex, op, ap = row.get("exec"), row.get("opt_path"), row.get("any_path")
    if not measured(ex) or ex < MIN_EXEC - TOLERANCE:
        out.append(f"Exec {percent(ex)} % < {percent(MIN_EXEC)} %")
    nodes, true = row.get("nodes"), row.get("true_states")
    if (not measured(nodes) or not true or not
            NODES_LOW * true - TOLERANCE <= nodes <= NODES_HIGH * true + TOLERANCE):
        out.append(f"nodes {nodes} / {true} outside [{NODES_LOW}, {NODES_HIGH}] x |V*|")
    if not measured(op) or op < MIN_OPT_PATH - TOLERANCE:
        out.append(f"OptPath {percent(op)} % < {percent(MIN_OPT_PATH)} %")
    if not measured(ap) or ap < MIN_ANY_PATH - TOLERANCE:
        out.append(f"AnyPath {percent(ap)} % < {percent(MIN_ANY_PATH)} %")
    i2p = row.get("i2p")
    if measured(i2p) and i2p < MIN_I2P - TOLERANCE:
        out.append(f"I2P {percent(i2p)} % < {percent(MIN_I2P)} %")
    return out


def passes(row: dict) -> bool:
    """The acceptance rule: Exec >= :data:`MIN_EXEC`, nodes within [:data:`NODES_LOW`,
    :data:`NODES_HIGH`] x |V*|, OptPath >= :data:`MIN_OPT_PATH`, AnyPath >= :data:`MIN_ANY_PATH`
    and, where measured, I2P >= :data:`MIN_I2P` (each with :data:`TOLERANCE`)."""
    return not failures(row)


CALIBRATION = ("passed_quiet", "false_alarm", "caught", "silent")
CALIBRATION_TITLES = {"passed_quiet": "passed & quiet", "false_alarm": "passed & warned "
                      "(false alarm)", "caught": "missed & warned (caught)",
                      "silent": "missed & quiet (silent failure)"}


def calibration(rows: list[dict]) -> dict[str, dict[str, int]]:
    """Per split (and ``all``), how the warning matched the pass rule: counts of
    :data:`CALIBRATION` (``silent`` is the one that must be 0)."""
    out = {s: dict.fromkeys(CALIBRATION, 0) for s in (*SPLITS, "all")}
    for r in rows:
        ok, warned = passes(r), bool(r.get("suspect"))
        kind = ("false_alarm" if warned else "passed_quiet") if ok else \
            ("caught" if warned else "silent")
        for s in (r.get("split", TUNING), "all"):
            out.setdefault(s, dict.fromkeys(CALIBRATION, 0))[kind] += 1
    return out
