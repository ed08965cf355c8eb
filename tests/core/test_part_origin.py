"""Issue 28 row 10: TCP posts accept a part whose origin is offset from the rotary centre (the
header states the work offset to set), and ``--part-origin X,Y,Z`` sets it without copying a
machine preset (joint programs too)."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.cli.main import main as cli_main
from blisk_cam.core.errors import PostError
from blisk_cam.core.machine.description import MACHINES_DIR, forward, load_machine
from blisk_cam.core.post.export import export_nc, nc_program
from blisk_cam.core.toolpath.paths_io import write_paths_json
from tests.support.nc import demo_path

PRESET = (MACHINES_DIR / "ac-trunnion.toml").read_text()


@pytest.fixture(scope="module")
def demo():
    return demo_path()


@pytest.mark.parametrize("post", ["fanuc", "siemens"])
def test_tcp_post_with_the_part_above_the_table(demo, tmp_path, post):
    f = tmp_path / "lifted.toml"
    f.write_text(PRESET.replace("origin = [0, 0, 0]", "origin = [0, 0, 20]"))
    lifted = load_machine(f)
    assert np.allclose(lifted.part_origin, [0, 0, 20])
    out = tmp_path / f"p.{post}"
    export_nc(demo, lifted, post, None, out)  # before: PostError (shifted [part] frame)
    text = out.read_text()
    head = text.upper()
    assert "WORK OFFSET" in head and "Z20.0000" in head.replace(" ", "")
    # the planned poses' tip words and rotaries do not depend on where the part sits (the
    # controller's TCP adds it through the work offset; only the blocks linearization inserts
    # may differ: the rotaries' lever arm changed)
    _, b1 = nc_program(demo, lifted, post)
    _, b0 = nc_program(demo, "ac-trunnion", post)
    k1, k0 = b1.source >= 0, b0.source >= 0
    assert np.array_equal(b1.source[k1], b0.source[k0])
    assert np.allclose(b1.tip[k1], b0.tip[k0], atol=1e-9)
    assert np.allclose(b1.angles[k1], b0.angles[k0], atol=1e-9)


def test_turned_part_frame_still_refused(demo, tmp_path):
    f = tmp_path / "turned.toml"
    f.write_text(PRESET.replace("x = [1, 0, 0]", "x = [0, 1, 0]"))
    with pytest.raises(PostError, match="turned"):
        export_nc(demo, load_machine(f), "fanuc", None, tmp_path / "x.nc")


def test_part_origin_flag(demo, tmp_path, capsys):
    js = tmp_path / "p.json"
    write_paths_json(demo, js)
    out = tmp_path / "p.ngc"
    base = ["nc", "--paths", str(js), "--machine", "ac-trunnion", "--post", "linuxcnc",
            "--out", str(out), "--quiet"]
    assert cli_main([*base, "--part-origin", "1.5,-2,20"]) == 0
    capsys.readouterr()
    text = out.read_text()
    assert "X1.5000 Y-2.0000 Z20.0000" in text.replace("  ", " ")
    # the joint program: forward kinematics of its blocks, with the part there, lands on the
    # planned tips
    m = load_machine("ac-trunnion")
    from dataclasses import replace

    moved = replace(m, part_origin=np.array([1.5, -2.0, 20.0]))
    rows = []
    for line in text.splitlines():
        if line.startswith("G1 "):
            w = {t[0]: float(t[1:]) for t in line.split()[1:] if t[0] in "XYZAC"}
            if len(w) == 5:
                rows.append([w[k] for k in "XYZAC"])
    q = np.array(rows)
    tips, _ = forward(moved, q[:, :3], np.radians(q[:, 3:]))
    planned = demo.program.tip
    d = np.min(np.linalg.norm(tips[:, None] - planned[None], axis=2), axis=1)
    assert np.median(d) < 1e-3
    for bad in ("1,2", "a,b,c", "1,2,nan"):
        assert cli_main([*base, "--part-origin", bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "--part-origin" in err[0]
