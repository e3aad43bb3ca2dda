"""``vggc-cp notebook``: execute a research notebook with parameters."""

from __future__ import annotations

import ast
from pathlib import Path

from vggc_cp.errors import VggcError


def register(sub) -> None:
    p = sub.add_parser(
        "notebook", help="execute a notebook with parameters, write its outputs",
        description="Execute a notebook with parameters. The input is never overwritten: without "
                    "-o the executed copy is written next to it as X.executed.ipynb.")
    p.add_argument("notebook", help=".ipynb with a cell tagged 'parameters'")
    p.add_argument("-p", "--param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter (VALUE is a Python literal); repeatable")
    p.add_argument("-o", "--output",
                   help="executed notebook (default: X.executed.ipynb next to the input X.ipynb)")
    p.add_argument("--timeout", type=int, default=3600, help="seconds per cell")
    p.set_defaults(func=cmd_notebook)


def parse_params(items: list[str]) -> dict:
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or not name.isidentifier():
            raise VggcError(f"--param {item!r}: expected NAME=VALUE")
        try:
            out[name] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            out[name] = value
    return out


def default_output(notebook: str) -> Path:
    """Where an executed notebook goes without ``-o``: ``X.executed.ipynb`` beside ``X.ipynb``.

    The input (usually a tracked notebook) is never overwritten; an executed copy given as
    input is rewritten in place rather than growing a second ``.executed`` suffix.
    """
    path = Path(notebook)
    if path.name.endswith(".executed.ipynb"):
        return path
    stem = path.name[:-len(".ipynb")] if path.name.endswith(".ipynb") else path.name
    return path.with_name(f"{stem}.executed.ipynb")


def cmd_notebook(args) -> int:
    from vggc_cp.notebooks import run_notebook

    output = args.output or default_output(args.notebook)
    run = run_notebook(args.notebook, parse_params(args.param), output, timeout=args.timeout)
    print(f"executed {run.path} ({run.cells} cells) in {run.seconds:.1f} s -> {run.output}")
    return 0
