"""Every ``--help`` of the command line shows the defaults of its options, once."""

from __future__ import annotations

import argparse
import re

import pytest

from vggc_cp.cli import build_parser, iter_parsers


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
