"""``vggc-cp inspect`` and ``vggc-cp evaluate``."""

from __future__ import annotations

import json

from vggc_cp.trace import load_trace, summarize


def register(sub) -> None:
    p = sub.add_parser("inspect", help="validate a trace and print its facts")
    p.add_argument("trace", help="trace .npz")
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=cmd_inspect)


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
