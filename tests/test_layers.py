"""The package's floors: no module imports from a floor above its own, no CLI command
module imports another (issue 18), and no import cycle between modules (issue 25). Read from the
source with :mod:`ast`, lazy imports inside functions included.

Import cycles: the graph has an edge ``a -> b`` for every import of module ``b`` anywhere in
``a``'s source -- at the top or inside a function (a lazy import closes a cycle as surely, only
later: ``experiments.table1`` and ``table1_methods`` imported each other that way) -- except
under ``if TYPE_CHECKING:``, which never runs. ``from pkg import name`` counts as ``pkg.name``
when ``name`` is a module, else as ``pkg``; importing ``pkg.mod`` is not counted as importing
``pkg`` (its ``__init__``) too. Any cycle, of two modules or more, fails."""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import vggc_cp

ROOT = Path(vggc_cp.__file__).parent

#: Floors, low to high; a module's floor is that of its longest listed prefix.
FLOORS = (
    ("vggc_cp", "vggc_cp.version", "vggc_cp.errors", "vggc_cp.atomic", "vggc_cp.safeio", "vggc_cp.score",
     "vggc_cp.recorded",
     "vggc_cp.trace", "vggc_cp.graph", "vggc_cp.solution"),
    ("vggc_cp.vision", "vggc_cp.sim", "vggc_cp.solvers", "vggc_cp.baselines",
     "vggc_cp.importers", "vggc_cp.export"),
    ("vggc_cp.pipeline", "vggc_cp.learned"),
    ("vggc_cp.localize",),
    ("vggc_cp.evaluate",),
    ("vggc_cp.experiments",),
    ("vggc_cp.plots", "vggc_cp.notebooks", "vggc_cp.graph_plots", "vggc_cp.report",
     "vggc_cp.api"),
    ("vggc_cp.cli", "vggc_cp.__main__"),
)


#: The one import from a lower floor to a higher one: the package's ``__getattr__`` (PEP 562)
#: loads its face, :mod:`vggc_cp.api`, when one of its names is first used.
FACE_IMPORTS = {("vggc_cp", "vggc_cp.api")}


def module_name(path: Path, root: Path = ROOT) -> str:
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def floor_of(name: str) -> int:
    best, floor = -1, None
    for i, prefixes in enumerate(FLOORS):
        for p in prefixes:
            if (name == p or name.startswith(p + ".")) and len(p) > best:
                best, floor = len(p), i
    assert floor is not None, f"{name} is on no floor: add it to FLOORS"
    return floor


