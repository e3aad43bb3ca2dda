"""``vggc-cp generate``, ``vggc-cp envs``, ``vggc-cp render`` and ``vggc-cp bench generate``."""

from __future__ import annotations

import contextlib
import tempfile
import time
from pathlib import Path

from vggc_cp.errors import VggcError

BENCH_NAME = "fruit-6x8"
BENCH_TRANSITIONS = 1500
BENCH_SIZE = 128
BENCH_LIMIT_S = 60.0


def register(sub) -> None:
    from vggc_cp.sim import benchmark_names

    p = sub.add_parser("generate", help="explore a PyBullet benchmark and write a trace",
                       description="Random valid pick/place episodes from random valid starts (or "
                                   "the benchmark's home states), "
                                   "rendered headless. Benchmarks: " + ", ".join(benchmark_names()))
    p.add_argument("bench", metavar="BENCH", nargs="?", default=None,
                   help="benchmark name, random-S or a spec string task:... (see `vggc-cp envs`)")
    p.add_argument("--task", default=None, metavar="TASK",
                   help="a task beyond the seven instead of BENCH: 'random' (drawn from "
                        "--task-seed), random-S, a spec string task:... or a JSON file with "
                        "{\"spec\": \"task:...\"} (a trace's meta['task'])")
    p.add_argument("--task-seed", type=int, default=None, metavar="S",
                   help="with --task random: the seed the task is drawn from (default: --seed)")
    p.add_argument("-o", "--output", required=True, help="trace .npz to write")
    p.add_argument("--transitions", type=int, default=None,
                   help="|D|, number of transitions (default: the paper's)")
    p.add_argument("--seed", type=int, default=0, help="random seed")
    p.add_argument("--size", default="64", metavar="SIZE",
                   help="image side in pixels, or WIDTHxHEIGHT (e.g. 640x480)")
    p.add_argument("--novel", type=int, default=0, metavar="K",
                   help="also write K fresh renders of visited states to <output stem>.novel.npz")
    p.add_argument("--look", default="clean", metavar="LOOK",
                   help="clean: the renderer the learning defaults were tuned on; "
                        "randomized: a stand-in for another renderer or a real camera -- table "
                        "colour and texture, region markers, camera pose, light, object shapes, "
                        "sizes and shades drawn per trace, lighting gain, tint and sensor noise "
                        "per frame, all from --seed; robot: randomized plus a Panda arm resting "
                        "above the region it last acted on, a camera shake of up to 2 px, a slow "
                        "lighting drift and a mug that moves between some frames; armless: "
                        "the robot look with its arm hidden (the same draws; what the arm "
                        "costs)")
    p.add_argument("--episodes", default=None, metavar="JSON",
                   help="with --append: record exactly these episodes (vggc-episodes/1, e.g. "
                        "from `vggc-cp suggest`), each from the true state of its start "
                        "observation, in the trace's look; an illegal action ends its episode")
    p.add_argument("--append", default=None, metavar="TRACE",
                   help="with --episodes: a trace written by generate; the output holds its "
                        "observations, then the recorded episodes (BENCH may be omitted: "
                        "the trace's meta['benchmark'])")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_generate)

    p = sub.add_parser("envs", help="list the task families, the benchmarks and their parameters")
    p.add_argument("--tasks", default=None, metavar="SEEDS",
                   help="also list the tasks drawn from these seeds (e.g. 0:9 or 3,5)")
    p.set_defaults(func=cmd_envs)

    p = sub.add_parser("render", help="draw a contact sheet of a trace's observations")
    p.add_argument("trace", help="trace .npz")
    p.add_argument("-o", "--output", required=True, help="image to write (.png)")
    p.add_argument("--max", type=int, default=48, help="at most this many observations")
    p.add_argument("--no-states", action="store_true", help="leave ground-truth states out")
    p.set_defaults(func=cmd_render)


def register_bench(bench_sub) -> None:
    p = bench_sub.add_parser(
        "generate", help=f"time `generate {BENCH_NAME}` at |D|={BENCH_TRANSITIONS}, "
                         f"{BENCH_SIZE} px, against a bare PyBullet render")
    p.add_argument("--transitions", type=int, default=BENCH_TRANSITIONS,
                   help="|D| of the generated trace")
    p.add_argument("--size", type=int, default=BENCH_SIZE, help="image side in pixels")
    p.set_defaults(func=cmd_bench_generate)


def _write(generated, output: str, novel: int) -> list[str]:
    from vggc_cp.sim.novel import novel_path, save_novel
    from vggc_cp.trace import save_trace

    save_trace(generated.trace, output)
    written = [output]
    if novel:
        path = novel_path(output)
        save_novel(path, generated.novel_observations, generated.novel_states)
        written.append(str(path))
    return written


