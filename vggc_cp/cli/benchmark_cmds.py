"""``vggc-cp baseline`` (run one baseline on a trace) and ``vggc-cp benchmark`` (Table 1)."""

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
    p.set_defaults(func=cmd_baseline)


def cmd_baseline(args) -> int:
    cls = lookup(BASELINES, args.name, "baseline")
    options = parse_params(cls.config_class, args.param)
    trace = load_trace(args.trace)
    result = get_baseline(args.name, config=cls.config_class(**options)).fit(trace)
    write_solution(args.output, baseline_solution(trace, result))
    v = result.stats["violations"]
    print(f"{result.solver}: {v['nodes']} nodes ({v['pick_nodes']} pick, {v['place_nodes']} "
          f"place), {v['edges']} edges, {v['exactly_one']} Exactly-One violations "
          f"({v['exactly_one_transitions']} transitions), {result.seconds:.1f} s")
    print(f"selected  {result.stats['params']}")
    print(f"sweep     {len(result.stats['grid'])} points, rule: {result.stats['selection']}")
    print(f"wrote     {args.output}")
    return 0
