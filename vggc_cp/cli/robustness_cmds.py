"""``vggc-cp robustness``: the default ``solve`` on every benchmark, seed and look;
``vggc-cp calibration``: how its warning matched the pass rule; ``vggc-cp settle``: whether
suggested episodes settle its misses and warned runs."""

from __future__ import annotations

import argparse
import os


def register(sub) -> None:
    p = sub.add_parser(
        "robustness", help="the default solve on benchmarks x seeds x looks: pass rate and "
                           "whether the warning caught every miss",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        description="Generate (or reuse) one trace per benchmark, look and seed, learn its graph "
                    "with the default pipeline (what `vggc-cp solve trace.npz` runs), evaluate "
                    "it, and write robustness.csv and robustness.md into --out. Finished cells "
                    "are cached there and skipped on a rerun with the same settings. Besides "
                    "the seven benchmarks it runs tasks drawn beyond them (random-S, --tasks). "
                    "Trace seeds >= 3 and tasks drawn from task seeds >= 100 are the held-out "
                    "split, reported separately.")
    p.add_argument("--out", required=True, help="output and cache folder")
    p.add_argument("--benchmarks", default="all",
                   help="comma-separated task names (the seven benchmarks, random-S, "
                        "task:...), all (the seven) or none")
    p.add_argument("--seeds", default="0:4",
                   help="trace seeds of --benchmarks: an inclusive range A:B or "
                        "comma-separated integers")
    p.add_argument("--tasks", default="0:9,100:119",
                   help="task seeds S of the random tasks random-S to run besides "
                        "--benchmarks (ranges A:B and integers, comma-separated), or none")
    p.add_argument("--task-seeds", default="0", help="trace seeds of the random tasks")
    p.add_argument("--looks", default="all",
                   help="comma-separated looks, or all (clean, randomized, robot); armless "
                        "(the robot look with its arm hidden) by name")
    p.add_argument("--transitions", type=int, default=None,
                   help="|D| of every trace; None: the paper's per benchmark")
    p.add_argument("--queries", "-Q", type=int, default=1500, help="evaluation queries")
    p.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                   help="worker processes (cells in parallel)")
    p.add_argument("--i2p", action="store_true",
                   help="also train a localizer and measure localization / I2P / Exec-I2P on "
                        "novel renders, for the seeds of --i2p-seeds (minutes per cell)")
    p.add_argument("--i2p-seeds", default="0", help="seeds measured with --i2p")
    p.add_argument("--novel", type=int, default=150, help="novel renders per trace for --i2p")
    p.add_argument("--i2p-queries", type=int, default=150,
                   help="start/goal image pairs for --i2p")
    p.add_argument("--force", action="store_true", help="recompute cached cells")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_robustness)

    p = sub.add_parser(
        "calibration", help="how the warning matched the pass rule in a robustness.csv: "
                            "false alarms and silent failures per split and look, old and new "
                            "verdict",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        description="Read the rows of `vggc-cp robustness` (OUT/robustness.csv) and count, per "
                    "split and look, passed runs that were warned (false alarms) and missed "
                    "runs that were not (silent failures), for the row's verdict (new: the "
                    "chance of change) and the former fixed thresholds recomputed from the "
                    "row (old); then the runs binned by chance of change.")
    p.add_argument("tables", nargs="+", metavar="robustness.csv",
                   help="robustness.csv file(s) of `vggc-cp robustness`; their rows are pooled")
    p.add_argument("-o", "--output", default=None, help="also write the tables to this .md")
    p.add_argument("--png", default=None, help="also draw the calibration plot to this .png")
    p.set_defaults(func=cmd_calibration)

    p = sub.add_parser(
        "settle", help="on a robustness study's misses and warned runs: do the episodes "
                       "`suggest` proposes settle the graph, against as many random "
                       "transitions?",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        description="For every run of OUT_DIR/robustness.csv that missed or was warned: per "
                    "round, append the episodes `vggc-cp suggest` proposes for the previous "
                    "round's graph (as `generate --episodes --append`) and learn again with "
                    "the default solve; against it, generate the same task, seed and look "
                    "with as many transitions (the random walk continued) and learn that. "
                    "Prints per case and round |D|, nodes, Exec, warning, pass and whether "
                    "the graph is settled (passes, no warning), then how many cases each "
                    "kind of data settled. Reads OUT_DIR, writes nothing there.")
    p.add_argument("out_dir", metavar="OUT_DIR",
                   help="folder written by `vggc-cp robustness --out OUT_DIR`")
    p.add_argument("--rounds", type=int, default=2, help="rounds of new data per case")
    p.add_argument("--max-episodes", type=int, default=20, metavar="N",
                   help="most episodes suggested per round")
    p.add_argument("--only", default=None, metavar="COL=VALUE,...",
                   help="only the cases whose robustness.csv row has these values (e.g. "
                        "look=robot,benchmark=fruit-4x6; a column given twice: either "
                        "value)")
    p.add_argument("--limit", type=int, default=None, metavar="N",
                   help="only the first N cases")
    p.add_argument("-o", "--output", default=None,
                   help="also write the tables to this .md and the records to the .csv "
                        "beside it")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_settle)


