"""A STRIPS domain and problem of the learned graph, for classical planners.

Encoding (one action schema per action name, the edges as static facts)::

    (:predicates (at-node ?n - node) (edge-A ?from ?to - node) ...)
    (:action A :parameters (?from ?to - node)
       :precondition (and (at-node ?from) (edge-A ?from ?to))
       :effect (and (not (at-node ?from)) (at-node ?to)))

The problem lists the nodes ``n<u>`` as objects, ``(edge-A n<u> n<v>)`` for every edge, the
start as ``(at-node n<start>)`` and the goal ``(at-node n<goal>)``. Every action costs one, so
an optimal plan is a shortest path (``vggc-cp plan``'s length). Action names become PDDL
names (letters, digits, ``-``, ``_``; lower case; made unique); the domain's comments map
them back.
"""

from __future__ import annotations

import re

from vggc_cp.export.base import ExportRequest, register_exporter
from vggc_cp.graph import TaskGraph

PROBLEM_SUFFIX = "-problem.pddl"


def pddl_names(names) -> dict[str, str]:
    """``{action name: PDDL name}``: invalid characters made ``_``, lower case, a letter
    first, unique (a ``-2``, ``-3`` ... suffix)."""
    out, used = {}, set()
    for name in names:
        base = re.sub(r"[^a-z0-9_-]", "_", name.lower())
        if not base or not base[0].isalpha():
            base = "a-" + base
        cand, k = base, 2
        while cand in used:
            cand, k = f"{base}-{k}", k + 1
        used.add(cand)
        out[name] = cand
    return out


def _ident(text: str) -> str:
    base = re.sub(r"[^a-z0-9_-]", "-", text.lower()).strip("-") or "graph"
    return base if base[0].isalpha() else "g-" + base


@register_exporter("pddl", needs_start_goal=True,
                   help=f"PDDL domain at OUT and problem at OUT's stem + {PROBLEM_SUFFIX} "
                        f"(STRIPS; pyperplan solves it)")
def pddl(graph: TaskGraph, request: ExportRequest) -> dict[str, str]:
    """``{"": domain, "-problem.pddl": problem}`` (module docstring)."""
    used = sorted({graph.action_names[a] for (_, a, _) in graph.edges})
    names = pddl_names(used)
    domain_name = _ident(request.name)
    d = [f"; vggc-cp task graph: {graph.n_nodes} nodes, {graph.n_edges} edges",
         *[f"; action {names[a]} = {a!r}" for a in used],
         f"(define (domain {domain_name})",
         "  (:requirements :strips :typing)",
         "  (:types node)",
         "  (:predicates (at-node ?n - node)"]
    d += [f"               (edge-{names[a]} ?from ?to - node)" for a in used]
    d[-1] += ")"
    for a in used:
        n = names[a]
        d += [f"  (:action {n}",
              "    :parameters (?from ?to - node)",
              f"    :precondition (and (at-node ?from) (edge-{n} ?from ?to))",
              "    :effect (and (not (at-node ?from)) (at-node ?to)))"]
    d.append(")")
    p = [f"(define (problem {domain_name}-from-n{request.start}-to-n{request.goal})",
         f"  (:domain {domain_name})",
         "  (:objects " + " ".join(f"n{u}" for u in graph.nodes) + " - node)",
         "  (:init",
         f"    (at-node n{request.start})"]
    p += [f"    (edge-{names[graph.action_names[a]]} n{u} n{v})"
          for (u, a, v) in sorted(graph.edges)]
    p[-1] += ")"
    p += [f"  (:goal (at-node n{request.goal}))", ")"]
    return {"": "\n".join(d) + "\n", PROBLEM_SUFFIX: "\n".join(p) + "\n"}
