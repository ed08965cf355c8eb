"""Issue 28 row 9: program text is ASCII for every controller (no Ø in a Fanuc comment: the
tool is written "D12"), and programs are written with the user's umask, not 0600."""

from __future__ import annotations

import copy
import os
import stat

import pytest

from blisk_cam.core.post.common import write_atomic
from blisk_cam.core.post.export import POSTS, export_nc
from tests.support.nc import demo_path


@pytest.fixture(scope="module")
def demo():
    return demo_path()


def _machine(post):
    return "bc-trunnion" if post in ("heidenhain", "apt") else "ac-trunnion"


@pytest.mark.parametrize("post", POSTS)
def test_program_text_is_ascii(demo, tmp_path, post):
    p = copy.deepcopy(demo)
    out = tmp_path / f"ü_Ø.{post}"  # a non-ASCII file name still gives an ASCII program
    export_nc(p, _machine(post), post, None, out)
    raw = out.read_bytes()
    assert raw.isascii(), [ln for ln in raw.decode().splitlines() if not ln.isascii()][:3]
    text = raw.decode().upper()
    d = f"D{p.tool.d:g}"
    assert d in text  # the tool still stated, as D12


@pytest.mark.skipif(os.name == "nt", reason="Windows files have no POSIX permission bits")
@pytest.mark.parametrize("mask", [0o022, 0o002, 0o077])
def test_programs_are_written_with_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        f = write_atomic(tmp_path / "p.nc", "G0 X0\n")
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(f).st_mode) == 0o666 & ~mask
