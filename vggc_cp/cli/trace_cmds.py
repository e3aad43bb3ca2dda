"""``vggc-cp inspect`` and ``vggc-cp evaluate``."""

from __future__ import annotations

import json

from vggc_cp.cli.options import add_i2p_options
from vggc_cp.errors import VggcError
from vggc_cp.evaluate import DYNAMICS, evaluate_trace
from vggc_cp.evaluate.paper_reading import CONSISTENCY, READINGS, evaluate_trace_paper
from vggc_cp.graph import check
from vggc_cp.solution import read_solution, verify_solution
from vggc_cp.trace import load_trace, summarize


def register(sub) -> None:
    p = sub.add_parser("inspect", help="validate a trace and print its facts")
    p.add_argument("trace", help="trace .npz")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=cmd_inspect)
    register_evaluate(sub)


def cmd_inspect(args) -> int:
    info = summarize(load_trace(args.trace))
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    print(f"trace          {args.trace}")
    print(f"observations   N = {info['observations']}  ({info['image_size'][0]}x{info['image_size'][1]} RGB)")
    print(f"transitions    |D| = {info['transitions']}")
    print(f"episodes       {info['episodes']}")
    print(f"actions        |A| = {info['actions']}")
    for name, count in info["action_counts"].items():
        print(f"  {name:<24} {count}")
    print(f"roles          pick {info['pick_observations']}, place {info['place_observations']}")
    if "distinct_states" in info:
        print(f"states         {info['distinct_states']} distinct ground-truth states")
    return 0


def register_evaluate(sub) -> None:
    p = sub.add_parser("evaluate", help="score a solution against the trace's ground truth")
    p.add_argument("trace", help="trace .npz with ground-truth 'states'")
    p.add_argument("solution", help="solution .json")
    p.add_argument("--queries", "-Q", type=int, default=1500, help="start/goal queries")
    p.add_argument("--seed", type=int, default=0, help="seed of the query sampler")
    p.add_argument("--dynamics", choices=DYNAMICS, default="auto",
                   help="true transitions for Exec: the simulator's (sim), the trace's (trace), "
                        "or sim when the trace names a benchmark (auto)")
    p.add_argument("--reading", choices=READINGS, default="exact",
                   help="exact: ours only (consistency from the labels; OptPath = every "
                        "shortest plan validates, AnyPath = some shortest plan); paper: also the "
                        "paper's metrics as the paper states them (OptPath = some shortest plan, "
                        "AnyPath = some plan of any length; consistency through --model's "
                        "predictions on the trace when given)")
    p.add_argument("--consistency", choices=CONSISTENCY, default=None,
                   help="--reading paper: C(u) holds every state mapped to u (all) or only "
                        "each node's majority state (default: all)")
    p.add_argument("--json", action="store_true", help="print JSON")
    add_i2p_options(p)
    p.set_defaults(func=cmd_evaluate)


