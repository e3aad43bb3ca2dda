"""``vggc-cp distances``, ``vggc-cp show-attention`` and ``vggc-cp bench distance``."""

from __future__ import annotations

import sys

import numpy as np

from vggc_cp.errors import VggcError


def register(sub) -> None:
    from vggc_cp.cli.options import add_backend_arguments, add_distance_arguments
    from vggc_cp.vision import ATTENTION_BACKENDS

    p = sub.add_parser("distances", help="compute (or load) the within-role visual distances of "
                                         "a trace and cache them")
    p.add_argument("trace", help="trace .npz")
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    add_distance_arguments(p)
    add_backend_arguments(p, "the Sinkhorn row blocks of --distance-rows")
    p.set_defaults(func=cmd_distances)

    s = sub.add_parser("show-attention", help="draw attention maps over their images")
    s.add_argument("trace", help="trace .npz")
    s.add_argument("-i", "--indices", default="0", metavar="I,J,...",
                   help="observation indices (comma-separated)")
    s.add_argument("-o", "--output", required=True, help="PNG to write")
    s.add_argument("--attention", default="saliency", metavar="NAME",
                   help=f"attention backend: {', '.join(sorted(ATTENTION_BACKENDS))}")
    s.add_argument("--weights", default=None, metavar="PATH",
                   help="DINOv2 weights file (default $VGGC_CP_DINOV2_WEIGHTS)")
    s.add_argument("--grid", type=int, default=16, help="patch grid side")
    s.add_argument("--floor", type=float, default=0.01, help="uniform floor")
    s.set_defaults(func=cmd_show_attention)


def register_bench(bench_sub) -> None:
    b = bench_sub.add_parser(
        "distance", help="pairs/s of our batched Sinkhorn divergence vs a naive ot.sinkhorn2 "
                         "loop and POT's batched solver, on the same pairs")
    b.add_argument("--trace", default=None,
                   help="take saliency maps of this trace (default: synthetic blob maps)")
    b.add_argument("--pairs", type=int, default=20000, help="pairs timed for ours")
    b.add_argument("--naive-pairs", type=int, default=60,
                   help="first pairs timed for the naive loop")
    b.add_argument("--batch-pairs", type=int, default=16,
                   help="first pairs timed for POT's batched solver")
    b.add_argument("--batch-size", type=int, default=16,
                   help="problems per ot.batch call (default 16, POT's fastest here: a "
                        "batch iterates until its slowest problem converges)")
    b.add_argument("--maps", type=int, default=600, help="synthetic maps")
    b.add_argument("--grid", type=int, default=16, help="patch grid side")
    b.add_argument("--eps", type=float, default=0.05, help="entropic regularisation")
    b.add_argument("--tol", type=float, default=1e-6, help="marginal tolerance")
    b.add_argument("--threads", type=int, default=2, help="CPU threads of ours")
    b.add_argument("--device", default="torch", help="device of ours")
    b.add_argument("--seed", type=int, default=0, help="seed of the synthetic maps and the timed pairs")
    b.set_defaults(func=cmd_bench_distance)


def cmd_distances(args) -> int:
    from vggc_cp.cli.options import cluster_from_args, config_from_args
    from vggc_cp.trace import load_trace
    from vggc_cp.vision import compute_distances_full

    cfg = config_from_args(args)
    trace = load_trace(args.trace)
    with cluster_from_args(args) as cluster:
        res = compute_distances_full(trace, cfg, progress=not args.quiet, executor=cluster)
    where = str(res.path) if res.path is not None else "(not cached: --no-cache)"
    print(f"trace          {args.trace}")
    print(f"attention      {cfg.backend} on a {cfg.grid}x{cfg.grid} grid, eps {cfg.eps:g}")
    print(f"distances      {'loaded from' if res.cached else 'written to'} {where}")
    for name, d in (("pick", res.dist_pick), ("place", res.dist_place)):
        m = len(d)
        off = d[np.triu_indices(m, k=1)]
        if off.size:
            print(f"{name:<6} {m:>6} obs, {off.size} pairs: min {off.min():.4g}, median "
                  f"{np.median(off):.4g}, mean {off.mean():.4g}, max {off.max():.4g}")
        else:
            print(f"{name:<6} {m:>6} obs, no pairs")
    if not res.cached:
        sec = res.stats.get("seconds", {})
        print(f"seconds        attention {sec.get('attention', 0):.2f}, sinkhorn "
              f"{sec.get('sinkhorn', 0):.2f}")
        groups = [("", res.stats)] + [(f" hue {k[7:]}", v) for k, v in res.stats.items()
                                      if k.startswith("colour_") and isinstance(v, dict)]
        for group, role in ((g, r) for g in groups for r in ("pick", "place")):
            st = group[1].get(role)
            if st:
                print(f"sinkhorn {role:<5}{group[0]} {st['problems']} problems, "
                      f"{st['iterations_mean']:.1f} iterations on average (max "
                      f"{st['iterations_max']}), max marginal error "
                      f"{st['max_marginal_error']:.1e}, {st['unconverged']} unconverged, "
                      f"{st['mode']} on {st['device']}")
    return 0


