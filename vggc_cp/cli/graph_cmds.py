"""``vggc-cp show``, ``vggc-cp report`` and ``vggc-cp export``: a learned graph for eyes and
for other tools."""

from __future__ import annotations

from pathlib import Path

from vggc_cp.errors import VggcError

SHOW_FORMATS = ("png", "svg", "html")


def register(sub) -> None:
    p = sub.add_parser("show", help="draw a solution's graph, each node as its most typical "
                                    "observation (PNG, SVG or HTML)")
    p.add_argument("solution", help="solution .json")
    p.add_argument("trace", help="the trace .npz it was learned on")
    p.add_argument("-o", "--output", required=True, metavar="OUT",
                   help="graph.png, graph.svg or graph.html (by the suffix)")
    p.add_argument("--plan-from", type=int, default=None, metavar="I",
                   help="highlight the shortest plan from the node of observation I ...")
    p.add_argument("--plan-to", type=int, default=None, metavar="J",
                   help="... to the node of observation J")
    p.set_defaults(func=cmd_show)

    p = sub.add_parser("report", help="one self-contained HTML page about a solution: graph, "
                                      "threshold path, confidence, nodes, warnings")
    p.add_argument("solution", help="solution .json")
    p.add_argument("trace", help="the trace .npz it was learned on")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="report .html")
    p.set_defaults(func=cmd_report)

    from vggc_cp.export import EXPORTERS  # the package registers every format

    p = sub.add_parser("export", help="write a solution's graph for other tools: networkx "
                                      "JSON, GraphML, DOT, PDDL")
    p.add_argument("solution", help="solution .json")
    p.add_argument("--to", required=True, metavar="FORMAT",
                   help="; ".join(f"{k}: {v.help}" for k, v in EXPORTERS.items()))
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="file to write")
    p.add_argument("--start-obs", type=int, default=None, metavar="I",
                   help="pddl: the start is the node of observation I")
    p.add_argument("--goal-obs", type=int, default=None, metavar="J",
                   help="pddl: the goal is the node of observation J")
    p.set_defaults(func=cmd_export)


def _node_of(labels, i: int | None, opt: str, source: str) -> int | None:
    if i is None:
        return None
    n = len(labels)
    if not 0 <= i < n:
        raise VggcError(f"{opt} {i} is out of range: {source} labels {n} observations "
                        f"(0..{n - 1})")
    return int(labels[i])


def _solution_and_trace(args):
    """The solution, checked against its trace, the trace, and the induced graph."""
    from vggc_cp.solution import read_solution, verify_solution
    from vggc_cp.trace import load_trace

    solution = read_solution(args.solution)
    trace = load_trace(args.trace)
    graph = verify_solution(solution, trace, args.solution, args.trace)
    return solution, trace, graph


def _picture(args, solution, trace, graph, plan=()):
    from vggc_cp.frames import StreamedFrames, gather
    from vggc_cp.graph_plots import GraphPicture, doubt_pairs, pixel_medoids
    from vggc_cp.report import strip_members

    medoids = pixel_medoids(trace.observations, graph.members)
    frames = trace.observations
    if isinstance(frames, StreamedFrames):  # the images shown, read in one pass of the file
        frames = gather(frames, [i for u in graph.nodes for i in
                                 strip_members(graph.members[u], medoids.get(u))])
    return GraphPicture(graph, frames, medoids, list(plan), doubt_pairs(solution.extra, graph),
                        f"{Path(args.trace).name}: {graph.n_nodes} nodes, {graph.n_edges} edges")


def cmd_show(args) -> int:
    fmt = Path(args.output).suffix.lstrip(".").lower()
    if fmt not in SHOW_FORMATS:
        raise VggcError(f"{args.output}: -o: {fmt or 'no suffix'!r} is not one of "
                        f"{', '.join(SHOW_FORMATS)}")
    if (args.plan_from is None) != (args.plan_to is None):
        raise VggcError("--plan-from and --plan-to go together")
    solution, trace, graph = _solution_and_trace(args)
    plan = []
    if args.plan_from is not None:
        from vggc_cp.graph import shortest_plan

        start = _node_of(solution.labels, args.plan_from, "--plan-from", args.solution)
        goal = _node_of(solution.labels, args.plan_to, "--plan-to", args.solution)
        plan = shortest_plan(graph, start, goal)
        if plan is None:
            raise VggcError(f"--plan-to {args.plan_to}: node {goal} is unreachable from node "
                            f"{start}")
    from vggc_cp.graph_plots import save_graph

    save_graph(_picture(args, solution, trace, graph, plan), args.output)
    print(f"graph          {graph.n_nodes} nodes, {graph.n_edges} edges"
          + (f", plan of {len(plan)} actions highlighted" if args.plan_from is not None else ""))
    print(f"wrote          {args.output}")
    return 0


def cmd_report(args) -> int:
    if Path(args.output).suffix.lower() not in (".html", ".htm"):
        raise VggcError(f"{args.output}: -o: a report is an .html file")
    solution, trace, graph = _solution_and_trace(args)
    from vggc_cp.atomic import write_text
    from vggc_cp.report import report_html

    text = report_html(_picture(args, solution, trace, graph), solution.extra,
                       solution_name=str(args.solution), trace_name=str(args.trace))
    write_text(args.output, text)
    print(f"report         {graph.n_nodes} nodes, {len(text) / 1024:.0f} KiB")
    print(f"wrote          {args.output}")
    return 0


def cmd_export(args) -> int:
    from vggc_cp.export import ExportRequest, export_graph, get_exporter, output_paths
    from vggc_cp.safeio import check_output
    from vggc_cp.solution import read_solution, verify_standalone

    exporter = get_exporter(args.to)
    given = [o for o, v in (("--start-obs", args.start_obs), ("--goal-obs", args.goal_obs))
             if v is not None]
    if exporter.needs_start_goal and len(given) < 2:
        raise VggcError(f"--to {args.to} needs --start-obs and --goal-obs")
    if given and not exporter.needs_start_goal:
        raise VggcError(f"{given[0]} applies to --to pddl, not to --to {args.to}")
    solution = read_solution(args.solution)
    verify_standalone(solution, args.solution)
    graph = solution.edge_graph()
    start = _node_of(solution.labels, args.start_obs, "--start-obs", args.solution)
    goal = _node_of(solution.labels, args.goal_obs, "--goal-obs", args.solution)
    request = ExportRequest(start=start, goal=goal, name=Path(args.solution).stem)
    for suffix, path in output_paths(args.output, ("", "-problem.pddl")
                                     if exporter.needs_start_goal else ("",)).items():
        if suffix:
            check_output(path, "the problem file", {"solution": args.solution})
    for path in export_graph(graph, args.to, args.output, request):
        print(f"wrote          {path}")
    return 0
