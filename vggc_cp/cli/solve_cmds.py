"""``vggc-cp solve``, ``vggc-cp plan`` and ``vggc-cp bench sweep``: parse, call the library, print."""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from pathlib import Path

from vggc_cp.cli.options import (
    add_backend_arguments,
    add_cpsat_arguments,
    add_distance_arguments,
    add_image_plan_options,
    cluster_from_args,
    config_from_args,
    cpsat_solver_from_args,
    wants_image_plan,
)
from vggc_cp.errors import VggcError

#: ``solve``'s solver when none is named: the pipeline (:mod:`vggc_cp.pipeline`): evidence,
#: congruence-closure merging over thresholds, least description length, confidence.
DEFAULT_SOLVER = "merge"
#: ``solve`` options that only the grid solvers read: refused under ``--solver merge``.
GRID_ONLY = ("k_pick", "k_place", "jobs", "tau", "plot", "deterministic", "max_actions",
             "codeterministic", "cannot_link", "objective", "hint", "optimize")
#: ``solve`` options that only the merge solver reads: refused under the grid solvers.
MERGE_ONLY = ("evidence", "thresholds", "exact", "fallback")
BENCH_NAME = "fruit-4x6"
BENCH_TRANSITIONS = 700
BENCH_LIMIT_S = 120.0


