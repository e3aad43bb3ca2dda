"""``vggc-cp notebook``: execute a research notebook with parameters."""

from __future__ import annotations

import ast
import math
from pathlib import Path

from vggc_cp.errors import VggcError

#: longest VALUE of one ``-p NAME=VALUE`` (characters)
MAX_PARAM_CHARS = 10_000
#: longest ``--timeout`` (seconds per cell): a week
MAX_TIMEOUT = 7 * 24 * 3600


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
    p.add_argument("--timeout", type=int, default=3600,
                   help=f"seconds per cell, 1 to {MAX_TIMEOUT}")
    p.set_defaults(func=cmd_notebook)


def _plain(value, where: str):
    """``value`` when it is made of None, bool, int, finite float, str, list, tuple and dict
    (what the executed notebook's JSON metadata can record); else a refusal."""
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise VggcError(f"{where}: {value!r} is not a finite number")
        return value
    if isinstance(value, (list, tuple)):
        return type(value)(_plain(v, where) for v in value)
    if isinstance(value, dict):
        return {_plain(k, where): _plain(v, where) for k, v in value.items()}
    raise VggcError(f"{where}: a {type(value).__name__} value is not accepted (numbers, strings, "
                    f"True/False/None, lists, tuples and dicts of them)")


def parse_params(items: list[str]) -> dict:
    """``["x=5", "name=abc"]`` -> ``{"x": 5, "name": "abc"}`` (a VALUE that is no Python
    literal is a string)."""
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        shown = item if len(item) <= 60 else item[:60] + "..."
        if not sep or not name.isidentifier():
            raise VggcError(f"--param {shown!r}: expected NAME=VALUE")
        if len(value) > MAX_PARAM_CHARS:
            raise VggcError(f"--param {name}: the value has {len(value):,} characters, above the "
                            f"cap of {MAX_PARAM_CHARS:,} (notebook_cmds.MAX_PARAM_CHARS)")
        if not value.isprintable():
            raise VggcError(f"--param {name}: the value holds control characters")
        try:
            parsed = ast.literal_eval(value)
        except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
            parsed = value
        out[name] = _plain(parsed, f"--param {name}")
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

    if not 1 <= args.timeout <= MAX_TIMEOUT:
        raise VggcError(f"--timeout {args.timeout}: expected seconds per cell from 1 to "
                        f"{MAX_TIMEOUT}")
    params = parse_params(args.param)
    output = args.output or default_output(args.notebook)
    run = run_notebook(args.notebook, params, output, timeout=args.timeout)
    print(f"executed {run.path} ({run.cells} cells) in {run.seconds:.1f} s -> {run.output}")
    return 0
