"""The ``vggc-cp`` command line: parses, calls the library, prints. Nothing else.

Each module in :data:`COMMAND_MODULES` contributes sub-commands through
``register(subparsers)`` and, optionally, benchmark targets of ``vggc-cp bench`` through
``register_bench(bench_subparsers)``. A sub-command sets ``func(args) -> int``.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from vggc_cp.errors import VggcError

COMMAND_MODULES = [
    "vggc_cp.cli.trace_cmds",
    "vggc_cp.cli.vision_cmds",
    "vggc_cp.cli.sim_cmds",
    "vggc_cp.cli.solve_cmds",
    "vggc_cp.cli.localize_cmds",
    "vggc_cp.cli.benchmark_cmds",
    "vggc_cp.cli.notebook_cmds",
    "vggc_cp.cli.compare_cmds",
    "vggc_cp.cli.robustness_cmds",
]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vggc-cp",
        description="Learn discrete pick/place task graphs from RGB traces (VGGC + CP-SAT).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    bench = sub.add_parser("bench", help="benchmarks that print ratios against a baseline")
    bench_sub = bench.add_subparsers(dest="target", metavar="TARGET")
    bench_sub.required = True
    for name in COMMAND_MODULES:
        module = importlib.import_module(name)
        module.register(sub)
        if hasattr(module, "register_bench"):
            module.register_bench(bench_sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except VggcError as exc:
        print(f"vggc-cp: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("vggc-cp: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