def cmd_evaluate(args) -> int:
    if args.queries < 1:
        raise VggcError(f"--queries must be positive, got {args.queries}")
    if args.consistency is not None and args.reading != "paper":  # before any work
        raise VggcError("--consistency applies to --reading paper only")
    trace = load_trace(args.trace)
    solution = read_solution(args.solution)
    graph = verify_solution(solution, trace, args.solution, args.trace)
    loaded = i2p_inputs(args, trace, solution)  # --model / --novel checked before any work
    localizer = loaded[0] if loaded else _paper_localizer(args, solution)
    metrics, used = evaluate_trace(trace, graph, solution.labels, n_queries=args.queries,
                                   seed=args.seed, dynamics=args.dynamics)
    out = metrics.as_dict() | {"dynamics": used, "solver": solution.solver}
    if solution.extra.get("constraints") == "none":
        out["exactly_one_violations"] = len(check(graph).of_kind("exactly_one"))
    i2p = i2p_results(args, trace, solution, loaded)
    if i2p is not None:
        out["i2p"] = i2p
    calibration = _calibration(solution, out)
    if calibration is not None:
        out["warning"] = calibration
    paper = _paper_reading(args, trace, graph, solution, localizer)
    if paper is not None:
        out["paper_reading"] = paper.as_dict()
    if args.json:
        print(json.dumps(out, indent=2))
        return 0
    print(f"learned graph  {metrics.nodes} node{'' if metrics.nodes == 1 else 's'}, "
          f"{metrics.edges} edge{'' if metrics.edges == 1 else 's'} ({solution.solver}, "
          f"k = ({solution.k_pick}, {solution.k_place}), J = {solution.J:.4g})")
    print(f"true graph G*  {metrics.true_states} states, {metrics.true_edges} transitions")
    print(f"queries        Q = {metrics.queries} (seed {args.seed}); Exec on {used} dynamics")
    if "exactly_one_violations" in out:
        print(f"constraints    none claimed: {out['exactly_one_violations']} Exactly-One violations")
    if paper is None:
        for name, value in (("TransPrec", metrics.trans_prec), ("TransCov", metrics.trans_cov),
                            ("OptPath", metrics.opt_path), ("AnyPath", metrics.any_path),
                            ("Exec", metrics.exec)):
            print(f"{name:<14} {100 * value:6.2f} %")
    else:
        _print_both(metrics, paper)
    if i2p is not None:
        print_i2p(i2p)
    if calibration is not None:
        said = "suspect" if calibration["fired"] else "no warning"
        verdict = ("passes" if not calibration["misses"] else
                   "misses (" + "; ".join(calibration["misses"]) + ")")
        right = "right" if calibration["right"] else (
            "a false alarm" if calibration["fired"] else "WRONG: a silent failure")
        print(f"warning        solve said {said}; the graph {verdict} -> the warning was {right}")
    return 0


def _paper_localizer(args, solution):
    """The ``--model`` of ``--reading paper`` (its assignment map f), read and checked before
    any work; None without one."""
    if args.reading != "paper" or args.model is None:
        return None
    from vggc_cp.localize import check_model_matches, load_localizer

    localizer = load_localizer(args.model)
    check_model_matches(localizer, solution, args.model)
    return localizer


def _paper_reading(args, trace, graph, solution, localizer=None):
    """The paper's reading for ``--reading paper`` (None for ``exact``)."""
    if args.reading != "paper":
        if args.consistency is not None:
            raise VggcError("--consistency applies to --reading paper only")
        return None
    return evaluate_trace_paper(trace, graph, solution.labels, n_queries=args.queries,
                                seed=args.seed, consistency=args.consistency or "all",
                                localizer=localizer)


def _print_both(metrics, paper) -> None:
    """The four figures under both readings side by side, then Exec (ours only)."""
    f = "the localizer" if paper.assignment == "localizer" else "the labels"
    print(f"paper reading  f = {f} (agrees with the labels on {100 * paper.agreement:.2f} %), "
          f"C(u): {paper.consistency} states")
    print(f"{'':<14} {'exact':>8}   {'paper':>8}")
    for name, ours, theirs in (("TransPrec", metrics.trans_prec, paper.trans_prec),
                               ("TransCov", metrics.trans_cov, paper.trans_cov),
                               ("OptPath", metrics.opt_path, paper.opt_path),
                               ("AnyPath", metrics.any_path, paper.any_path)):
        print(f"{name:<14} {100 * ours:6.2f} %   {100 * theirs:6.2f} %")
    print(f"{'Exec':<14} {100 * metrics.exec:6.2f} %")


def _calibration(solution, metrics: dict) -> dict | None:
    """Whether ``solve``'s warning matched the graph's quality (the robustness study's pass
    rule), for solutions that record a confidence; None otherwise."""
    conf = solution.extra.get("confidence")
    if not isinstance(conf, dict) or not isinstance(conf.get("suspect"), bool):
        return None
    from vggc_cp.experiments.robustness import failures

    row = {"exec": metrics["exec"], "opt_path": metrics["opt_path"],
           "any_path": metrics["any_path"], "nodes": metrics["nodes"],
           "true_states": metrics["true_states"]}
    if isinstance(metrics.get("i2p"), dict):
        row["i2p"] = metrics["i2p"].get("i2p")
    misses = failures(row)
    fired = conf["suspect"]
    return {"fired": fired, "misses": misses, "right": fired == bool(misses)}


