"""One version: ``core/version.py`` is where it is written; the extension manifest, the Python
project, the add-on and the NC program header say the same."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import blisk_cam
from blisk_cam.core.post import common
from blisk_cam.core.version import __version__

ROOT = Path(__file__).resolve().parents[2]


def test_manifest_and_pyproject_say_the_version():
    manifest = tomllib.loads((ROOT / "blisk_cam" / "blender_manifest.toml").read_text())
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert re.fullmatch(r"\d+\.\d+\.\d+", __version__)
    assert manifest["version"] == __version__
    assert project["version"] == __version__


def test_the_addon_and_the_program_header_say_the_version():
    assert blisk_cam.__version__ == __version__
    assert common.version() == __version__


def test_the_version_is_written_once():
    """No other file of the package assigns a version string of its own (the paths JSON's
    format number, an int, is another thing)."""
    pattern = re.compile(r"^\s*\w*version\w*\s*=\s*[\"']\d", re.M | re.I)
    writers = [p.relative_to(ROOT).as_posix() for p in (ROOT / "blisk_cam").rglob("*.py")
               if pattern.search(p.read_text(encoding="utf-8"))]
    assert writers == ["blisk_cam/core/version.py"]
