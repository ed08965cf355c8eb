"""The house rules of ``docs/ARCHITECTURE.md``, read from the source with ``ast``.

Every import counts, the ones inside functions too (``ast.walk``): an import deferred into a
function is still a dependency, and hiding a circle there is what these rules forbid.

* no import cycle in the package;
* the core's floors only go down (a core package imports only floors below its own);
* core never imports outside core; ``verify`` never imports ``paths`` or ``process``;
  ``paths`` never imports ``collision``, ``verify`` or ``process``; ``kernels`` imports nothing
  from core but ``errors``; the Blender side never imports ``cli`` or ``batch``; only
  ``batch`` imports dask; only ``kernels`` imports the compiled extension;
* inside core, a function-level import is only of a third-party module a run may not need
  (an optional dependency, or scipy.spatial where a k-d tree is built and scipy.sparse where
  the numpy route builds a graph: ~60 ms of the CLI's startup), with its reason on the line
  (``# optional: ...``);
* no private name (``_x``) is imported across a package boundary;
* the core's, ``blender``'s and ``cli``'s ``__init__`` files are signs (one docstring);
* no module is longer than 900 lines.

Each rule is also run on a planted violation, so a rule that cannot fail is caught here.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "blisk_cam"
CORE = "blisk_cam.core"

#: the core's floors (LAYOUT.md): a package may import only packages on floors below its
#: own, and itself
FLOORS = {
    "errors": 1, "version": 1, "runtime": 1, "kernels": 1,
    "options": 2, "presets": 2, "files": 2, "geometry": 2,
    "tool": 3, "part": 3,
    "toolpath": 4,
    "paths": 5, "verify": 5, "machine": 5, "stock": 5, "hub": 5,
    "collision": 6, "post": 6, "robot": 6, "channel": 6,
    "process": 7, "display": 7,
}
#: imports allowed across floors that are not strictly downward: (importer, imported) packages
FLOOR_EXCEPTIONS: set[tuple[str, str]] = set()
#: what a package must never import (prefixes of dotted module names)
NEVER = {
    "blisk_cam.core.verify": ("blisk_cam.core.paths", "blisk_cam.core.process"),
    "blisk_cam.core.paths": ("blisk_cam.core.collision", "blisk_cam.core.verify",
                             "blisk_cam.core.process"),
}
BLENDER_SIDE = ("blisk_cam.blender", "blisk_cam.properties", "blisk_cam.operators",
                "blisk_cam.panels", "blisk_cam.gizmos")
#: the compiled extension's module name (the kernels issue builds it)
EXTENSION = "blisk_cam_kernels"
MAX_LINES = 900


# ------------------------------------------------------------------------------ reading
def _module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _files() -> dict[str, Path]:
    return {_module_name(p): p for p in PACKAGE.rglob("*.py")}


class Import:
    """One imported name: ``module`` (absolute), ``name`` (or None for ``import module``),
    whether it is at module level, its line and the source line's text."""

    def __init__(self, module, name, top, line, text):
        self.module, self.name, self.top, self.line, self.text = module, name, top, line, text


