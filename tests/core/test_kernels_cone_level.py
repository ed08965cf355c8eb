"""The crossing part of a level's slice in one compiled call (``kernels.slicing.cone_level``,
issue 21) against its numpy reference (``MeshConeSlicer._crossing``) on the same inputs: the
same crossed edges, links, crossings and normals bit for bit, and the same whole slices, on
the demo blade (with its fillet) and on Rotor 37 as stored, at levels inside, at the ends
(s = 1 counts a vertex on the level as above), beyond the mesh and through mesh vertices.

Tests comparing the two backends skip (saying why) when the extension is not built."""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import slicing as compiled_slicing
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import MorphingCones
from blisk_cam.core.paths.slicing import MeshConeSlicer
from tests.support.blades import nasa_blade
from tests.support.kernels import needs_compiled

compiled = needs_compiled("cone_level")


@pytest.fixture(scope="module", params=["demo", "rotor37"])
def slicer(request):
    if request.param == "demo":
        d = make_demo_blisk(resolution=0.3, fillet=True)
        mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
        return MeshConeSlicer(mesh, d.axis, MorphingCones(d.hub_cone, d.tip_cone))
    V, F, c1, c2 = nasa_blade("rotor37")
    return MeshConeSlicer(TriMesh.from_arrays(V, F), Axis(), MorphingCones(c1, c2))


def _levels(slicer):
    """Inside, the ends, beyond, and the levels of a few mesh vertices (a vertex on the
    level: crossings at t = 0 or 1, repeated points)."""
    s = slicer.s[np.isfinite(slicer.s)]
    through = np.quantile(s, [0.1, 0.35, 0.62, 0.9], method="nearest")
    return [0.0, 0.0137, 0.5, 0.913, 1.0, -0.5, 1.7, *(float(x) for x in through)]


def _kernel(slicer, s, cand):
    return compiled_slicing.cone_level(
        slicer.r, slicer.z, slicer.radial, slicer.mesh.V, slicer.vertex_normals,
        slicer.mesh.F, slicer.edges, slicer.face_edges, cand,
        slicer.morph.segment_lines(s)[0], slicer.on_tol, not s < 1.0)


@compiled
def test_cone_level_is_the_numpy_crossing_bit_for_bit(slicer):
    crossed = 0
    for s in _levels(slicer):
        cand = slicer._candidate_faces(s, slicer._s_margin)
        got = _kernel(slicer, s, cand)
        with backend.numpy_only():
            ref = slicer._crossing(s, cand, slicer.morph.segment_lines(s))
        if ref is None:
            assert len(got[0]) == 0 and got[1].shape == (0, 2), s
            continue
        for g, r in zip(got, ref[1:], strict=True):
            assert g.shape == r.shape and np.array_equal(g, r), s
        crossed += len(ref[0])
        # independent: the crossings lie on the level's cone (a vertex within on_tol of it
        # counts as on it), the normals are unit
        uedges, _, pts, t, nrm = got
        r, z = meridional(pts, slicer.axis)
        alpha, beta, gamma = slicer.morph.segment_lines(s)[0]
        assert np.all(np.abs(alpha * r + beta * z + gamma) <= slicer.on_tol + 1e-9), s
        assert np.allclose(np.linalg.norm(nrm, axis=1), 1.0)
        assert np.all((t >= 0) & (t <= 1))
    assert crossed > 1000


@compiled
def test_slices_are_the_numpy_slices(slicer):
    for s in _levels(slicer):
        got = slicer.slice(s)
        with backend.numpy_only():
            ref = slicer.slice(s)
        assert len(got) == len(ref), s
        for g, r in zip(got, ref, strict=True):
            assert g.closed == r.closed
            for name in ("points", "normals", "edge", "t", "face"):
                assert np.array_equal(getattr(g, name), getattr(r, name)), (s, name)


@compiled
def test_cone_level_refuses_ids_out_of_range(slicer):
    cand = np.array([0, len(slicer.mesh.F)])
    with pytest.raises(ValueError, match="out of range"):
        _kernel(slicer, 0.5, cand)


@needs_compiled("slicer_candidates")
def test_candidate_faces_are_the_numpy_ones(slicer):
    """The candidate faces of a level in one compiled call are the numpy reference's ids, and
    (independently) every face whose s range meets [s − m, s + m], ascending."""
    m = slicer._s_margin
    rng = np.random.default_rng(2)
    found = 0
    for s in [*_levels(slicer), *rng.uniform(-0.1, 1.1, 40)]:
        got = slicer._candidate_faces(s, m)
        with backend.numpy_only():
            ref = slicer._candidate_faces(s, m)
        assert got.dtype == np.int64 and np.array_equal(got, ref), s
        brute = np.flatnonzero((slicer.face_smin <= s + m) & (slicer.face_smax >= s - m))
        assert np.array_equal(got, brute), s
        found += len(got)
    assert found > 10000


@needs_compiled("slicer_candidates")
def test_candidate_faces_refuse_ids_out_of_range(slicer):
    n = len(slicer.face_smin)
    with pytest.raises(ValueError, match="out of range"):
        compiled_slicing.slicer_candidates(np.array([0, n]), 0, 2, np.zeros(0, np.int64),
                                           slicer.face_smin, slicer.face_smax, 0.0, 1.0, 0.0)
    # a range past the end is clamped, as a Python slice
    got = compiled_slicing.slicer_candidates(np.array([0, 1]), 1, 9, np.array([2]),
                                             slicer.face_smin, slicer.face_smax,
                                             -np.inf, np.inf, -np.inf)
    assert got.tolist() == [1, 2]
