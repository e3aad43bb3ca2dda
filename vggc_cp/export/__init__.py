"""Exports of a learned graph for other tools: ``vggc-cp export s.json --to FORMAT -o OUT``.

Formats (registry :data:`EXPORTERS`, one module each):

``json``
    networkx node-link JSON (:mod:`.node_link`), read back by ``networkx.node_link_graph``.
``graphml``
    GraphML (:mod:`.graphml`), read back by ``networkx.read_graphml``.
``dot``
    Graphviz DOT text (:mod:`.dot`), written without graphviz.
``pddl``
    A STRIPS domain and problem (:mod:`.pddl`) that a classical planner solves: the plan from
    the start node to the goal node.

Every format holds one node per learned node (``role``, ``size``) and one edge per
``(u, action, v)``, labelled by the action's name.
"""

from __future__ import annotations

from pathlib import Path

from vggc_cp.atomic import write_text
from vggc_cp.errors import VggcError
from vggc_cp.export import dot, graphml, node_link, pddl  # noqa: F401  (register the formats)
from vggc_cp.export.base import EXPORTERS, Exporter, ExportRequest, get_exporter, register_exporter
from vggc_cp.graph import TaskGraph

__all__ = ["EXPORTERS", "ExportRequest", "Exporter", "export_graph", "export_texts",
           "get_exporter", "output_paths", "register_exporter"]


def export_texts(graph: TaskGraph, fmt: str, request: ExportRequest | None = None
                 ) -> dict[str, str]:
    """The texts of ``graph`` in format ``fmt``: ``{suffix: text}`` (``""``: the main file)."""
    exporter = get_exporter(fmt)
    request = request or ExportRequest()
    if exporter.needs_start_goal and (request.start is None or request.goal is None):
        raise VggcError(f"export format {fmt!r} needs a start and a goal (--start-obs, "
                        f"--goal-obs)")
    for what, u in (("start", request.start), ("goal", request.goal)):
        if u is not None and u not in graph.members:
            raise VggcError(f"the {what} node {u} is not a node of the graph")
    return exporter.write(graph, request)


def output_paths(out: str | Path, suffixes) -> dict[str, Path]:
    """Where each text goes: ``""`` at ``out``, another suffix next to it (``g.pddl`` and
    ``g-problem.pddl``)."""
    out = Path(out)
    return {s: out if not s else out.with_name(out.stem + s) for s in suffixes}


def export_graph(graph: TaskGraph, fmt: str, out: str | Path,
                 request: ExportRequest | None = None) -> list[Path]:
    """Write ``graph`` in format ``fmt`` at ``out`` (and next to it); returns the paths
    written (each atomically)."""
    texts = export_texts(graph, fmt, request)
    paths = output_paths(out, texts)
    for suffix, text in texts.items():
        write_text(paths[suffix], text)
    return list(paths.values())