def _split(text: str) -> list[str]:
    return [x.strip() for x in text.split(",") if x.strip()]


def cmd_robustness(args) -> int:
    from pathlib import Path

    from vggc_cp.cli.options import parse_seeds
    from vggc_cp.experiments.robustness import (
        RobustnessConfig,
        run_robustness,
        suite_looks,
    )
    from vggc_cp.experiments.robustness_tables import write_tables
    from vggc_cp.safeio import check_output_dir, check_trace_budget
    from vggc_cp.sim import benchmark_names

    check_output_dir(args.out, "--out", ("cells", "traces", "solutions", "models"),
                     ("robustness.csv", "robustness.md"))

    benches = (tuple(benchmark_names()) if args.benchmarks == "all"
               else () if args.benchmarks == "none" else tuple(_split(args.benchmarks)))
    tasks = () if args.tasks == "none" else tuple(
        s for part in _split(args.tasks) for s in parse_seeds(part, "--tasks"))
    looks = suite_looks() if args.looks == "all" else tuple(_split(args.looks))
    cfg = RobustnessConfig(Path(args.out), benches, parse_seeds(args.seeds), looks,
                           args.transitions, tasks=tasks,
                           task_seeds=parse_seeds(args.task_seeds, "--task-seeds"),
                           n_queries=args.queries,
                           jobs=args.jobs, i2p=args.i2p,
                           i2p_seeds=parse_seeds(args.i2p_seeds, "--i2p-seeds"),
                           novel=args.novel, i2p_queries=args.i2p_queries, force=args.force)
    for bench in cfg.benchmarks:
        check_trace_budget(cfg.n_transitions(bench), cfg.size, "--transitions")
        if cfg.i2p:
            check_trace_budget(cfg.novel, cfg.size, "--novel")
    run = run_robustness(cfg, progress=not args.quiet)
    csv, md = write_tables(run.rows, cfg.out, run.seconds)
    print(md.read_text(encoding="utf-8"), end="")
    print(f"\ncells: {run.computed} computed, {run.reused} reused, {run.seconds:.1f} s")
    print(f"wrote {csv}")
    print(f"wrote {md}")
    return 0


def cmd_calibration(args) -> int:
    from vggc_cp.atomic import write_text
    from vggc_cp.experiments.calibration import (
        calibration_markdown,
        calibration_rows,
        read_rows,
    )
    from vggc_cp.safeio import check_input, check_output

    inputs = {}
    for k, path in enumerate(args.tables):
        check_input(path, "robustness table")
        inputs[f"table {k}"] = str(path)
    if args.output and args.png and os.path.realpath(args.output) == os.path.realpath(args.png):
        from vggc_cp.errors import VggcError

        raise VggcError(f"{args.png}: --png and --output name the same file")
    for opt, path in (("--output", args.output), ("--png", args.png)):
        if path:
            check_output(path, opt, inputs)
    rows = [r for path in args.tables for r in read_rows(path)]
    md = calibration_markdown(rows, ", ".join(args.tables))
    if args.output:
        write_text(args.output, md)
    if args.png:
        from vggc_cp.plots import plot_calibration

        plot_calibration(calibration_rows(rows), rows, args.png)
    print(md, end="")
    for path in (args.output, args.png):
        if path:
            print(f"wrote {path}")
    return 0


def cmd_settle(args) -> int:
    from vggc_cp.errors import VggcError
    from vggc_cp.experiments.settle import (
        csv_path,
        read_cases,
        run_settle,
        settle_markdown,
        write_settle,
    )
    from vggc_cp.safeio import check_output

    if args.rounds < 1:
        raise VggcError(f"--rounds must be at least 1, got {args.rounds}")
    if args.max_episodes < 1:
        raise VggcError(f"--max-episodes must be at least 1, got {args.max_episodes}")
    if args.output:
        if args.output.lower().endswith(".csv"):
            raise VggcError(f"{args.output}: -o names the markdown report; the .csv is "
                            f"written beside it")
        check_output(args.output, "--output")
        check_output(csv_path(args.output), "--output (its .csv)")
    cases = read_cases(args.out_dir, args.only, args.limit)
    bar = None
    if not args.quiet and cases:
        from tqdm import tqdm

        bar = tqdm(total=len(cases) * args.rounds * 2, desc="settle", unit="arm", leave=False)

    def step(what: str) -> None:
        bar.set_postfix_str(what, refresh=False)
        bar.update(1)

    try:
        run = run_settle(cases, args.rounds, args.max_episodes,
                         progress=step if bar is not None else None)
    finally:
        if bar is not None:
            bar.close()
    print(settle_markdown(run.records, args.out_dir), end="")
    print(f"\n{run.cases} case(s), {run.rounds} round(s), {run.seconds:.1f} s")
    if args.output:
        md, table = write_settle(run.records, args.output, args.out_dir)
        print(f"wrote {md}")
        print(f"wrote {table}")
    return 0
