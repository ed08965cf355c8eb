"""Measured truths about the demo blisk (blisk_cam.core.part.blisk).

Every check measures the generated arrays geometrically (cones, circles fitted to the edges,
thicknesses, winding numbers, distances to a finer clean mesh) and compares with the
requested parameters, so that a wrong geometry fails.
"""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.axis import meridional
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import DemoBlisk, make_demo_blisk
from blisk_cam.core.part.blisk_params import (
    DemoParameterError,
    DemoParams,
    blade_grid_shape,
    blade_triangle_count,
)

CONE_TOL = 1e-9  # mm


# ------------------------------------------------------------------------------ helpers
@pytest.fixture(scope="module")
def clean():
    return make_demo_blisk(resolution=0.5)


@pytest.fixture(scope="module")
def clean_mesh(clean):
    return TriMesh.from_arrays(clean.blade_vertices, clean.blade_faces)


@pytest.fixture(scope="module")
def scan():
    return make_demo_blisk(resolution=0.5, scan_like=True, seed=11)


@pytest.fixture(scope="module")
def edges_blisk():
    """Different LE and TE radii, fine enough to resolve them well."""
    return make_demo_blisk(resolution=1.0, le_radius=0.25, te_radius=0.45)


def cone_distances(blisk: DemoBlisk, points):
    r, z = meridional(points, blisk.axis)
    return blisk.hub_cone.signed_distance(r, z), blisk.tip_cone.signed_distance(r, z)


def loops_by_cone(blisk: DemoBlisk, mesh: TriMesh):
    """The boundary loops as {'hub': ids, 'tip': ids}; fails unless exactly one per cone."""
    loops = mesh.boundary_loops()
    assert len(loops) == 2
    out = {}
    for loop in loops:
        dh, dt = cone_distances(blisk, mesh.V[loop])
        key = "hub" if np.abs(dh).max() < np.abs(dt).max() else "tip"
        out[key] = loop
    assert set(out) == {"hub", "tip"}
    return out


def morph_ratio(blisk: DemoBlisk, points):
    return blisk.morphing_cones.ratio_of_points(points, blisk.axis)


def grid_rows(blisk: DemoBlisk):
    """Clean blade vertices as (n_v, n_u, 3) — the documented structured grid."""
    n_v, n_u = blisk.grid_shape
    return blisk.blade_vertices.reshape(n_v, n_u, 3)


def kasa_circle(p2):
    """Algebraic circle fit in 2-D: centre (2,), radius."""
    A = np.c_[2.0 * p2, np.ones(len(p2))]
    b = (p2**2).sum(axis=1)
    c = np.linalg.lstsq(A, b, rcond=None)[0]
    return c[:2], float(np.sqrt(c[2] + c[0] ** 2 + c[1] ** 2))


def farthest_pair(P):
    d = np.linalg.norm(P[:, None] - P[None], axis=2)
    i, j = np.unravel_index(np.argmax(d), d.shape)
    return (i, j) if P[i, 2] < P[j, 2] else (j, i)  # flow toward +z: LE first


def edge_circle(P, which, depth):
    """Fit a circle to the section points within ``depth`` (mm, along the chord) of the
    leading ('le', smaller z) or trailing edge, in their best-fit plane (the local tangent
    plane of the cone: the points span < 1 mm on a cone of radius ~ 200 mm).

    Returns radius, max residual, number of points, centre (3-D)."""
    i, j = farthest_pair(P)
    chord = (P[j] - P[i]) / np.linalg.norm(P[j] - P[i])
    end, sgn = (i, 1.0) if which == "le" else (j, -1.0)
    sel = sgn * ((P - P[end]) @ chord) < depth
    Q = P[sel]
    cen = Q.mean(axis=0)
    _, _, vt = np.linalg.svd(Q - cen)
    X = (Q - cen) @ vt[:2].T
    ctr, rad = kasa_circle(X)
    resid = np.abs(np.linalg.norm(X - ctr, axis=1) - rad).max()
    return rad, resid, int(sel.sum()), cen + ctr @ vt[:2]