def _is_type_checking(node: ast.AST) -> bool:
    test = node.test if isinstance(node, ast.If) else None
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _runtime_nodes(tree: ast.AST):
    """Every node of ``tree`` but those under ``if TYPE_CHECKING:``."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        if _is_type_checking(node):
            todo.extend(node.orelse)
        else:
            todo.extend(ast.iter_child_nodes(node))


def imports_of(path: Path, root: Path = ROOT) -> set[str]:
    """Every module of the package at ``root`` that ``path`` imports at run time (``from
    vggc_cp import x`` counts as ``vggc_cp.x`` when ``x`` is a module)."""
    package = root.name
    out = set()
    for node in _runtime_nodes(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == package}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                and node.module.split(".")[0] == package:
            base = root.parent.joinpath(*node.module.split("."))
            subs = [a.name for a in node.names
                    if (base / f"{a.name}.py").is_file() or (base / a.name).is_dir()]
            out |= {f"{node.module}.{s}" for s in subs} or {node.module}
    return out


def all_imports(root: Path = ROOT) -> dict[str, set[str]]:
    return {module_name(p, root): imports_of(p, root) for p in sorted(root.rglob("*.py"))}


@functools.lru_cache(maxsize=1)
def package_imports() -> dict[str, frozenset[str]]:
    """:func:`all_imports` of the package, parsed once for all the tests here."""
    return {m: frozenset(i) for m, i in all_imports().items()}


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """One cycle ``[a, b, ..., a]`` per strongly connected group of modules that import each
    other (Tarjan's algorithm; self-imports ignored), sorted."""
    index, low, stack, on_stack, groups = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w == v or w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(set(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(_one_cycle(graph, g) for g in groups)


def _one_cycle(graph: dict[str, set[str]], group: set[str]) -> list[str]:
    """A cycle through the smallest name of a strongly connected ``group`` (breadth first)."""
    start = min(group)
    parent = {start: None}
    queue = [start]
    while queue:
        v = queue.pop(0)
        for w in sorted(graph[v] & group):
            if w == start:
                path = [v]
                while parent[path[-1]] is not None:
                    path.append(parent[path[-1]])
                return [*reversed(path), start]
            if w not in parent:
                parent[w] = v
                queue.append(w)
    raise AssertionError(f"{sorted(group)} is not strongly connected")


def test_every_module_is_on_a_floor():
    for name in package_imports():
        floor_of(name)


def test_no_module_imports_from_a_higher_floor():
    upward = sorted((m, i) for m, imps in package_imports().items() for i in imps
                    if floor_of(i) > floor_of(m) and (m, i) not in FACE_IMPORTS)
    assert upward == [], "imports from a higher floor:\n" + "\n".join(
        f"  {m} -> {i}" for m, i in upward)


def test_cli_commands_never_import_each_other():
    cmds = {m: imps for m, imps in package_imports().items()
            if m.startswith("vggc_cp.cli.") and m.endswith("_cmds")}
    crossing = sorted((m, i) for m, imps in cmds.items() for i in imps if i in cmds and i != m)
    assert crossing == [], "CLI command modules importing each other:\n" + "\n".join(
        f"  {m} -> {i}" for m, i in crossing)


def test_the_checker_sees_lazy_and_from_package_imports(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("def f():\n    from vggc_cp import plots\n    import vggc_cp.cli.trace_cmds\n"
                   "from vggc_cp.errors import VggcError\n")
    assert imports_of(src) == {"vggc_cp.plots", "vggc_cp.cli.trace_cmds", "vggc_cp.errors"}
    assert floor_of("vggc_cp.plots") > floor_of("vggc_cp.experiments.perf") \
        > floor_of("vggc_cp.evaluate.metrics") > floor_of("vggc_cp.pipeline")


def test_no_import_cycles():
    cycles = import_cycles(package_imports())
    assert cycles == [], "modules that import each other:\n" + "\n".join(
        "  " + " -> ".join(c) for c in cycles)


def test_the_cycle_checker_catches_a_cycle(tmp_path):
    """A synthetic package: ``a`` imports ``b`` at the top, ``b`` imports ``c`` inside a
    function, ``c`` imports ``a``: one cycle of three; ``d`` and ``a`` importing each other only
    under ``if TYPE_CHECKING:`` is none."""
    pkg = tmp_path / "toy"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from typing import TYPE_CHECKING\nimport toy.sub.b\n"
                              "if TYPE_CHECKING:\n    from toy import d\n")
    (pkg / "sub" / "b.py").write_text("def f():\n    from toy.sub import c\n")
    (pkg / "sub" / "c.py").write_text("from toy.a import x\n")
    (pkg / "d.py").write_text("import typing\nif typing.TYPE_CHECKING:\n    import toy.a\n"
                              "else:\n    import toy.sub\n")
    graph = all_imports(pkg)
    assert graph["toy.d"] == {"toy.sub"}
    assert import_cycles(graph) == [["toy.a", "toy.sub.b", "toy.sub.c", "toy.a"]]
    (pkg / "sub" / "c.py").write_text("x = 1\n")
    assert import_cycles(all_imports(pkg)) == []
    # two modules importing each other lazily, both ways
    (pkg / "e.py").write_text("def f():\n    import toy.g\n")
    (pkg / "g.py").write_text("def f():\n    from toy import e\n")
    assert import_cycles(all_imports(pkg)) == [["toy.e", "toy.g", "toy.e"]]
