"""GraphML (``networkx.generate_graphml``): a multigraph whose edge ids are action names."""

from __future__ import annotations

from vggc_cp.export.base import ExportRequest, register_exporter
from vggc_cp.graph import TaskGraph, to_networkx


@register_exporter("graphml", help="GraphML (networkx.read_graphml reads it; yEd, Gephi)")
def graphml(graph: TaskGraph, request: ExportRequest) -> dict[str, str]:
    """``{"": text}``: nodes with ``role``, ``size`` (and ``medoid``), edges with id and
    ``action`` the action's name; the graph's ``action_names`` joined by newlines."""
    import networkx as nx

    g = to_networkx(graph, request.medoids or None, support=False)
    g.graph["action_names"] = "\n".join(g.graph["action_names"])
    return {"": "\n".join(nx.generate_graphml(g)) + "\n"}