def point_polyline_distance(P, A, B):
    """Distance of each point of P (k, 3) to the segments A[i] → B[i]."""
    AB = B - A
    t = np.einsum("kij,ij->ki", P[:, None] - A[None], AB) / np.einsum("ij,ij->i", AB, AB)
    t = np.clip(t, 0.0, 1.0)
    Q = A[None] + t[..., None] * AB[None]
    return np.linalg.norm(P[:, None] - Q, axis=2).min(axis=1)


def section_thickness(P):
    """Largest distance from a point of one side to the other side of a closed section."""
    i, j = sorted(farthest_pair(P))
    s1, s2 = P[i : j + 1], np.r_[P[j:], P[: i + 1]]
    return max(
        point_polyline_distance(s1, s2[:-1], s2[1:]).max(),
        point_polyline_distance(s2, s1[:-1], s1[1:]).max(),
    )


def winding_numbers(V, F, Q):
    """Generalised winding number of the closed triangle soup (V, F) at points Q."""
    A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    out = np.empty(len(Q))
    for k, q in enumerate(Q):
        a, b, c = A - q, B - q, C - q
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (
            la * lb * lc
            + np.einsum("ij,ij->i", a, b) * lc
            + np.einsum("ij,ij->i", a, c) * lb
            + np.einsum("ij,ij->i", b, c) * la
        )
        out[k] = 2.0 * np.arctan2(num, den).sum() / (4.0 * np.pi)
    return out


def capped(blisk: DemoBlisk, V, F):
    """Close the open tube with a fan per boundary loop, built from the raw winding (the cap
    runs each boundary half-edge backwards, so a consistent tube gives a consistent solid)."""
    he = np.stack([F, np.roll(F, -1, axis=1)], axis=2).reshape(-1, 2)
    n = len(V)
    key = he[:, 0] * n + he[:, 1]
    rev = he[:, 1] * n + he[:, 0]
    bnd = he[~np.isin(rev, key)]
    dh, _ = cone_distances(blisk, V[bnd[:, 0]])
    on_hub = np.abs(dh) < 1e-6
    cen = [V[bnd[on_hub, 0]].mean(axis=0), V[bnd[~on_hub, 0]].mean(axis=0)]
    V2 = np.vstack([V, cen])
    cap = np.c_[bnd[:, 1], bnd[:, 0], np.where(on_hub, n, n + 1)]
    return V2, np.vstack([F, cap])


# ------------------------------------------------------------------------------ cones
@pytest.mark.parametrize(
    "overrides",
    [
        {},
        {"fillet": False},
        {"scan_like": True, "seed": 3},
        {"hub_cone": (120.0, -30.0, 120.0, 40.0), "tip_cone": (200.0, -30.0, 190.0, 40.0)},
    ],
    ids=["default", "no-fillet", "scan-like", "cylinder-hub"],
)
def test_blade_has_two_boundary_loops_exactly_on_the_cones(overrides):
    b = make_demo_blisk(resolution=0.3, **overrides)
    mesh = TriMesh.from_arrays(b.blade_vertices, b.blade_faces)
    assert mesh.welded_vertices == 0 and mesh.dropped_faces == 0
    loops = loops_by_cone(b, mesh)
    dh, _ = cone_distances(b, mesh.V[loops["hub"]])
    _, dt = cone_distances(b, mesh.V[loops["tip"]])
    assert np.abs(dh).max() <= CONE_TOL
    assert np.abs(dt).max() <= CONE_TOL
    # and nothing else of the blade is outside the band between the cones
    s = morph_ratio(b, b.blade_vertices)
    assert s.min() > -1e-6 and s.max() < 1 + 1e-6


def test_every_clean_vertex_lies_on_the_morphing_cone_of_its_span(clean):
    # the parametrisation puts (u, v) on the LMC at s = v (paper 001, Eqs. 1-4)
    s = morph_ratio(clean, clean.blade_vertices)
    assert np.abs(s - clean.blade_uv[:, 1]).max() < 1e-12
    rows = grid_rows(clean)
    s_rows = s.reshape(rows.shape[:2])
    assert np.ptp(s_rows, axis=1).max() < 1e-12  # each grid row is one CC-curve-like section


def test_default_dimensions_are_realistic(clean):
    p = clean.params
    assert clean.blade_count == 24 and clean.axis.as_list() == [0, 0, 0, 0, 0, 1]
    r, z = meridional(clean.blade_vertices, clean.axis)
    assert 145 < r.min() < 160 and 215 < r.max() < 232
    assert -40 < z.min() and z.max() < 40
    assert p.le_radius == pytest.approx(0.3) and p.fillet_radius == pytest.approx(8.0)