def _task_name(args) -> str:
    """The task ``generate`` explores: BENCH, or --task (exactly one of them)."""
    from vggc_cp.sim.tasks import RANDOM_PREFIX, read_task_argument

    if (args.bench is None) == (args.task is None):
        raise VggcError("give a benchmark BENCH or --task, not both and not neither")
    if args.task_seed is not None and args.task != "random":
        raise VggcError("--task-seed goes with --task random")
    if args.task is None:
        return args.bench
    if args.task == "random":
        seed = args.seed if args.task_seed is None else args.task_seed
        return read_task_argument(f"{RANDOM_PREFIX}{seed}")
    return read_task_argument(args.task)


def cmd_generate(args) -> int:
    if args.episodes is not None or args.append is not None:
        return _generate_append(args)
    from vggc_cp.sim import get_benchmark
    from vggc_cp.sim.looks import check_look

    args.bench = _task_name(args)
    spec = get_benchmark(args.bench).spec
    check_look(args.look)
    d = spec.default_transitions if args.transitions is None else args.transitions
    if args.novel < 0:
        raise VggcError(f"--novel must be at least 0, got {args.novel}")
    from vggc_cp.safeio import TEMP_MARK, cap, check_image_size, check_trace_budget, temp_file
    from vggc_cp.sim.explore import parse_image_size

    height, width = parse_image_size(args.size)
    check_image_size(height, width, "--size")
    # frames beyond the memory cap are rendered into a temporary file beside the output
    spill = (d + 1) * height * width * 3 > cap("max_bytes")
    check_trace_budget(d, (height, width), "--transitions",
                       "max_frame_bytes" if spill else "max_bytes")
    if args.novel:
        check_trace_budget(args.novel, (height, width), "--novel")
    out = Path(args.output)
    with contextlib.ExitStack() as stack:
        frames_file = stack.enter_context(temp_file(out.parent, f".{out.name}{TEMP_MARK}",
                                                    ".frames")) if spill else None
        return _generate_into(args, d, height, width, frames_file)


def _generate_into(args, d: int, height: int, width: int, frames_file) -> int:
    from vggc_cp.sim.explore import generate

    bars = []

    def on_frame(total: int) -> None:
        if not bars:
            from tqdm import tqdm

            bars.append(tqdm(total=total, unit="frame", desc=args.bench[:40], leave=False))
        bars[0].update(1)

    try:
        generated = generate(args.bench, d, args.seed, (height, width), args.novel,
                             on_frame=None if args.quiet else on_frame, look=args.look,
                             frames_file=frames_file)
    finally:
        for bar in bars:
            bar.close()
    written = _write(generated, args.output, args.novel)
    if not args.quiet:
        tr = generated.trace
        print(f"{args.bench}: {tr.n_obs} observations, |D| = {tr.n_transitions}, "
              f"{len(set(tr.states.tolist()))} distinct states, {len(tr.episodes())} episodes, "
              f"{width}x{height} px, seed {args.seed}, {args.look} look")
        for path in written:
            print(f"wrote {path}")
    return 0


def _generate_append(args) -> int:
    """``generate [BENCH] --episodes next.json --append t.npz -o t2.npz``."""
    from vggc_cp.safeio import check_input
    from vggc_cp.sim.append import append_episodes, read_episodes
    from vggc_cp.trace import load_trace, save_trace

    if args.episodes is None or args.append is None:
        raise VggcError("--episodes and --append go together")
    for opt, given in (("--task", args.task is not None), ("--novel", args.novel != 0),
                       ("--transitions", args.transitions is not None),
                       ("--task-seed", args.task_seed is not None)):
        if given:
            raise VggcError(f"{opt} does not apply with --append (the trace fixes the task, "
                            f"its look and its seed)")
    check_input(args.append, "append")
    check_input(args.episodes, "episodes")
    trace = load_trace(args.append)
    bench = trace.meta.get("benchmark")
    if args.bench is not None and args.bench != bench:
        raise VggcError(f"{args.append}: field 'meta.benchmark' is {bench!r}, not BENCH "
                        f"{args.bench!r}")
    requests, sha = read_episodes(args.episodes, trace)
    appended = append_episodes(trace, requests, episodes_sha256=sha)
    save_trace(appended.trace, args.output)
    if not args.quiet:
        for k, rec in enumerate(appended.recorded):
            if rec.illegal_action is not None:
                print(f"episode {k}: action {rec.illegal_at} ({rec.illegal_action}) is illegal "
                      f"in state {rec.state}: episode ended after {len(rec.executed)} "
                      f"action(s)")
        kept = sum(1 for r in appended.recorded if r.executed)
        print(f"{bench}: appended {kept} of {len(requests)} episodes, "
              f"{appended.added_transitions} transitions, to {trace.n_obs} observations "
              f"-> {appended.trace.n_obs}")
        print(f"wrote {args.output}")
    return 0


