"""``blisk_cam.core`` is pure numpy/scipy: it imports, with every module, in a process where
``bpy``, ``bmesh`` and ``mathutils`` cannot be imported; importing ``blisk_cam`` itself does not
import bpy; the ruff rule that keeps it so fires; and the package uses relative imports only
(an installed extension is imported as ``bl_ext.<repo>.blisk_cam``)."""

import ast
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "blisk_cam"
CORE = PACKAGE / "core"
BLENDER_MODULES = ("bpy", "bmesh", "mathutils")

# Runs in a fresh interpreter: a meta-path finder that refuses the Blender modules (even when
# the bpy wheel is installed in this venv), then every module of blisk_cam/core.
BLOCKED_IMPORT_SCRIPT = r"""
import importlib, json, pkgutil, sys

BLOCKED = {blocked!r}

class BlockBlender:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"{{name}} is blocked: blisk_cam.core must not need Blender")
        return None

sys.meta_path.insert(0, BlockBlender())

import blisk_cam
import blisk_cam.core
names = ["blisk_cam", "blisk_cam.core"]
for info in pkgutil.walk_packages(blisk_cam.core.__path__, "blisk_cam.core."):
    importlib.import_module(info.name)
    names.append(info.name)
leaked = sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED)
print(json.dumps({{"imported": names, "leaked": leaked}}))
"""


def core_module_names():
    """Every module of core, subpackages included (dotted names)."""
    names = []
    for p in CORE.rglob("*.py"):
        parts = list(p.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        names.append(".".join(parts))
    return sorted(names)


def test_core_imports_without_blender():
    script = BLOCKED_IMPORT_SCRIPT.format(blocked=BLENDER_MODULES)
    proc = subprocess.run(
        [sys.executable, "-c", script],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["leaked"] == []
    assert set(core_module_names()) <= set(result["imported"])


def test_blocker_really_blocks():
    """Control: the same finder makes ``import bpy`` fail."""
    script = BLOCKED_IMPORT_SCRIPT.format(blocked=BLENDER_MODULES).replace(
        "import blisk_cam\n", "import bpy\n", 1
    )
    proc = subprocess.run(
        [sys.executable, "-c", script],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
        stdin=subprocess.DEVNULL,
    )
    assert proc.returncode != 0
    assert "bpy is blocked" in proc.stderr


def _ruff():
    if importlib.util.find_spec("ruff") is None:
        pytest.skip("ruff is not installed in this environment (it is in .venv/bpy45)")
    return [sys.executable, "-m", "ruff"]


def _ruff_stdin(source, filename):
    return subprocess.run(
        [*_ruff(), "check", "--no-cache", "--output-format", "concise"]
        + ["--stdin-filename", filename, "-"],
        cwd=ROOT,
        input=source,
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.parametrize(
    "line", ["import bpy", "import bmesh", "import mathutils", "from mathutils import Vector"]
)
def test_ruff_bans_blender_imports_in_core(line):
    name = line.split()[1].split(".")[0]
    source = f"{line}\n\nprint({line.split()[-1]})\n"
    proc = _ruff_stdin(source, "blisk_cam/core/_probe.py")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "TID251" in proc.stdout and f"`{name}` is banned" in proc.stdout


def test_ruff_accepts_numpy_in_core():
    proc = _ruff_stdin("import numpy as np\n\nprint(np.zeros(1))\n", "blisk_cam/core/_probe.py")
    assert proc.returncode == 0, proc.stdout + proc.stderr


def _absolute_self_imports(path):
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            bad += [a.name for a in node.names if a.name.split(".")[0] == "blisk_cam"]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module.split(".")[0] == "blisk_cam":
                bad.append(node.module)
    return bad


def test_package_uses_relative_imports_only():
    offenders = {
        str(p.relative_to(ROOT)): bad
        for p in sorted(PACKAGE.rglob("*.py"))
        if "wheels" not in p.parts and (bad := _absolute_self_imports(p))
    }
    assert offenders == {}


def test_core_source_has_no_blender_import():
    """Independent of ruff: no module of core names bpy/bmesh/mathutils in an import."""
    offenders = {}
    for path in sorted(CORE.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            hits = [n for n in names if n.split(".")[0] in BLENDER_MODULES]
            if hits:
                offenders.setdefault(str(path.relative_to(ROOT)), []).extend(hits)
    assert offenders == {}
