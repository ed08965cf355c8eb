"""``python -m blisk_cam simulate``: outputs, verdict exit status, rest machining from a saved
stock, bad input. A small analytic blade on a hub cone, coarse resolution (cheap)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from blisk_cam.cli.main import main
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.paths_io import write_paths_json
from blisk_cam.core.toolpath.types import MOVE_CUT, MOVE_RAPID, Program, ToolPath
from tests.support.blades import tube_blade
from tests.support.mesh_files import write_binary_stl


def _files(tmp_path, dive: float):
    V, F, mc = tube_blade(n_u=48, n_v=12)
    blade = write_binary_stl(tmp_path / "blade.stl", V, F)
    hub = tmp_path / "hub.csv"
    c = mc.cone1
    hub.write_text(f"{c.r1}, {c.z1}\n{c.r2}, {c.z2}\n")
    # a rapid down the radial line at θ = −4° (in the passage) to r = 110 − dive, and back
    e = np.array([math.cos(math.radians(-4)), math.sin(math.radians(-4)), 0.0])
    tips = np.array([e * 150 + [0, 0, 5], e * (110.0 - dive) + [0, 0, 5], e * 150 + [0, 0, 5]])
    m = len(tips)
    prog = Program(tips, np.tile(e, (m, 1)), np.array([MOVE_RAPID, MOVE_RAPID, MOVE_CUT],
                                                      np.int8),
                   np.full(m, -1), np.full(m, -1), np.zeros(m, np.uint8))
    path = ToolPath(Axis(), Cone(c.r1, c.z1, c.r2, c.z2), mc.cone2, Cutter.ball(2.0), 0.05, 0.02,
                    [], program=prog)
    paths = write_paths_json(path, tmp_path / "paths.json")
    return blade, hub, paths


def test_simulate_crash_exit_5_and_outputs(tmp_path, capsys):
    blade, hub, paths = _files(tmp_path, dive=12.0)  # tip at r 98: 3.5 mm into the hub
    out = tmp_path / "report.json"
    rc = main(["simulate", "--part", str(blade), "--hub-profile", str(hub), "--blade-count",
               "30", "--stock", "allowance:0.2", "--program", str(paths), "--resolution", "0.4",
               "--out", str(out), "--deviation", str(tmp_path / "dev.ply"),
               "--stock-mesh", str(tmp_path / "stock.stl"),
               "--save-stock", str(tmp_path / "state.npz")])
    err = capsys.readouterr().err
    assert rc == 5, err
    assert "verdict: FAILED" in err and "row 1" in err and "%" in err  # progress on stderr
    rep = json.loads(out.read_text())
    assert not rep["passed"]
    assert (1, "rapid") in [(c["row"], c["kind"]) for c in rep["crashes"]]
    assert rep["volume_removed_mm3"]["by_move"]["rapid"] > 0
    raw = (tmp_path / "dev.ply").read_bytes()
    head, body = raw.split(b"end_header\n", 1)
    assert b"property float deviation\nproperty uchar judged" in head
    n = int(head.split(b"element vertex ")[1].split(b"\n")[0])
    vert = np.frombuffer(body[:17 * n], dtype=[("p", "<f4", 3), ("d", "<f4"), ("j", "u1")])
    # the judged flags are the verdict's: its count of vertices not judged, the deviation
    # read back as written, and the rapid's gouge among the judged vertices
    assert int((vert["j"] == 0).sum()) >= rep["deviation_mm"]["not_judged_vertices"]
    assert vert["j"].max() == 1 and set(np.unique(vert["j"])) <= {0, 1}
    judged_dev = vert["d"][vert["j"] == 1].astype(float)
    assert np.isfinite(judged_dev).all()
    assert rep["deviation_mm"]["max_gouge"] > 0
    assert -judged_dev.min() == pytest.approx(rep["deviation_mm"]["max_gouge"], abs=1e-5)
    assert (tmp_path / "stock.stl").stat().st_size > 84
    # the next operation starts from the saved stock: a program in the air removes nothing
    # and finds the same deviation (the gouges of the first run are still there)
    blade, hub, paths = _files(tmp_path, dive=-20.0)
    rc = main(["simulate", "--part", str(blade), "--hub-profile", str(hub), "--blade-count",
               "30", "--stock", str(tmp_path / "state.npz"), "--program", str(paths),
               "--out", str(tmp_path / "report2.json")])
    capsys.readouterr()
    rep2 = json.loads((tmp_path / "report2.json").read_text())
    assert rep2["volume_removed_mm3"]["sector"] == 0.0 and not rep2["crashes"]
    assert rep2["volume_initial_mm3"]["sector"] == rep["volume_remaining_mm3"]["sector"]
    assert rep2["deviation_mm"] == rep["deviation_mm"]
    assert rc == (0 if rep2["passed"] else 5)


def test_simulate_bad_input(tmp_path, capsys):
    blade, hub, paths = _files(tmp_path, dive=-20.0)
    base = ["simulate", "--part", str(blade), "--hub-profile", str(hub), "--blade-count", "30",
            "--program", str(paths), "--out", str(tmp_path / "r.json")]
    assert main(base + ["--stock", str(tmp_path / "missing.csv")]) == 1
    assert "not found" in capsys.readouterr().err
    assert main(base + ["--stock", "allowance:abc"]) == 2
    assert main(base + ["--stock", "allowance:0.1", "--resolution", "0"]) == 2
    assert main(["simulate", "--part", str(blade), "--hub-profile", str(hub), "--blade-count",
                 "30", "--program", str(paths), "--stock", "allowance:0.1", "--out",
                 str(paths)]) == 2  # an input is never overwritten
    err = capsys.readouterr().err
    assert "also an input" in err and "Traceback" not in err
    assert not (tmp_path / "r.json").exists()
