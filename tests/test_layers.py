"""The package's floors: no module imports from a floor above its own, and no CLI command
module imports another (issue 18). Read from the source with :mod:`ast`, lazy imports inside
functions included."""

from __future__ import annotations

import ast
from pathlib import Path

import vggc_cp

ROOT = Path(vggc_cp.__file__).parent

#: Floors, low to high; a module's floor is that of its longest listed prefix.
FLOORS = (
    ("vggc_cp", "vggc_cp.version", "vggc_cp.errors", "vggc_cp.atomic", "vggc_cp.safeio", "vggc_cp.score",
     "vggc_cp.trace", "vggc_cp.graph", "vggc_cp.solution"),
    ("vggc_cp.vision", "vggc_cp.sim", "vggc_cp.solvers", "vggc_cp.baselines",
     "vggc_cp.importers", "vggc_cp.export"),
    ("vggc_cp.pipeline",),
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


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def floor_of(name: str) -> int:
    best, floor = -1, None
    for i, prefixes in enumerate(FLOORS):
        for p in prefixes:
            if (name == p or name.startswith(p + ".")) and len(p) > best:
                best, floor = len(p), i
    assert floor is not None, f"{name} is on no floor: add it to FLOORS"
    return floor


def imports_of(path: Path) -> set[str]:
    """Every ``vggc_cp`` module that ``path`` imports (``from vggc_cp import x`` counts as
    ``vggc_cp.x`` when ``x`` is a module)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == "vggc_cp"}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                and node.module.split(".")[0] == "vggc_cp":
            base = ROOT.parent.joinpath(*node.module.split("."))
            subs = [a.name for a in node.names
                    if (base / f"{a.name}.py").is_file() or (base / a.name).is_dir()]
            out |= {f"{node.module}.{s}" for s in subs} or {node.module}
    return out


def all_imports() -> dict[str, set[str]]:
    return {module_name(p): imports_of(p) for p in sorted(ROOT.rglob("*.py"))}


def test_every_module_is_on_a_floor():
    for name in all_imports():
        floor_of(name)


def test_no_module_imports_from_a_higher_floor():
    upward = sorted((m, i) for m, imps in all_imports().items() for i in imps
                    if floor_of(i) > floor_of(m) and (m, i) not in FACE_IMPORTS)
    assert upward == [], "imports from a higher floor:\n" + "\n".join(
        f"  {m} -> {i}" for m, i in upward)


def test_cli_commands_never_import_each_other():
    cmds = {m: imps for m, imps in all_imports().items()
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
