"""The ``vggc-cp`` command line: parses, calls the library, prints. Nothing else.

Each module in :data:`COMMAND_MODULES` contributes sub-commands through
``register(subparsers)`` and, optionally, benchmark targets of ``vggc-cp bench`` through
``register_bench(bench_subparsers)``. A sub-command sets ``func(args) -> int``.
"""

from __future__ import annotations

import argparse
import contextlib
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
    "vggc_cp.cli.import_cmds",
    "vggc_cp.cli.verdict_cmds",
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


def _on_signal(signum, _frame):
    """SIGTERM (and SIGHUP): remove the temporary files of writes in progress, then exit."""
    from vggc_cp.atomic import cleanup_temps

    cleanup_temps()
    print(f"vggc-cp: terminated by signal {signum}", file=sys.stderr)
    raise SystemExit(128 + signum)


@contextlib.contextmanager
def _signal_handlers():
    """Install :func:`_on_signal` for SIGTERM/SIGHUP while a command runs (main thread only)."""
    saved = {}
    try:
        for sig in (signal.SIGTERM, getattr(signal, "SIGHUP", None)):
            if sig is not None:
                saved[sig] = signal.signal(sig, _on_signal)
    except ValueError:  # not the main thread: leave signals alone
        pass
    try:
        yield
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)


def main(argv: list[str] | None = None) -> int:
    from vggc_cp.atomic import cleanup_temps

    try:
        with _signal_handlers():
            parser = build_parser()
            args = parser.parse_args(argv)
            from vggc_cp.safeio import preflight

            preflight(args)  # inputs and outputs checked before any work
            return int(args.func(args) or 0)
    except VggcError as exc:
        print(f"vggc-cp: error: {_one_line(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        cleanup_temps()
        print("vggc-cp: interrupted", file=sys.stderr)
        return 130


def _one_line(text: str) -> str:
    """An error message on one line (control characters of file names escaped)."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
