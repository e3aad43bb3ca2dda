"""``vggc-cp bench scale``: how the default ``solve`` grows with the trace (issue 27).

Traces of one benchmark (fruit-6x8, seed 5) at growing ``|D|`` are generated once into a
cache folder (generation is timed apart); the default learning (footprint evidence, merge path
on candidate pairs of descriptor codes, selection and confidence) runs on each, stage by
stage, in this process:

* **evidence**: footprints, descriptors and their codes (:func:`vggc_cp.pipeline.evidence_problem`);
* **merge path**: the threshold grid and the merges along it (:func:`vggc_cp.pipeline.merge_path`);
* **confidence**: description lengths and held-out prediction (:func:`vggc_cp.pipeline.assess_path`);
* **trace hash**: the ``trace_sha256`` the solution records (:meth:`vggc_cp.trace.Trace.content_hash`;
  for frames read from the file it is computed beside the stages before, and this one waits
  for what is left of it).

Each stage reports its wall time and the peak resident memory of the process while it ran
(sampled every 10 ms from ``/proc/self/statm``; the process's ``ru_maxrss`` where that file is
missing). The growth exponent is the least-squares slope of ``log(wall)`` on ``log(|D|)``.
"""

from __future__ import annotations

import os
import resource
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vggc_cp.errors import VggcError

#: What ``bench scale`` measures by default.
SIZES = (1500, 3000, 6000, 12000, 20000)
BENCH = "fruit-6x8"
SEED = 5
STAGES = ("evidence", "merge path", "confidence", "trace hash")


@dataclass(frozen=True)
class ScaleConfig:
    """Settings of :func:`run_scale`.

    Attributes
    ----------
    sizes : tuple of int
        ``|D|`` of the traces, ascending.
    bench : str
    seed : int
    cache : Path
        Folder of the generated traces (reused when present).
    image : tuple of int or None
        ``(height, width)`` of the images (None: the generator's default square).
    """

    sizes: tuple[int, ...] = SIZES
    bench: str = BENCH
    seed: int = SEED
    cache: Path = field(default_factory=lambda: Path(".cache") / "vggc-cp" / "bench")
    image: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        if not self.sizes or any(int(n) < 1 for n in self.sizes):
            raise VggcError(f"sizes must be positive transition counts, got {self.sizes}")
        object.__setattr__(self, "sizes", tuple(sorted(int(n) for n in self.sizes)))


@dataclass(frozen=True)
class StageRecord:
    """Wall seconds, CPU seconds of this process and peak resident memory (bytes) of one
    stage (on a shared machine the CPU seconds say what the wall time would be alone)."""

    stage: str
    seconds: float
    peak_bytes: int
    cpu_seconds: float = 0.0


@dataclass(frozen=True)
class SizeRecord:
    """One trace size: its generation and the stages of the default learning."""

    transitions: int
    observations: int
    image: tuple[int, int]
    generate_seconds: float
    stages: tuple[StageRecord, ...]
    nodes: int
    suspect: bool

    @property
    def seconds(self) -> float:
        """Wall seconds of the learning (generation excluded)."""
        return sum(s.seconds for s in self.stages)

    @property
    def cpu_seconds(self) -> float:
        return sum(s.cpu_seconds for s in self.stages)

    @property
    def peak_bytes(self) -> int:
        return max(s.peak_bytes for s in self.stages)


def _rss_bytes() -> int:
    try:
        with open("/proc/self/statm", encoding="ascii") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


class PeakMemory:
    """Context manager: the peak resident memory of this process while it is open, sampled
    every ``interval`` seconds by a thread (attribute ``peak``, bytes)."""

    def __init__(self, interval: float = 0.01):
        self.interval = interval
        self.peak = 0
        self._stop = threading.Event()

    def _run(self) -> None:
        while not self._stop.wait(self.interval):
            self.peak = max(self.peak, _rss_bytes())

    def __enter__(self) -> PeakMemory:
        self.peak = _rss_bytes()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()
        self.peak = max(self.peak, _rss_bytes())


def trace_path(cfg: ScaleConfig, transitions: int) -> Path:
    shape = "" if cfg.image is None else f"-{cfg.image[1]}x{cfg.image[0]}"
    return cfg.cache / f"{cfg.bench}-d{transitions}-s{cfg.seed}{shape}.npz"


def cached_trace(cfg: ScaleConfig, transitions: int) -> tuple[Path, float]:
    """The file of the trace of ``transitions`` (generated and saved on first use) and the
    generation's seconds (0 when it was cached)."""
    from vggc_cp.trace import save_trace

    path = trace_path(cfg, transitions)
    if path.is_file():
        return path, 0.0
    from vggc_cp.sim.explore import generate

    kw = {} if cfg.image is None else {"size": cfg.image}
    t0 = time.perf_counter()
    trace = generate(cfg.bench, transitions, seed=cfg.seed, **kw).trace
    seconds = time.perf_counter() - t0
    path.parent.mkdir(parents=True, exist_ok=True)
    save_trace(trace, path)
    return path, seconds


