import numpy as np
import pytest
import trimesh

from blisk_cam.core.errors import MeshError
from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.cones import Cone, MorphingCones
from blisk_cam.core.paths.slicing import MeshConeSlicer

AX = Axis()


def _check_curve_on_mesh_and_cone(mesh, slicer, c, tol=1e-9):
    # on the cone: meridional signed distance
    r, z = meridional(c.points, AX)
    assert np.abs(slicer.morph.f(c.s, r, z)).max() < tol
    # on the mesh: distance to the segment of the mesh edge it claims to lie on
    a, b = mesh.V[mesh.edges[c.edge, 0]], mesh.V[mesh.edges[c.edge, 1]]
    ab = b - a
    u = np.clip(np.einsum("ij,ij->i", c.points - a, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
    assert np.linalg.norm(c.points - (a + u[:, None] * ab), axis=1).max() < 1e-9
    if c.s in (0.0, 1.0):
        return  # end levels run through boundary vertices; repeated points were merged
    # consecutive points lie on edges of a common face (the polyline runs inside faces)
    fe = mesh.edge_faces[c.edge]
    nxt = np.roll(fe, -1, axis=0) if c.closed else fe[1:]
    cur = fe if c.closed else fe[:-1]
    shared = (cur[:, :, None] == nxt[:, None, :]) & (cur[:, :, None] >= 0)
    assert np.all(np.any(shared, axis=(1, 2)))


def test_tube_levels_are_closed_loops_on_mesh_and_cone(tube):
    V, F, mc = tube
    mesh = TriMesh.from_arrays(V, F)
    sl = MeshConeSlicer(mesh, AX, mc)
    for s in (0.0, 0.13, 0.5, 0.77, 1.0):
        curves = sl.slice(s)
        assert len(curves) == 1 and curves[0].closed
        _check_curve_on_mesh_and_cone(mesh, sl, curves[0])


def test_end_levels_are_the_boundary_loops(tube):
    V, F, mc = tube
    mesh = TriMesh.from_arrays(V, F)
    sl = MeshConeSlicer(mesh, AX, mc)
    loops = mesh.boundary_loops()
    assert len(loops) == 2
    for s in (0.0, 1.0):
        (c,) = sl.slice(s)
        # every boundary vertex of that end is a point of the curve, nothing else
        r, z = meridional(mesh.V, AX)
        on = [lp for lp in loops if np.abs(mc.f(s, r[lp], z[lp])).max() < 1e-6][0]
        d = np.linalg.norm(c.points[:, None, :] - mesh.V[on][None], axis=2).min(axis=1)
        assert len(c) == len(on) and d.max() < 1e-12


def test_float32_noise_on_boundary_still_gives_one_clean_loop(tube):
    V, F, mc = tube
    V32 = V.astype(np.float32).astype(np.float64)  # STL precision: ~1e-5 mm at r = 140 mm
    rng = np.random.default_rng(3)
    V32 += rng.normal(0, 5e-6, V32.shape)
    mesh = TriMesh.from_arrays(V32, F)
    sl = MeshConeSlicer(mesh, AX, mc)
    for s in (0.0, 1.0):
        curves = sl.slice(s)
        assert len(curves) == 1 and curves[0].closed
        r, z = meridional(curves[0].points, AX)
        assert np.abs(mc.f(s, r, z)).max() < 1e-4
        assert len(curves[0]) == 96  # one point per boundary vertex, no ragged extras


def test_unwelded_flipped_and_degenerate_input_gives_the_same_level(tube):
    V, F, mc = tube
    ref = MeshConeSlicer(TriMesh.from_arrays(V, F), AX, mc).slice(0.4)[0]
    # STL-like: every triangle its own three vertices; a third of them wound backwards;
    # plus a zero-area triangle
    soup = V[F].reshape(-1, 3)
    Fs = np.arange(len(soup)).reshape(-1, 3)
    Fs[::3] = Fs[::3, ::-1]
    soup = np.vstack([soup, soup[:1], soup[:1] + [1e-3, 0, 0], soup[:1] + [2e-3, 0, 0]])
    Fs = np.vstack([Fs, [len(soup) - 3, len(soup) - 2, len(soup) - 1]])
    mesh = TriMesh.from_arrays(soup, Fs)
    assert mesh.flipped_faces > 0 and mesh.welded_vertices > 0
    c = MeshConeSlicer(mesh, AX, mc).slice(0.4)[0]
    assert len(c) == len(ref)
    assert abs(c.length() - ref.length()) < 1e-9


def test_hole_splits_the_curve_into_open_pieces(tube):
    V, F, mc = tube
    mesh = TriMesh.from_arrays(V, F)
    sl = MeshConeSlicer(mesh, AX, mc)
    s = 0.5
    # punch a hole of radius 1.5 mm around one point of the level
    p0 = sl.slice(s)[0].points[10]
    cen = mesh.V[mesh.F].mean(1)
    keep = np.linalg.norm(cen - p0, axis=1) > 1.5
    holed = TriMesh.from_arrays(mesh.V, mesh.F[keep])
    curves = MeshConeSlicer(holed, AX, mc).slice(s)
    assert len(curves) == 1 and not curves[0].closed
    # its two ends are on the hole's boundary edges
    ef = holed.edge_faces[curves[0].edge[[0, -1]]]
    assert np.all(ef[:, 1] == -1)


def test_disk_lmc_equals_plane_section_of_trimesh(rotor37):
    V, F, _, _ = rotor37
    mesh = TriMesh.from_arrays(V, F)
    z0 = 20.0
    mc = MorphingCones(Cone(150, z0 - 10, 300, z0 - 10), Cone(150, z0 + 10, 300, z0 + 10))
    sl = MeshConeSlicer(mesh, AX, mc)
    curves = sl.slice(0.5)
    # the plane crosses the open blade from hub to tip: two open curves (the two sides)
    assert len(curves) == 2 and not any(c.closed for c in curves)
    tm = trimesh.Trimesh(mesh.V, mesh.F, process=False)
    segs = trimesh.intersections.mesh_plane(tm, [0, 0, 1], [0, 0, z0])
    ref_len = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1).sum()
    assert abs(sum(c.length() for c in curves) - ref_len) < 1e-6 * ref_len
    assert max(np.abs(c.points[:, 2] - z0).max() for c in curves) < 1e-9


def test_nasa_rotor37_levels(rotor37):
    V, F, c1, c2 = rotor37
    mesh = TriMesh.from_arrays(V, F)
    mc = MorphingCones(c1, c2)
    sl = MeshConeSlicer(mesh, AX, mc)
    for s in (0.0, 0.5, 1.0):
        curves = sl.slice(s)
        assert len(curves) == 1 and curves[0].closed
        _check_curve_on_mesh_and_cone(mesh, sl, curves[0])


def test_nan_and_empty_meshes_are_refused():
    with pytest.raises(MeshError, match="NaN"):
        TriMesh.from_arrays([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]], [[0, 1, 2]])
    with pytest.raises(MeshError, match="no faces"):
        TriMesh.from_arrays(np.zeros((3, 3)), np.zeros((0, 3), dtype=int))
    with pytest.raises(MeshError, match="out of range"):
        TriMesh.from_arrays(np.eye(3), [[0, 1, 3]])


def test_cones_parametrised_by_tube_fixture_are_consistent(make_tube):
    V, F, mc = make_tube(cone1=(100, 0, 100, 40), cone2=(140, 0, 140, 40))  # cylinders
    mesh = TriMesh.from_arrays(V, F)
    sl = MeshConeSlicer(mesh, AX, mc)
    (c,) = sl.slice(0.5)
    r, _ = meridional(c.points, AX)
    assert np.abs(r - 120).max() < 1e-9
