"""``vggc-cp report``: one self-contained HTML page about a learned graph.

The page holds the graph figure (:mod:`vggc_cp.graph_plots`), the threshold path (description
length and node count per threshold, from the solution's ``grid``), the confidence and its
reasons, a strip of thumbnails per node, the warnings, and what to record next (the
solution's ``suggest`` and ``doubts`` fields, when it has them). Every image is embedded as a
``data:`` URI; the page loads nothing from anywhere (no script, no style sheet, no link).
"""

from __future__ import annotations

import html
import json

import numpy as np

from vggc_cp.graph_plots import (
    GraphPicture,
    draw_graph,
    figure_bytes,
    image_png,
    png_data_uri,
    pyplot,
    role_name,
)

STRIP = 8
STYLE = ("body{font-family:sans-serif;margin:1.5em;max-width:70em}"
         "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;"
         "font-size:90%}.strip img{margin:1px;border:1px solid #999}"
         ".warn{color:#a40000}.sel{font-weight:bold;background:#eef}")


def path_rows(extra: dict) -> list[dict]:
    """The rows of the solution's ``grid`` that are thresholds of a merge path (each with
    ``threshold`` and ``nodes``), or none."""
    grid = extra.get("grid")
    if not isinstance(grid, list):
        return []
    return [r for r in grid if isinstance(r, dict) and isinstance(r.get("threshold"),
                                                                  (int, float))
            and isinstance(r.get("nodes"), int)]


def path_figure(rows: list[dict]) -> bytes:
    """PNG: node count and description length against the threshold (log scale); the
    selected threshold marked."""
    plt = pyplot()
    t = [r["threshold"] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 2.8), constrained_layout=True)
    handles = ax.plot(t, [r["nodes"] for r in rows], "o-", color="#1f77b4", ms=4,
                      label="nodes", zorder=3)
    ax.set_xscale("log")
    ax.set_xlabel("merge threshold")
    ax.set_ylabel("nodes", color="#1f77b4")
    dl = [r.get("description_length") for r in rows]
    if all(isinstance(x, (int, float)) for x in dl):
        ax2 = ax.twinx()
        handles += ax2.plot(t, dl, "s--", color="#2ca02c", ms=3, label="description length")
        ax2.set_ylabel("description length (nats)", color="#2ca02c")
    for r in rows:
        if r.get("selected"):
            handles.append(ax.axvline(r["threshold"], color="#d62728", ls=":", lw=1,
                                      label="selected"))
    ax.legend(handles=handles, fontsize=7, loc="upper right")
    return figure_bytes(fig, "png")


def _items(value) -> list[str]:
    """A ``suggest``/``doubts``-like field as readable lines."""
    if value is None:
        return []
    if isinstance(value, (str, int, float)):
        return [str(value)]
    if isinstance(value, list):
        out = []
        for v in value:
            if isinstance(v, dict):
                text = v.get("text") or v.get("why") or v.get("reason")
                nodes = v.get("nodes")
                head = f"nodes {nodes}: " if nodes is not None else ""
                out.append(head + (str(text) if text else json.dumps(v, sort_keys=True)))
            else:
                out.append(str(v))
        return out
    if isinstance(value, dict):
        return [f"{k}: {json.dumps(v, sort_keys=True)}" for k, v in value.items()]
    return [str(value)]


def strip_members(members, medoid: int | None, strip: int = STRIP) -> list[int]:
    """The observations of a node's thumbnail strip: its medoid first, then evenly spaced
    members, ``strip`` in all."""
    mem = np.asarray(members)
    pick = mem if len(mem) <= strip else mem[np.linspace(0, len(mem) - 1, strip)
                                             .round().astype(int)]
    first = [int(medoid)] if medoid is not None else []
    return first + [int(i) for i in pick if int(i) not in first][:strip - len(first)]


