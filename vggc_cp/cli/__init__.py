"""The ``vggc-cp`` command line: parses, calls the library, prints. Nothing else.

Each module in :data:`COMMAND_MODULES` contributes sub-commands through
``register(subparsers)`` and, optionally, benchmark targets of ``vggc-cp bench`` through
``register_bench(bench_subparsers)``. A sub-command sets ``func(args) -> int``.
"""

from __future__ import annotations

import argparse
import difflib
import functools
import importlib
import os
import re
import signal
import sys
from collections.abc import Sequence

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
    "vggc_cp.cli.graph_cmds",
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


def _did_you_mean(word: str, choices) -> str:
    """``"; did you mean X?"`` for the choice closest to ``word`` (difflib), or ``""``."""
    close = difflib.get_close_matches(word, [str(c) for c in choices], n=1, cutoff=0.6)
    return f"; did you mean {close[0]}?" if close else ""


class Parser(argparse.ArgumentParser):
    """The parser of ``vggc-cp`` and of every sub-command (sub-parsers inherit the class).

    * A prefix of an option is not taken for the option (``allow_abbrev=False``):
      ``--k-pi`` is an error, not ``--k-pick``.
    * An unknown option is reported by the sub-command it was given to, with its usage and
      the nearest option ("did you mean --k-pick?"); a mistyped choice (a command name, a
      ``choices`` value) gets the nearest choice too. Exit 2, as every argparse error.
    """

    def __init__(self, *args, allow_abbrev: bool = False, **kwargs):
        super().__init__(*args, allow_abbrev=allow_abbrev, **kwargs)

    def parse_known_args(self, args=None, namespace=None):
        self._given = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(args, namespace)

    def parse_args(self, args=None, namespace=None):
        namespace, extras = self.parse_known_args(args, namespace)
        if extras:
            self.chosen(namespace).error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace

    def chosen(self, namespace: argparse.Namespace) -> Parser:
        """The deepest sub-command parser that ``namespace`` went through (self if none)."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                child = action.choices.get(getattr(namespace, action.dest, None))
                if isinstance(child, Parser):
                    return child.chosen(namespace)
        return self

    def _hint(self, message: str) -> str:
        """The nearest choice of an invalid choice, else the nearest option of the first
        option given here that this parser does not know (a missing required argument may be
        a mistyped one)."""
        found = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)$", message)
        if found:
            return _did_you_mean(found.group(1), re.findall(r"'([^']*)'", found.group(2)))
        known = {o for a in self._actions for o in a.option_strings}
        for word in getattr(self, "_given", ()):
            if word == "--":
                break
            flag = word.split("=", 1)[0]
            if flag.startswith("--") and flag not in known:
                hint = _did_you_mean(flag, sorted(o for o in known if o.startswith("--")))
                return hint if "unrecognized" in message else (
                    f" ({flag} is not an option{hint})" if hint else f" ({flag} is not an option)")
        return ""

    def error(self, message: str):
        if "did you mean" not in message:
            message += self._hint(message)
        super().error(message)


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


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser of ``vggc-cp``, built afresh on every call.

    Without ``argv``, every sub-command. With the command line ``argv``, only the module that
    registers the sub-command (or ``bench`` target) it names contributes, which parses, helps
    and refuses ``argv`` exactly as the whole tree would: the whole tree costs about 25 ms
    (gettext and the terminal's size for each of its 37 parsers and 300 options) and
    :func:`main` builds one per call, which tests do hundreds of times. A command line that
    names no known sub-command (an option, a typo, ``bench`` alone) gets the whole tree, for
    the usage and the nearest choice.

    Fresh rather than kept: a registry entry added since the last call (an importer's new
    layout) is there, and nothing one parse leaves on a parser (the defaults it handed out,
    ``Parser._given``) reaches the next.
    """
    if argv is not None:
        owner = _owners().get(_named(argv))
        if owner is not None:
            parser, owners = _build(owner)
            if _named(argv) in owners:  # else the module no longer registers it
                return parser
    return _build()[0]


def _named(argv: Sequence[str]) -> tuple[str, ...]:
    """What ``argv`` names: ``(command,)``, ``("bench", target)``, or ``()``."""
    words = list(argv[:2])
    return tuple(words) if words[:1] == ["bench"] and len(words) == 2 else tuple(words[:1])


