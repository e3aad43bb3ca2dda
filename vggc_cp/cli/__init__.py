"""The ``vggc-cp`` command line: parses, calls the library, prints. Nothing else.

Each module in :data:`COMMAND_MODULES` contributes sub-commands through
``register(subparsers)`` and, optionally, benchmark targets of ``vggc-cp bench`` through
``register_bench(bench_subparsers)``. A sub-command sets ``func(args) -> int``.
"""

from __future__ import annotations

import argparse
import importlib
import signal
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


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Every option's help ends with its default, unless there is nothing to show.

    Nothing is added when the default is None, False or empty (the help says in words what
    happens then) or when the help already speaks of its default (``%(default)s`` or
    ``(default ...``), so no help reads ``(default 2) (default: 2)``.
    """

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default
        if (default is None or default is False or default is argparse.SUPPRESS
                or (isinstance(default, (str, list, tuple)) and not default)
                or "%(default" in text or "(default" in text):
            return text
        return super()._get_help_string(action)


def iter_parsers(parser: argparse.ArgumentParser, prefix: str = "vggc-cp"):
    """Yield ``(name, parser)`` for ``parser`` and every sub-command parser below it."""
    yield prefix, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            seen = set()
            for name, child in action.choices.items():
                if id(child) not in seen:  # aliases share one parser
                    seen.add(id(child))
                    yield from iter_parsers(child, f"{prefix} {name}")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vggc-cp",
        description="Learn discrete pick/place task graphs from RGB traces (VGGC + CP-SAT).",
        formatter_class=HelpFormatter,
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
    for _name, each in iter_parsers(parser):
        each.formatter_class = HelpFormatter  # every --help shows the defaults
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run one command; bad input: one line, exit 2; SIGINT/SIGTERM/SIGHUP: exit 130/143/129
    within about a second, temporary files removed (:mod:`vggc_cp.interrupts`)."""
    from vggc_cp.interrupts import exit_code, guard, received

    try:
        with guard():
            try:
                parser = build_parser()
                args = parser.parse_args(argv)
                from vggc_cp.safeio import preflight

                preflight(args)  # inputs and outputs checked before any work
                code = int(args.func(args) or 0)
            except VggcError as exc:
                if received() is None:
                    print(f"vggc-cp: error: {_one_line(str(exc))}", file=sys.stderr)
                code = 2
            except KeyboardInterrupt:  # a SIGINT before the handler was installed, or ours
                code = exit_code(received() or signal.SIGINT)
            except SystemExit:
                if received() is None:
                    raise  # argparse's --help / usage errors
                code = exit_code(received())
            if received() is not None:  # never swallowed, whoever caught it on the way
                from vggc_cp.interrupts import announce
                from vggc_cp.safeio import cleanup_temps

                cleanup_temps()
                announce(received())
                code = exit_code(received())
            return code
    except KeyboardInterrupt:  # a second Ctrl-C while unwinding
        return exit_code(received() or signal.SIGINT)


def _one_line(text: str) -> str:
    """An error message on one line (control characters of file names escaped)."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
