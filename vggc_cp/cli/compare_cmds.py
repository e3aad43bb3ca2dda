"""``vggc-cp compare``: the greedy heuristic against the exact CP-SAT model, cell by cell.

Also provides the CP-SAT options and the sweep that ``vggc-cp solve --solver cpsat|both`` uses.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from vggc_cp.errors import VggcError


def add_cpsat_arguments(p) -> None:
    """The CP-SAT options shared by ``compare`` and ``solve``."""
    p.add_argument("--cpsat-params", default="", metavar="S",
                   help='OR-Tools CP-SAT parameters, "field:value,..." (default '
                        '"max_time_in_seconds:10,num_workers:2", per solved cell)')
    p.add_argument("--deterministic", action="store_true",
                   help="CP-SAT: one node and one action lead to one node")
    p.add_argument("--max-actions", type=int, default=None, metavar="K",
                   help="CP-SAT: at most K distinct actions leave a node")
    p.add_argument("--codeterministic", action="store_true",
                   help="CP-SAT: one action into a node comes from one node")
    p.add_argument("--cannot-link", type=float, default=None, metavar="D",
                   help="CP-SAT: observations farther apart than visual distance D never "
                        "share a node")
    p.add_argument("--objective", choices=("J", "none"), default="J",
                   help="CP-SAT: minimize the quantized visual score J or decide "
                        "feasibility only")
    p.add_argument("--hint", default=None, metavar="SOLUTION",
                   help="CP-SAT: a solution JSON of this trace (e.g. of a larger cell) offered "
                        "to every cell: a hint where valid, else merged into the cell's colours "
                        "and repaired by CP-SAT (a start, never a proof)")
    p.add_argument("--optimize", choices=("minimal", "all"), default="minimal",
                   help="CP-SAT cells whose J is minimized: those of the fewest feasible nodes "
                        "or every feasible cell")


def make_cpsat_solver(args, tau: float | None = None, n_obs: int | None = None):
    """The :class:`~vggc_cp.solvers.cpsat.CpSatSolver` of the parsed options (errors: exit 2).

    With ``n_obs`` (the trace's observation count) a ``--hint`` solution must label exactly that
    many observations.
    """
    from vggc_cp.solvers.cpsat import CpSatSolver

    greedy_options = {} if tau is None else {"tau": tau}
    hints = []
    if getattr(args, "hint", None):
        from vggc_cp.solution import read_solution

        labels = read_solution(args.hint).labels
        if n_obs is not None and len(labels) != n_obs:
            raise VggcError(f"{args.hint}: field 'labels' has {len(labels)} entries, the trace "
                            f"has {n_obs} observations")
        hints.append((f"--hint {args.hint}", labels))
    return CpSatSolver(objective=args.objective, deterministic=args.deterministic,
                       max_actions=args.max_actions, params=args.cpsat_params,
                       greedy_options=greedy_options, codeterministic=args.codeterministic,
                       cannot_link=args.cannot_link, hints=hints)


def cpsat_sweeps(problem, kp, kq, args, *, tau: float | None = None, jobs: int = 1,
                 select: str = "fewest", progress: bool = False):
    """``(greedy sweep, CP-SAT exact sweep)`` over one grid; the greedy one warm-starts CP-SAT."""
    from vggc_cp.solvers.cpsat import exact_sweep
    from vggc_cp.solvers.greedy import GreedySolver
    from vggc_cp.solvers.sweep import run_sweep

    solver = make_cpsat_solver(args, tau, n_obs=problem.n_obs)
    greedy = run_sweep(problem, GreedySolver(**solver.greedy_options), kp, kq, jobs=jobs,
                       select=select, progress=progress)
    exact = exact_sweep(problem, kp, kq, solver, greedy.results, optimize=args.optimize,
                        select=select, progress=progress)
    return greedy, exact


def register(sub) -> None:
    from vggc_cp.vision import add_distance_arguments

    p = sub.add_parser("compare", help="greedy vs exact CP-SAT over the (k_pick, k_place) grid")
    p.add_argument("trace", help="trace .npz")
    p.add_argument("--k-pick", default=None, metavar="A:B",
                   help="k_pick values, inclusive (default: derived from the actions)")
    p.add_argument("--k-place", default=None, metavar="A:B",
                   help="k_place values, inclusive (default: derived from the actions)")
    p.add_argument("--tau", type=float, default=None, help="greedy K_vis temperature")
    p.add_argument("--jobs", type=int, default=1, help="greedy sweep worker processes")
    p.add_argument("--csv", default=None, metavar="CSV", help="write the per-cell table")
    p.add_argument("--plot", default=None, metavar="PNG", help="draw the two grids side by side")
    p.add_argument("--quiet", action="store_true", help="no progress bars, no per-cell table")
    add_cpsat_arguments(p)
    add_distance_arguments(p)
    p.set_defaults(func=cmd_compare)


def _fmt(x, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if isinstance(x, float):
        return f"{x:.{digits}f}"
    return str(x)


def cmd_compare(args) -> int:
    import pandas as pd

    from vggc_cp.atomic import write_text
    from vggc_cp.solvers import Problem
    from vggc_cp.solvers.cpsat import compare_records, node_frontier
    from vggc_cp.solvers.sweep import action_counts, default_grid, parse_range
    from vggc_cp.trace import load_trace
    from vggc_cp.vision import compute_distances, config_from_args

    make_cpsat_solver(args, args.tau)  # bad --cpsat-params fail before any work
    if args.max_actions is not None and args.max_actions < 1:
        raise VggcError(f"--max-actions must be at least 1, got {args.max_actions}")
    trace = load_trace(args.trace)
    t0 = time.perf_counter()
    dist_pick, dist_place = compute_distances(trace, config_from_args(args),
                                              progress=not args.quiet)
    t_dist = time.perf_counter() - t0
    problem = Problem.from_trace(trace, dist_pick, dist_place)
    dp, dq = default_grid(problem)
    kp = parse_range(args.k_pick, "--k-pick") if args.k_pick else dp
    kq = parse_range(args.k_place, "--k-place") if args.k_place else dq
    greedy, exact = cpsat_sweeps(problem, kp, kq, args, tau=args.tau, jobs=args.jobs,
                                 progress=not args.quiet)
    rows = compare_records(greedy, exact)
    table = pd.DataFrame.from_records(rows)
    print(f"trace          {args.trace}: |D| = {trace.n_transitions}, pick {problem.n_pick}, "
          f"place {problem.n_place}; distances {t_dist:.1f} s")
    print(f"grid           k_pick {kp.start}..{kp.stop - 1} x k_place {kq.start}..{kq.stop - 1}"
          f" = {len(rows)} cells; greedy {greedy.seconds:.1f} s, CP-SAT {exact.seconds:.1f} s")
    if not args.quiet:
        # greedy_feasible (greedy_J is "-" without a colouring), greedy_seconds and the model
        # sizes stay in --csv: the printed table keeps within 120 characters
        shown = table.drop(columns=["greedy_feasible", "greedy_seconds", "variables",
                                    "constraints"], errors="ignore")
        for col in ("greedy_J", "cpsat_J", "bound", "gap"):
            shown[col] = [_fmt(v) for v in shown[col]]
        shown = shown.rename(columns={"cpsat_status": "status", "cpsat_seconds": "cpsat_s"})
        print(shown.to_markdown(index=False, disable_numparse=True))
    counts = table["cpsat_status"].value_counts().to_dict()
    print("CP-SAT cells   " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    both = table[table["greedy_feasible"] & table["cpsat_J"].notna()]
    better = int((both["cpsat_J"] < both["greedy_J"] - 1e-9).sum())
    only_cp = table[~table["greedy_feasible"] & table["cpsat_J"].notna()]
    print(f"greedy         colouring in {int(table['greedy_feasible'].sum())} cells; CP-SAT "
          f"lower J in {better} of {len(both)} shared cells; colouring where greedy has none: "
          f"{len(only_cp)} cells")
    need = max(*action_counts(problem), 1)
    cp_front = node_frontier(exact, need=need)
    g_front = node_frontier(greedy, proof=exact, need=need)
    for name, front, sweep in (("greedy", g_front, greedy), ("cpsat", cp_front, exact)):
        best = sweep.best
        if front.nodes is None:
            print(f"{name:<14} no colouring in the grid")
            continue
        print(f"{name:<14} fewest nodes {front.nodes} in cells {list(front.cells)}; proved "
              f"minimal: {front.verdict}; selected ({best.k_pick}, "
              f"{best.k_place}) J {best.J:.4f} {best.status}")
    if args.csv:
        write_text(args.csv, table.to_csv(index=False))
        print(f"csv            {args.csv}")
    if args.plot:
        from vggc_cp.plots import plot_compare_grids

        k1, k2, j_greedy = greedy.j_matrix()
        _, _, j_cpsat = exact.j_matrix()
        status = {(r.k_pick, r.k_place): r.status for r in exact.results}
        sel = [None if s.best is None else (s.best.k_pick, s.best.k_place)
               for s in (greedy, exact)]
        plot_compare_grids(k1, k2, j_greedy, j_cpsat, status, args.plot, selected=sel,
                           title=f"{Path(args.trace).name}: greedy vs CP-SAT")
        print(f"plot           {args.plot}")
    return 0
