"""Every module's docstring examples run and hold (the face's own, with the data they name,
are in ``test_api.py`` too): an example is part of the documentation, and one that no longer
holds misleads whoever copies it."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
from pathlib import Path

import pytest

import vggc_cp

ROOT = Path(vggc_cp.__file__).resolve().parents[1]
MODULES = sorted(m.name for m in pkgutil.walk_packages(vggc_cp.__path__, "vggc_cp.")
                 if not m.name.endswith("__main__"))


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_hold(name, monkeypatch):
    monkeypatch.chdir(ROOT)                   # examples name files such as data/fruit-2x3.npz
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples fail"
