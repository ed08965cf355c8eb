"""Constant machining error linear interpolation (issue 12, paper 002): error model, block
search, chord baseline, exact evaluation, NC hook and CLI flags.

Acceptance runs: the demo blade's leading edge and Rotor 37 passes, Ø12 ball, AC trunnion,
axis near radial, dense passes (chord 0.002 mm), [dM] = 10 µm.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.machine import block_search as B
from blisk_cam.core.machine import interpolation as I
from blisk_cam.core.machine.block_error import (
    contact_lever,
    error_gradients,
    machine_jacobian,
    pose_error,
)
from blisk_cam.core.machine.description import forward, load_machine
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from tests.support.blades import nasa_blade

TOL = 0.01  # [dM], mm


@pytest.fixture(scope="module")
def machine():
    return load_machine("ac-trunnion")


@pytest.fixture(scope="module")
def demo():
    from blisk_cam.core.part.blisk import make_demo_blisk
    from blisk_cam.core.part.cones import Cone

    d = make_demo_blisk(resolution=0.5, fillet=True, fillet_radius=10.0)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    req = PathRequest(axis=d.axis, cone1=Cone(170.0, -25.0, 185.0, 35.0), cone2=d.tip_cone,
                      tool_radius=6.0, cusp=3.0, chord=0.002, axis_mode="radial",
                      radial_tilt=math.radians(75.0))
    return mesh, plan_paths(mesh, req).path


@pytest.fixture(scope="module")
def rotor37():
    from blisk_cam.core.geometry.axis import Axis

    V, F, c1, c2 = nasa_blade("rotor37")
    mesh = TriMesh.from_arrays(V, F)
    req = PathRequest(axis=Axis(), cone1=c1, cone2=c2, tool_radius=6.0, cusp=3.0, chord=0.002,
                      axis_mode="radial", radial_tilt=math.radians(75.0))
    return mesh, plan_paths(mesh, req).path


def edge_window(curve, half_length=15.0):
    """Slice of a pass around its sharpest axis turn per mm (the leading or trailing edge)."""
    seg = np.linalg.norm(np.diff(curve.tip, axis=0), axis=1)
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", curve.axis[1:], curve.axis[:-1]), -1, 1))
    k = int(np.argmax(ang / np.maximum(seg, 1e-9)))
    s = np.concatenate([[0], np.cumsum(seg)])
    keep = np.abs(s - s[k]) <= half_length
    return np.nonzero(keep)[0]


def dense_passes(path, machine, window=True):
    out = []
    for c in path.curves:
        idx = edge_window(c) if window else np.arange(len(c))
        out.append(I.prepare_pass(machine, path.tool, c.tip[idx], c.axis[idx], c.normal[idx]))
    return out


# ---------------------------------------------------------------- error model
def test_jacobian_matches_forward(machine):
    rng = np.random.default_rng(1)
    q = np.column_stack([rng.uniform(-50, 50, (6, 3)), rng.uniform(0.3, 1.5, 6),
                         rng.uniform(-3, 3, 6)])
    JP, JO = machine_jacobian(machine, q)
    dq = rng.normal(size=(6, 5)) * np.array([1e-3, 1e-3, 1e-3, 1e-6, 1e-6])
    t0, a0 = forward(machine, q[:, :3], q[:, 3:])
    t1, a1 = forward(machine, (q + dq)[:, :3], (q + dq)[:, 3:])
    assert np.allclose(t1 - t0, np.einsum("nik,nk->ni", JP, dq), atol=1e-9)
    assert np.allclose(a1 - a0, np.einsum("nik,nk->ni", JO, dq), atol=1e-11)
    assert np.allclose(JO[:, :, :3], 0.0)  # J_RT = 0 (paper 002 Eq. 5)


def test_ball_error_is_centre_offset_along_normal(demo):
    """Eq. (14) for a ball: d_M = l_P + l_θ = (ΔP + ρ ΔO)·n; linear gradients agree with the
    exact finite-rotation form for small deviations."""
    _, path = demo
    c = path.curves[0]
    n, a, tip = c.normal[:50], c.axis[:50], c.tip[:50]
    lever = contact_lever(path.tool, n, a)
    assert np.allclose(lever, 6.0 * a, atol=1e-9)
    rng = np.random.default_rng(2)
    dP = rng.normal(size=(50, 3)) * 0.01
    b = a + rng.normal(size=(50, 3)) * 1e-3
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    lP, lT, dM = pose_error(tip, a, tip + dP, b, n, lever)
    assert np.allclose(lP, np.einsum("ij,ij->i", dP, n))
    assert np.allclose(dM, np.einsum("ij,ij->i", dP + 6.0 * (b - a), n), atol=1e-9)


def test_gradients_match_exact_model(demo, machine):
    _, path = demo
    c = path.curves[1]
    dp = I.prepare_pass(machine, path.tool, c.tip[:40], c.axis[:40], c.normal[:40])
    rng = np.random.default_rng(3)
    dq = rng.normal(size=(len(dp), 5)) * np.array([1e-3, 1e-3, 1e-3, 1e-5, 1e-5])
    tp, ax = forward(machine, (dp.q + dq)[:, :3], (dp.q + dq)[:, 3:])
    lP, lT, dM = pose_error(dp.tip, dp.axis, tp, ax, dp.normal, dp.lever)
    # first order: the residue is O(|Δθ|² · 200 mm) ≈ 1e-7 mm against values ~1e-3 mm
    assert np.allclose(np.einsum("nk,nk->n", dp.gP, dq), lP, rtol=0, atol=2e-7)
    assert np.allclose(np.einsum("nk,nk->n", dp.gT, dq), lT, rtol=0, atol=2e-7)
    JP, JO = machine_jacobian(machine, dp.q)
    gP, gT, Jc = error_gradients(JP, JO, dp.normal, dp.axis, dp.lever)
    assert np.allclose(np.einsum("ni,nik,nk->n", dp.normal, Jc, dq),
                       np.einsum("nk,nk->n", gP + gT, dq), atol=1e-10)


# ---------------------------------------------------------------- acceptance
def _accept(mesh, dps, machine, cutter, name):
    md = MeshDistance(mesh)
    t0 = time.perf_counter()
    ends = B.search_constant_error(dps, TOL)
    speed = sum(len(d) for d in dps) / (time.perf_counter() - t0)
    bounds = [B.block_bounds_rows(dp, e[:-1], e[1:]) for dp, e in zip(dps, ends, strict=True)]
    meas = [B.measure_blocks(machine, cutter, dp, e, mesh=md, samples=8,
                                 per_dense=0.5)[0]
            for dp, e in zip(dps, ends, strict=True)]
    m_ce = np.concatenate(meas)
    b_ce = np.concatenate(bounds)
    n_ce = len(m_ce)
    # conservative bound, nothing above [dM] + 1 µm
    worst = int(np.argmax(m_ce - b_ce))
    assert np.all(m_ce <= b_ce + 1e-9), (
        f"{name}: measured above bound on {np.sum(m_ce > b_ce + 1e-9)} blocks, worst "
        f"{1000 * m_ce[worst]:.4f} vs {1000 * b_ce[worst]:.4f} µm")
    assert m_ce.max() <= TOL + 1e-3
    assert b_ce.max() <= TOL * (1 + 1e-9)
    # band: the last block of each pass is a remainder; ≥ 90 % of blocks in 70–100 % of [dM]
    frac = np.mean((m_ce >= 0.7 * TOL) & (m_ce <= TOL + 1e-3))
    assert frac >= 0.9, f"{name}: only {frac:.1%} of blocks in band"
    # chord height at equal measured maximum
    h, _, M = B.match_chord_height(dps, machine, cutter, float(m_ce.max()), mesh=md,
                                   samples=16)
    m_ch = np.concatenate(M)
    n_ch = len(m_ch)
    # the chord maximum jumps with h: equal = the largest h not above constant-error's
    assert m_ch.max() <= m_ce.max() + 1e-4, (m_ch.max(), m_ce.max())
    saving = 1 - n_ce / n_ch
    print(f"{name}: constant-error {n_ce} blocks (measured {m_ce.min() / TOL:.1%}–"
          f"{m_ce.max() / TOL:.1%} of [dM], {frac:.1%} in band), chord {1000 * h:.2f} µm "
          f"{n_ch} blocks ({m_ch.min() / TOL:.1%}–{m_ch.max() / TOL:.1%}): −{saving:.1%}; "
          f"search {speed:,.0f} dense poses/s")
    assert saving >= 0.40, f"{name}: only {saving:.1%} fewer blocks ({n_ce} vs {n_ch})"


def test_demo_leading_edge_acceptance(demo, machine):
    mesh, path = demo
    _accept(mesh, dense_passes(path, machine, window=True), machine, path.tool, "demo LE")


def test_rotor37_edge_acceptance(rotor37, machine):
    mesh, path = rotor37
    dps = dense_passes(path, machine, window=True)
    _accept(mesh, dps, machine, path.tool, "Rotor 37")


# ---------------------------------------------------------------- program hook, NC, CLI
def test_interpolate_program_keeps_links_and_ends(demo, machine):
    _, path = demo
    new, rep = I.interpolate_program(path, machine, "constant-error", max_error=TOL)
    old = path.program
    prog = new.program
    assert rep.blocks < rep.original
    # every non-cut pose survives unchanged, in order
    keep_old = old.move != 0
    keep_new = prog.move != 0
    assert np.allclose(old.tip[keep_old], prog.tip[keep_new])
    assert np.array_equal(old.move[keep_old], prog.move[keep_new])
    # the thinned poses solve back to the joints they came from (poses lie on the pass)
    assert rep.measured_band[1] <= 1.0 + 1e-6
    assert np.all(np.isfinite(prog.tip))
    d = rep.as_dict()
    assert d["cut_blocks"] == rep.blocks and d["method"] == "constant-error"
    assert "constant-error" in rep.summary()
    assert rep.poses_per_second > 0


def test_bad_input(demo, machine):
    _, path = demo
    for bad in (0.0, -1.0, float("nan"), None):
        with pytest.raises(BliskCamError, match="max_error"):
            I.interpolate_program(path, machine, "constant-error", max_error=bad)
    with pytest.raises(BliskCamError, match="chord_height"):
        I.interpolate_program(path, machine, "chord", chord_height=0)
    with pytest.raises(BliskCamError, match="unknown interpolation method"):
        I.interpolate_program(path, machine, "spline", max_error=TOL)
    with pytest.raises(BliskCamError, match="unknown bound"):
        I.interpolate_program(path, machine, "constant-error", max_error=TOL, bound="x")
    dp = dense_passes(path, machine)[0]
    with pytest.raises(BliskCamError, match="max_error"):
        B.search_constant_error(dp, -0.1)
    with pytest.raises(BliskCamError, match="two poses"):
        I.prepare_pass(machine, path.tool, np.zeros((1, 3)), [[0, 0, 1]], [[0, 0, 1]])


def test_nc_export_and_cli(demo, tmp_path, capsys):
    from blisk_cam.cli.main import main as cli_main
    from blisk_cam.core.toolpath.paths_io import write_paths_json

    _, path = demo
    pj = tmp_path / "p.json"
    write_paths_json(path, pj)
    base = ["--paths", str(pj), "--machine", "ac-trunnion", "--post", "linuxcnc"]
    assert cli_main(["nc", *base, "--out", str(tmp_path / "a.ngc")]) == 0
    plain = capsys.readouterr().out
    assert "interpolation" not in plain
    rc = cli_main(["nc", *base, "--out", str(tmp_path / "b.ngc"), "--interpolation",
                             "constant-error", "--max-error", "0.01", "--report",
                             str(tmp_path / "r.json")])
    assert rc == 0
    out = capsys.readouterr().out
    assert "interpolation constant-error" in out and "% of [dM]" in out
    head = (tmp_path / "b.ngc").read_text().splitlines()[:12]
    assert any("interpolation constant-error" in h and "cut blocks" in h for h in head)
    rep = json.loads((tmp_path / "r.json").read_text())["interpolation"]
    assert rep["cut_blocks"] > 0 and len(rep["measured_band_pct"]) == 2
    n_a = sum(1 for ln in (tmp_path / "a.ngc").read_text().splitlines() if ln.startswith("G1"))
    n_b = sum(1 for ln in (tmp_path / "b.ngc").read_text().splitlines() if ln.startswith("G1"))
    assert n_b < n_a
    assert cli_main(["nc", *base, "--out", str(tmp_path / "c.ngc"), "--interpolation", "chord",
                               "--chord-height", "0.003"]) == 0
    capsys.readouterr()
    # usage errors (exit 2, one line): options that need each other, bounds, choices
    assert cli_main(["nc", *base, "--out", str(tmp_path / "d.ngc"), "--interpolation",
                               "constant-error"]) == 2
    assert "--max-error" in capsys.readouterr().err
    assert cli_main(["nc", *base, "--out", str(tmp_path / "e.ngc"), "--interpolation",
                               "constant-error", "--max-error", "-1"]) == 2
    assert "> 0" in capsys.readouterr().err
    assert cli_main(["nc", *base, "--out", str(tmp_path / "e.ngc"), "--interpolation", "spline",
                               "--max-error", "0.01"]) == 2
    assert "spline" in capsys.readouterr().err
    assert not (tmp_path / "d.ngc").exists() and not (tmp_path / "e.ngc").exists()


def test_search_properties(demo, machine):
    """Ends cover each pass in order, fall between dense poses, respect the rotary step; the
    paper's arc-wise bound (max |l_P| + max |l_θ| per arc) is never below the pointwise one;
    searching passes together or one by one gives the same blocks."""
    _, path = demo
    dps = dense_passes(path, machine)[:3]
    together = B.search_constant_error(dps, TOL)
    for dp, e in zip(dps, together, strict=True):
        assert e[0] == 0 and e[-1] == len(dp) - 1 and np.all(np.diff(e) > 0)
        assert np.any(np.abs(e - np.round(e)) > 1e-6)  # block ends between dense poses
        alone = B.search_constant_error(dp, TOL)
        assert np.allclose(alone, e)
        pw = B.block_bounds_rows(dp, e[:-1], e[1:])
        pa = B.block_bounds_rows(dp, e[:-1], e[1:], bound="paper")
        assert np.all(pa >= pw - 1e-12)
        assert np.all(pw <= TOL * (1 + 1e-9))
    step = math.radians(0.2)
    e = B.search_constant_error(dps[0], TOL, max_rotary_step=step)
    q = dps[0].joints_at(e)
    assert np.abs(np.diff(q[:, 3:], axis=0)).max() <= step + 1e-12
    # the chord baseline honours its chord height
    e = B.search_chord(dps[0], 0.003)
    assert np.all(B.chord_heights_rows(dps[0], e[:-1], e[1:]) <= 0.003 + 1e-12)


def test_bull_nose_leading_edge(machine):
    """A 6/2 bull nose: the corner centre is off the axis (Eqs. 11–13 rotate it with the
    axis); the bound stays conservative against the mesh."""
    from blisk_cam.core.part.blisk import make_demo_blisk
    from blisk_cam.core.part.cones import Cone

    d = make_demo_blisk(resolution=0.5, fillet=True, fillet_radius=10.0)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    req = PathRequest(axis=d.axis, cone1=Cone(170.0, -25.0, 185.0, 35.0), cone2=d.tip_cone,
                      tool_type="bull", tool_radius=6.0, corner_radius=2.0, cusp=1.9,
                      chord=0.002, axis_mode="radial", radial_tilt=math.radians(75.0))
    path = plan_paths(mesh, req).path
    dps = dense_passes(path, machine)[:2]
    md = MeshDistance(mesh)
    ends = B.search_constant_error(dps, TOL)
    b = np.concatenate([B.block_bounds_rows(dp, e[:-1], e[1:]) for dp, e in zip(dps, ends,
                                                                                strict=True)])
    m = np.concatenate([B.measure_blocks(machine, path.tool, dp, e, mesh=md, samples=8,
                                         per_dense=0.5)[0]
                        for dp, e in zip(dps, ends, strict=True)])
    w = int(np.argmax(m - b))
    assert np.all(m <= b + 1e-9), (len(m), np.sum(m > b), m[w], b[w])
    assert np.mean((m >= 0.7 * TOL) & (m <= TOL)) >= 0.9