def read_imports(path: Path, name: str) -> list[Import]:
    source = path.read_text(encoding="utf-8")
    lines = source.splitlines()
    tree = ast.parse(source)
    top = {id(n) for n in tree.body}
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = []
    for node in ast.walk(tree):
        text = lines[node.lineno - 1] if hasattr(node, "lineno") else ""
        if isinstance(node, ast.Import):
            out += [Import(a.name, None, id(node) in top, node.lineno, text) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out += [Import(mod, a.name, id(node) in top, node.lineno, text) for a in node.names]
    return out


def import_graph(files=None) -> dict[str, set[str]]:
    """{module: modules of the package it imports}, counting imports inside functions.
    ``from pkg import sub`` is an edge to the module ``pkg.sub``; ``from pkg import name`` an
    edge to ``pkg`` (its ``__init__``), parents included."""
    files = files if files is not None else _files()
    graph = {}
    for name, path in files.items():
        edges = set()
        for imp in read_imports(path, name):
            full = f"{imp.module}.{imp.name}" if imp.name else imp.module
            target = full if full in files else imp.module
            if target in files and target != name:
                edges.add(target)
        graph[name] = edges
    return graph


# ------------------------------------------------------------------------------ rules
def find_cycle(graph):
    """One cycle as a list of modules, or None."""
    state, stack = {}, []

    def visit(u):
        state[u] = 1
        stack.append(u)
        for v in sorted(graph.get(u, ())):
            if state.get(v) == 1:
                return stack[stack.index(v):] + [v]
            if v not in state:
                found = visit(v)
                if found:
                    return found
        stack.pop()
        state[u] = 2
        return None

    for u in sorted(graph):
        if u not in state:
            found = visit(u)
            if found:
                return found
    return None


def _core_package(module: str) -> str | None:
    if not module.startswith(CORE + "."):
        return None
    return module[len(CORE) + 1:].split(".")[0]


def floor_violations(graph) -> list[str]:
    out = []
    for mod, targets in graph.items():
        own = _core_package(mod)
        if own is None:
            continue
        for t in targets:
            other = _core_package(t)
            if other is None or other == own:
                continue
            if own not in FLOORS or other not in FLOORS:
                out.append(f"{mod} → {t}: package without a floor (add it to FLOORS)")
            elif FLOORS[other] >= FLOORS[own] and (own, other) not in FLOOR_EXCEPTIONS:
                out.append(f"{mod} (floor {FLOORS[own]}) → {t} (floor {FLOORS[other]})")
    return out


def rule_violations(imports: dict[str, list[Import]]) -> list[str]:
    """The never-import rules, on {module: its imports}."""
    out = []
    for mod, imps in imports.items():
        for imp in imps:
            full = f"{imp.module}.{imp.name}" if imp.name else imp.module
            top = imp.module.split(".")[0]
            if mod.startswith(CORE) and top == "blisk_cam" and not imp.module.startswith(CORE):
                out.append(f"{mod}:{imp.line} core imports outside core: {full}")
            for pkg, banned in NEVER.items():
                if mod.startswith(pkg) and any(full.startswith(b) for b in banned):
                    out.append(f"{mod}:{imp.line} {pkg} must not import {full}")
            if mod.startswith(CORE + ".kernels") and imp.module.startswith(CORE) \
                    and not imp.module.startswith((CORE + ".kernels", CORE + ".errors")):
                out.append(f"{mod}:{imp.line} kernels imports {full} (only errors)")
            if mod.startswith(BLENDER_SIDE) and full.startswith(("blisk_cam.cli",
                                                                 "blisk_cam.batch")):
                out.append(f"{mod}:{imp.line} the Blender side imports {full}")
            if top == "dask" and not mod.startswith("blisk_cam.batch"):
                out.append(f"{mod}:{imp.line} imports dask outside blisk_cam.batch")
            if top == EXTENSION and not mod.startswith(CORE + ".kernels"):
                out.append(f"{mod}:{imp.line} imports the compiled extension outside kernels")
    return out


def deferred_core_imports(imports: dict[str, list[Import]]) -> list[str]:
    """Function-level imports in core that are not of an optional third-party dependency
    with its reason beside it."""
    out = []
    for mod, imps in imports.items():
        if not mod.startswith(CORE):
            continue
        for imp in imps:
            if imp.top:
                continue
            ours = imp.module.split(".")[0] == "blisk_cam" or imp.module == ""
            if ours or "# optional:" not in imp.text:
                out.append(f"{mod}:{imp.line} imports {imp.module} inside a function")
    return out


def _package_of(module: str, packages: set[str]) -> str:
    return module if module in packages else module.rsplit(".", 1)[0]


def private_crossings(imports: dict[str, list[Import]], packages: set[str]) -> list[str]:
    out = []
    for mod, imps in imports.items():
        for imp in imps:
            if not imp.module.startswith("blisk_cam") or not imp.name:
                continue
            if imp.name.startswith("_") and not imp.name.startswith("__"):
                if _package_of(imp.module, packages) != _package_of(mod, packages):
                    out.append(f"{mod}:{imp.line} imports private {imp.module}.{imp.name}")
    return out


def _all_imports(files):
    return {name: read_imports(path, name) for name, path in files.items()}


def _packages(files):
    return {name for name, path in files.items() if path.name == "__init__.py"}


# ------------------------------------------------------------------------------ the tree
def test_no_import_cycle_counting_imports_inside_functions():
    graph = import_graph()
    assert len(graph) > 80  # the walk found the package
    cycle = find_cycle(graph)
    assert cycle is None, " → ".join(cycle)


def test_core_floors_only_go_down():
    graph = import_graph()
    assert {_core_package(m) for m in graph} - {None} <= set(FLOORS)
    assert floor_violations(graph) == []


def test_never_import_rules_hold():
    assert rule_violations(_all_imports(_files())) == []


def test_core_defers_no_import_of_its_own():
    assert deferred_core_imports(_all_imports(_files())) == []


def test_no_private_name_crosses_a_package():
    files = _files()
    assert private_crossings(_all_imports(files), _packages(files)) == []


def test_package_inits_are_signs():
    """The core's, blender's and cli's ``__init__`` hold one docstring and nothing else (no
    re-exports: they would hide where a name lives)."""
    signs = [p for p in PACKAGE.rglob("__init__.py")
             if _module_name(p).startswith(("blisk_cam.core", "blisk_cam.blender",
                                            "blisk_cam.cli"))]
    assert len(signs) >= 12
    for p in signs:
        body = ast.parse(p.read_text(encoding="utf-8")).body
        assert len(body) == 1 and isinstance(body[0], ast.Expr) \
            and isinstance(body[0].value, ast.Constant), f"{p} is not a sign"
        assert len(body[0].value.value.strip()) > 40, f"{p}: say what lives there"


def test_no_module_over_900_lines():
    long = {n: len(p.read_text(encoding="utf-8").splitlines()) for n, p in _files().items()}
    assert {n: k for n, k in long.items() if k > MAX_LINES} == {}


# ------------------------------------------------------------------------------ planted
def _imp(module, name=None, top=True, text=""):
    return Import(module, name, top, 1, text)


def test_cycle_finder_finds_a_planted_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set()}) is None


