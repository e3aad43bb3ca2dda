"""The exporter registry: one function per format, ``write(graph, request) -> {suffix: text}``.

An exporter turns a :class:`~vggc_cp.graph.TaskGraph` into text files; ``request`` carries the
start and goal nodes (only PDDL reads them) and optional node attributes. It returns one text
per file: the key ``""`` is the file named by ``-o``, any other key a file next to it (PDDL's
problem). Adding a format is a module that calls :func:`register_exporter` and a line in
:mod:`vggc_cp.export` importing it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from vggc_cp.errors import lookup
from vggc_cp.graph import TaskGraph


@dataclass(frozen=True)
class ExportRequest:
    """What an exporter may read besides the graph.

    Attributes
    ----------
    start, goal : int or None
        Start and goal nodes (PDDL's problem).
    medoids : dict[int, int]
        Most typical observation of each node, where known (a ``medoid`` node attribute).
    name : str
        The graph's name (PDDL's domain and problem, DOT's graph).
    """

    start: int | None = None
    goal: int | None = None
    medoids: dict[int, int] = field(default_factory=dict)
    name: str = "vggc"


@dataclass(frozen=True)
class Exporter:
    """One registered format.

    Attributes
    ----------
    name : str
    write : callable
        ``(graph, request) -> {suffix: text}``.
    needs_start_goal : bool
        Whether ``request.start`` and ``request.goal`` are required (and read).
    help : str
    """

    name: str
    write: Callable[[TaskGraph, ExportRequest], dict[str, str]]
    needs_start_goal: bool = False
    help: str = ""


#: format name -> :class:`Exporter`.
EXPORTERS: dict[str, Exporter] = {}


def register_exporter(name: str, *, needs_start_goal: bool = False, help: str = ""):
    """Decorator: register ``write(graph, request) -> {suffix: text}`` as format ``name``."""
    def deco(fn):
        EXPORTERS[name] = Exporter(name, fn, needs_start_goal, help)
        return fn
    return deco


def get_exporter(name: str) -> Exporter:
    """The exporter of format ``name`` (unknown names list the known ones)."""
    return lookup(EXPORTERS, name, "export format")