def report_html(pic: GraphPicture, extra: dict, *, solution_name: str, trace_name: str,
                strip: int = STRIP) -> str:
    """The report page (module docstring) of ``pic`` and the solution's other fields
    ``extra``."""
    e = html.escape
    graph = pic.graph
    parts = [f"<h1>Learned graph of {e(trace_name)}</h1>",
             f"<p>solution <code>{e(solution_name)}</code>: {graph.n_nodes} nodes "
             f"({', '.join(f'{k} {v}' for k, v in graph.count_by_role().items() if v)}), "
             f"{graph.n_edges} edges, {len(graph.action_names)} actions; evidence "
             f"<code>{e(str(extra.get('evidence', '?')))}</code>, selection "
             f"<code>{e(str(extra.get('select', '?')))}</code>.</p>",
             "<h2>Graph</h2>",
             f'<img alt="the learned graph" src="{png_data_uri(figure_bytes(draw_graph(pic), "png"))}">']
    conf = extra.get("confidence") if isinstance(extra.get("confidence"), dict) else None
    warnings = []
    parts.append("<h2>Confidence</h2>")
    if conf is None:
        parts.append("<p>The solution records no confidence (only the default pipeline, "
                     "<code>vggc-cp solve</code>, assesses it).</p>")
    else:
        suspect = bool(conf.get("suspect"))
        held = conf.get("heldout") if isinstance(conf.get("heldout"), dict) else {}
        parts.append(f"<p class=\"{'warn' if suspect else ''}\"><b>"
                     f"{'suspect' if suspect else 'no warning'}</b></p><ul>")
        for key, label in (("p_change", "chance of change (share of re-runs with a fifth of "
                                        "the episodes left out that change the graph)"),
                           ("margin", "description-length margin (nats per transition)"),
                           ("plateau", "thresholds giving the same partition (plateau)"),
                           ("obs_per_node", "observations per node")):
            if key in conf:
                v = conf[key]
                text = f"{v:.4g}" if isinstance(v, float) else str(v)
                parts.append(f"<li>{label}: {e(text)}</li>")
        for key in ("predicted", "contradicted", "unseen"):
            if isinstance(held.get(key), (int, float)):
                parts.append(f"<li>held-out transitions {key}: {100 * held[key]:.1f} %</li>")
        parts.append("</ul>")
        reasons = conf.get("reasons") or []
        if reasons:
            parts.append("<p>Reasons:</p><ul>" + "".join(f"<li>{e(str(r))}</li>"
                                                         for r in reasons) + "</ul>")
            if suspect:
                warnings += [str(r) for r in reasons]
        notes = conf.get("notes") or []
        if notes:
            parts.append("<p>Notes (reported, not warnings):</p><ul>"
                         + "".join(f"<li>{e(str(n))}</li>" for n in notes) + "</ul>")
    cands = extra.get("candidates")
    if isinstance(cands, list) and len(cands) > 1:
        sizes = {c.get("nodes") for c in cands if isinstance(c, dict)}
        if len(sizes) > 1:
            warnings.append("the evidences tried give graphs of different sizes: "
                            + ", ".join(f"{c.get('evidence')} {c.get('nodes')}"
                                        for c in cands if isinstance(c, dict)))
    rows = path_rows(extra)
    parts.append("<h2>Threshold path</h2>")
    if rows:
        parts.append(f'<img alt="threshold path" src="{png_data_uri(path_figure(rows))}">')
        parts.append("<table><tr><th>threshold</th><th>nodes</th><th>description length</th>"
                     "</tr>")
        for r in rows:
            dl = r.get("description_length")
            parts.append(f"<tr class=\"{'sel' if r.get('selected') else ''}\">"
                         f"<td>{r['threshold']:.6g}</td><td>{r['nodes']}</td>"
                         f"<td>{'' if dl is None else e(str(dl))}</td></tr>")
        parts.append("</table>")
    else:
        parts.append("<p>The solution records no threshold path (a grid solver's "
                     "solution).</p>")
    parts.append("<h2>Nodes</h2><table><tr><th>node</th><th>role</th><th>observations</th>"
                 "<th>medoid and members</th></tr>")
    for u in graph.nodes:
        mem = np.asarray(graph.members[u])
        strip_html = ""
        if pic.observations is not None:
            shown = strip_members(mem, pic.medoids.get(u), strip)
            strip_html = "".join(
                f'<img title="observation {i}" alt="observation {i}" '
                f'src="{png_data_uri(image_png(pic.observations[i], 56))}">' for i in shown)
        parts.append(f"<tr id=\"node-{u}\"><td>node {u}</td><td>{role_name(graph, u)}</td>"
                     f"<td>{len(mem)}</td><td class=\"strip\">{strip_html}</td></tr>")
    parts.append("</table>")
    parts.append("<h2>Warnings</h2>")
    parts.append("<ul>" + "".join(f"<li class=\"warn\">{e(w)}</li>" for w in warnings)
                 + "</ul>" if warnings else "<p>None.</p>")
    record = _items(extra.get("suggest")) + [f"doubt: {x}" for x in _items(extra.get("doubts"))]
    if record:
        parts.append("<h2>What to record next</h2><ul>"
                     + "".join(f"<li>{e(x)}</li>" for x in record) + "</ul>")
    title = f"vggc-cp report: {e(trace_name)}"
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + title
            + "</title><style>" + STYLE + "</style></head><body>\n" + "\n".join(parts)
            + "\n</body></html>\n")