#: most observations one show-attention picture draws
MAX_INDICES = 64


def parse_indices(text: str, n: int) -> list[int]:
    """``"0,5,9"`` -> ``[0, 5, 9]``, each in ``[0, n)``, at most :data:`MAX_INDICES`; a clear
    error otherwise."""
    out = []
    parts = text.split(",", MAX_INDICES + 1)
    if len(parts) > MAX_INDICES:
        raise VggcError(f"--indices: more than {MAX_INDICES} indices, above the cap of "
                        f"{MAX_INDICES} (vision_cmds.MAX_INDICES)")
    for part in parts:
        part = part.strip()
        try:
            i = int(part)
        except ValueError:
            raise VggcError(f"--indices: {part[:40]!r} is not an integer") from None
        if not 0 <= i < n:
            raise VggcError(f"--indices: observation {i} is out of range [0, {n - 1}]")
        out.append(i)
    if not out:
        raise VggcError("--indices: no index given")
    return out


def cmd_show_attention(args) -> int:
    from vggc_cp.safeio import check_grid
    from vggc_cp.trace import ROLE_NAMES, load_trace
    from vggc_cp.vision import AttentionConfig, attention_maps
    from vggc_cp.vision.attention import SALIENCY_BACKENDS
    from vggc_cp.vision.overlay import draw_attention

    trace = load_trace(args.trace)
    idx = parse_indices(args.indices, trace.n_obs)
    params = AttentionConfig(grid=args.grid, floor=args.floor, weights=args.weights)
    if args.grid < 2:
        raise VggcError(f"--grid must be at least 2, got {args.grid}")
    if not 0 < args.floor < 1:
        raise VggcError(f"--floor must lie in (0, 1), got {args.floor}")
    check_grid(trace, args.grid)
    if args.attention in SALIENCY_BACKENDS:  # the background is the trace's
        maps = attention_maps(trace.observations, args.attention, params)[idx]
    else:
        maps = attention_maps(trace.observations[idx], args.attention, params)
    roles = trace.roles()
    titles = [f"o{i} ({ROLE_NAMES[roles[i]]})" for i in idx]
    draw_attention(trace.observations[idx], maps, titles, args.output)
    print(f"wrote {args.output} ({len(idx)} image{'' if len(idx) == 1 else 's'}, {args.attention} on a "
          f"{args.grid}x{args.grid} grid)")
    return 0


def cmd_bench_distance(args) -> int:
    from vggc_cp.vision.bench import random_pairs, run_bench, synthetic_maps

    rng = np.random.default_rng(args.seed)
    if args.trace:
        from vggc_cp.trace import load_trace
        from vggc_cp.vision import AttentionConfig, attention_maps

        trace = load_trace(args.trace)
        maps = attention_maps(trace.observations, "saliency", AttentionConfig(grid=args.grid))
        maps = maps[np.flatnonzero(trace.roles() == 0)]
        source = f"saliency maps of the pick observations of {args.trace}"
    else:
        maps = synthetic_maps(args.maps, args.grid, rng)
        source = f"{args.maps} synthetic blob maps"
    if len(maps) < 2:
        raise VggcError("bench distance: fewer than two maps")
    pairs = random_pairs(len(maps), args.pairs, rng)
    print(f"maps           {source}, {args.grid}x{args.grid} grid, eps {args.eps:g}, "
          f"tol {args.tol:g}", file=sys.stderr)
    res = run_bench(maps, pairs, args.eps, tol=args.tol, naive_pairs=args.naive_pairs,
                    batch_pairs=args.batch_pairs, batch_size=args.batch_size,
                    threads=args.threads, device=args.device,
                    log=lambda s: print(s, file=sys.stderr))
    print("pairs/s at our OT problems per pair (cross term + amortised self terms):")
    print(f"ours           {res.ours_pairs_per_s:10.1f} pairs/s  ({res.pairs} pairs)")
    print(f"naive          {res.naive_pairs_per_s:10.1f} pairs/s  ({res.naive_pairs} pairs, "
          f"ot.sinkhorn2 loop)")
    print(f"POT batched    {res.batch_pairs_per_s:10.1f} pairs/s  ({res.batch_pairs} pairs, "
          f"ot.batch.solve_batch)")
    print(f"ratio naive    {res.ratio_naive:10.1f}x  (target >= 20x)")
    print(f"ratio batched  {res.ratio_batch:10.1f}x  (target >= 2x)")
    print(f"max rel diff   {max(res.max_rel_diff_naive, res.max_rel_diff_batch):.2e}  "
          f"(vs naive {res.max_rel_diff_naive:.2e}, vs batched {res.max_rel_diff_batch:.2e})")
    return 0