# ------------------------------------------------------------------------------ orientation
def test_orientation_is_consistent_and_outward(clean_mesh):
    assert clean_mesh.flipped_faces == 0
    b = make_demo_blisk(resolution=0.3)
    V, F = b.blade_vertices, b.blade_faces
    V2, F2 = capped(b, V, F)
    n_v, n_u = b.grid_shape
    # face centroids of two rows (mid-span and near the hub, in the fillet), all around
    rows = [n_v // 2, 1]
    faces = np.concatenate([np.arange(2 * n_u * j, 2 * n_u * (j + 1), 3) for j in rows])
    c = V[F[faces]].mean(axis=1)
    n = np.cross(V[F[faces, 1]] - V[F[faces, 0]], V[F[faces, 2]] - V[F[faces, 0]])
    n /= np.linalg.norm(n, axis=1)[:, None]
    eps = 0.05  # mm, well below the 0.3 mm edge radius
    w_in = winding_numbers(V2, F2, c - eps * n)
    w_out = winding_numbers(V2, F2, c + eps * n)
    assert np.abs(w_in - 1.0).max() < 1e-6  # one step against the normal: inside the metal
    assert np.abs(w_out).max() < 1e-6  # one step along it: outside


def test_scan_like_orientation_is_consistent(scan):
    mesh = TriMesh.from_arrays(scan.blade_vertices, scan.blade_faces)
    assert mesh.flipped_faces == 0 and mesh.welded_vertices == 0 and mesh.dropped_faces == 0
    loops_by_cone(scan, mesh)


# ------------------------------------------------------------------------------ section shape
def test_leading_and_trailing_edge_radii_are_the_requested_ones(edges_blisk):
    b = edges_blisk
    rows = grid_rows(b)
    s_rows = morph_ratio(b, rows[:, 0])
    for s_target in (0.5, 1.0):
        P = rows[np.argmin(np.abs(s_rows - s_target))]
        for which, want in (("le", 0.25), ("te", 0.45)):
            rad, resid, n_pts, _ = edge_circle(P, which, depth=0.5 * want)
            assert n_pts >= 10, "the edge must be resolved with many points"
            assert rad == pytest.approx(want, rel=0.02)  # the issue asks 10 %
            assert resid < 0.01 * want  # the points really are on a circle


def test_edges_are_resolved_densely():
    b = make_demo_blisk(resolution=1.0)
    rows = grid_rows(b)
    P = rows[len(rows) // 2]
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    i, j = farthest_pair(P)
    for end in (i, j):
        on_arc = np.linalg.norm(P - P[end], axis=1) < 0.35  # ~ the 0.3 mm edge arc
        assert on_arc.sum() >= 40  # ≥ 40 points per edge at resolution 1
        assert seg[on_arc].max() < 0.03
    # mid-chord spacing ~ the span spacing; the grading between is gentle
    assert 0.4 < seg.max() < 0.8
    assert (seg / np.roll(seg, 1)).max() < 1.6


def test_thickness_stagger_and_chord_follow_the_span_laws():
    b = make_demo_blisk(resolution=1.0, fillet=False)
    p = b.params
    rows = grid_rows(b)
    s_rows = morph_ratio(b, rows[:, 0])
    for j in (0, len(rows) // 2, len(rows) - 1):
        v = float(s_rows[j])
        P = rows[j]
        t_want = p.max_thickness_hub + v * (p.max_thickness_tip - p.max_thickness_hub)
        assert section_thickness(P) == pytest.approx(t_want, rel=0.01)
        # chord and stagger from the LE/TE circle centres, in the (meridional, θ) frame
        _, _, _, c_le = edge_circle(P, "le", 0.15)
        _, _, _, c_te = edge_circle(P, "te", 0.15)
        chord = c_te - c_le
        mid = 0.5 * (c_le + c_te)
        th = math.atan2(mid[1], mid[0])
        A, B = b.morphing_cones.generatrix(v)
        e = (B - A) / np.linalg.norm(B - A)
        e_m = np.array([e[0] * math.cos(th), e[0] * math.sin(th), e[1]])
        e_t = np.array([-math.sin(th), math.cos(th), 0.0])
        stagger = math.atan2(chord @ e_t, chord @ e_m)
        want = p.stagger_hub + v * (p.stagger_tip - p.stagger_hub)
        assert math.degrees(abs(stagger - want)) < 0.3
        assert np.linalg.norm(chord) == pytest.approx(p.chord_hub, rel=0.005)


def test_lean_turns_the_tip_section_about_the_axis():
    lean = math.radians(12.0)
    b0 = make_demo_blisk(resolution=0.3, lean=0.0)
    b1 = make_demo_blisk(resolution=0.3, lean=lean)
    tip = b0.blade_uv[:, 1] == 1.0
    hub = b0.blade_uv[:, 1] == 0.0
    r0, z0 = meridional(b0.blade_vertices[tip], b0.axis)
    r1, z1 = meridional(b1.blade_vertices[tip], b1.axis)
    assert np.allclose(r0, r1, atol=1e-9) and np.allclose(z0, z1, atol=1e-9)
    th0 = np.arctan2(b0.blade_vertices[tip, 1], b0.blade_vertices[tip, 0])
    th1 = np.arctan2(b1.blade_vertices[tip, 1], b1.blade_vertices[tip, 0])
    # expected turn: tan(lean) · (hub-to-tip height at the stacking point) / r there
    hc, tc = b0.hub_cone, b0.tip_cone
    q = 0.5 * (tc.p1 + tc.p2)  # stack_position 0.5
    height = abs(hc.signed_distance(q[0], q[1]))
    assert np.allclose(th1 - th0, math.tan(lean) * height / q[0], atol=1e-12)
    assert np.allclose(b0.blade_vertices[hub], b1.blade_vertices[hub], atol=1e-12)


def test_fillet_flares_the_hub_section_by_its_radius_and_meets_the_hub_tangentially():
    rf = 8.0
    bf = make_demo_blisk(resolution=0.5, fillet=True, fillet_radius=rf)
    b0 = make_demo_blisk(resolution=0.5, fillet=False)
    foot_f = bf.blade_vertices[bf.blade_uv[:, 1] == 0.0]
    foot_0 = b0.blade_vertices[b0.blade_uv[:, 1] == 0.0]
    loop0 = np.vstack([foot_0, foot_0[:1]])
    # the flared foot is the offset of the plain foot by ρ_f on the hub cone
    d = point_polyline_distance(foot_f, loop0[:-1], loop0[1:])
    assert np.abs(d - rf).max() < 0.02
    # tangency: the faces along the foot have normals close to the hub normal
    hc = bf.hub_cone
    e = (hc.p2 - hc.p1) / np.linalg.norm(hc.p2 - hc.p1)
    n_m = np.array([-e[1], e[0]]) * np.sign(-e[1])  # meridional normal, away from the axis

    def foot_face_angles(b):
        F = b.blade_faces
        first = np.all(b.blade_uv[F, 1] < 0.03, axis=1) & np.any(b.blade_uv[F, 1] == 0.0, axis=1)
        V = b.blade_vertices
        n = np.cross(V[F[first, 1]] - V[F[first, 0]], V[F[first, 2]] - V[F[first, 0]])
        n /= np.linalg.norm(n, axis=1)[:, None]
        c = V[F[first]].mean(axis=1)
        th = np.arctan2(c[:, 1], c[:, 0])
        hub_n = np.c_[n_m[0] * np.cos(th), n_m[0] * np.sin(th), np.full(len(th), n_m[1])]
        return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, hub_n), -1, 1)))

    assert foot_face_angles(bf).max() < 10.0
    assert foot_face_angles(b0).min() > 45.0
    # above the fillet the two blades coincide (the flare only thickens the foot)
    v_above = 0.5
    u = np.linspace(0.0, 4.0, 97)[:-1]
    assert np.abs(bf.surface_points(u, v_above) - b0.surface_points(u, v_above)).max() < 1e-12