@functools.cache
def _owners() -> dict[tuple[str, ...], tuple[str, bool]]:
    """Which module registers each sub-command, and whether as a ``bench`` target (learned
    from one whole tree per process; :func:`build_parser` checks each use)."""
    return _build()[1]


def _build(only: tuple[str, bool] | None = None):
    """The parser with every module's sub-commands, or only those ``only`` names (a module,
    and whether its ``bench`` targets); and the ``_named`` key -> ``only`` of each one built."""
    parser = Parser(
        prog="vggc-cp",
        description="Learn discrete pick/place task graphs from RGB traces (VGGC + CP-SAT).",
        epilog="Start here: `vggc-cp solve TRACE.npz -o solution.json` runs the default "
               "pipeline; then `vggc-cp plan solution.json --start-obs I --goal-obs J`. "
               "Each command's own --help describes it.",
        formatter_class=HelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    bench = sub.add_parser("bench", help="benchmarks that print ratios against a baseline")
    bench_sub = bench.add_subparsers(dest="target", metavar="TARGET")
    bench_sub.required = True
    owners: dict[tuple[str, ...], tuple[str, bool]] = {}
    for name in COMMAND_MODULES:
        module = importlib.import_module(name)
        if only in (None, (name, False)):
            owners.update(_registered(module.register, sub, (), (name, False)))
        if hasattr(module, "register_bench") and only in (None, (name, True)):
            owners.update(_registered(module.register_bench, bench_sub, ("bench",),
                                      (name, True)))
    for _name, each in iter_parsers(parser):
        each.formatter_class = HelpFormatter  # every --help shows the defaults
    return parser, owners


def _registered(register, action, prefix: tuple[str, ...], owner: tuple[str, bool]) -> dict:
    """Call ``register(action)``; the ``_named`` key of each sub-command it added -> ``owner``."""
    before = set(action.choices)
    register(action)
    return {(*prefix, new): owner for new in action.choices if new not in before}


def _pipe_closed() -> int:
    """Exit code 141 (128 + SIGPIPE) after the standard output's reader went away; what
    is still buffered for it goes nowhere, so the interpreter's last flush cannot fail too,
    and temporary output files are removed."""
    from vggc_cp.safeio import cleanup_temps

    cleanup_temps()
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # a replaced stdout (a test's capture)
        pass
    return 141


def main(argv: list[str] | None = None) -> int:
    """Run one command; bad input: one line, exit 2; SIGINT/SIGTERM/SIGHUP: exit 130/143/129
    within about a second, temporary files removed (:mod:`vggc_cp.interrupts`)."""
    from vggc_cp.interrupts import exit_code, guard, received

    try:
        with guard():
            try:
                if argv is None:
                    argv = sys.argv[1:]
                args = build_parser(argv).parse_args(argv)
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
            except BrokenPipeError:
                # the reader of our output went away (`vggc-cp inspect T | head`): stop as a
                # SIGPIPE would, without a traceback and without half-written outputs
                code = _pipe_closed()
            except Exception:
                if received() is None:
                    raise
                # after a signal, the error is its doing: a library turned the interrupt into
                # another exception on the way (numpy comparing structured arrays in np.unique
                # re-raises it as a TypeError)
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


def run() -> None:
    """The command-line entry point (``vggc-cp``, ``python -m vggc_cp``): :func:`main`, then
    the exit. After a signal the process ends at once (``os._exit``, streams flushed): a
    stage's worker threads may still be running, and the interpreter's shutdown would wait for
    them or abort on them."""
    try:
        code = main()
    except KeyboardInterrupt:  # a Ctrl-C that reached the top while the command unwound
        code = 130
    from vggc_cp.interrupts import end_children, received

    if received() is not None:
        end_children()  # workers stop as a Ctrl-C stops them: no temporary file left
        from vggc_cp.safeio import cleanup_temps

        cleanup_temps()
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(code)
    try:
        sys.stdout.flush()  # what is still buffered, while a closed pipe can be answered
    except BrokenPipeError:
        code = _pipe_closed()
    sys.exit(code)


def _one_line(text: str) -> str:
    """An error message on one line (control characters of file names escaped)."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
