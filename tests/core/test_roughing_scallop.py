"""Channel roughing (#23): the depth per cut from a scallop height, and the floor band's flute
check held to 0.02 mm of the allowance.

The step cusp formula is checked against two sampled outlines of the cutter moved along a
wall (the cusp read off their lower envelope); the flute check against the exact distance
of the cutter to a plane and to a concave cylinder (closed form: the flute of a bull nose is
the solid cylinder of radius e from the corner's height up, grown by a ball of radius r);
the roughing with a level scallop by the stock simulation at 1 mm (coarse, cheap: the judge's
±res/√2, see tests/core/test_roughing.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.cli.main import build_parser, main
from blisk_cam.core.channel.floor_band import FluteCheck
from blisk_cam.core.channel.level_scallop import (
    WALL_SLOPE,
    check_depth_options,
    cusp_of_step,
    step_for_scallop,
)
from blisk_cam.core.errors import BliskCamError, ToolError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.part.model import part_from_demo, theta_about
from blisk_cam.core.process.roughing import RoughRequest, plan_roughing
from blisk_cam.core.stock.blank import stock_from_envelope
from blisk_cam.core.stock.deviation import deviation_map
from blisk_cam.core.stock.removal import remove_program
from blisk_cam.core.stock.simulation import part_surface
from blisk_cam.core.tool.cutter import Cutter
from tests.core.test_roughing import _demo, _tool

RES = 1.0
ALLOWANCE = 0.5
SCALLOP = 0.5


# ------------------------------------------------------------------ the step cusp formula
def _sampled_cusp(cutter, psi, d, n=400):
    """The cusp (mm) two copies of the cutter's outline (sampled, ``n`` arc points) leave on
    a wall touched at the contact angle ``psi`` when the lower copy is ``d`` mm further along
    the wall (deeper along the axis): where their lower envelopes cross between the contacts
    (found by bisection), measured from the wall."""
    prof = cutter.profile(n)
    out = np.vstack([(prof * [-1, 1])[::-1], prof])  # (ρ, h), both halves of the section
    # the wall's normal into the tool's side, and the direction along it toward the deeper
    # level (the axis is +h, the wall on the +ρ side)
    nrm = np.array([-math.cos(psi), math.sin(psi)])
    tan = -np.array([math.sin(psi), math.cos(psi)])
    x0, y0 = out @ tan, out @ nrm
    wall, xc = y0.min(), x0[np.argmin(y0)]

    def lower(x, y, q):  # the outline's lowest y over the abscissa q
        a, b = x[:-1], x[1:]
        t = (q - a) / np.where(b - a == 0, 1e-300, b - a)
        yy = y[:-1] + t * (y[1:] - y[:-1])
        return float(np.where((q >= np.minimum(a, b)) & (q <= np.maximum(a, b)), yy,
                              np.inf).min())

    lo, hi = xc, xc + d
    for _ in range(60):
        m = 0.5 * (lo + hi)
        if lower(x0, y0, m) > lower(x0 + d, y0, m):
            hi = m
        else:
            lo = m
    m = 0.5 * (lo + hi)
    return min(lower(x0, y0, m), lower(x0 + d, y0, m)) - wall


@pytest.mark.parametrize("cutter", [Cutter.bull(4.0, 1.0, h=60.0), Cutter.ball(3.0, h=60.0),
                                    Cutter.flat(4.0, h=60.0)], ids=["bull", "ball", "flat"])
def test_step_cusp_formula_matches_the_sampled_outlines(cutter):
    ball = cutter.type == "ball"
    for psi_deg in (3.0, 10.0, 25.0, 45.0, 60.0, 75.0):
        psi = math.radians(psi_deg)
        for h in (0.05, 0.3, 1.0):
            d = float(step_for_scallop(h, psi, cutter.r, ball))
            # the largest step leaves the scallop height, measured on the outlines
            assert _sampled_cusp(cutter, psi, d) == pytest.approx(h, abs=2e-3), (psi_deg, h)
            assert float(cusp_of_step(d, psi, cutter.r, ball)) == pytest.approx(h, abs=1e-9)
    # the two limits the docstring names: two circles, and the sharp corner's s |n·a|
    r, psi = 1.0, math.radians(45.0)
    for d in (0.2, 0.8, 1.2):
        assert float(cusp_of_step(d, psi, r, False)) == pytest.approx(
            r - math.sqrt(r * r - d * d / 4), abs=1e-9)
    s = 2.0
    assert float(cusp_of_step(s / math.cos(psi), psi, 0.0, False)) == pytest.approx(
        s * math.sin(psi), abs=1e-9)


# ------------------------------------------------------------------ the floor band's check
def _grid_mesh(points_of, nu, nv):
    """A quad grid (nu × nv points from ``points_of(u, v)``) as triangles."""
    u, v = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    V = points_of(u.ravel(), v.ravel())
    i = (u[:-1, :-1] * nv + v[:-1, :-1]).ravel()
    F = np.concatenate([np.stack([i, i + nv, i + nv + 1], 1), np.stack([i, i + nv + 1, i + 1],
                                                                          1)])
    return V, F


def _face_normals(V, F):
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    return n / np.linalg.norm(n, axis=1)[:, None]


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _core_rims(cutter, tip, ax, top, n=4000):
    """(2n, 3) points of the two rims (ρ = e at the corner's height and at ``top``) of the
    core cylinder whose growth by the corner radius is the flute."""
    ref = np.array([0.0, 0.0, 1.0]) if abs(ax[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = _unit(np.cross(ax, ref))
    v = np.cross(ax, u)
    ph = np.linspace(0, 2 * math.pi, n, endpoint=False)
    ring = cutter.e * (np.cos(ph)[:, None] * u + np.sin(ph)[:, None] * v)
    return np.vstack([tip + cutter.f * ax + ring, tip + top * ax + ring])


class _Unrefined(FluteCheck):
    """The check as it was: the 48-point ring alone."""

    REFINE = 1


def test_flute_check_keeps_the_exact_allowance_on_a_plane_and_in_a_concave_fillet():
    """The floor band admits a pose when the check's clearance is ≥ −tol; the exact clearance
    of the flute must then be ≥ −0.02 mm (acceptance #23: never below 0.5 − 0.02): the check
    may over-state the exact clearance by at most 0.02 − tol. Before the outline's sag was
    counted and the ring refined round the nearest points it over-stated it by up to 0.013
    (0.023 into the allowance in all)."""
    cutter = Cutter.bull(4.0, 1.0, h=24.0)
    axis = Axis(np.zeros(3), np.array([0.0, 0.0, 1.0]))
    hub = np.array([[100.0, -50.0], [100.0, 50.0]])  # far below
    top = cutter.f + cutter.max_radius
    rng = np.random.default_rng(23)
    # a plane through (150, 0, 0), its normal toward the tool
    n0 = _unit(np.array([0.3, 1.0, 0.2]))
    e1 = _unit(np.cross(n0, [0.0, 0.0, 1.0]))
    e2 = np.cross(n0, e1)
    q0 = np.array([150.0, 0.0, 0.0])
    V, F = _grid_mesh(lambda i, j: q0 + (i[:, None] * 0.5 - 12) * e1 + (j[:, None] * 0.5 - 12)
                      * e2, 49, 49)
    F = np.where((_face_normals(V, F) @ n0 > 0)[:, None], F, F[:, ::-1])
    check = FluteCheck(cutter, V, F, axis, math.pi, hub, ALLOWANCE, ALLOWANCE, height=top)
    coarse = _Unrefined(cutter, V, F, axis, math.pi, hub, ALLOWANCE, ALLOWANCE, height=top)
    over, over_raw = [], []
    for _ in range(150):
        psi = rng.uniform(0.0, math.radians(80.0))  # the axis's angle from the wall
        w = _unit(rng.normal(size=3) - (rng.normal(size=3) @ n0) * n0)
        w = _unit(w - (w @ n0) * n0)
        ax = math.sin(psi) * n0 + math.cos(psi) * w
        delta = rng.uniform(-0.03, 0.03)
        # exact: min over the core of n·x, less the corner radius
        lift = ALLOWANCE + delta + cutter.r - cutter.f * (n0 @ ax) + \
            cutter.e * np.linalg.norm(n0 - (n0 @ ax) * ax)
        tip = q0 + lift * n0 + rng.uniform(-2, 2) * e1 + rng.uniform(-2, 2) * e2
        exact = float((_core_rims(cutter, tip, ax, top) - q0).dot(n0).min()) - cutter.r - \
            ALLOWANCE
        assert exact == pytest.approx(delta, abs=1e-6)
        c = float(check.clearance(tip[None], ax[None])[0])
        over.append(c - exact)
        over_raw.append(float(coarse.clearance(tip[None], ax[None])[0]) + coarse.sag - exact)
    # a pipe of radius 6 about a line along the blisk axis through (150, 0): the tool inside
    # touches it with its corner; exact: 6 − the largest distance of the flute from the line
    Rf, L0 = 6.0, np.array([150.0, 0.0])
    V, F = _grid_mesh(lambda i, j: np.stack([L0[0] + Rf * np.cos(i * 2 * math.pi / 120),
                                             L0[1] + Rf * np.sin(i * 2 * math.pi / 120),
                                             j * 0.5 - 10.0], 1), 121, 41)
    cen = V[F].mean(axis=1)
    inward = np.concatenate([L0 - cen[:, :2], np.zeros((len(F), 1))], 1)
    F = np.where((np.einsum("ij,ij->i", _face_normals(V, F), inward) > 0)[:, None], F,
                 F[:, ::-1])
    check = FluteCheck(cutter, V, F, axis, math.pi, hub, ALLOWANCE, ALLOWANCE, height=top)
    coarse = _Unrefined(cutter, V, F, axis, math.pi, hub, ALLOWANCE, ALLOWANCE, height=top)
    for _ in range(150):
        al = rng.uniform(0, 2 * math.pi)
        ax = _unit(np.array([math.cos(al), math.sin(al), 0.0]) + rng.uniform(-0.3, 0.3, 3))
        tip = np.array([L0[0], L0[1], rng.uniform(-2, 2)]) - 4.0 * ax + \
            rng.uniform(-0.8, 0.8) * _unit(np.cross(ax, [0.0, 0.0, 1.0]))

        def far(tip, ax=ax):  # (largest distance, on the corner's rim: the grown top rim
            # is not the flute's flat end)
            P = _core_rims(cutter, tip, ax, top)
            d = np.linalg.norm(P[:, :2] - L0, axis=1)
            return float(d.max()) + cutter.r, P[np.argmax(d)], np.argmax(d) < len(d) // 2

        dmax, p, _ = far(tip)
        radial = _unit(np.r_[p[:2] - L0, 0.0])
        tip = tip + (Rf - ALLOWANCE - dmax - rng.uniform(-0.03, 0.03)) * radial
        dmax, _, corner = far(tip)
        exact = Rf - dmax - ALLOWANCE
        if abs(exact) > 0.1 or not corner:
            continue
        c = float(check.clearance(tip[None], ax[None])[0])
        over.append(c - exact)
        over_raw.append(float(coarse.clearance(tip[None], ax[None])[0]) + coarse.sag - exact)
    assert len(over) > 200
    assert max(over) <= 0.02 - check.tol, max(over)
    # the test can fail: without the sag and the refined ring the check over-stated by more
    assert max(over_raw) > 0.02 - check.tol, max(over_raw)


# ------------------------------------------------------------------ roughing with a scallop
@pytest.fixture(scope="module")
def scalloped():
    part = part_from_demo(_demo())
    stock = stock_from_envelope(part, 2.0, RES)
    # (the floor band's surface-driven passes left out, to stay cheap: judged above it)
    req = RoughRequest(tool=_tool(), stepover=6.0, level_scallop=SCALLOP,
                       max_depth_per_cut=8.0, allowance=ALLOWANCE, floor_band_step=0.0)
    path = plan_roughing(part, req, stock)
    sim = stock.copy()
    res = remove_program(sim, path.program, path.tool, sweep_tolerance=0.05)
    V, F, N, surf = part_surface(part, RES)
    on_blade = np.zeros(len(V), bool)
    on_blade[np.unique(F[~part.part_mesh()[2]])] = True
    P, Nn = V[surf], N[surf]
    return part, path, res.crashes, P, Nn, on_blade[surf], deviation_map(sim, P, Nn,
                                                                         reach_out=12.0)


def test_scallop_levels_vary_with_the_walls_and_stay_within_the_cap(scalloped):
    _, path, *_ = scalloped
    s = path.stats
    steps = np.array(s["level_steps_mm"])
    assert s["level_scallop_mm"] == SCALLOP and len(steps) == s["levels"] - 1 > 3
    assert steps.max() <= 8.0 + 1e-9 and s["depth_per_cut_mm"] <= 8.0 + 1e-9
    # the spacing follows the walls: by the fillet the walls lie flatter and the steps
    # shrink; up the blade they grow
    assert steps.max() - steps.min() > 0.5, steps
    assert steps[-1] < steps.max() - 0.5
    # the floor band reaches over the hub fillet (4 mm on the demo) + the corner radius + R
    # sin 20° (fillet_band): the fillet's radius measured on the blade mesh
    assert s["floor_band_height_mm"] == pytest.approx(
        ALLOWANCE + 4.0 + 1.0 + 4.0 * math.sin(math.radians(20.0)), abs=0.25)


def test_scallop_roughing_leaves_at_most_the_scallop_on_the_walls(scalloped):
    """Acceptance #23 with a level scallop h: on the blade walls above the floor band the
    simulated stock holds between 0.5 − 0.02 and 0.5 + h (± the judge's res/√2); no crash."""
    part, path, crashes, P, N, on_blade, dev = scalloped
    assert crashes == []
    r, th, z = theta_about(P, part.axis)
    H = part.hub_profile
    radial = np.stack([np.cos(th), np.sin(th), np.zeros_like(th)], 1)
    wall = on_blade & (np.abs(np.einsum("ij,ij->i", N, radial)) <= math.sin(WALL_SLOPE))
    above = r - np.interp(z, H[:, 1], H[:, 0]) >= path.stats["floor_band_height_mm"]
    sel = wall & above
    assert sel.sum() > 1000
    bound = ALLOWANCE + SCALLOP + RES / math.sqrt(2)
    assert dev[sel].max() <= bound, (f"{(dev[sel] > bound).sum()} points above the bound, by "
                                     f"up to {dev[sel].max() - bound:.3f} mm")
    assert dev.min() >= ALLOWANCE - 0.02 - RES / math.sqrt(2), dev.min()


def test_bad_scallop_options_are_named(capsys):
    c = _tool()

    def req(**kw):
        return RoughRequest(tool=c, stepover=5.0, **kw)

    for kw, err, msg in (
            (dict(level_scallop=0.0), BliskCamError, "level scallop height must be > 0"),
            (dict(level_scallop=-1.0), BliskCamError, "level scallop height must be > 0"),
            (dict(level_scallop=30.0), BliskCamError, "not below the largest step 24"),
            (dict(level_scallop=0.2, max_depth_per_cut=30.0), ToolError,
             "more than the flute length 24"),
            (dict(level_scallop=0.2, depth_per_cut=4.0), BliskCamError, "not both"),
            (dict(), BliskCamError, "give the depth per cut"),
            (dict(depth_per_cut=4.0, max_depth_per_cut=6.0), BliskCamError, "leave it out")):
        with pytest.raises(err, match=msg):
            check_depth_options(req(**kw), c)
    assert check_depth_options(req(level_scallop=0.2), c) == (None, 0.2, 24.0)
    assert check_depth_options(req(depth_per_cut=4.0), c) == (4.0, None, 4.0)
    base = ["rough", "--part", "b.stl", "--blade-count", "24", "--stock", "envelope:2",
            "--tool", "flat", "--tool-diameter", "8", "--stepover", "4", "--out", "r.json"]
    args = build_parser().parse_args(base + ["--level-scallop", "0.3"])
    assert args.level_scallop == 0.3 and args.depth_per_cut is None
    assert main(base + ["--level-scallop", "0.3", "--depth-per-cut", "4"]) == 2
    assert "not allowed with argument" in capsys.readouterr().err
    assert main(base) == 2  # one of the two is required
    assert "--depth-per-cut" in capsys.readouterr().err
    assert main(base + ["--level-scallop", "0"]) == 2
    assert "--level-scallop" in capsys.readouterr().err
    assert main(base + ["--depth-per-cut", "4", "--max-depth-per-cut", "6"]) == 2
    assert "--max-depth-per-cut caps the steps" in capsys.readouterr().err


def test_a_job_takes_the_level_scallop(tmp_path):
    from blisk_cam.core.process.job import iter_run_job, load_job
    from tests.core.test_process_kinds import ROUGH_JOB

    job = tmp_path / "bad.toml"
    assert "depth_per_cut = 8\n" in ROUGH_JOB
    for text, msg in ((ROUGH_JOB.replace("depth_per_cut = 8\n", "level_scallop = 0.3\n"
                                         "depth_per_cut = 8\n"), "give one of the keys"),
                      (ROUGH_JOB.replace("depth_per_cut = 8\n", "level_scallop = 40\n"),
                       "level scallop height 40 mm is not below")):
        job.write_text(text)
        gen = iter_run_job(load_job(job))
        with pytest.raises(BliskCamError, match=r"operation 1 \('roughing'\).*" + msg):
            for _ in range(3):
                next(gen)