# ------------------------------------------------------------------------------ resolution
def test_triangle_count_scales_with_resolution():
    assert 9_000 <= blade_triangle_count(0.316) <= 11_000
    assert blade_triangle_count(1.0) == 100_000
    assert blade_triangle_count(4.5) >= 2_000_000  # generated by bench/bench_demo.py
    assert blade_triangle_count(2.0) / blade_triangle_count(1.0) == pytest.approx(4.0, rel=0.02)
    for res in (0.316, 1.0):
        b = make_demo_blisk(resolution=res)
        assert len(b.blade_faces) == blade_triangle_count(res)
        n_v, n_u, _, _ = blade_grid_shape(res)
        assert b.blade_vertices.shape == (n_v * n_u, 3)
        assert b.blade_faces.dtype == np.int64 and b.blade_vertices.dtype == np.float64


# ------------------------------------------------------------------------------ scan-like
def test_scan_like_is_deterministic_for_a_seed():
    a = make_demo_blisk(resolution=0.3, scan_like=True, seed=5)
    b = make_demo_blisk(resolution=0.3, scan_like=True, seed=5)
    c = make_demo_blisk(resolution=0.3, scan_like=True, seed=6)
    assert np.array_equal(a.blade_vertices, b.blade_vertices)
    assert np.array_equal(a.blade_faces, b.blade_faces)
    assert not np.array_equal(a.blade_vertices, c.blade_vertices)
    # the noise level does not change the triangulation
    d = make_demo_blisk(resolution=0.3, scan_like=True, seed=5, scan_noise=0.0)
    assert np.array_equal(a.blade_faces, d.blade_faces)


