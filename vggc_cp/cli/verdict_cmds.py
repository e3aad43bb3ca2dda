"""``vggc-cp doubts`` and ``vggc-cp suggest``: the decisions a solution doubts, drawn, and the
episodes to record next to settle them."""

from __future__ import annotations

from vggc_cp.errors import VggcError


def register(sub) -> None:
    p = sub.add_parser("doubts", help="draw a solution's doubts: the observations of each "
                                      "side, side by side, with the evidence")
    p.add_argument("solution", help="solution .json (from `vggc-cp solve`)")
    p.add_argument("trace", help="the trace .npz it was learned on")
    p.add_argument("-o", "--output", required=True,
                   help="image to write (.png); nothing is written when there is no doubt")
    p.add_argument("--first", type=int, default=10, metavar="N",
                   help="draw the N most pressing doubts (a solution lists up to 40); 0: all")
    p.set_defaults(func=cmd_doubts)

    p = sub.add_parser("suggest", help="propose episodes to record that would settle a "
                                       "solution's doubts (vggc-episodes/1 JSON)")
    p.add_argument("solution", help="solution .json (from `vggc-cp solve`)")
    p.add_argument("trace", help="the trace .npz it was learned on")
    p.add_argument("-o", "--output", required=True, help="episodes .json to write")
    p.add_argument("--max-episodes", type=int, default=20, metavar="N",
                   help="most episodes proposed (best first)")
    p.add_argument("--per-doubt", type=int, default=3, metavar="K",
                   help="most probing actions per doubt and direction")
    p.set_defaults(func=cmd_suggest)


def _load(args):
    """The solution, its doubts and the trace it was learned on (checked against it)."""
    from vggc_cp.solution import read_solution, verify_solution
    from vggc_cp.solvers.doubts import parse_doubts
    from vggc_cp.trace import load_trace

    solution = read_solution(args.solution)
    trace = load_trace(args.trace).without_states()
    verify_solution(solution, trace, args.solution, args.trace)
    doubts = parse_doubts(solution.extra.get("doubts"), args.solution)
    nodes = set(solution.labels.tolist())
    for k, d in enumerate(doubts):
        for u in d.nodes:
            if u not in nodes:
                raise VggcError(f"{args.solution}: field 'doubts[{k}].nodes' names node {u}, "
                                f"which no observation has")
        for side in d.observations:
            for o in side:
                if o >= trace.n_obs:
                    raise VggcError(f"{args.solution}: field 'doubts[{k}].observations' "
                                    f"names observation {o}, the trace has {trace.n_obs}")
    return solution, doubts, trace


def cmd_doubts(args) -> int:
    from vggc_cp.sim.sheet import pair_sheet
    from vggc_cp.solvers.doubt_text import doubt_caption

    if args.first < 0:
        raise VggcError(f"--first must be at least 0 (0: all), got {args.first}")
    _solution, doubts, trace = _load(args)
    if not doubts:
        print(f"{args.solution}: no doubts (the images and the actions settle every decision, "
              f"or the solution predates doubts); nothing written")
        return 0
    drawn = doubts[:args.first] if args.first else doubts
    rows = [(list(d.observations[0]), list(d.observations[1]), doubt_caption(k, d))
            for k, d in enumerate(drawn)]
    pair_sheet(trace, rows, args.output, _read_outlines(trace, drawn))
    of = f" of {len(doubts)}" if len(drawn) < len(doubts) else ""
    print(f"wrote {args.output} ({len(drawn)}{of} doubt(s))")
    return 0


def _read_outlines(trace, doubts) -> list | None:
    """For every doubt, the footprint sites of its ``read_sites`` summed (what only a
    reading of the images sets apart: outlined on the sheet), else None; None for all when
    no doubt has them (the footprints are computed only then)."""
    if not any(isinstance(d.evidence.get("read_sites"), list) for d in doubts):
        return None
    from vggc_cp.vision.footprints import action_footprints

    sites = action_footprints(trace.without_states()).sites
    index = {name: a for a, name in enumerate(trace.action_names)}
    out = []
    for d in doubts:
        names = d.evidence.get("read_sites")
        taken = [index[n] for n in names if n in index] if isinstance(names, list) else []
        out.append(sites[taken].sum(axis=0) if taken else None)
    return out


def cmd_suggest(args) -> int:
    import json

    from vggc_cp.atomic import write_text
    from vggc_cp.solvers.suggest import episodes_document, suggest_episodes

    if args.max_episodes < 1:
        raise VggcError(f"--max-episodes must be at least 1, got {args.max_episodes}")
    if args.per_doubt < 1:
        raise VggcError(f"--per-doubt must be at least 1, got {args.per_doubt}")
    solution, doubts, trace = _load(args)
    proposals = suggest_episodes(trace, solution.labels, doubts, args.max_episodes,
                                 args.per_doubt)
    doc = episodes_document(trace, proposals, args.solution)
    write_text(args.output, json.dumps(doc, indent=1) + "\n")
    total = sum(len(p.actions) for p in proposals)
    print(f"{len(doubts)} doubt(s) -> {len(proposals)} episode(s), {total} transitions")
    for p in proposals[:10]:
        print(f"  doubt {p.doubt}: from observation {p.start_observation}: "
              f"{' '.join(p.actions)}")
    print(f"wrote {args.output}")
    return 0