def cmd_envs(args) -> int:
    from vggc_cp.cli.options import parse_seeds
    from vggc_cp.sim import benchmark_names, get_benchmark
    from vggc_cp.sim.tasks import FAMILIES, describe, format_spec

    head = ("bench", "m", "n", "R", "|A|", "states", "paper |V*|", "default |D|", "attention",
            "episodes")
    rows = []
    for name in benchmark_names():
        b = get_benchmark(name)
        s = b.spec
        starts = "any state" if s.start_states == 0 else f"{s.start_states} home"
        rows.append((name, s.m, s.n, s.R, s.n_actions, len(b.all_states()), s.paper_states,
                     s.default_transitions, s.attention,
                     f"{s.episode_length[0]}-{s.episode_length[1]} from {starts}"))
    widths = [max(len(str(r[i])) for r in (head, *rows)) for i in range(len(head))]
    fmt = "  ".join(f"{{:<{w}}}" if i in (0, len(head) - 1) else f"{{:>{w}}}"
                    for i, w in enumerate(widths))
    print(fmt.format(*head).rstrip())
    for row in rows:
        print(fmt.format(*row).rstrip())
    print("states: the full reachable state count (pick and place states); "
          "paper |V*|: states a trace at the default |D| visits;\n"
          "attention: the backend `vggc-cp benchmark --attention auto` uses;\n"
          "episodes: transitions per exploration episode, and where each begins")
    print("\nfamilies:")
    for fam, text in FAMILIES.items():
        print(f"  {fam:<7} {text}")
    if args.tasks is not None:
        print("\ndrawn tasks (generate random-S, or --task random --task-seed S):")
        for seed in parse_seeds(args.tasks, "--tasks"):
            spec = get_benchmark(f"random-{seed}").spec
            print(f"  random-{seed}: {describe(spec)}; {spec.paper_states} states, "
                  f"default |D| {spec.default_transitions}")
            print(f"    {format_spec(spec)}")
    return 0


def cmd_render(args) -> int:
    from vggc_cp.sim.sheet import contact_sheet
    from vggc_cp.trace import load_trace

    count = contact_sheet(load_trace(args.trace), args.output, args.max,
                          show_states=not args.no_states)
    print(f"wrote {args.output} ({count} observation{'' if count == 1 else 's'})")
    return 0


def cmd_bench_generate(args) -> int:
    import numpy as np

    from vggc_cp.sim import get_benchmark
    from vggc_cp.sim.arrange import fresh_arrangement
    from vggc_cp.sim.explore import generate
    from vggc_cp.sim.render import Scene, empty_scene_frame_seconds

    if args.transitions < 1:
        raise VggcError(f"--transitions must be at least 1, got {args.transitions}")
    from vggc_cp.safeio import check_image_size, check_trace_budget

    check_image_size(args.size, args.size, "--size")
    check_trace_budget(args.transitions, args.size, "--transitions")
    frames = args.transitions + 1
    reps = min(frames, 300)
    empty = empty_scene_frame_seconds(args.size, reps)
    bench = get_benchmark(BENCH_NAME)
    with Scene(bench, args.size) as scene:
        rng = np.random.default_rng(0)
        scene.pose(fresh_arrangement(bench, bench.all_states()[0], rng))
        static = scene.frame_seconds(reps)
    t0 = time.perf_counter()
    generated = generate(BENCH_NAME, args.transitions, 0, args.size)
    t_gen = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as tmp:
        t1 = time.perf_counter()
        _write(generated, str(Path(tmp) / "bench.npz"), 0)
        t_save = time.perf_counter() - t1
    total = t_gen + t_save
    per_frame = total / frames
    print(f"generate {BENCH_NAME} |D|={args.transitions} at {args.size} px: {total:.2f} s "
          f"(explore+render {t_gen:.2f} s, save {t_save:.2f} s), {frames} frames")
    print(f"  {per_frame * 1e3:.2f} ms per frame")
    print(f"  baseline, bare render of the same {BENCH_NAME} scene standing still: "
          f"{static * 1e3:.2f} ms per frame; ratio {per_frame / static:.2f}x")
    print(f"  baseline, bare render of an empty PyBullet scene: {empty * 1e3:.2f} ms per frame; "
          f"ratio {per_frame / empty:.2f}x")
    verdict = "within" if total <= BENCH_LIMIT_S else "OVER"
    print(f"  {verdict} the {BENCH_LIMIT_S:.0f} s target")
    return 0
