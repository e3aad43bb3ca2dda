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
    _register_bench_scale(bench_sub)


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


def _register_bench_scale(bench_sub) -> None:
    b = bench_sub.add_parser(
        "scale", help="wall time and peak memory of the default solve as |D| grows",
        description="Generate (once, into --cache-dir) fruit-6x8 traces of growing |D|, run "
                    "the default learning (footprint evidence, candidate-pair merge path, "
                    "confidence) on each and print wall time and peak resident memory per "
                    "stage, and the fitted growth exponent of the wall time (log-log least "
                    "squares). Generation is timed apart.")
    b.add_argument("--sizes", default="1500,3000,6000,12000,20000",
                   help="comma-separated |D| values")
    b.add_argument("--seed", type=int, default=5, help="trace seed")
    b.add_argument("--cache-dir", default=None,
                   help="folder of the generated traces (default: $VGGC_CP_CACHE/bench or "
                        ".cache/vggc-cp/bench)")
    b.add_argument("--camera", default="640x480", metavar="WxH",
                   help="also measure one trace of WxH images at --camera-transitions "
                        "(none: skip)")
    b.add_argument("--camera-transitions", type=int, default=1500,
                   help="|D| of the camera-sized trace")
    b.add_argument("--repeats", type=int, default=3,
                   help="the camera-sized trace and the default-size one at the same |D| are "
                        "each measured this many times, alternately; the ratio is of the "
                        "fastest of each")
    b.add_argument("--csv", default=None, help="also write one row per size and stage here")
    b.set_defaults(func=cmd_bench_scale)


def cmd_bench_scale(args) -> int:
    import os
    from pathlib import Path

    from vggc_cp.errors import VggcError
    from vggc_cp.experiments.scale import (
        ScaleConfig,
        camera_runs,
        fastest,
        growth_exponent,
        run_scale,
    )
    from vggc_cp.vision import CACHE_ENV

    try:
        sizes = tuple(int(s) for s in _split(args.sizes))
    except ValueError:
        raise VggcError(f"--sizes {args.sizes!r}: expected comma-separated integers") from None
    env = os.environ.get(CACHE_ENV)
    cache = Path(args.cache_dir) if args.cache_dir else \
        Path(env) / "bench" if env else Path(".cache") / "vggc-cp" / "bench"
    cfg = ScaleConfig(sizes, seed=args.seed, cache=cache)
    if args.repeats < 1:
        raise VggcError(f"--repeats must be at least 1, got {args.repeats}")
    camera = None
    if args.camera.lower() != "none":  # checked before any measurement
        from vggc_cp.sim.explore import parse_image_size

        camera = parse_image_size(args.camera, "--camera")
    gib = float(1 << 30)
    print(f"scale          {cfg.bench}, seed {cfg.seed}, traces in {cache}")
    print(f"{'|D|':>7} {'obs':>7} {'generate':>9} {'load':>15} {'evidence':>15} {'merge path':>15} "
          f"{'confidence':>15} {'trace hash':>15} {'total':>8} {'cpu':>8} {'peak':>8} nodes")

    def show(rec) -> None:
        cells = " ".join(f"{s.seconds:7.1f} s {s.peak_bytes / gib:4.2f} G"
                         for s in rec.stages)
        gen = f"{rec.generate_seconds:7.1f} s" if rec.generate_seconds else "   cached"
        print(f"{rec.transitions:>7} {rec.observations:>7} {gen} {cells} {rec.seconds:6.1f} s "
              f"{rec.cpu_seconds:6.1f} s {rec.peak_bytes / gib:6.2f} G {rec.nodes}"
              f"{' suspect' if rec.suspect else ''}", flush=True)

    records = run_scale(cfg, show)
    cam_records = []
    if len(records) >= 2:
        k = growth_exponent([r.transitions for r in records], [r.seconds for r in records])
        kc = growth_exponent([r.transitions for r in records],
                             [r.cpu_seconds for r in records])
        print(f"growth         wall time ~ |D|^{k:.2f}, CPU time ~ |D|^{kc:.2f} "
              f"({records[0].transitions}..{records[-1].transitions}, least squares on log-log)")
    if camera is not None:
        h, w = camera
        print(f"camera         {w}x{h} against the default size at |D| = "
              f"{args.camera_transitions}, {args.repeats} run(s) each, alternately")
        refs, cams = camera_runs(cfg, (h, w), args.camera_transitions, args.repeats, show)
        cam_records.append(fastest(cams))
        cam, ref = fastest(cams), fastest(refs)
        runs = ", ".join(f"{c.seconds:.1f}/{r.seconds:.1f}" for c, r in zip(cams, refs))
        print(f"camera         {w}x{h} at |D| = {cam.transitions}: {cam.seconds:.1f} s "
              f"({cam.cpu_seconds:.1f} s CPU), peak {max(c.peak_bytes for c in cams) / gib:.2f} "
              f"GiB: {cam.seconds / ref.seconds:.2f}x the {ref.image[1]} px wall time, "
              f"{cam.cpu_seconds / ref.cpu_seconds:.2f}x its CPU time (fastest of each; "
              f"runs {runs} s)")
    if args.csv:
        from vggc_cp.atomic import write_text
        from vggc_cp.experiments.scale import record_rows, rows_csv

        write_text(args.csv, rows_csv(record_rows([*records, *cam_records])))
        print(f"wrote          {args.csv}")
    return 0