def register_bench(bench_sub) -> None:
    p = bench_sub.add_parser("evaluate", help="exact metrics vs plan enumeration, per query")
    p.add_argument("--trace", help="trace .npz (default: fruit-6x8, |D|=1500, seed 0, 32 px)")
    p.add_argument("--queries", "-Q", type=int, default=1500, help="start/goal queries")
    p.add_argument("--reference-queries", type=int, default=100,
                   help="queries the enumeration baseline runs")
    p.add_argument("--seed", type=int, default=0, help="seed of the query sampler")
    p.set_defaults(func=cmd_bench_evaluate)


def cmd_bench_evaluate(args) -> int:
    import time

    from vggc_cp.evaluate import GroundTruth, simulator_step
    from vggc_cp.evaluate.bench import bench_evaluate, coarse_labels

    if args.trace:
        trace = load_trace(args.trace)
    else:
        from vggc_cp.sim.explore import generate

        trace = generate("fruit-6x8", 1500, seed=0, size=32).trace
    gt = GroundTruth.from_trace(trace)
    step = simulator_step(trace, gt)
    print(f"trace: |D| = {trace.n_transitions}, {gt.n_states} states, Q = {args.queries}, "
          f"dynamics: {'sim' if step else 'trace'}")
    for name, labels in (("ground-truth labels", gt.obs_state),
                         ("states merged 2:1", coarse_labels(gt, trace.roles(), 2)),
                         ("states merged 4:1", coarse_labels(gt, trace.roles(), 4))):
        t0 = time.perf_counter()
        res = bench_evaluate(trace, labels, args.queries, args.reference_queries, args.seed,
                             step=step)
        total = time.perf_counter() - t0
        print(f"[{name}]")
        print(f"  exact product search : {res.exact_seconds:8.3f} s for {res.queries} queries "
              f"({1e3 * res.exact_per_query:.3f} ms/query)")
        print(f"  plan enumeration     : {res.reference_seconds:8.3f} s for "
              f"{res.reference_queries} queries ({1e3 * res.reference_per_query:.3f} ms/query)")
        print(f"  ratio (enumeration / exact, per query): {res.ratio:.1f}x; agree: {res.agree}; "
              f"wall {total:.2f} s")
    return 0


def i2p_inputs(args, trace, solution) -> tuple | None:
    """The localizer and novel renders of ``evaluate --model M --novel N``, read and checked
    (:func:`vggc_cp.evaluate.i2p.load_checkpoint`) before any work; None without them."""
    if getattr(args, "model", None) is None and getattr(args, "novel", None) is None:
        return None
    if args.model is None or args.novel is None:
        if args.novel is None and getattr(args, "reading", "exact") == "paper":
            return None  # --model alone: the paper reading's assignment map, no I2P
        raise VggcError("I2P evaluation needs both --model and --novel")
    if args.i2p_queries < 1:
        raise VggcError(f"--i2p-queries must be positive, got {args.i2p_queries}")
    from vggc_cp.evaluate.i2p import load_checkpoint

    return load_checkpoint(trace, solution, args.model, args.novel, args.trace)


def i2p_results(args, trace, solution, loaded: tuple | None) -> dict | None:
    """I2P figures for ``evaluate`` of what :func:`i2p_inputs` read (None without it)."""
    if loaded is None:
        return None
    from vggc_cp.evaluate.i2p import measure_checkpoint

    return measure_checkpoint(trace, solution, args.model, args.novel,
                              n_queries=args.i2p_queries, seed=args.seed,
                              dynamics=args.dynamics, trace_source=args.trace,
                              loaded=loaded).as_dict()


def print_i2p(d: dict) -> None:
    print(f"novel images   {d['images']}; I2P queries Q = {d['queries']}, Exec-I2P on "
          f"{d['dynamics']} dynamics")
    print(f"{'Localization':<14} {100 * d['localization']:6.2f} %")
    print(f"{'I2P':<14} {100 * d['i2p']:6.2f} %")
    print(f"{'Exec-I2P':<14} {100 * d['exec_i2p']:6.2f} %")
