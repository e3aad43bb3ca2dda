"""Graphviz DOT text, written here (no graphviz needed): pick nodes boxes, place nodes
ellipses, edges labelled by action."""

from __future__ import annotations

from vggc_cp.export.base import ExportRequest, register_exporter
from vggc_cp.graph import TaskGraph
from vggc_cp.trace import ROLE_NAMES

SHAPES = {"pick": "box", "place": "ellipse", "mixed": "diamond"}


def quote(text: str) -> str:
    """A DOT double-quoted string."""
    return '"' + str(text).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


@register_exporter("dot", help="Graphviz DOT text (dot -Tsvg draws it)")
def dot(graph: TaskGraph, request: ExportRequest) -> dict[str, str]:
    """``{"": text}``: ``digraph NAME { ... }``, one node statement ``n<u>`` per node (label:
    id, role, observations), one edge statement per ``(u, action, v)`` labelled by action."""
    lines = [f"digraph {quote(request.name)} {{", "  rankdir=LR;"]
    for u in graph.nodes:
        r = graph.node_role[u]
        role = ROLE_NAMES[r] if r >= 0 else "mixed"
        size = len(graph.members[u])
        label = f"{u}\n{role}\n{size} obs"
        lines.append(f"  n{u} [label={quote(label)}, shape={SHAPES[role]}, role={quote(role)}, "
                     f"size={size}];")
    for u, a, v in graph.edge_list():
        lines.append(f"  n{u} -> n{v} [label={quote(a)}, action={quote(a)}];")
    lines.append("}")
    return {"": "\n".join(lines) + "\n"}
