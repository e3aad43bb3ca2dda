"""``vggc-cp baseline`` (run one baseline on a trace), ``vggc-cp benchmark`` (Table 1) and
``vggc-cp bench startup`` (how fast the command line starts)."""

from __future__ import annotations

from vggc_cp.baselines import BASELINES, baseline_solution, get_baseline, parse_params
from vggc_cp.errors import lookup
from vggc_cp.solution import write_solution
from vggc_cp.trace import load_trace


def register(sub) -> None:
    p = sub.add_parser("baseline", help="learn a graph with a baseline (pca-hdbscan, lsr)",
                       description="Run a baseline of the paper's Table 1 on a trace and write "
                                   "the solution JSON (field constraints = none: Exactly-One "
                                   "is not enforced; evaluate reports its violations).")
    p.add_argument("name", help=f"baseline: {', '.join(sorted(BASELINES))}")
    p.add_argument("trace", help="trace .npz")
    p.add_argument("-o", "--output", required=True, help="solution .json to write")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUES",
                   help="option of the baseline's config (comma-separated values for a sweep "
                        "grid), e.g. min_cluster_size=3,5 or d_m=4,12; repeatable")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_baseline)
    register_benchmark(sub)


def register_bench(bench_sub) -> None:
    p = bench_sub.add_parser(
        "startup", help="time `vggc-cp --help` and `vggc-cp plan --help` against `python -c "
                        "pass` in one run, and list the heavy modules they import (none)")
    p.add_argument("--repeats", type=int, default=5,
                   help="timed runs of each command; the fastest counts")
    p.add_argument("--limit", type=float, default=1.0,
                   help="the start-up, in seconds, that a command must stay within")
    p.set_defaults(func=cmd_bench_startup)


def cmd_bench_startup(args) -> int:
    from vggc_cp.errors import VggcError
    from vggc_cp.experiments.perf import STARTUP_COMMANDS, time_startup

    if args.repeats < 1:
        raise VggcError(f"--repeats must be at least 1, got {args.repeats}")
    for argv in STARTUP_COMMANDS:
        t = time_startup(argv, args.repeats)
        verdict = "within" if t.seconds <= args.limit else "OVER"
        print(f"startup        python -m vggc_cp {' '.join(argv)}: {t.seconds:.3f} s (fastest of "
              f"{args.repeats}; CPU {t.cpu_seconds:.3f} s), {t.modules} modules imported, "
              f"heavy modules: {', '.join(t.heavy) or 'none'}")
        print(f"  baseline, python -c pass: {t.baseline_seconds:.3f} s; ratio {t.ratio:.1f}x; "
              f"{verdict} the {args.limit:g} s target")
    return 0


def cmd_baseline(args) -> int:
    cls = lookup(BASELINES, args.name, "baseline")
    options = parse_params(cls.config_class, args.param)
    trace = load_trace(args.trace)
    result = get_baseline(args.name, config=cls.config_class(**options)).fit(
        trace, progress=not args.quiet)
    write_solution(args.output, baseline_solution(trace, result))
    v = result.stats["violations"]
    print(f"{result.solver}: {v['nodes']} nodes ({v['pick_nodes']} pick, {v['place_nodes']} "
          f"place), {v['edges']} edges, {v['exactly_one']} Exactly-One "
          f"violation{'' if v['exactly_one'] == 1 else 's'} "
          f"({v['exactly_one_transitions']} transitions), {result.seconds:.1f} s")
    print(f"selected  {result.stats['params']}")
    print(f"sweep     {len(result.stats['grid'])} points, rule: {result.stats['selection']}")
    print(f"wrote     {args.output}")
    return 0


def _split(text: str) -> list[str]:
    return [x.strip() for x in text.split(",") if x.strip()]


def _scalar(text: str):
    for cast in (int, float):
        try:
            return cast(text)
        except ValueError:
            pass
    return {"true": True, "false": False, "none": None}.get(text.lower(), text)


def method_options(items: list[str]) -> dict:
    """``METHOD.KEY=VALUE`` strings -> ``{method: {key: value}}``.

    Baseline keys are fields of the baseline's config (comma-separated values for sweep
    grids); solver keys are keyword arguments of the solver (one value, commas kept).
    """
    from vggc_cp.errors import VggcError

    grouped: dict[str, list[str]] = {}
    for item in items:
        head, sep, _ = item.partition("=")
        method, dot, _key = head.partition(".")
        if not sep or not dot:
            raise VggcError(f"--param {item!r}: expected METHOD.KEY=VALUE")
        grouped.setdefault(method.strip(), []).append(item.split(".", 1)[1])
    out: dict[str, dict] = {}
    for method, kvs in grouped.items():
        if method in BASELINES:
            out[method] = parse_params(BASELINES[method].config_class, kvs)
        else:
            out[method] = {k.strip(): _scalar(v.strip()) for k, _, v in
                           (kv.partition("=") for kv in kvs)}
    return out


