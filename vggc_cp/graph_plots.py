"""The picture of a learned graph (``vggc-cp show``, ``vggc-cp report``): nodes drawn as their
most typical observation, edges labelled by action.

Layout (networkx and matplotlib only, no graphviz): pick nodes in the upper band, place nodes
in the lower one (every edge joins the two bands: a pick leads to a place node and back), each
band ordered by the barycentre of its neighbours (a few sweeps, as in layered drawing) so that
edges cross little. A band wider than :data:`BAND_WIDTH` nodes wraps onto more rows. Up to
:data:`MAX_IMAGES` nodes each node is its medoid image in a frame (blue: pick, orange: place);
beyond, a small square (pick) or disc (place) and the edges as plain lines (a plan's edges stay
arrows), so a few hundred nodes stay readable and quick to draw; edge labels are drawn up to
:data:`MAX_EDGE_LABELS` edges.

The medoid of a node is its member of least total pixel distance to the others, on at most
:data:`MEDOID_SAMPLE` members (evenly spaced) of images subsampled to about 24 pixels a side:
cheap, and needing no evidence distances (a solution file does not hold them).
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vggc_cp.atomic import atomic_path
from vggc_cp.graph import TaskGraph
from vggc_cp.trace import ROLE_NAMES

MAX_IMAGES = 60
MAX_EDGE_LABELS = 80
BAND_WIDTH = 24
MEDOID_SAMPLE = 48
COLOURS = {"pick": "#1f77b4", "place": "#ff7f0e", "mixed": "#7f7f7f"}
PLAN_COLOUR = "#d62728"
DOUBT_COLOUR = "#9467bd"
FORMATS = ("png", "svg", "html")


def role_name(graph: TaskGraph, u: int) -> str:
    r = graph.node_role[u]
    return ROLE_NAMES[r] if r >= 0 else "mixed"


def small_images(observations: np.ndarray, side: int = 24) -> np.ndarray:
    """``observations`` (uint8, (N, H, W, 3)) subsampled by a stride to about ``side`` pixels
    a side, float32, flattened: shape (N, h*w*3)."""
    n, h, w, _ = observations.shape
    sy, sx = max(1, h // side), max(1, w // side)
    return observations[:, ::sy, ::sx].reshape(n, -1).astype(np.float32) / 255


def pixel_medoids(observations: np.ndarray, members: dict[int, np.ndarray],
                  sample: int = MEDOID_SAMPLE) -> dict[int, int]:
    """``{node: observation}``: each node's member of least summed Euclidean distance between
    subsampled images, among at most ``sample`` evenly spaced members (the first of equal
    ones)."""
    chosen = {}
    for u, mem in members.items():
        mem = np.asarray(mem)
        if len(mem) > sample:
            mem = mem[np.linspace(0, len(mem) - 1, sample).round().astype(int)]
        chosen[u] = mem
    # every sampled image read once, in order (one pass over a trace read from its file)
    want = np.unique(np.concatenate([np.asarray(m, dtype=np.int64) for m in chosen.values()]
                                    or [np.zeros(0, np.int64)]))
    small = {}
    for s in range(0, len(want), 64):
        idx = want[s:s + 64]
        for i, f in zip(idx.tolist(), small_images(observations[idx])):
            small[i] = f
    out = {}
    for u, mem in chosen.items():
        f = np.stack([small[int(i)] for i in mem])
        sq = (f * f).sum(1)
        d = np.sqrt(np.maximum(sq[:, None] + sq[None, :] - 2 * f @ f.T, 0))
        out[int(u)] = int(mem[int(np.argmin(d.sum(axis=1)))])
    return out


def _barycentre_order(nodes: list[int], fixed: dict[int, float], neighbours) -> list[int]:
    def key(u):
        xs = [fixed[v] for v in neighbours(u) if v in fixed]
        return (sum(xs) / len(xs) if xs else math.inf, u)
    return sorted(nodes, key=key)


def band_layout(graph: TaskGraph, sweeps: int = 4) -> dict[int, tuple[float, float]]:
    """``{node: (x, y)}``: pick nodes in the upper band, place (and mixed) nodes in the lower
    one, ordered by barycentres; a band of more than :data:`BAND_WIDTH` nodes wraps."""
    import networkx as nx

    g = nx.Graph()
    g.add_nodes_from(graph.nodes)
    g.add_edges_from((u, v) for (u, _, v) in graph.edges)
    top = [u for u in graph.nodes if graph.node_role[u] == 0]
    bottom = [u for u in graph.nodes if graph.node_role[u] != 0]
    pos_x: dict[int, float] = {}
    order_top, order_bottom = list(top), list(bottom)
    for u in order_top:
        pos_x[u] = order_top.index(u)
    for _ in range(sweeps):
        order_bottom = _barycentre_order(order_bottom, pos_x, g.neighbors)
        pos_x.update({u: i for i, u in enumerate(order_bottom)})
        order_top = _barycentre_order(order_top, pos_x, g.neighbors)
        pos_x.update({u: i for i, u in enumerate(order_top)})
    width = max(len(order_top), len(order_bottom), 1)
    cols = min(width, BAND_WIDTH)
    pos: dict[int, tuple[float, float]] = {}
    rows_top = math.ceil(len(order_top) / cols) if order_top else 0
    for order, y0 in ((order_top, 0.0), (order_bottom, -(rows_top + 1.0))):
        n = len(order)
        for i, u in enumerate(order):
            row, col = divmod(i, cols)
            in_row = min(cols, n - row * cols)
            pos[u] = ((col + 0.5) * cols / in_row, y0 - row)
    return pos


@dataclass
class GraphPicture:
    """What :func:`draw_graph` draws.

    Attributes
    ----------
    graph : TaskGraph
    observations : ndarray, uint8, shape (N, H, W, 3), a mapping {index: image}, or None
        The trace's images (nodes are drawn as their medoid when given).
    medoids : dict[int, int]
    plan : list of (u, action index, v)
        Edges to highlight.
    doubts : list of (a, b)
        Node pairs the solution doubts (a dashed link).
    title : str
    """

    graph: TaskGraph
    observations: np.ndarray | None = None
    medoids: dict[int, int] = field(default_factory=dict)
    plan: list = field(default_factory=list)
    doubts: list = field(default_factory=list)
    title: str = ""


def doubt_pairs(extra: dict, graph: TaskGraph) -> list[tuple[int, int]]:
    """The node pairs of a solution's ``doubts`` field (a list of ``{"nodes": [a, b], ...}``)
    that name nodes of ``graph``; nothing when absent or malformed."""
    out = []
    doubts = extra.get("doubts") if isinstance(extra, dict) else None
    for d in doubts if isinstance(doubts, list) else []:
        nodes = d.get("nodes") if isinstance(d, dict) else None
        if (isinstance(nodes, list) and len(nodes) == 2
                and all(isinstance(x, int) and x in graph.members for x in nodes)):
            out.append((int(nodes[0]), int(nodes[1])))
    return out


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def draw_graph(pic: GraphPicture):
    """A matplotlib figure of ``pic`` (layout: :func:`band_layout`); every node's artists
    carry the SVG id ``node-<u>``, every edge's ``edge-<u>-<action>-<v>``."""
    from matplotlib.offsetbox import AnnotationBbox, OffsetImage
    from matplotlib.patches import FancyArrowPatch

    plt = pyplot()
    graph = pic.graph
    pos = band_layout(graph)
    n = graph.n_nodes
    images = pic.observations is not None and n <= MAX_IMAGES and pic.medoids
    xs = [p[0] for p in pos.values()] or [0.0]
    ys = [p[1] for p in pos.values()] or [0.0]
    span_x, span_y = max(xs) - min(xs) + 1, max(ys) - min(ys) + 1
    scale = 1.6 if images else 0.6
    fig_w = min(max(4.0, span_x * scale + 1), 40.0)
    fig_h = min(max(3.0, span_y * scale * 1.4 + 1), 40.0)
    fig, ax = plt.subplots(figsize=(fig_w, fig_h))
    ax.set_xlim(min(xs) - 0.8, max(xs) + 0.8)
    ax.set_ylim(min(ys) - 0.8, max(ys) + 0.8)
    ax.set_axis_off()
    on_plan = {(u, a, v) for (u, a, v) in pic.plan}
    plan_nodes = {u for (u, _, _) in pic.plan} | {v for (_, _, v) in pic.plan}
    ends = {pic.plan[0][0]: "start", pic.plan[-1][2]: "goal"} if pic.plan else {}
    labels = graph.n_edges <= MAX_EDGE_LABELS
    rad = 0.15  # one sign for all: the two directions between two nodes bend apart
    edges = sorted(graph.edges)
    if n > MAX_IMAGES:  # many nodes: the edges off the plan as one collection of lines
        from matplotlib.collections import LineCollection

        cold = [e for e in edges if e not in on_plan]
        lines = LineCollection([(pos[u], pos[v]) for (u, _, v) in cold], colors="#555555",
                               linewidths=0.4, alpha=0.3 if pic.plan else 0.5, zorder=1)
        lines.set_gid("edges")
        ax.add_collection(lines)
        edges = [e for e in edges if e in on_plan]
    for (u, a, v) in edges:
        hot = (u, a, v) in on_plan
        arrow = FancyArrowPatch(pos[u], pos[v], connectionstyle=f"arc3,rad={rad}",
                                arrowstyle="-|>", mutation_scale=10 if n <= MAX_IMAGES else 6,
                                lw=2.5 if hot else 0.8, color=PLAN_COLOUR if hot else "#555555",
                                alpha=1.0 if hot or not pic.plan else 0.45,
                                shrinkA=22 if images else 5, shrinkB=22 if images else 5,
                                zorder=1)
        arrow.set_gid(f"edge-{u}-{graph.action_names[a]}-{v}")
        ax.add_patch(arrow)
        if labels:
            (x1, y1), (x2, y2) = pos[u], pos[v]
            cx, cy = (x1 + x2) / 2 + rad * (y2 - y1), (y1 + y2) / 2 - rad * (x2 - x1)
            t = 0.3  # near the source: the two directions' labels do not meet
            lx = (1 - t) ** 2 * x1 + 2 * t * (1 - t) * cx + t * t * x2
            ly = (1 - t) ** 2 * y1 + 2 * t * (1 - t) * cy + t * t * y2
            ax.text(lx, ly, graph.action_names[a], fontsize=6, ha="center", va="center",
                    color=PLAN_COLOUR if hot else "#333333", zorder=2,
                    bbox={"boxstyle": "round,pad=0.1", "fc": "white", "ec": "none",
                          "alpha": 0.7})
    for (a, b) in pic.doubts:
        line, = ax.plot([pos[a][0], pos[b][0]], [pos[a][1], pos[b][1]], ls="--", lw=1.5,
                        color=DOUBT_COLOUR, zorder=3)
        line.set_gid(f"doubt-{a}-{b}")
        ax.text((pos[a][0] + pos[b][0]) / 2, (pos[a][1] + pos[b][1]) / 2, "?", fontsize=12,
                color=DOUBT_COLOUR, ha="center", va="center", zorder=4, weight="bold")
    for u in graph.nodes:
        role = role_name(graph, u)
        colour = PLAN_COLOUR if u in plan_nodes else COLOURS[role]
        x, y = pos[u]
        if images:
            img = pic.observations[pic.medoids[u]]
            zoom = 48 / max(img.shape[:2])
            box = AnnotationBbox(OffsetImage(img, zoom=zoom), (x, y), frameon=True,
                                 pad=0.15, zorder=5,
                                 bboxprops={"edgecolor": colour,
                                            "linewidth": 3 if u in plan_nodes else 2,
                                            "boxstyle": "square" if role == "pick"
                                            else "round,pad=0.15"})
            box.set_gid(f"node-{u}")
            ax.add_artist(box)
            end = f" {ends[u]}" if u in ends else ""
            ax.text(x, y - 0.42, f"{u} ({len(graph.members[u])}){end}", fontsize=7,
                    ha="center", va="top", zorder=6, color=PLAN_COLOUR if end else "black")
        else:
            dot = ax.scatter([x], [y], s=40 if n <= 200 else 16, marker="s" if role == "pick"
                             else "o", color=colour, zorder=5,
                             edgecolors="black", linewidths=0.5)
            dot.set_gid(f"node-{u}")
            if n <= 200 or u in ends:
                ax.text(x, y - 0.18, f"{u} {ends.get(u, '')}".strip(), fontsize=5,
                        ha="center", va="top", zorder=6)
    title = pic.title or f"{n} nodes, {graph.n_edges} edges"
    ax.set_title(f"{title}\nupper band: pick nodes (square frames), lower band: place nodes "
                 f"(round frames)", fontsize=9)
    return fig