def register(sub) -> None:
    from vggc_cp.solvers import SOLVERS
    from vggc_cp.solvers import greedy as _greedy  # noqa: F401  (registers "greedy")
    from vggc_cp.solvers.merge import PATH_SELECTIONS
    from vggc_cp.solvers.sweep import SELECTIONS
    from vggc_cp.vision.evidence import evidence_names

    p = sub.add_parser("solve", help="learn a task graph with the default pipeline (visual "
                                     "evidence, merging over thresholds, least description "
                                     "length, confidence; --solver greedy|cpsat for the "
                                     "paper's (k_pick, k_place) grid); writes the solution JSON",
                       description="Learn the task graph of a trace and write its solution "
                                   "JSON. By default the pipeline of vggc_cp.pipeline: action "
                                   "footprints (or attention distances) as visual evidence, "
                                   "congruence-closure merging over a grid of thresholds, "
                                   "least description length, and a confidence check. "
                                   "--solver greedy, cpsat, both or brute sweep the paper's "
                                   "(k_pick, k_place) grid instead.")
    p.add_argument("trace", help="trace .npz")
    p.add_argument("-o", "--output", required=True, help="solution .json to write")
    p.add_argument("--solver", default=DEFAULT_SOLVER,
                   help=f"colouring solver: {', '.join(sorted(SOLVERS))}, or both (greedy, then "
                        f"CP-SAT warm-started by it; cpsat does the same) (default "
                        f"{DEFAULT_SOLVER}: the rule whose plans execute best on the seven "
                        f"benchmarks; greedy with --select fewest is the paper's VGGC)")
    p.add_argument("--k-pick", default=None, metavar="A:B",
                   help="k_pick values, inclusive (default: derived from the actions; "
                        "grid solvers only)")
    p.add_argument("--k-place", default=None, metavar="A:B",
                   help="k_place values, inclusive (default: derived from the actions)")
    p.add_argument("--jobs", type=int, default=1, help="parallel worker processes")
    p.add_argument("--tau", type=float, default=None,
                   help="K_vis temperature (default: per role, the median within-role distance)")
    p.add_argument("--select", default=None,
                   help=f"selection rule: over the k grid {', '.join(sorted(SELECTIONS))} "
                        f"(default fewest); over the merge solver's thresholds "
                        f"{', '.join(sorted(PATH_SELECTIONS))} (default mdl)")
    p.add_argument("--thresholds", default=None, metavar="T1,T2,...",
                   help="merge solver: visual-distance thresholds to try (default: a geometric "
                        "grid from the noise scale of nearest-neighbour distances to the 90th "
                        "percentile of all distances)")
    p.add_argument("--evidence", default="auto", metavar="NAME",
                   help="merge solver: the visual evidence; auto (action footprints; where "
                        "they cannot read the trace, the keypoint attention distances: see "
                        "--fallback), attention (the Sinkhorn distances of --attention), or a "
                        f"registered evidence: {', '.join(evidence_names())}")
    p.add_argument("--fallback", default=None, choices=("refused", "suspect", "never"),
                   help="merge solver, --evidence auto: when the keypoint evidence runs after "
                        "the footprints: refused (default: only where the footprints cannot "
                        "read the trace), suspect (also where their graph is suspect; costs "
                        "the keypoint Sinkhorn distances), never")
    p.add_argument("--exact", action="store_true",
                   help="merge solver: also ask CP-SAT for the fewest nodes under the merge's "
                        "constraints (determinism, co-determinism, Exactly-One, its widest "
                        "within-node distance as cannot-link) and report whether merge is "
                        "node-minimal")
    p.add_argument("--plot", default=None, metavar="PNG", help="draw J over the grid")
    p.add_argument("--table", choices=("pivot", "cells", "none"), default="pivot",
                   help="print the grid as J per cell (pivot), one row per cell with "
                        "feasible, status, J, seconds (cells), or not at all")
    p.add_argument("--quiet", action="store_true", help="no progress bars, no grid table")
    p.add_argument("--timings", action="store_true",
                   help="record wall-clock seconds in the solution file (off by default, so "
                        "the same inputs give the same bytes)")
    distance = add_distance_arguments(p)
    add_cpsat_arguments(p)
    add_backend_arguments(p, "the grid solvers' distance blocks and cells, and the merge "
                             "path's evidence blocks")
    p.set_defaults(func=cmd_solve, distance_options=distance, option_defaults={
        d: p.get_default(d) for d in (*GRID_ONLY, *MERGE_ONLY, *distance, "cpsat_params")})

    q = sub.add_parser("plan", help="shortest pick/place plan on a solution's graph between the "
                                    "nodes of two trace observations (or two images)")
    q.add_argument("solution", help="solution .json")
    q.add_argument("--start-obs", type=int, default=None, metavar="I",
                   help="index of the start observation in the solved trace")
    q.add_argument("--goal-obs", type=int, default=None, metavar="J",
                   help="index of the goal observation in the solved trace")
    add_image_plan_options(q)
    q.add_argument("--json", action="store_true",
                   help="print the plan as one JSON object (nodes, found, length, actions, "
                        "steps) instead of text")
    q.set_defaults(func=cmd_plan)


