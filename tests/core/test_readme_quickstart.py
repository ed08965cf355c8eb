"""Issue 28 row 2: the README quick start checks collisions, with the holder it states: the
Rotor 37 command parses with this CLI (flags and values valid), its collision mode is not off,
it gives the blade count once (no deprecated --blades) and a --holder that the text names."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

from blisk_cam.cli.main import build_parser
from blisk_cam.cli.paths import _check_paths_args

ROOT = Path(__file__).resolve().parents[2]


def quick_start():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    section = text.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```sh\n(.*?)```", section, flags=re.S)
    cmd = next(b for b in blocks if "blisk_cam paths" in b)
    return section, shlex.split(cmd.replace("\\\n", " "))


def test_quick_start_checks_collisions_with_a_stated_holder(monkeypatch):
    section, argv = quick_start()
    argv = argv[argv.index("blisk_cam") + 1:]
    monkeypatch.chdir(ROOT)
    args = build_parser().parse_args(argv)
    _check_paths_args(args)
    assert args.collision.mode in ("check", "avoid")
    assert args.collision.blade_count == 36 and "--blades" not in argv
    # the holder is named in the text too, not only in the command
    assert args.holder is not None and section.count(args.holder) >= 2
    assert args.nc and args.verify
