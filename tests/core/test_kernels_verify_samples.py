"""The sample grids of verify's surface samples in one compiled call
(``kernels.grid.grid_samples``, issue 21) against their numpy reference
(``verify.samples._grid_samples_numpy``) on the same inputs: the same points, faces,
barycentric coordinates, vertex ids, grid edges and edge faces bit for bit, on Rotor 37 as
stored and on the demo blade, at the default spacing (no face with one segment), at a
spacing giving faces of 1, 2, 3… segments (the shared mesh edges of the n = 1 faces kept
once) and at one so coarse every face has one segment; the smooth normals
(``TriMesh.interpolate_normals``, compiled) against their numpy reference bit for bit, at
grid points, random points, corners, a zero sum and NaN weights; and whole surface samples
the same on both backends.

Tests comparing the two backends skip (saying why) when the extension is not built."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import grid as compiled_grid
from blisk_cam.core.kernels import weld as compiled_weld
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import MorphingCones
from blisk_cam.core.verify.samples import _grid_samples_numpy, default_spacing, surface_samples
from tests.support.blades import nasa_blade
from tests.support.kernels import needs_compiled

compiled = needs_compiled("grid_samples")


@pytest.fixture(scope="module", params=["rotor37", "demo"])
def part(request):
    if request.param == "demo":
        d = make_demo_blisk(resolution=0.3, fillet=True)
        return (TriMesh.from_arrays(d.blade_vertices, d.blade_faces), d.axis,
                MorphingCones(d.hub_cone, d.tip_cone))
    V, F, c1, c2 = nasa_blade("rotor37")
    return TriMesh.from_arrays(V, F), Axis(), MorphingCones(c1, c2)


def _faces_and_counts(mesh, axis, cones, spacing):
    """The faces reaching into the region and their segments per side, as
    :func:`surface_samples` picks them."""
    V, F = mesh.V, mesh.F
    fs = cones.ratio_of_points(V, axis)[F]
    faces = np.nonzero((fs.max(axis=1) >= -1e-3) & (fs.min(axis=1) <= 1.0 + 1e-3))[0]
    T = V[F[faces]]
    elen = np.linalg.norm(T - np.roll(T, -1, axis=1), axis=2).max(axis=1)
    return faces, np.maximum(np.ceil(elen / spacing), 1).astype(np.int64), elen


def _same_bits(got, ref):
    assert len(got) == len(ref) == 6
    for g, r in zip(got, ref, strict=True):
        assert g.dtype == r.dtype and g.shape == r.shape
        assert np.array_equal(g.view(np.uint64) if g.dtype == np.float64 else g,
                              r.view(np.uint64) if r.dtype == np.float64 else r)


@compiled
@pytest.mark.parametrize("which", ["default", "mixed", "coarse"])
def test_grid_samples_are_the_numpy_reference_bit_for_bit(part, which):
    mesh, axis, cones = part
    faces, nf, elen = _faces_and_counts(mesh, axis, cones, default_spacing(3.0, 0.01))
    if which == "mixed":
        faces, nf, _ = _faces_and_counts(mesh, axis, cones, float(np.median(elen)))
        assert {1, 2} <= set(np.unique(nf).tolist())
    elif which == "coarse":
        faces, nf, _ = _faces_and_counts(mesh, axis, cones, 2.0 * float(elen.max()))
        assert np.all(nf == 1)
    else:
        assert nf.min() > 1
    ref = _grid_samples_numpy(mesh.V, mesh.F, faces, nf)
    got = compiled_grid.grid_samples(mesh.V, mesh.F, faces, nf)
    assert got is not None
    _same_bits(got, ref)
    # the n = 1 faces' mesh edges were kept once: no edge twice
    e = ref[4]
    assert len(np.unique(e, axis=0)) == len(e)


@compiled
def test_grid_samples_decline_out_of_range_ids(part):
    mesh, _, _ = part
    faces = np.array([0, len(mesh.F)], dtype=np.int64)
    assert compiled_grid.grid_samples(mesh.V, mesh.F, faces, np.ones(2, np.int64)) is None
    assert compiled_grid.grid_samples(mesh.V, mesh.F, faces[:1], np.zeros(1, np.int64)) is None


@compiled
def test_surface_samples_are_the_same_on_both_backends(part):
    mesh, axis, cones = part
    sp = default_spacing(3.0, 0.01)
    got = surface_samples(mesh, cones, axis, sp)
    with backend.numpy_only():
        ref = surface_samples(mesh, cones, axis, sp)
    for name in ("points", "normals", "face", "bary", "s", "vertex", "edges", "edge_face"):
        assert np.array_equal(getattr(got, name), getattr(ref, name)), name
    assert (got.spacing, got.n_boundary) == (ref.spacing, ref.n_boundary)
    assert got.n_boundary > 0


@compiled
def test_interpolate_normals_are_the_numpy_reference_bit_for_bit(part):
    mesh, _, _ = part
    rng = np.random.default_rng(21)
    k = 20000
    face = rng.integers(0, len(mesh.F), k)
    bary = rng.dirichlet([1.0, 1.0, 1.0], k)
    bary[:30] = np.eye(3)[np.arange(30) % 3]  # corners
    bary[30] = 0.0  # a zero sum: left as it is
    bary[31] = [np.nan, 0.5, 0.5]
    bary[32] = [1e-300, 0.0, 0.0]
    ref = mesh._interpolate_normals_numpy(face, bary)
    for f in (face, face.astype(np.int32)):
        got = mesh.interpolate_normals(f, bary)
        assert got.dtype == ref.dtype and got.shape == ref.shape
        assert np.array_equal(got.view(np.uint64), ref.view(np.uint64))
    assert np.all(ref[30] == 0.0) and np.all(np.isnan(ref[31]))
    # the kernel declines what numpy does otherwise (negative ids wrap) or refuses
    assert compiled_weld.interpolate_normals(mesh.vertex_normals, mesh.F,
                                             np.array([-1]), bary[:1]) is None
    assert np.array_equal(mesh.interpolate_normals(np.array([-1]), bary[:1]),
                          mesh._interpolate_normals_numpy(np.array([-1]), bary[:1]))
