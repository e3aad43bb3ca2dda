"""Every ``--help`` of the command line shows the defaults of its options, once; a mistyped
option or choice gets the sub-command's usage and the nearest name, and no prefix of an option
stands for it."""

from __future__ import annotations

import argparse
import re

import pytest

from vggc_cp.cli import Parser, build_parser, iter_parsers, main


def _shown(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """The help text of ``action`` as ``--help`` prints it (defaults expanded)."""
    formatter = parser._get_formatter()
    return formatter._expand_help(action) if action.help else ""


def _needs_default(action: argparse.Action) -> bool:
    default = action.default
    if not action.option_strings or action.help == argparse.SUPPRESS:
        return False
    if default is None or default is False or default is argparse.SUPPRESS:
        return False
    return not (isinstance(default, (str, list, tuple)) and not default)


PARSERS = list(iter_parsers(build_parser()))


def test_every_sub_command_is_walked():
    names = {name for name, _ in PARSERS}
    assert {"vggc-cp solve", "vggc-cp compare", "vggc-cp notebook",
            "vggc-cp bench solve"} <= names


@pytest.mark.parametrize("name,parser", PARSERS, ids=[name for name, _ in PARSERS])
def test_help_shows_every_default_once(name, parser):
    missing, doubled = [], []
    for action in parser._actions:
        if not _needs_default(action):
            continue
        text = " ".join(_shown(parser, action).split())
        if str(action.default) not in text and "default" not in text:
            missing.append((action.option_strings[0], action.default, text))
        if len(re.findall(r"\(default\b", text)) > 1:
            doubled.append((action.option_strings[0], text))
    assert not missing, f"{name}: defaults not shown: {missing}"
    assert not doubled, f"{name}: defaults shown twice: {doubled}"
    parser.format_help()  # every help string formats


def test_options_whose_none_stands_for_a_computed_value_say_which():
    """``--tau`` None is a per-role median, not "no temperature": every command says so."""
    seen = 0
    for name, parser in PARSERS:
        for action in parser._actions:
            if "--tau" in action.option_strings:
                seen += 1
                assert "default: per role, the median" in _shown(parser, action), name
    assert seen >= 2


def test_every_parser_refuses_prefixes_of_options():
    for name, parser in PARSERS:
        assert isinstance(parser, Parser) and parser.allow_abbrev is False, name


def _refused(capsys, argv: list[str]) -> str:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    return captured.err


@pytest.mark.parametrize("argv,usage,hint", [
    (["solve", "t.npz", "-o", "s.json", "--k-pik", "3"], "usage: vggc-cp solve",
     "unrecognized arguments: --k-pik 3; did you mean --k-pick?"),
    # a unique prefix is not taken for the option
    (["solve", "t.npz", "-o", "s.json", "--k-pi", "3"], "usage: vggc-cp solve",
     "did you mean --k-pick?"),
    (["plan", "s.json", "--start-ob", "0", "--goal-obs", "1"], "usage: vggc-cp plan",
     "did you mean --start-obs?"),
    (["bench", "sweep", "--job", "2"], "usage: vggc-cp bench sweep", "did you mean --jobs?"),
    (["solve", "t.npz", "--outptu", "s.json"], "usage: vggc-cp solve",
     "(--outptu is not an option; did you mean --output?)"),
    (["slove", "t.npz"], "usage: vggc-cp ", "did you mean solve?"),
    (["solve", "t.npz", "-o", "s.json", "--table", "cels"], "usage: vggc-cp solve",
     "did you mean cells?"),
])
def test_a_mistyped_option_gets_usage_and_the_nearest_name(capsys, argv, usage, hint):
    err = _refused(capsys, argv)
    assert err.startswith(usage) and hint in err
    assert err.strip().splitlines()[-1].startswith(f"{usage[7:].strip()}: error: ")


def test_an_unknown_option_far_from_every_name_gets_no_guess(capsys):
    err = _refused(capsys, ["solve", "t.npz", "-o", "s.json", "--zzzz"])
    assert "unrecognized arguments: --zzzz" in err and "did you mean" not in err


def _signature(parser: argparse.ArgumentParser) -> list:
    """What parsing with ``parser`` depends on: its actions and its ``set_defaults``."""
    return [(a.option_strings, a.dest, a.nargs, a.const, a.default, a.type, a.required,
             sorted(a.choices) if isinstance(a.choices, dict) else a.choices)
            for a in parser._actions] + [parser._defaults]


@pytest.mark.parametrize("name", [name for name, _ in PARSERS[1:]])
def test_the_parser_of_one_command_line_is_the_whole_trees_part(name):
    """``build_parser(argv)`` (what :func:`main` parses with) builds only the sub-command that
    ``argv`` names, and it helps and parses as in the whole tree, sub-commands below included."""
    words = name.split()[1:]
    whole, part = dict(PARSERS), dict(iter_parsers(build_parser(words)))
    below = [n for n in whole if n == name or n.startswith(name + " ")]
    for n in below:
        assert part[n].format_help() == whole[n].format_help(), n
        assert part[n].format_usage() == whole[n].format_usage(), n
        assert _signature(part[n]) == _signature(whole[n]), n
    if words != ["bench"]:
        assert len(part) < len(whole)


@pytest.mark.parametrize("argv", [[], ["--help"], ["slove"], ["bench"], ["bench", "sweeep"]])
def test_a_command_line_naming_no_sub_command_gets_the_whole_tree(argv):
    assert [n for n, _ in iter_parsers(build_parser(argv))] == [n for n, _ in PARSERS]


def test_each_command_line_gets_a_fresh_parser():
    """Nothing one parse hands out (a list default) or registers is kept for the next."""
    from vggc_cp.importers import IMPORTERS, Argument, Importer, register_importer

    first = build_parser(["notebook", "n.ipynb"]).parse_args(["notebook", "n.ipynb"])
    first.param.append("x=1")
    again = build_parser(["notebook", "n.ipynb"]).parse_args(["notebook", "n.ipynb"])
    assert again.param == []
    register_importer(Importer("npy-help-test", "h", "d.", (Argument("array", "a"),),
                               lambda config, array: None))
    try:
        args = build_parser(["import", "npy-help-test"]).parse_args(
            ["import", "npy-help-test", "x.npy", "-o", "t.npz"])
        assert args.importer == "npy-help-test" and args.array == "x.npy"
    finally:
        IMPORTERS.pop("npy-help-test")