def measure(path: Path, generate_seconds: float = 0.0) -> SizeRecord:
    """The default learning's stages on the trace file ``path``: loading it (frames above
    ``max_bytes`` stay in the file and are inflated by the evidence, :mod:`vggc_cp.frames`),
    the footprint evidence, the merge path and the confidence (its states unread)."""
    from vggc_cp.learned import FOOTPRINTS, LearnConfig
    from vggc_cp.pipeline import assess_path, evidence_problem, merge_path
    from vggc_cp.trace import load_trace

    options = LearnConfig(evidence=FOOTPRINTS)
    stages = []

    def timed(name, fn):
        with PeakMemory() as mem:
            t0, c0 = time.perf_counter(), time.process_time()
            out = fn()
            seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
        stages.append(StageRecord(name, seconds, mem.peak, cpu))
        return out

    trace = timed("load", lambda: load_trace(path).without_states())
    problem = timed("evidence", lambda: evidence_problem(trace, FOOTPRINTS, options))
    learned = timed("merge path", lambda: merge_path(problem, options))
    _, conf = timed("confidence", lambda: assess_path(trace, problem, learned, options))
    timed("trace hash", trace.content_hash)
    return SizeRecord(trace.n_transitions, trace.n_obs, trace.image_shape, generate_seconds,
                      tuple(stages), learned.best.n_nodes, conf.suspect)


def growth_exponent(sizes, seconds) -> float:
    """Least-squares slope of ``log(seconds)`` on ``log(sizes)`` (nan for fewer than two)."""
    x, y = np.log(np.asarray(sizes, float)), np.log(np.maximum(np.asarray(seconds, float), 1e-9))
    if len(x) < 2:
        return float("nan")
    return float(np.polyfit(x, y, 1)[0])


def run_scale(cfg: ScaleConfig, on_record=None) -> list[SizeRecord]:
    """Measure every size of ``cfg`` (``on_record(record)`` after each)."""
    out = []
    for n in cfg.sizes:
        rec = measure(*cached_trace(cfg, n))
        out.append(rec)
        if on_record is not None:
            on_record(rec)
    return out


def camera_runs(cfg: ScaleConfig, image: tuple[int, int], transitions: int, repeat: int = 3,
                on_record=None) -> tuple[list[SizeRecord], list[SizeRecord]]:
    """The camera comparison: the trace of ``image`` (height, width) at ``transitions`` and
    the trace of the generator's default size at the same ``|D|``, each measured ``repeat``
    times, alternately (the default size first; ``on_record(record)`` after each). The ratio
    to report is of the fastest of each (:func:`fastest`): on a shared machine the slower
    runs measure the other processes too, as :mod:`timeit` says of its repeats."""
    if int(repeat) < 1:
        raise VggcError(f"repeat must be at least 1, got {repeat}")
    small = ScaleConfig((transitions,), cfg.bench, cfg.seed, cfg.cache)
    big = ScaleConfig((transitions,), cfg.bench, cfg.seed, cfg.cache, image=tuple(image))
    refs, cams = [], []
    for _ in range(int(repeat)):
        for conf, out in ((small, refs), (big, cams)):
            rec = measure(*cached_trace(conf, transitions))
            out.append(rec)
            if on_record is not None:
                on_record(rec)
    return refs, cams


def fastest(records: list[SizeRecord]) -> SizeRecord:
    """The record of least wall time."""
    return min(records, key=lambda r: r.seconds)


#: Columns of :func:`record_rows` (the CSV of ``bench scale --csv``).
COLUMNS = ("transitions", "observations", "height", "width", "stage", "seconds",
           "cpu_seconds", "peak_bytes", "nodes")


def record_rows(records) -> list[dict]:
    """One row per size and stage (:data:`COLUMNS`)."""
    return [{"transitions": r.transitions, "observations": r.observations,
             "height": r.image[0], "width": r.image[1], "stage": s.stage,
             "seconds": round(s.seconds, 3), "cpu_seconds": round(s.cpu_seconds, 3),
             "peak_bytes": int(s.peak_bytes), "nodes": r.nodes}
            for r in records for s in r.stages]


def rows_csv(rows: list[dict]) -> str:
    """CSV text of :func:`record_rows`."""
    lines = [",".join(COLUMNS)]
    lines += [",".join(str(row[c]) for c in COLUMNS) for row in rows]
    return "\n".join(lines) + "\n"


def read_rows(path) -> list[dict]:
    """Rows of a CSV written by ``bench scale --csv`` (errors name the file and line)."""
    from vggc_cp.safeio import check_input

    check_input(path, "scale CSV")
    text = Path(path).read_text(encoding="utf-8").splitlines()
    if not text or tuple(text[0].split(",")) != COLUMNS:
        raise VggcError(f"{path}: expected the header {','.join(COLUMNS)}")
    rows = []
    for k, line in enumerate(text[1:], 2):
        parts = line.split(",")
        if len(parts) != len(COLUMNS):
            raise VggcError(f"{path}: line {k} has {len(parts)} fields, expected {len(COLUMNS)}")
        try:
            row = {c: (v if c == "stage" else float(v) if c in ("seconds", "cpu_seconds")
                       else int(v)) for c, v in zip(COLUMNS, parts)}
        except ValueError:
            raise VggcError(f"{path}: line {k} holds a value that is not a number") from None
        rows.append(row)
    return rows