def test_scan_noise_never_carries_the_blade_across_a_cone():
    # with a fillet the first rows are micrometres above the hub; large noise must not push
    # them below it
    b = make_demo_blisk(resolution=1.0, scan_like=True, scan_noise=0.05, seed=1)
    s = morph_ratio(b, b.blade_vertices)
    assert s.min() > -1e-12 and s.max() < 1.0 + 1e-12
    moved = np.linalg.norm(b.blade_vertices - b.surface_points(*b.blade_uv.T), axis=1)
    assert np.sqrt(np.mean(moved**2)) == pytest.approx(0.05, rel=0.1)


def test_scan_like_triangulation_is_irregular(clean, scan):
    def valences(F, n):
        return np.bincount(F.ravel(), minlength=n)

    def max_angles(V, F):
        P = V[F]
        out = []
        for k in range(3):
            u = P[:, (k + 1) % 3] - P[:, k]
            w = P[:, (k + 2) % 3] - P[:, k]
            cos = (
                np.einsum("ij,ij->i", u, w) / np.linalg.norm(u, axis=1) / np.linalg.norm(w, axis=1)
            )
            out.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
        return np.max(out, axis=0)

    interior = (clean.blade_uv[:, 1] > 0) & (clean.blade_uv[:, 1] < 1)
    assert np.unique(valences(clean.blade_faces, len(clean.blade_vertices))[interior]).size == 1
    interior_s = (scan.blade_uv[:, 1] > 0) & (scan.blade_uv[:, 1] < 1)
    assert np.unique(valences(scan.blade_faces, len(scan.blade_vertices))[interior_s]).size >= 4
    assert max_angles(clean.blade_vertices, clean.blade_faces).max() < 150.0
    assert (max_angles(scan.blade_vertices, scan.blade_faces) > 170.0).sum() > 10  # slivers


@pytest.fixture(scope="module")
def reference():
    """A finer clean blade and its vertex normals, to measure distances to the true surface."""
    ref = make_demo_blisk(resolution=1.5)
    V, F = ref.blade_vertices, ref.blade_faces
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    acc = np.zeros_like(V)
    for k in range(3):
        np.add.at(acc, F[:, k], fn)
    return cKDTree(V), V, acc / np.linalg.norm(acc, axis=1)[:, None]


