"""Fixtures of the import tests: the shipped trace every layout is written from."""

from __future__ import annotations

import pytest
from recordings import SHIPPED

from vggc_cp.trace import load_trace


@pytest.fixture(scope="module")
def original():
    return load_trace(SHIPPED)