def register_benchmark(sub) -> None:
    import os

    from vggc_cp.cli.options import add_backend_arguments
    from vggc_cp.experiments.table1 import DEFAULT_METHODS
    from vggc_cp.experiments.table1_methods import METHODS

    p = sub.add_parser("benchmark", help="the paper's Table 1: every method on every benchmark",
                       description="Generate or reuse traces, run every method, evaluate with "
                                   "Q queries, write table1.csv and table1.md into --out. "
                                   "Finished cells are cached there and skipped on a rerun.")
    p.add_argument("--benchmarks", default="all",
                   help="comma-separated benchmark names, or all")
    p.add_argument("--methods", default=",".join(DEFAULT_METHODS),
                   help=f"comma-separated methods: {', '.join(METHODS)} ")
    p.add_argument("--seeds", default="0", help="comma-separated trace seeds")
    p.add_argument("--transitions", type=int, default=None,
                   help="|D| of every trace (default: the paper's per benchmark)")
    p.add_argument("--queries", "-Q", type=int, default=1500, help="evaluation queries")
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                   help="worker processes / cluster tasks (default: the CPU count, here %(default)s)")
    add_backend_arguments(p, "the traces, distances and cells")
    p.add_argument("--out", default="benchmark", help="output and cache folder")
    p.add_argument("--param", action="append", default=[], metavar="METHOD.KEY=VALUE",
                   help="method option, e.g. cpsat.params=max_time_in_seconds:5 or "
                        "lsr.steps=300; repeatable")
    p.add_argument("--i2p", default="", metavar="METHODS",
                   help="comma-separated methods whose graphs also get a trained localizer and "
                        "localization / I2P / Exec-I2P on novel renders (default none)")
    p.add_argument("--novel", type=int, default=150,
                   help="novel renders per trace for --i2p")
    p.add_argument("--i2p-queries", type=int, default=150,
                   help="start/goal image pairs for --i2p (the paper's Q is 150)")
    p.add_argument("--attention", default="saliency", metavar="NAME",
                   help="attention backend of the visual distances (saliency, keypoints, "
                        "dinov2), or auto: each benchmark's own (fruit keypoints, blocks "
                        "saliency)")
    p.add_argument("--force", action="store_true", help="recompute cached cells")
    p.add_argument("--table-only", action="store_true",
                   help="run nothing: write the tables from the cells cached so far "
                        "(unfinished cells marked)")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=cmd_benchmark)


#: most seeds one benchmark run takes
MAX_SEEDS = 10_000


def cmd_benchmark(args) -> int:
    from pathlib import Path

    from vggc_cp.errors import VggcError
    from vggc_cp.experiments.table1 import BenchmarkConfig, collect_rows, run_benchmark
    from vggc_cp.experiments.table1_tables import write_tables
    from vggc_cp.sim import benchmark_names

    benches = benchmark_names() if args.benchmarks == "all" else tuple(_split(args.benchmarks))
    try:
        seeds = tuple(int(s) for s in _split(args.seeds))
    except ValueError:
        raise VggcError(f"--seeds {args.seeds!r}: expected comma-separated integers") from None
    from vggc_cp.safeio import check_size, check_trace_budget

    check_size(len(seeds), "--seeds (count)", 1, MAX_SEEDS, f"the cap of {MAX_SEEDS:,} seeds")
    if any(not 0 <= s < 2**32 for s in seeds):
        raise VggcError(f"--seeds {args.seeds[:60]!r}: seeds are integers from 0 to 2^32 - 1")
    check_trace_budget(args.transitions, 64, "--transitions")
    if args.i2p:
        check_trace_budget(args.novel, 64, "--novel")
    cfg = BenchmarkConfig(Path(args.out), benches, tuple(_split(args.methods)), seeds,
                          args.transitions, args.queries, args.jobs, args.backend,
                          args.scheduler, method_options(args.param), args.force,
                          tuple(_split(args.i2p)) if args.i2p else (), args.novel,
                          args.i2p_queries, args.attention)
    if args.table_only:
        rows, missing = collect_rows(cfg)
        csv, md = write_tables(rows, cfg.out)
        print(md.read_text(encoding="utf-8"), end="")
        print(f"cells          {len(rows) - missing} cached, {missing} not finished in "
              f"{cfg.out}/cells")
        print(f"wrote          {csv}, {md}")
        return 0
    run = run_benchmark(cfg, progress=not args.quiet)
    csv, md = write_tables(run.rows, cfg.out, run.seconds)
    print(md.read_text(encoding="utf-8"), end="")
    print(f"cells          {run.computed} computed, {run.reused} reused from {cfg.out}/cells "
          f"({run.seconds:.1f} s, jobs {cfg.jobs}, {cfg.backend})")
    print(f"wrote          {csv}, {md}")
    return 0