@pytest.mark.parametrize("sigma", [0.0, 0.004])
def test_scan_like_differs_from_the_clean_surface_by_the_stated_noise(reference, sigma):
    tree, Vr, Nr = reference
    b = make_demo_blisk(resolution=0.7, scan_like=True, scan_noise=sigma, seed=3)
    # away from the fillet, where the finer clean mesh is flat enough to measure µm
    s = morph_ratio(b, b.blade_vertices)
    sel = (s > 0.3) & (s < 0.95)
    P = b.blade_vertices[sel]
    _, q = tree.query(P)
    d = np.einsum("ij,ij->i", P - Vr[q], Nr[q])
    if sigma == 0.0:
        # the jitter moves points along the exact surface only
        assert np.sqrt(np.mean(d**2)) < 0.001
    else:
        assert d.std() == pytest.approx(sigma, rel=0.08)
        assert abs(d.mean()) < 0.1 * sigma
    # the boundaries stay exactly on the cones
    hub = b.blade_uv[:, 1] == 0.0
    tip = b.blade_uv[:, 1] == 1.0
    assert np.abs(cone_distances(b, b.blade_vertices[hub])[0]).max() <= CONE_TOL
    assert np.abs(cone_distances(b, b.blade_vertices[tip])[1]).max() <= CONE_TOL


# ------------------------------------------------------------------------------ copies, hub
def test_blade_copies_are_rotations_that_do_not_touch(clean):
    V0, F0 = clean.blade(0)
    V1, F1 = clean.blade(1)
    assert F1 is clean.blade_faces and np.array_equal(F0, F1)
    r0, z0 = meridional(V0, clean.axis)
    r1, z1 = meridional(V1, clean.axis)
    assert np.allclose(r0, r1, atol=1e-9) and np.allclose(z0, z1, atol=1e-12)
    dth = np.angle(np.exp(1j * (np.arctan2(V1[:, 1], V1[:, 0]) - np.arctan2(V0[:, 1], V0[:, 0]))))
    assert np.allclose(dth, clean.pitch, atol=1e-12)
    assert np.allclose(clean.blade(clean.blade_count)[0], V0)
    assert np.allclose(clean.blade(-1)[0], clean.blade(clean.blade_count - 1)[0])
    # neighbours are separated by more than the longest edge: no intersection
    edge = np.linalg.norm(V0[F0] - V0[np.roll(F0, -1, axis=1)], axis=2).max()
    gap = cKDTree(V0).query(V1)[0].min()
    assert gap > max(edge, 2.0)
    insts = clean.blade_instances([0, 2])
    assert len(insts) == 2 and np.allclose(insts[1][0], clean.blade(2)[0])


def test_hub_strip_lies_on_the_hub_cone_under_the_blades(clean):
    H, HF = clean.hub_vertices, clean.hub_faces
    dh, _ = cone_distances(clean, H)
    assert np.abs(dh).max() <= CONE_TOL
    mesh = TriMesh.from_arrays(H, HF)
    assert mesh.flipped_faces == 0 and len(mesh.boundary_loops()) == 1
    n = np.cross(H[HF[:, 1]] - H[HF[:, 0]], H[HF[:, 2]] - H[HF[:, 0]])
    c = H[HF].mean(axis=1)
    radial = c.copy()
    radial[:, 2] = 0.0
    assert np.all(np.einsum("ij,ij->i", n, radial) > 0)  # outward = away from the axis
    # covers the blade foot (and its neighbours') with margin
    foot = clean.blade_vertices[clean.blade_uv[:, 1] == 0.0]
    th_h = np.arctan2(H[:, 1], H[:, 0])
    for i in clean.hub_blade_indices():
        Vi = clean.blade(i)[0][clean.blade_uv[:, 1] == 0.0]
        th = np.arctan2(Vi[:, 1], Vi[:, 0])
        assert th_h.min() < th.min() and th.max() < th_h.max()
    assert clean.hub_blade_indices() == [-1, 0, 1]
    hc = clean.hub_cone
    e = (hc.p2 - hc.p1) / np.linalg.norm(hc.p2 - hc.p1)
    rz_h = np.c_[np.hypot(H[:, 0], H[:, 1]), H[:, 2]] @ e
    rz_f = np.c_[np.hypot(foot[:, 0], foot[:, 1]), foot[:, 2]] @ e
    assert rz_h.min() < rz_f.min() - 5.0 and rz_h.max() > rz_f.max() + 5.0


def test_full_ring_and_combined():
    b = make_demo_blisk(resolution=0.15, blade_count=12, hub_pitches=12)
    mesh = TriMesh.from_arrays(b.hub_vertices, b.hub_faces)
    assert len(mesh.boundary_loops()) == 2 and mesh.flipped_faces == 0
    V, F = b.combined()
    nb = len(b.blade_faces)
    assert len(F) == len(b.hub_faces) + 12 * nb
    assert F.min() == 0 and F.max() == len(V) - 1 and F.dtype == np.int64
    V3, F3 = make_demo_blisk(resolution=0.15).combined(hub=False)
    assert len(F3) == 3 * nb


