"""The command line starts light (issue 25): building the parser and printing any ``--help``
imports none of :data:`vggc_cp.experiments.perf.HEAVY_MODULES` (a command imports what it
needs when it runs), checked in fresh interpreters by the modules they import, never by a
timed assertion; ``vggc-cp bench startup`` reports the same and the seconds."""

from __future__ import annotations

import json

import pytest

from vggc_cp.cli import build_parser, iter_parsers, main
from vggc_cp.experiments.perf import HEAVY_MODULES, heavy_among, imported_modules, run_python

#: Builds the parser and formats every sub-command's help, in a fresh interpreter.
WALK = """
import json, sys
from vggc_cp.cli import build_parser, iter_parsers
names = []
for name, parser in iter_parsers(build_parser()):
    parser.format_help()
    names.append(name)
print(json.dumps({"names": names, "modules": sorted(sys.modules)}))
"""


def test_no_help_of_any_sub_command_imports_a_heavy_module():
    """Every registered sub-command (a new command module is walked as soon as it is in
    ``COMMAND_MODULES``)."""
    res = run_python(["-c", WALK])
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert set(out["names"]) == {name for name, _ in iter_parsers(build_parser())}
    assert {"vggc-cp solve", "vggc-cp plan", "vggc-cp bench startup"} <= set(out["names"])
    heavy = heavy_among(out["modules"])
    assert heavy == (), f"building the parser imports {heavy}: import them where they are used"


def test_help_through_main_imports_no_heavy_module():
    """Through :func:`vggc_cp.cli.main`, as ``vggc-cp plan --help`` runs it."""
    modules = imported_modules(("plan", "--help"))
    assert "vggc_cp.cli.solve_cmds" in modules and "numpy" in modules  # the command was built
    assert heavy_among(modules) == ()


def test_the_check_sees_heavy_packages_by_their_top_name():
    assert heavy_among(["numpy", "torch.nn", "pandas", "otter", "vggc_cp.ot"]) == \
        ("pandas", "torch")
    assert {"torch", "ortools", "pybullet", "matplotlib", "pandas", "ot", "scipy", "sklearn",
            "dask"} <= set(HEAVY_MODULES)


@pytest.mark.slow  # six fresh interpreters
def test_bench_startup_prints_seconds_ratio_and_imports(capsys):
    assert main(["bench", "startup", "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert out.count("heavy modules: none") == 2
    assert "python -m vggc_cp --help: " in out and "python -m vggc_cp plan --help: " in out
    assert out.count("baseline, python -c pass: ") == 2 and "target" in out