def register_bench(bench_sub) -> None:
    p = bench_sub.add_parser(
        "solve", help="time the default solve against the previous default (saliency "
                      "Sinkhorn + cascade) on one trace, in one run (default: fruit-6x8, "
                      "|D| = 1500, seed 0)",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--trace", default=None, help="trace .npz; none: generate fruit-6x8 at the paper's |D|")
    p.add_argument("--seed", type=int, default=0, help="seed of the generated trace")
    p.add_argument("--limit", type=float, default=2.0,
                   help="the largest acceptable ratio of the default to the previous default")
    p.add_argument("--fallback-limit", type=float, default=1.5,
                   help="the largest acceptable ratio of the default to the footprint "
                        "evidence alone")
    p.add_argument("--repeats", type=int, default=3,
                   help="runs of the default and of the footprint evidence alone, "
                        "alternately; each keeps its fastest")
    p.set_defaults(func=cmd_bench_solve)

    p = bench_sub.add_parser(
        "sweep", help=f"time the whole greedy sweep on {BENCH_NAME} at |D|={BENCH_TRANSITIONS} "
                      f"(distances cached): jobs=2 against jobs=1")
    p.add_argument("--transitions", type=int, default=BENCH_TRANSITIONS,
                   help="|D| of the generated trace")
    p.add_argument("--seed", type=int, default=0, help="seed of the generated trace")
    p.add_argument("--cache-dir", default=None,
                   help="where the generated trace is kept (default $VGGC_CP_CACHE/bench or "
                        "./.cache/vggc-cp/bench); distances use their own cache")
    p.add_argument("--jobs", type=int, default=2, help="workers of the timed sweep")
    p.set_defaults(func=cmd_bench_sweep)


# ------------------------------------------------------------------ solve


def _config_record(cfg) -> dict | str:
    if dataclasses.is_dataclass(cfg):
        return {k: v if isinstance(v, (int, float, str, bool, type(None))) else repr(v)
                for k, v in dataclasses.asdict(cfg).items()}
    return repr(cfg)


def _make_solver(name: str, tau: float | None):
    from vggc_cp.solvers import get_solver

    options = {} if tau is None else {"tau": tau}
    try:
        return get_solver(name, **options)
    except TypeError:
        raise VggcError(f"solver {name!r} takes no --tau") from None
    except ValueError as exc:
        raise VggcError(f"solver {name!r}: {exc}") from None


def _grid_ranges(k_pick: str | None, k_place: str | None) -> tuple[range | None, range | None]:
    """``--k-pick`` / ``--k-place`` as ranges (None: the default grid of the problem)."""
    from vggc_cp.solvers.sweep import parse_range

    return (parse_range(k_pick, "--k-pick") if k_pick else None,
            parse_range(k_place, "--k-place") if k_place else None)


def check_solver_name(name: str) -> None:
    """Refuse an unknown ``--solver`` before any work, listing every valid name (``both`` too)."""
    from vggc_cp.errors import lookup
    from vggc_cp.solvers import SOLVERS

    lookup({**SOLVERS, "both": None}, name, "solver")


def _refuse_inapplicable(args) -> None:
    """Refuse an option that the chosen solver would silently ignore."""
    defaults = getattr(args, "option_defaults", {})

    def given(dest: str) -> bool:
        return dest in defaults and getattr(args, dest) != defaults[dest]

    def flag(dest: str) -> str:
        return "--" + dest.replace("_", "-")

    if args.solver == "merge":
        for dest in GRID_ONLY:
            if given(dest):
                raise VggcError(f"{flag(dest)} applies to the grid solvers (--solver greedy, "
                                f"cpsat, both, brute), not to --solver merge")
        if given("cpsat_params") and not args.exact:
            raise VggcError("--cpsat-params applies to --solver merge only with --exact")
        if given("fallback") and args.evidence != "auto":
            raise VggcError(f"--fallback applies to --evidence auto, not to --evidence "
                            f"{args.evidence}")
        if args.evidence == "footprints":
            for dest in getattr(args, "distance_options", ()):
                if given(dest):
                    raise VggcError(f"{flag(dest)} applies to the attention distances "
                                    f"(--evidence auto or attention), not to --evidence "
                                    f"footprints")
    else:
        for dest in MERGE_ONLY:
            if given(dest):
                raise VggcError(f"{flag(dest)} applies to --solver merge, not to --solver "
                                f"{args.solver}")


def cmd_solve(args) -> int:
    from vggc_cp.pipeline import grid_sweep
    from vggc_cp.solvers.sweep import get_selection

    check_solver_name(args.solver)
    _refuse_inapplicable(args)
    if args.solver == "merge":
        return _solve_merge(args)
    args.select = args.select or "fewest"
    get_selection(args.select)  # unknown names fail before any work
    exact = args.solver in ("cpsat", "both")
    if exact:
        cpsat_solver_from_args(args, args.tau)  # bad --cpsat-params fail before any work
    else:
        solver = _make_solver(args.solver, args.tau)
    k_pick, k_place = _grid_ranges(args.k_pick, args.k_place)
    with cluster_from_args(args) as cluster:
        trace, cfg, problem, t_dist = _problem(args, cluster)
        if exact:
            solver = cpsat_solver_from_args(args, args.tau, n_obs=problem.n_obs)
        grid = grid_sweep(problem, solver, k_pick, k_place, jobs=args.jobs, select=args.select,
                          optimize=args.optimize, progress=not args.quiet, executor=cluster)
    greedy, sweep, kp, kq = grid.greedy, grid.sweep, grid.k_pick, grid.k_place
    if exact and args.solver == "both" and greedy.best is not None:
        g = greedy.best
        print(f"greedy         selected k_pick {g.k_pick}, k_place {g.k_place}: "
              f"{g.n_nodes} nodes, J {g.J:.4f} ({greedy.seconds:.1f} s)")
    n_found = sum(r.found for r in sweep.results)
    print(f"trace          {args.trace}: {trace.n_obs} observations, |D| = "
          f"{trace.n_transitions}, pick {problem.n_pick}, place {problem.n_place}")
    print(f"distances      {t_dist:.1f} s")
    print(f"sweep          {sweep.solver}, k_pick {kp.start}..{kp.stop - 1} x k_place "
          f"{kq.start}..{kq.stop - 1}: {len(sweep.results)} cell{'' if len(sweep.results) == 1 else 's'}, "
          f"{n_found} with a colouring, "
          f"{sweep.seconds:.1f} s (jobs {args.jobs})")
    if not args.quiet and args.table == "cells":
        table = sweep.table()[["k_pick", "k_place", "feasible", "status", "J", "seconds",
                               "nodes", "selected"]]
        print(table.to_markdown(index=False, floatfmt=".4f"))
    elif not args.quiet and args.table == "pivot":
        print("J per cell (- no colouring, * selected):")
        print(sweep.pivot_text())
    if args.plot:
        from vggc_cp.plots import plot_sweep_grid

        k1, k2, J = sweep.j_matrix()
        best = sweep.best
        plot_sweep_grid(k1, k2, J, args.plot,
                        selected=None if best is None else (best.k_pick, best.k_place),
                        title=f"{Path(args.trace).name}: J over the grid ({sweep.solver})")
        print(f"plot           {args.plot}")
    best = sweep.best
    if best is None:
        from vggc_cp.solvers.base import INFEASIBLE

        proved = sum(r.status == INFEASIBLE for r in sweep.results)
        undecided = len(sweep.results) - proved
        why = (f"{proved} proved infeasible, {undecided} undecided (CP-SAT out of time or the "
               f"greedy heuristic gave up)" if undecided else "all proved infeasible")
        hint = ("try larger --k-pick/--k-place" if not undecided else
                "try larger --k-pick/--k-place, --solver cpsat, or a longer time limit "
                "(--cpsat-params max_time_in_seconds:...)")
        raise VggcError(f"no cell of the grid has a colouring ({len(sweep.results)} cells: "
                        f"{why}); {hint}; nothing written")
    _write_chosen(args, trace, cfg, problem, best, f"k_pick {best.k_pick}, k_place "
                  f"{best.k_place} ({args.select})", select=args.select, grid=sweep.records(),
                  seconds={"distances": round(t_dist, 3), "sweep": round(sweep.seconds, 3)})
    return 0


def _problem(args, executor=None):
    """Load the trace and compute (or reuse) its distances (row blocks on ``executor``):
    ``(trace, cfg, problem, seconds)``."""
    from vggc_cp.pipeline import visual_problem
    from vggc_cp.trace import load_trace

    trace = load_trace(args.trace)
    cfg = config_from_args(args)
    vp = visual_problem(trace, cfg, progress=not args.quiet, executor=executor)
    return trace, cfg, vp.problem, vp.seconds


def _write_chosen(args, trace, cfg, problem, best, how: str, **extra) -> None:
    """Write the chosen result as the solution JSON and print its summary line."""
    from vggc_cp.learned import solution_record
    from vggc_cp.solution import jsonable, write_solution

    graph = problem.graph(best.labels)
    data = solution_record(problem, best, distances=_config_record(cfg), trace=str(args.trace),
                           trace_sha256=trace.content_hash(), stats=jsonable(best.stats),
                           **extra)
    write_solution(args.output, data, timings=getattr(args, "timings", False))
    counts = graph.count_by_role()
    print(f"chosen         {how}: {graph.n_nodes} nodes ({counts['pick']} pick, "
          f"{counts['place']} place), {graph.n_edges} edges, J {best.J:.4f}, {best.status}")
    print(f"wrote          {args.output}")


def _parse_thresholds(text: str | None) -> list[float] | None:
    if text is None:
        return None
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise VggcError(f"--thresholds {text!r}: expected comma-separated numbers") from None
    if not values or any(not v > 0 for v in values):
        raise VggcError(f"--thresholds {text!r}: expected positive numbers")
    return values


def _learn_options(args):
    """The :class:`~vggc_cp.learned.LearnConfig` of ``solve``'s merge options (it refuses an
    unknown evidence or rule, naming the known ones)."""
    from vggc_cp.learned import LearnConfig

    thresholds = _parse_thresholds(args.thresholds)
    return LearnConfig(evidence=args.evidence, distance=config_from_args(args),
                       rule=args.select or "mdl",
                       thresholds=None if thresholds is None else tuple(thresholds),
                       fallback=getattr(args, "fallback", None) or "refused")


def _solve_merge(args) -> int:
    """``solve --solver merge``: the pipeline's evidence, merge path, selection, confidence."""
    from vggc_cp.pipeline import learn_graph
    from vggc_cp.recorded import recorded_facts
    from vggc_cp.trace import load_trace

    options = _learn_options(args)
    trace = load_trace(args.trace)
    with cluster_from_args(args) as executor:  # --backend dask: the evidence's blocks there
        learned = learn_graph(trace, options, progress=not args.quiet, executor=executor)
    chosen = learned.chosen
    problem, path = chosen.problem, chosen.path
    print(f"trace          {args.trace}: {trace.n_obs} observations, |D| = "
          f"{trace.n_transitions}, pick {problem.n_pick}, place {problem.n_place}")
    facts = recorded_facts(trace)
    if facts.appended:
        print(f"recorded       {len(facts.resets)} reset(s), {len(facts.refusals)} refused "
              f"action(s) (meta.appended): read as facts")
    if facts.undo:
        print(f"recorded       {len(facts.undo)} undo pair(s) (meta.undo): a graph that "
              f"breaks one is flagged")
    if facts.sites:
        print(f"recorded       {len(facts.sites)} site(s) (meta.sites): a node that takes two "
              f"picks or two places of one is flagged")
    for note in learned.skipped:
        print(f"evidence       skipped {note}")
    for cand in learned.candidates:
        mark = "*" if cand is chosen else " "
        print(f"evidence     {mark} {cand.evidence:<11} {cand.best.n_nodes} nodes, description "
              f"length {cand.description_length:.1f}, "
              f"{'suspect' if cand.confidence.suspect else 'no warning'} ({cand.seconds:.1f} s)")
        for note in cand.notes:
            print(f"               {note}")
    n = len(path.results)
    print(f"merge path     {n} threshold{'' if n == 1 else 's'}, {path.seconds:.1f} s")
    if not args.quiet and args.table != "none":
        import pandas as pd

        table = pd.DataFrame(learned.path_records())[["threshold", "nodes", "k_pick",
                                                      "k_place", "description_length",
                                                      "selected"]]
        print(table.to_markdown(index=False, floatfmt=".4f"))
    best = chosen.best
    extra = {}
    if args.exact:
        from vggc_cp.solvers.merge_exact import DEFAULT_PARAMS, exact_counterpart

        # CP-SAT reads the (n, n) matrices: a problem of descriptor codes builds them here
        dense = problem.dense() if hasattr(problem, "dense") else problem
        exact = exact_counterpart(dense, best, params=args.cpsat_params or DEFAULT_PARAMS,
                                  progress=not args.quiet)
        print(f"exact          CP-SAT under merge's constraints: {exact.summary()} "
              f"({exact.seconds:.1f} s)")
        extra = {"exact": {"minimal_nodes": exact.minimal_nodes, "proved": exact.proved,
                           "cannot_link": exact.cannot_link,
                           "seconds": round(exact.seconds, 3)}}
    conf = learned.confidence
    learned.save(args.output, timings=getattr(args, "timings", False), **extra)
    graph = learned.graph
    counts = graph.count_by_role()
    print(f"chosen         threshold {learned.threshold:.4f} ({path.rule}): {graph.n_nodes} "
          f"nodes ({counts['pick']} pick, {counts['place']} place), {graph.n_edges} edges, "
          f"J {best.J:.4f}, {best.status}{_cuts(best)}")
    print(f"wrote          {args.output}")
    files = f"{args.output} {args.trace}"  # the commands the reasons and notes suggest
    print(f"confidence     {conf.summary().replace('SOLUTION TRACE', files)}")
    _print_doubts(learned.doubts)
    if conf.suspect:
        reasons = "; ".join(conf.reasons).replace("SOLUTION TRACE", files)
        print(f"vggc-cp: warning: the learned graph is suspect ({reasons}); the doubts above "
              f"say which decisions", file=sys.stderr)
    return 0


def _cuts(best) -> str:
    """``"; N node(s) cut by the sites' readings"`` where the merge's graph was cut, and
    ``"; N lone episode(s) moved ..."`` where lone episodes were moved."""
    stats = best.stats or {}
    cuts, moved = int(stats.get("read_splits", 0)), int(stats.get("lone_moves", 0))
    return ((f"; {cuts} node(s) cut where the sites' readings show two states" if cuts else "")
            + (f"; {moved} lone episode(s) moved onto the path their actions walk"
               if moved else ""))


def _print_doubts(doubts) -> None:
    """The doubts table after the summary (``vggc-cp doubts`` draws them, ``suggest``
    proposes episodes to settle them)."""
    from vggc_cp.solvers.doubt_text import SHOWN_DOUBTS, format_doubts

    if not doubts:
        print("doubts         none: the images and the actions settle every decision")
        return
    print(f"doubts         {len(doubts)} decision(s) the trace does not settle, closest first "
          f"(draw: vggc-cp doubts; settle: vggc-cp suggest)")
    for line in format_doubts(doubts):
        print(f"  {line}")
    if len(doubts) > SHOWN_DOUBTS:
        print(f"  ... and {len(doubts) - SHOWN_DOUBTS} more in the solution (vggc-cp suggest "
              f"reads them all)")



# ------------------------------------------------------------------ plan


def cmd_plan(args) -> int:
    obs_given = args.start_obs is not None or args.goal_obs is not None
    if wants_image_plan(args):
        if obs_given:
            raise VggcError("give either --start-obs/--goal-obs or the image options, not both")
        return cmd_image_plan(args)
    if args.start_obs is None or args.goal_obs is None:
        raise VggcError("plan needs --start-obs and --goal-obs")
    from vggc_cp.graph import format_plan, shortest_plan
    from vggc_cp.solution import read_solution, verify_standalone
    from vggc_cp.trace import ROLE_NAMES

    solution = read_solution(args.solution)
    verify_standalone(solution, args.solution)  # unknown actions, roles, Exactly-One
    n = len(solution.labels)
    for opt, i in (("--start-obs", args.start_obs), ("--goal-obs", args.goal_obs)):
        if not 0 <= i < n:
            raise VggcError(f"{opt} {i} is out of range: {args.solution} labels {n} "
                            f"observations (0..{n - 1})")
    graph = solution.edge_graph()
    start, goal = int(solution.labels[args.start_obs]), int(solution.labels[args.goal_obs])
    role = {u: ROLE_NAMES[r] if r >= 0 else "mixed" for u, r in graph.node_role.items()}
    plan = shortest_plan(graph, start, goal)
    if args.json:
        found = plan is not None
        print(json.dumps({"start_obs": args.start_obs, "start": start, "start_role": role[start],
                          "goal_obs": args.goal_obs, "goal": goal, "goal_role": role[goal],
                          "found": found, "length": len(plan) if found else None,
                          "actions": [graph.action_names[a] for _, a, _ in plan or ()],
                          "steps": format_plan(graph, plan) if found else []}, indent=2))
        return 0 if found else 1
    print(f"start          observation {args.start_obs} -> node {start} ({role[start]})")
    print(f"goal           observation {args.goal_obs} -> node {goal} ({role[goal]})")
    if plan is None:
        print(f"plan           none: node {goal} is unreachable from node {start}")
        return 1
    print(f"plan           {len(plan)} action{'' if len(plan) == 1 else 's'}")
    for i, step in enumerate(format_plan(graph, plan), 1):
        print(f"  {i:>3}. {step}")
    return 0


def cmd_image_plan(args) -> int:
    """``vggc-cp plan solution.json --model m.pt --start a.png --goal b.png``."""
    from vggc_cp.localize import load_localizer, plan_images, read_image
    from vggc_cp.solution import read_solution, verify_standalone

    missing = [f"--{k}" for k in ("model", "start", "goal") if getattr(args, k, None) is None]
    if missing:
        raise VggcError(f"planning from images needs --model, --start and --goal "
                        f"(missing {', '.join(missing)})")
    solution = read_solution(args.solution)
    verify_standalone(solution, args.solution)
    localizer = load_localizer(args.model)
    start, goal = read_image(args.start), read_image(args.goal)
    result = plan_images(localizer, solution, start, goal, start_source=args.start,
                         goal_source=args.goal, solution_source=args.solution)
    if getattr(args, "json", False):
        print(json.dumps({"start": result.start, "start_confidence": result.start_confidence,
                          "goal": result.goal, "goal_confidence": result.goal_confidence,
                          "found": result.found, "length": len(result.actions) if result.found
                          else None, "actions": list(result.actions),
                          "steps": list(result.steps)}, indent=2))
        return 0 if result.found else 1
    print(f"start          node {result.start} (confidence {result.start_confidence:.3f}) "
          f"<- {args.start}")
    print(f"goal           node {result.goal} (confidence {result.goal_confidence:.3f}) "
          f"<- {args.goal}")
    if not result.found:
        print(f"plan           none: node {result.goal} is unreachable from node {result.start}")
        return 1
    n = len(result.actions)
    print(f"plan           {n} action{'' if n == 1 else 's'}")
    for i, step in enumerate(result.steps, 1):
        print(f"  {i:>3}. {step}")
    return 0


# ------------------------------------------------------------------ bench sweep


def _bench_trace(args):
    from vggc_cp.trace import load_trace, save_trace
    from vggc_cp.vision import CACHE_ENV

    env = os.environ.get(CACHE_ENV)
    root = Path(args.cache_dir) if args.cache_dir else \
        Path(env) / "bench" if env else Path(".cache") / "vggc-cp" / "bench"
    path = root / f"{BENCH_NAME}-d{args.transitions}-s{args.seed}.npz"
    if path.is_file():
        return load_trace(path), path, 0.0
    from vggc_cp.sim.explore import generate

    t0 = time.perf_counter()
    trace = generate(BENCH_NAME, args.transitions, args.seed).trace
    save_trace(trace, path)
    return trace, path, time.perf_counter() - t0


def cmd_bench_solve(args) -> int:
    from vggc_cp.experiments.perf import bench_solve
    from vggc_cp.trace import load_trace

    if args.repeats < 1:
        raise VggcError(f"--repeats must be at least 1, got {args.repeats}")
    if args.trace:
        trace, name = load_trace(args.trace), args.trace
    else:
        from vggc_cp.sim.explore import generate

        trace = generate("fruit-6x8", None, args.seed).trace
        name = f"fruit-6x8, |D| = {trace.n_transitions}, seed {args.seed} (generated)"
    t = bench_solve(trace.without_states(), repeats=args.repeats)
    print(f"solve          {name}: {trace.n_obs} observations; fastest of {t.repeats} runs "
          f"each of the default and the footprints alone")
    print(f"  default (pipeline, evidence {t.default_evidence}): {t.default_seconds:.1f} s, "
          f"{t.default_nodes} nodes{', suspect' if t.default_suspect else ''}")
    print(f"  footprints alone (--evidence footprints): {t.footprints_seconds:.1f} s, "
          f"{t.footprints_nodes} nodes")
    print(f"  baseline, previous default (saliency Sinkhorn, uncached, + cascade): "
          f"{t.previous_seconds:.1f} s, {t.previous_nodes} nodes")
    verdict = "within" if t.ratio <= args.limit else "OVER"
    print(f"  ratio {t.ratio:.2f}x: {verdict} the {args.limit:g}x target")
    fp_verdict = "within" if t.footprints_ratio <= args.fallback_limit else "OVER"
    print(f"  default / footprints alone {t.footprints_ratio:.2f}x: {fp_verdict} the "
          f"{args.fallback_limit:g}x target (what the fallback costs)")
    return 0


def cmd_bench_sweep(args) -> int:
    from vggc_cp.solvers import Problem
    from vggc_cp.solvers.greedy import GreedySolver
    from vggc_cp.solvers.sweep import default_grid, run_sweep
    from vggc_cp.vision import DistanceConfig, compute_distances

    if args.jobs < 1:
        raise VggcError(f"--jobs must be at least 1, got {args.jobs}")
    from vggc_cp.safeio import check_trace_budget

    check_trace_budget(args.transitions, 64, "--transitions")
    trace, path, t_gen = _bench_trace(args)
    how = f"generated in {t_gen:.1f} s" if t_gen else "cached"
    print(f"trace          {path} ({how})", file=sys.stderr)
    t0 = time.perf_counter()
    dist_pick, dist_place = compute_distances(trace, DistanceConfig(), progress=False)
    t_dist = time.perf_counter() - t0
    problem = Problem.from_trace(trace, dist_pick, dist_place)
    kp, kq = default_grid(problem)
    solver = GreedySolver()
    base = run_sweep(problem, solver, kp, kq, jobs=1)
    timed = run_sweep(problem, solver, kp, kq, jobs=args.jobs)
    same = all((a.status, a.n_nodes) == (b.status, b.n_nodes)
               for a, b in zip(base.results, timed.results))
    best = timed.best
    print(f"sweep {BENCH_NAME} |D|={trace.n_transitions} (pick {problem.n_pick}, place "
          f"{problem.n_place}), grid {kp.start}..{kp.stop - 1} x {kq.start}..{kq.stop - 1} "
          f"= {len(timed.results)} cells, distances {t_dist:.1f} s (cached after the first run)")
    print(f"  jobs={args.jobs}: {timed.seconds:.2f} s")
    print(f"  baseline, the same sweep inline (jobs=1): {base.seconds:.2f} s; "
          f"ratio {timed.seconds / base.seconds:.2f}x; same cells: {same}")
    if best is not None:
        print(f"  selected (fewest): k_pick {best.k_pick}, k_place {best.k_place}, "
              f"{best.n_nodes} nodes, J {best.J:.4f}")
    verdict = "within" if timed.seconds <= BENCH_LIMIT_S else "OVER"
    print(f"  {verdict} the {BENCH_LIMIT_S:.0f} s target")
    return 0