# ------------------------------------------------------------------------------ errors
@pytest.mark.parametrize(
    ("overrides", "name"),
    [
        ({"blade_count": 2}, "blade_count"),
        ({"blade_count": 24.5}, "blade_count"),
        ({"blade_count": 90}, "blade_count"),  # blades would intersect
        ({"resolution": 0.0}, "resolution"),
        ({"resolution": 50.0}, "resolution"),
        ({"le_radius": 0.01}, "le_radius"),
        ({"te_radius": 1.5}, "te_radius"),
        ({"fillet_radius": 2.0}, "fillet_radius"),
        ({"fillet_radius": 40.0}, "fillet_radius"),  # taller than 0.4 of the blade
        ({"stagger_tip": math.radians(85.0)}, "stagger_tip"),
        ({"camber_hub": float("nan")}, "camber_hub"),
        ({"max_thickness_hub": 20.0}, "max_thickness_hub"),
        ({"max_thickness_position": 0.9}, "max_thickness_position"),
        ({"hub_cone": (150.0, -25.0, 150.0, -25.0)}, "hub_cone"),
        ({"hub_cone": (150.0, -25.0)}, "hub_cone"),
        ({"tip_cone": (140.0, -25.0, 150.0, 35.0)}, "tip_cone"),  # below the hub
        ({"tip_cone": (140.0, -25.0, 190.0, 35.0)}, "tip_cone"),  # crosses the hub
        ({"hub_pitches": 0.5}, "hub_pitches"),
        ({"scan_noise": -0.001}, "scan_noise"),
        ({"scan_jitter": 0.6}, "scan_jitter"),
        ({"seed": -1}, "seed"),
        ({"fillet": "yes"}, "fillet"),
        ({"chord": 50.0}, "chord"),  # unknown parameter
    ],
)
def test_bad_parameters_raise_clear_errors(overrides, name):
    with pytest.raises(DemoParameterError, match=name) as info:
        make_demo_blisk(**{"resolution": 0.2, **overrides})
    assert isinstance(info.value, BliskCamError)
    assert "allowed" in str(info.value)


def test_params_object_and_overrides():
    p = DemoParams(resolution=0.2, blade_count=20)
    b = make_demo_blisk(p, lean=0.0)
    assert b.params.blade_count == 20 and b.params.lean == 0.0 and p.lean != 0.0
    with pytest.raises(DemoParameterError, match="DemoParams"):
        make_demo_blisk({"resolution": 0.2})


# ------------------------------------------------------------------------------ properties
@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(
    stagger_hub=st.floats(0.0, 45.0),
    stagger_tip=st.floats(20.0, 60.0),
    camber_hub=st.floats(0.0, 50.0),
    camber_tip=st.floats(-10.0, 30.0),
    t_hub=st.floats(2.5, 5.0),
    t_tip=st.floats(1.5, 3.0),
    le=st.floats(0.2, 0.5),
    te=st.floats(0.2, 0.5),
    lean=st.floats(-15.0, 15.0),
    fillet=st.booleans(),
    fillet_radius=st.floats(3.0, 10.0),
    blade_count=st.integers(12, 30),
    scan_like=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
    tip_dr=st.floats(-15.0, 15.0),
)
def test_any_valid_blisk_is_a_closed_oriented_tube_between_the_cones(
    stagger_hub, stagger_tip, camber_hub, camber_tip, t_hub, t_tip, le, te, lean, fillet,
    fillet_radius, blade_count, scan_like, seed, tip_dr,
):  # fmt: skip
    rad = math.radians
    try:
        b = make_demo_blisk(
            resolution=0.15,
            stagger_hub=rad(stagger_hub),
            stagger_tip=rad(stagger_tip),
            camber_hub=rad(camber_hub),
            camber_tip=rad(camber_tip),
            max_thickness_hub=t_hub,
            max_thickness_tip=t_tip,
            le_radius=le,
            te_radius=te,
            lean=rad(lean),
            fillet=fillet,
            fillet_radius=fillet_radius,
            blade_count=blade_count,
            scan_like=scan_like,
            seed=seed,
            tip_cone=(220.0 - tip_dr, -25.0, 220.0 + tip_dr, 35.0),
        )
    except DemoParameterError as err:
        assert "intersect" in str(err) or "thickness" in str(err)
        assume(False)
    mesh = TriMesh.from_arrays(b.blade_vertices, b.blade_faces)
    assert mesh.flipped_faces == 0 and mesh.welded_vertices == 0
    loops = loops_by_cone(b, mesh)
    assert np.abs(cone_distances(b, mesh.V[loops["hub"]])[0]).max() <= CONE_TOL
    assert np.abs(cone_distances(b, mesh.V[loops["tip"]])[1]).max() <= CONE_TOL
    # capped volume ≈ Σ (section area) · height: positive and of the right size
    V2, F2 = capped(b, b.blade_vertices, b.blade_faces)
    vol = np.einsum("ij,ij->i", V2[F2[:, 0]], np.cross(V2[F2[:, 1]], V2[F2[:, 2]])).sum() / 6
    approx = 50.0 * 0.6 * 0.5 * (t_hub + t_tip) * 60.0
    assert 0.5 * approx < vol < (3.0 if fillet else 1.5) * approx