#: No creation date nor tool stamp: the same inputs give the same bytes.
METADATA = {"png": {"Software": None}, "svg": {"Creator": None, "Date": None, "Format": None,
                                               "Type": None}}


def figure_bytes(fig, fmt: str) -> bytes:
    """The figure as ``png`` or ``svg`` bytes, without dates (the figure is closed)."""
    import matplotlib

    buf = io.BytesIO()
    with matplotlib.rc_context({"svg.hashsalt": "vggc-cp"}):
        fig.savefig(buf, format=fmt, dpi=110, bbox_inches="tight",
                    metadata=METADATA.get(fmt))
    pyplot().close(fig)
    return buf.getvalue()


def png_data_uri(data: bytes) -> str:
    import base64

    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def image_png(image: np.ndarray, side: int = 64) -> bytes:
    """One observation (uint8 (H, W, 3)) as PNG bytes, its longer side ``side`` pixels."""
    from PIL import Image

    im = Image.fromarray(np.ascontiguousarray(image))
    scale = side / max(im.size)
    im = im.resize((max(1, round(im.size[0] * scale)), max(1, round(im.size[1] * scale))),
                   Image.NEAREST)
    buf = io.BytesIO()
    im.save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def graph_html(pic: GraphPicture) -> str:
    """A self-contained HTML page: the graph (PNG) and one row per node (its id, role, size
    and medoid image), every image embedded as a ``data:`` URI."""
    import html

    figure = (f'<img alt="the learned graph" '
              f'src="{png_data_uri(figure_bytes(draw_graph(pic), "png"))}">')
    rows = []
    for u in pic.graph.nodes:
        img = ""
        if pic.observations is not None and u in pic.medoids:
            img = (f'<img alt="node {u}" src="'
                   f'{png_data_uri(image_png(pic.observations[pic.medoids[u]]))}">')
        rows.append(f"<tr id=\"row-node-{u}\"><td>node {u}</td><td>"
                    f"{role_name(pic.graph, u)}</td><td>{len(pic.graph.members[u])}</td>"
                    f"<td>{pic.medoids.get(u, '')}</td><td>{img}</td></tr>")
    title = html.escape(pic.title or "learned graph")
    return ("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + title
            + "</title></head><body>\n<h1>" + title + "</h1>\n" + figure
            + "\n<table><tr><th>node</th><th>role</th><th>observations</th><th>medoid</th>"
            "<th>image</th></tr>\n" + "\n".join(rows) + "\n</table>\n</body></html>\n")


def save_graph(pic: GraphPicture, path: str | Path) -> None:
    """Write the picture at ``path`` (``.png``, ``.svg`` or ``.html`` by its suffix),
    atomically."""
    fmt = Path(path).suffix.lstrip(".").lower()
    if fmt == "html":
        data = graph_html(pic).encode("utf-8")
    else:
        data = figure_bytes(draw_graph(pic), fmt)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