def test_a_deferred_import_is_an_edge(tmp_path):
    """The circle hidden in a function is seen: b imports a inside a function."""
    pkg = tmp_path / "blisk_cam"
    pkg.mkdir()
    (pkg / "__init__.py").write_text('"""x"""\n')
    (pkg / "a.py").write_text("from . import b\n")
    (pkg / "b.py").write_text("def f():\n    from .a import g\n")
    files = {"blisk_cam": pkg / "__init__.py", "blisk_cam.a": pkg / "a.py",
             "blisk_cam.b": pkg / "b.py"}
    graph = import_graph(files)
    assert graph["blisk_cam.b"] == {"blisk_cam.a"}
    assert find_cycle(graph) == ["blisk_cam.a", "blisk_cam.b", "blisk_cam.a"]


def test_a_name_from_the_parent_package_is_an_edge(tmp_path):
    """The old core/post/common → blisk_cam circle: a module takes a name from its package's
    ``__init__``, which imports the module back inside a function."""
    pkg = tmp_path / "blisk_cam"
    pkg.mkdir()
    (pkg / "__init__.py").write_text('VERSION = "1"\n\ndef register():\n    from . import a\n')
    (pkg / "a.py").write_text("from . import VERSION\n")
    files = {"blisk_cam": pkg / "__init__.py", "blisk_cam.a": pkg / "a.py"}
    graph = import_graph(files)
    assert graph == {"blisk_cam": {"blisk_cam.a"}, "blisk_cam.a": {"blisk_cam"}}
    assert find_cycle(graph) == ["blisk_cam", "blisk_cam.a", "blisk_cam"]


def test_floor_rule_catches_an_upward_and_a_sideways_import():
    up = {"blisk_cam.core.geometry.mesh": {"blisk_cam.core.part.cones"}}
    side = {"blisk_cam.core.machine.kinematics": {"blisk_cam.core.verify.measure"}}
    down = {"blisk_cam.core.verify.measure": {"blisk_cam.core.geometry.mesh"}}
    inside = {"blisk_cam.core.verify.measure": {"blisk_cam.core.verify.sweep"}}
    unknown = {"blisk_cam.core.attic.x": {"blisk_cam.core.errors"}}
    assert len(floor_violations(up)) == 1
    assert len(floor_violations(side)) == 1
    assert floor_violations(down) == floor_violations(inside) == []
    assert "without a floor" in floor_violations(unknown)[0]


def test_never_rules_catch_planted_violations():
    planted = {
        "blisk_cam.core.post.common": [_imp("blisk_cam", "__version__")],
        "blisk_cam.core.verify.measure": [_imp("blisk_cam.core.paths.passes", "x", top=False)],
        "blisk_cam.core.paths.passes": [_imp("blisk_cam.core.collision.scene", "x")],
        "blisk_cam.core.kernels.step": [_imp("blisk_cam.core.geometry.mesh", "TriMesh")],
        "blisk_cam.operators.common": [_imp("blisk_cam.cli.paths", "parse_holder", top=False)],
        "blisk_cam.blender.render": [_imp("blisk_cam.batch.run", "x")],
        "blisk_cam.cli.main": [_imp("dask.distributed", "Client")],
        "blisk_cam.core.paths.sampling": [_imp(EXTENSION, "forward_step")],
    }
    found = rule_violations(planted)
    assert len(found) == len(planted), found
    for mod in planted:
        assert any(f.startswith(mod + ":") for f in found), mod
    fine = {
        "blisk_cam.core.kernels.step": [_imp("blisk_cam.core.errors", "BliskCamError"),
                                        _imp(EXTENSION, "forward_step")],
        "blisk_cam.batch.run": [_imp("dask.distributed", "Client")],
        "blisk_cam.cli.blender": [_imp("blisk_cam.operators.common", "INTERNAL_ERROR")],
    }
    assert rule_violations(fine) == []


def test_deferred_import_rule_catches_planted_ones():
    planted = {"blisk_cam.core.paths.slicing": [
        _imp("blisk_cam.core.part.profiles", "Profile", top=False, text="from x import y"),
        _imp("trimesh", None, top=False, text="    import trimesh"),
    ]}
    assert len(deferred_core_imports(planted)) == 2
    fine = {"blisk_cam.core.paths.slicing": [
        _imp("trimesh", None, top=False, text="    import trimesh  # optional: not bundled"),
        _imp("blisk_cam.core.part.profiles", "Profile", top=True),
    ], "blisk_cam.cli.main": [_imp("blisk_cam.core.version", "__version__", top=False)]}
    assert deferred_core_imports(fine) == []


def test_private_rule_catches_a_planted_crossing():
    packages = {"blisk_cam.core.geometry", "blisk_cam.core.verify"}
    planted = {"blisk_cam.core.verify.sweep": [_imp("blisk_cam.core.geometry.bvh", "_Tree")]}
    inside = {"blisk_cam.core.verify.forest": [_imp("blisk_cam.core.verify.sweep", "_fast")]}
    assert len(private_crossings(planted, packages)) == 1
    assert private_crossings(inside, packages) == []