# --------------------------------------------------------------- fillet vs ball radius
def _principal_curvatures(P, u, v, hu=1e-4, hv=1e-5):
    """Principal curvatures (1/mm) of the exact surface P(u, v) at flat arrays u, v from
    central differences (first and second fundamental forms), signed so that > 0 is convex
    for the normal Xu × Xv, and that normal."""

    def f(du, dv):
        return P(u + du, v + dv)

    X = f(0, 0)
    Xu, Xv = (f(hu, 0) - f(-hu, 0)) / (2 * hu), (f(0, hv) - f(0, -hv)) / (2 * hv)
    Xuu = (f(hu, 0) - 2 * X + f(-hu, 0)) / hu**2
    Xvv = (f(0, hv) - 2 * X + f(0, -hv)) / hv**2
    Xuv = (f(hu, hv) - f(hu, -hv) - f(-hu, hv) + f(-hu, -hv)) / (4 * hu * hv)
    n = np.cross(Xu, Xv)
    n /= np.linalg.norm(n, axis=1)[:, None]
    E, Fm, G = (Xu * Xu).sum(1), (Xu * Xv).sum(1), (Xv * Xv).sum(1)
    L, M, N = (Xuu * n).sum(1), (Xuv * n).sum(1), (Xvv * n).sum(1)
    K = (L * N - M * M) / (E * G - Fm * Fm)
    Hm = (E * N - 2 * Fm * M + G * L) / (2 * (E * G - Fm * Fm))
    disc = np.sqrt(np.maximum(Hm * Hm - K, 0.0))
    return -(Hm + disc), -(Hm - disc)  # L = X'' · n < 0 on a convex surface seen along n


def _tightest_concave_radius(fillet_radius):
    """Smallest concave principal radius (mm) of the exact demo blade near the hub."""
    b = make_demo_blisk(resolution=0.2, fillet_radius=fillet_radius)
    # sign convention from a surely convex point: the leading-edge apex at mid-span
    k1, k2 = _principal_curvatures(b.surface_points, np.array([0.5]), np.array([0.5]))
    sign = 1.0 if max(k1[0], k2[0], key=abs) > 0 else -1.0
    uu, vv = np.meshgrid(np.linspace(0.0, 4.0, 1600, endpoint=False), np.linspace(0.004, 0.16, 24))
    k1, k2 = _principal_curvatures(b.surface_points, uu.ravel(), vv.ravel())
    kmin = np.minimum(sign * k1, sign * k2)
    return 1.0 / -kmin.min()


def test_fillet_concave_radius_against_the_6mm_ball():
    """The flare is sheared where the wall leans against the hub: its tightest concave radius
    is ≈ 0.72 ρ_f, below the 6 mm ball for the default 8 mm (the generator lifts and reports
    those poses, test_pathgen) and above it for 10 mm (the acceptance demo)."""
    r8 = _tightest_concave_radius(8.0)
    r10 = _tightest_concave_radius(10.0)
    assert 5.5 < r8 < 6.0
    assert 6.8 < r10 < 7.5
