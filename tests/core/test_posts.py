"""NC posts (issue 11 §3–5): every program read back and run through forward kinematics.

The FK round trip: each program is parsed with a small parser per dialect (LinuxCNC through
rs274's canonical output), the parsed joints go through :func:`forward`, and the tip must
land on the planned tip within 1 µm + the printed precision, the axis within 1e-5 rad.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from blisk_cam.cli.main import main as cli_main
from blisk_cam.core.errors import BliskCamError, PostError, ReachError
from blisk_cam.core.machine.description import forward, load_machine
from blisk_cam.core.post import common
from blisk_cam.core.post.blocks import SAFE, NcOptions
from blisk_cam.core.post.export import POSTS, export_nc, nc_program
from blisk_cam.core.toolpath.paths_io import path_to_dict, write_paths_json
from blisk_cam.core.toolpath.types import MOVE_CUT, MOVE_RAPID
from tests.support.mesh_files import write_binary_stl
from tests.support.nc import (
    RS274,
    demo_path,
    parse_apt,
    parse_canon,
    parse_fanuc,
    parse_siemens_program,
    parse_words,
    rotor37_path,
    run_rs274,
)

PRINT_MM = 0.5e-4  # 4 decimals
TIP_TOL = 1e-3 + 2 * PRINT_MM
AXIS_TOL = 1e-5
needs_rs274 = pytest.mark.skipif(
    RS274 is None, reason="rs274 (LinuxCNC, linuxcnc-uspace) is not installed"
)


@pytest.fixture(scope="module")
def demo():
    return demo_path()


@pytest.fixture(scope="module")
def rotor37():
    return rotor37_path()


def _angle(a, b):
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def read_back(post, machine, filename, tmp_path):
    """(tip (k, 3), axis (k, 3), angles_deg (k, 2) or None) of the pose blocks of a program,
    via the program text and forward kinematics only."""
    text = open(filename, encoding="utf-8").read()
    names = machine.axis_names
    if post == "linuxcnc":
        rc, canon = run_rs274(filename, tmp_path)
        assert rc == 0, canon[-500:]
        xyz, rot, _ = parse_canon(canon, names)
        tip, ax = forward(machine, xyz, np.radians(rot))
        return tip, ax, rot, xyz
    if post in ("fanuc", "heidenhain"):
        if post == "fanuc":
            xyz, rot = parse_fanuc(text, names)
        else:
            xyz, rot = parse_words(text, names, start=r"\d+ L X")
        # TCP: X Y Z are the tip in the part frame; the axis from the rotaries alone
        _, ax = forward(machine, np.zeros_like(xyz), np.radians(rot))
        return xyz, ax, rot, None
    if post == "siemens":
        xyz, ax = parse_siemens_program(text)
        return xyz, ax, None, None
    xyz, ax = parse_apt(text)
    return xyz, ax, None, None


def check_program(post, machine, path, opts, tmp_path, name="p.nc"):
    """Write, read back, compare with the block stream and with the planned program."""
    out = tmp_path / name
    rep = export_nc(path, machine, post, opts, out)
    _, blocks = nc_program(path, machine, post, opts)
    full = blocks.expanded()
    tip, ax, rot, xyz = read_back(post, machine, out, tmp_path)
    if post == "linuxcnc":
        # one motion per pose block, two per SAFE (retract, index the rotaries), plus the safe
        # start and the safe end
        safe = full.kind == SAFE
        assert len(tip) == len(full) + safe.sum() + 2
        keep = np.concatenate([[False], np.repeat(~safe, np.where(safe, 2, 1)), [False]])
        tip, ax, rot = tip[keep], ax[keep], rot[keep]
    pose = full.poses
    assert len(tip) == pose.sum() == rep.blocks
    assert np.abs(tip - full.tip[pose]).max() < TIP_TOL
    assert _angle(ax, full.axis[pose]).max() < AXIS_TOL
    # the planned program: every pose of every blade is there, in order
    prog = path.program
    src = full.source[pose]
    bl = full.blade[pose]
    n = opts.blades
    o, d = path.axis.o, path.axis.d
    for k in range(n):
        sel = (bl == k) & (src >= 0)
        assert np.array_equal(src[sel], np.arange(len(prog)))
        from blisk_cam.core.geometry.vectors import rotate_about

        turn = 2 * math.pi * k / n
        ptip, pax = rotate_about(prog.tip, d, turn, o), rotate_about(prog.axis, d, turn)
        assert np.abs(tip[sel] - ptip).max() < TIP_TOL
        assert _angle(ax[sel], pax).max() < AXIS_TOL
    if rot is not None:
        # limits on every block; no rotary > 5° between consecutive cut blocks
        for j, r in enumerate(machine.rotaries):
            if r.limits:
                lo, hi = np.degrees(r.limits)
                assert rot[:, j].min() >= lo - 1e-4 and rot[:, j].max() <= hi + 1e-4
        kind = full.kind[pose]
        cut = (kind[1:] == MOVE_CUT) & (kind[:-1] == MOVE_CUT)
        assert np.abs(np.diff(rot, axis=0))[cut].max() <= 5.0 + 1e-3
    if xyz is not None:
        for j, a in enumerate("XYZ"):
            lim = machine.linear.get(a)
            if lim:
                assert xyz[:, j].min() >= lim[0] - 1e-4 and xyz[:, j].max() <= lim[1] + 1e-4
    return rep, out


CASES = [
    ("linuxcnc", "ac-trunnion"), ("linuxcnc", "bc-trunnion"),
    ("fanuc", "ac-trunnion"), ("fanuc", "bc-head-table"),
    ("siemens", "ac-trunnion"), ("siemens", "bc-head-table"),
    ("heidenhain", "bc-trunnion"), ("heidenhain", "bc-head-table"),
    ("apt", "ac-trunnion"),
]


@pytest.mark.parametrize("post, machine", CASES)
def test_fk_round_trip_demo(demo, post, machine, tmp_path):
    if post == "linuxcnc" and RS274 is None:
        pytest.skip("rs274 (LinuxCNC, linuxcnc-uspace) is not installed")
    m = load_machine(machine)
    rep, out = check_program(post, m, demo, NcOptions(blade_name="demo"), tmp_path)
    text = out.read_text().lower()
    # header and program frame (fanuc comments are upper case)
    assert "blisk cam" in text and "d12 ball" in text and m.name.lower() in text and post in text
    assert "chord 0.1 mm" in text and "s10000" in text.replace("spindl/rpm,", "s")
    assert not any(".tmp" in f for f in os.listdir(out.parent))
    if post != "apt":
        assert rep.minutes > 0 and rep.inserted >= 0


@pytest.mark.parametrize("post, machine", [
    ("linuxcnc", "ac-trunnion"), ("fanuc", "bc-head-table"), ("siemens", "ac-trunnion"),
    ("heidenhain", "ac-trunnion"), ("apt", "ac-trunnion"),
])
def test_fk_round_trip_rotor37(rotor37, post, machine, tmp_path):
    if post == "linuxcnc" and RS274 is None:
        pytest.skip("rs274 (LinuxCNC, linuxcnc-uspace) is not installed")
    check_program(post, load_machine(machine), rotor37, NcOptions(blade_name="rotor37"), tmp_path)


@pytest.mark.parametrize("post, machine, indexed", [
    ("linuxcnc", "ac-trunnion", True),   # C is the blisk axis: O-word sub called per blade
    ("fanuc", "ac-trunnion", True),      # M98 sub, macro variables: XY turned, C offset
    ("siemens", "bc-head-table", True),  # repeated section under ROT Z
    ("heidenhain", "ac-trunnion", False),  # rotated CL data, solved again
    ("fanuc", "turned-axis", False),     # blisk axis not on C: rotated CL data
])
def test_blades_rotate_about_the_blisk_axis(demo, post, machine, indexed, tmp_path):
    if post == "linuxcnc" and RS274 is None:
        pytest.skip("rs274 (LinuxCNC, linuxcnc-uspace) is not installed")
    path = demo
    if machine == "turned-axis":
        import copy

        from blisk_cam.core.geometry.axis import Axis
        from blisk_cam.core.geometry.vectors import rotate_about

        path = copy.deepcopy(demo)  # the same blade, its blisk axis tilted by 1° about X
        path.axis = Axis((0.0, 0.0, 0.0), (0.0, -math.sin(0.01745), math.cos(0.01745)))
        path.program.tip = rotate_about(demo.program.tip, [1.0, 0, 0], 0.01745, [0, 0, 0])
        path.program.axis = rotate_about(demo.program.axis, [1.0, 0, 0], 0.01745)
        machine = "ac-trunnion"
    m = load_machine(machine)
    rep, out = check_program(post, m, path, NcOptions(blades=3), tmp_path)
    assert rep.indexed is indexed and rep.blades == 3
    text = out.read_text()
    if indexed and post == "linuxcnc":
        assert text.count("o100 call") == 3 and "C[#1+" in text
        assert "o100 call [-120.0000]" in text
    if indexed and post == "fanuc":
        assert text.count("M98 P1001") == 3 and "#2=-240.0000" in text
    if indexed and post == "siemens":
        assert "ROT Z=_BLADE*120.00000000" in text and "IF _BLADE<3 GOTOB BLADE_LOOP" in text


@needs_rs274
def test_rs274_every_linuxcnc_program_runs(demo, tmp_path):
    for opts in (NcOptions(), NcOptions(blades=24, coolant=False, spindle_cw=False)):
        out = tmp_path / "x.ngc"
        export_nc(demo, "ac-trunnion", "linuxcnc", opts, out)
        rc, canon = run_rs274(out, tmp_path)
        assert rc == 0
        assert "STRAIGHT_FEED" in canon and "PROGRAM_END" in canon


def test_tcp_post_refuses_turned_part_frame(demo, tmp_path):
    text = (load_machine("ac-trunnion").source and open(load_machine("ac-trunnion").source).read())
    f = tmp_path / "turned.toml"
    f.write_text(text.replace("x = [1, 0, 0]", "x = [0, 1, 0]"))
    m = load_machine(f)
    for post in ("fanuc", "siemens", "heidenhain"):
        with pytest.raises(PostError, match="turned \\[part\\] frame"):
            export_nc(demo, m, post, None, tmp_path / "t.nc")
    # the joint post accepts it and still round-trips
    if RS274 is not None:
        check_program("linuxcnc", m, demo, NcOptions(), tmp_path)


def test_unknown_post_and_unsupported_machine(demo, tmp_path):
    with pytest.raises(PostError, match="unknown post 'haas'.*linuxcnc, fanuc"):
        export_nc(demo, "ac-trunnion", "haas", None, tmp_path / "x.nc")
    with pytest.raises(PostError, match="table-table"):
        export_nc(demo, "bc-head-table", "linuxcnc", None, tmp_path / "x.nc")
    assert set(POSTS) == {"linuxcnc", "fanuc", "siemens", "heidenhain", "apt"}


def test_output_directory_missing(demo, tmp_path):
    with pytest.raises(PostError, match="does not exist"):
        export_nc(demo, "ac-trunnion", "fanuc", None, tmp_path / "nope" / "x.nc")


def test_atomic_write_leaves_nothing_on_failure(demo, tmp_path, monkeypatch):
    out = tmp_path / "x.nc"

    def boom(*a, **k):
        raise OSError("disk full (simulated)")

    monkeypatch.setattr(common.os, "replace", boom)
    with pytest.raises(OSError, match="simulated"):
        export_nc(demo, "ac-trunnion", "fanuc", None, out)
    assert os.listdir(tmp_path) == []
    # an existing good file survives a failed rewrite
    monkeypatch.undo()
    export_nc(demo, "ac-trunnion", "fanuc", None, out)
    good = out.read_text()
    monkeypatch.setattr(common.os, "replace", boom)
    with pytest.raises(OSError):
        export_nc(demo, "ac-trunnion", "siemens", None, out)
    assert out.read_text() == good and os.listdir(tmp_path) == ["x.nc"]


# --- the CLI module -------------------------------------------------------------------------
@pytest.fixture(scope="module")
def paths_files(demo, tmp_path_factory):
    d = tmp_path_factory.mktemp("paths")
    good = d / "demo.json"
    write_paths_json(demo, good)
    data = path_to_dict(demo)
    other = d / "other.json"
    other.write_text(json.dumps({**data, "format": "someone.else"}))
    v0 = d / "v0.json"
    v0.write_text(json.dumps({**data, "version": 0}))
    # the same blade with the axis turned beyond A 110° (the hub fillet of the demo does that)
    far = json.loads(json.dumps(data))
    far["program"]["axis"][5] = [0.0, -0.6, -0.8]
    farf = d / "far.json"
    farf.write_text(json.dumps(far))
    return {"good": good, "other": other, "v0": v0, "far": farf}


def _cli(args, capsys):
    rc = cli_main(["nc", *(str(a) for a in args)])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def test_cli_ok(paths_files, tmp_path, capsys):
    out = tmp_path / "demo.ngc"
    rc, so, se = _cli(["--paths", paths_files["good"], "--machine", "ac-trunnion", "--post",
                       "linuxcnc", "--out", out, "--blade-count", "2", "--feed", "800",
                       "--spindle",
                       "12000", "--tool-number", "3", "--coolant", "off"], capsys)
    # besides the progress lines, one stderr line: the path was never checked for collisions
    # (issue 28 rows 1, 13)
    lines = [x for x in se.splitlines() if not x.startswith("blisk_cam: nc ")]
    assert rc == 0 and out.exists() and len(lines) == 1
    assert "never checked for collisions" in lines[0]
    text = out.read_text()
    assert "T3 M6" in text and "S12000 M3" in text and "M9" in text and "blade: demo" in text


@pytest.mark.parametrize("case, words", [
    ("post", ["unknown post 'haas'"]),
    ("machine", ["unknown machine preset"]),
    ("other", ["not a Blisk CAM paths file"]),
    ("v0", ["invalid version"]),
    ("far", ["pose 5", "axis A", "outside its limits"]),
    ("dir", ["does not exist"]),
    ("toml", ["zero vector"]),
])
def test_cli_bad_input_one_line(paths_files, tmp_path, capsys, case, words):
    args = {"--paths": paths_files["good"], "--machine": "ac-trunnion", "--post": "fanuc",
            "--out": tmp_path / "x.nc"}
    if case == "post":
        args["--post"] = "haas"
    elif case == "machine":
        args["--machine"] = "dmu-fantasy"
    elif case in ("other", "v0", "far"):
        args["--paths"] = paths_files[case]
    elif case == "dir":
        args["--out"] = tmp_path / "missing" / "x.nc"
    elif case == "toml":
        f = tmp_path / "m.toml"
        src = open(load_machine("ac-trunnion").source).read()
        f.write_text(src.replace("axis = [1, 0, 0]", "axis = [0, 0, 0]"))
        args["--machine"] = f
    rc, so, se = _cli([x for kv in args.items() for x in kv], capsys)
    assert rc == 1
    lines = se.strip().splitlines()
    if case == "far":  # found while posting: after the posting's progress line (issue 28)
        assert lines[0].startswith("blisk_cam: nc ") and "%" in lines[0]
        lines = lines[1:]
    assert len(lines) == 1 and lines[0].startswith("blisk_cam: error: ")
    for w in words:
        assert w in lines[0]
    assert not (tmp_path / "x.nc").exists()


def test_cli_needs_no_bpy(paths_files, tmp_path):
    out = tmp_path / "a.apt"
    code = (
        "import sys; sys.modules['bpy'] = None\n"
        "from blisk_cam.cli.main import main\n"
        f"rc = main(['nc', '--paths', {str(paths_files['good'])!r}, '--machine', 'ac-trunnion', "
        f"'--post', 'apt', '--out', {str(out)!r}])\n"
        "assert 'bpy' not in [m for m in sys.modules if sys.modules[m] is not None]\n"
        "sys.exit(rc)\n"
    )
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    cp = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True,
                        timeout=120)
    assert cp.returncode == 0, cp.stderr
    assert out.read_text().startswith("PARTNO/")


def test_reach_error_from_export(demo, tmp_path):
    import copy

    p = copy.deepcopy(demo)
    p.program.axis[3] = [0.0, 0.0, -1.0]
    with pytest.raises(ReachError, match=r"pose 3 .*axis A = (-)?180\.0000°"):
        export_nc(p, "ac-trunnion", "linuxcnc", None, tmp_path / "x.ngc")
    assert isinstance(ReachError("x"), BliskCamError)


def test_report_and_options(demo, tmp_path):
    rep = export_nc(demo, "bc-trunnion", "heidenhain", NcOptions(feed=500), tmp_path / "h.h")
    assert set(rep.axis_ranges) == {"X", "Y", "Z", "B", "C"}
    assert rep.singular == [] and rep.max_deviation <= demo.chord
    text = (tmp_path / "h.h").read_text().splitlines()
    assert text[0] == "0 BEGIN PGM BLISK MM" and text[-1].endswith("END PGM BLISK MM")
    assert all(line.split()[0] == str(k) for k, line in enumerate(text))
    assert any("M128" in t for t in text) and any(" F500" in t for t in text)
    with pytest.raises(BliskCamError, match="blades"):
        export_nc(demo, "bc-trunnion", "apt", NcOptions(blades=0), tmp_path / "a.apt")
    assert MOVE_RAPID == 4


def test_paths_and_nc_in_one_run_match_the_nc_command(tmp_path, capsys):
    """``paths ... --nc`` (plan and post in one run, core API only) writes the same program as
    ``nc`` on the JSON it wrote, and that program runs in rs274."""
    from blisk_cam.cli import main as cli
    from blisk_cam.core.part.blisk import make_demo_blisk

    d = make_demo_blisk(resolution=0.3, fillet=True, fillet_radius=10.0)
    stl = write_binary_stl(tmp_path / "blade.stl", d.blade_vertices, d.blade_faces)
    cone1 = ["170", "-25", "185", "35"]
    cone2 = [str(x) for x in d.tip_cone.as_list()]
    one = tmp_path / "one.ngc"
    rc = cli.main(["paths", "--mesh", str(stl), "--cone1", *cone1, "--cone2", *cone2,
                   "--tool-diameter", "12", "--cusp", "0.5", "--chord", "0.1",
                   "--axis-mode", "radial", "--radial-tilt", "75", "--out",
                   str(tmp_path / "p.json"), "--nc", str(one), "--machine", "ac-trunnion",
                   "--post", "linuxcnc", "--blade-count", "2", "--collisions", "off",
                   "--spindle", "9000"])
    out = capsys.readouterr().out
    assert rc == 0 and "blocks" in out
    two = tmp_path / "two.ngc"
    rc = cli.main(["nc", "--paths", str(tmp_path / "p.json"), "--machine", "ac-trunnion",
                   "--post", "linuxcnc", "--out", str(two), "--blade-count", "2", "--spindle",
                   "9000"])
    assert rc == 0
    a = [x for x in one.read_text().splitlines() if not x.startswith("(blade:")]
    b = [x for x in two.read_text().splitlines() if not x.startswith("(blade:")]
    assert a == b and "S9000 M3" in a
    if shutil.which("rs274"):
        cp = subprocess.run(["rs274", "-g", str(one), str(tmp_path / "o.txt")],
                            stdin=subprocess.DEVNULL, capture_output=True, timeout=120)
        assert cp.returncode == 0
    # the flags are checked with the declared bounds: a usage error, nothing written
    bad = tmp_path / "bad.ngc"
    rc = cli.main(["nc", "--paths", str(tmp_path / "p.json"), "--machine", "ac-trunnion",
                   "--post", "linuxcnc", "--out", str(bad), "--max-rotary-step", "0"])
    assert rc == 2 and not bad.exists()
    assert "max rotary step" in capsys.readouterr().err.lower()


@pytest.mark.parametrize("encoding", ["cp1252", "cp1252:surrogateescape"])
def test_cli_writes_to_a_stream_that_cannot_encode_every_character(paths_files, tmp_path,
                                                                   encoding):
    """On Windows a redirected stdout/stderr is in the ANSI code page (cp1252), which has no
    '≈' (nc's summary line): the run still succeeds, the character printed as '?'."""
    out = tmp_path / "a.apt"
    code = (
        "import sys\n"
        "from blisk_cam.cli.main import main\n"
        f"sys.exit(main(['nc', '--paths', {str(paths_files['good'])!r}, '--machine', "
        f"'ac-trunnion', '--post', 'apt', '--out', {str(out)!r}]))\n"
    )
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = dict(os.environ, PYTHONIOENCODING=encoding)  # Windows Python under Wine: the second
    cp = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, env=env,
                        timeout=120)
    assert cp.returncode == 0, cp.stderr.decode("cp1252")
    summary = cp.stdout.decode("cp1252")
    assert "apt for AC trunnion" in summary and "blocks" in summary
    assert "? 1." in summary or "? 0." in summary  # "≈ 1.5 min" of cutting, as "?"
    assert out.read_text(encoding="ascii").startswith("PARTNO/")
