"""networkx node-link JSON (``networkx.node_link_data``, edges under ``"edges"``)."""

from __future__ import annotations

import json

from vggc_cp.export.base import ExportRequest, register_exporter
from vggc_cp.graph import TaskGraph, to_networkx


@register_exporter("json", help="networkx node-link JSON (networkx.node_link_graph reads it)")
def node_link_json(graph: TaskGraph, request: ExportRequest) -> dict[str, str]:
    """``{"": text}``: ``networkx.node_link_data`` of :func:`vggc_cp.graph.to_networkx`,
    nodes with ``role``, ``size`` (and ``medoid`` where known), edges with ``key`` and
    ``action`` (the action's name)."""
    import networkx as nx

    g = to_networkx(graph, request.medoids or None, support=False)
    data = nx.node_link_data(g, edges="edges")
    return {"": json.dumps(data, indent=1, sort_keys=True) + "\n"}
