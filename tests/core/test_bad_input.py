"""Bad input to the LMC path generator (issue #3): every case ends in a clear
:class:`BliskCamError` naming the problem, or in a documented, measured behaviour — and
never in a hang (each call runs under an alarm)."""

import signal
from contextlib import contextmanager

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError, ConeError, MeshError, ToleranceError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.paths.passes import generate_paths
from blisk_cam.core.verify.measure import verify_path
from tests.support.blades import tube_blade

RHO, H, E = 6.0, 0.2, 0.1  # a coarse tolerance keeps the small tube fast
AX = Axis()


@contextmanager
def time_limit(seconds):
    """Fail (instead of hanging) when the block runs longer than ``seconds``. Windows has no
    SIGALRM: there the block runs unguarded (a hang is then the test runner's timeout)."""
    if not hasattr(signal, "SIGALRM"):
        yield
        return

    def boom(signum, frame):
        raise TimeoutError(f"no answer within {seconds} s: a hang")

    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.fixture(scope="module")
def tube():
    V, F, mc = tube_blade(n_u=64, n_v=24)
    return V, F, mc.cone1, mc.cone2


@pytest.fixture(scope="module")
def tube_mesh(tube):
    V, F, c1, c2 = tube
    return TriMesh.from_arrays(V, F), c1, c2


def _gen(mesh, c1, c2, **kw):
    args = dict(tool_radius=RHO, cusp=H, chord=E)
    args.update(kw)
    with time_limit(60):
        return generate_paths(mesh, AX, c1, c2, **args)


def _refused(err_type, match, mesh, c1, c2, **kw):
    with pytest.raises(err_type, match=match) as info:
        _gen(mesh, c1, c2, **kw)
    assert isinstance(info.value, BliskCamError)


# ------------------------------------------------------------------------- tolerances
@pytest.mark.parametrize(
    "kw, match",
    [
        (dict(cusp=0.0), "cusp height must be a positive"),
        (dict(cusp=-0.05), "cusp height must be a positive"),
        (dict(chord=0.0), "chord tolerance must be a positive"),
        (dict(cusp=np.nan), "cusp height must be a positive"),
        (dict(chord=np.inf), "chord tolerance must be a positive"),
        (dict(tool_radius=0.0), "tool radius must be a positive"),
        (dict(cusp=7.0), "not smaller than the ball radius"),  # h > ρ: absurd
        (dict(chord=6.5), "not smaller than the ball radius"),
        (dict(cusp=1e-6), "below 0.1 µm"),
    ],
)
def test_bad_tolerances_are_refused(tube_mesh, kw, match):
    _refused(ToleranceError, match, *tube_mesh, **kw)


# ------------------------------------------------------------------------------ cones
def test_cones_that_miss_the_blade(tube_mesh):
    mesh, _, _ = tube_mesh
    _refused(ConeError, "miss the blade", mesh, Cone(300, -10, 304, 30), Cone(340, -10, 338, 30))


def test_cone_2_that_does_not_reach_the_blade(tube_mesh):
    mesh, c1, _ = tube_mesh
    # cone 2 beyond the blade's tip: the region's far end has no mesh
    _refused(ConeError, "cone 2 does not cut", mesh, c1, Cone(160, -10, 158, 30))


def test_identical_cones(tube_mesh):
    mesh, c1, _ = tube_mesh
    _refused(ConeError, "same cone", mesh, c1, c1)


def test_cones_crossing_inside_the_region(tube_mesh):
    mesh, c1, _ = tube_mesh
    # cone 2's generatrix crosses cone 1's between the end points: the LMCs would intersect
    _refused(ConeError, "cross", mesh, c1, Cone(140, -10, 95, 30))


# ------------------------------------------------------------------------------- meshes
def test_nan_vertices_are_refused_with_count_and_index(tube):
    V, F, _, _ = tube
    V = V.copy()
    V[[5, 9, 11]] = np.nan
    with pytest.raises(MeshError, match=r"3 vertices used by faces have NaN.*vertex 5"):
        TriMesh.from_arrays(V, F)


def test_non_manifold_mesh_is_refused(tube):
    V, F, c1, c2 = tube
    # a fin: a third face on an interior edge
    a, b = F[len(F) // 2, :2]
    V2 = np.vstack([V, V[a] + [0.0, 0.0, 5.0]])
    F2 = np.vstack([F, [[a, b, len(V)]]])
    with pytest.raises(MeshError, match="non-manifold"):
        _gen(TriMesh.from_arrays(V2, F2), c1, c2)


def test_stl_soup_with_flipped_and_degenerate_faces_gives_the_same_path(tube, tube_mesh):
    """Duplicate vertices (welded), inconsistent winding (fixed), zero-area and repeated
    triangles (dropped): the same passes as the clean mesh."""
    V, F, c1, c2 = tube
    ref = _gen(*tube_mesh)
    soup = V[F].reshape(-1, 3)
    Fs = np.arange(len(soup)).reshape(-1, 3)
    Fs[::3] = Fs[::3, ::-1]
    Fs = np.vstack([Fs, Fs[:5], [[0, 0, 1], [3, 4, 3]]])
    mesh = TriMesh.from_arrays(soup, Fs)
    assert mesh.flipped_faces > 0 and mesh.welded_vertices > 0 and mesh.dropped_faces == 7
    path = _gen(mesh, c1, c2)
    assert path.stats["passes"] == ref.stats["passes"]
    assert [c.s for c in path.curves][0] == 0.0 and path.curves[-1].s == 1.0
    # the same levels up to round-off (vertex order changes the summation order of the
    # normals, which can flip a discrete pose choice and so the secant's next trial)
    step = np.median(np.diff([c.s for c in ref.curves]))
    for a, b in zip(path.curves, ref.curves, strict=True):
        assert a.closed == b.closed and abs(a.s - b.s) < 0.05 * step


def test_hole_in_the_region_splits_curves_into_open_pieces_and_verify_passes(tube_mesh):
    """Documented behaviour: a level crossing a hole is an open curve whose ends lie on the
    hole's boundary; the path stays on the mesh and the cones and machines the rest."""
    mesh, c1, c2 = tube_mesh
    ref = _gen(mesh, c1, c2)
    mid = [c for c in ref.curves if 0.4 < c.s < 0.6][0]
    p0 = mid.cc[len(mid.cc) // 3]
    keep = np.linalg.norm(mesh.V[mesh.F].mean(axis=1) - p0, axis=1) > 2.5
    holed = TriMesh.from_arrays(mesh.V, mesh.F[keep])
    assert len(holed.boundary_loops()) == 3  # hub, tip, the hole
    path = _gen(holed, c1, c2)
    pieces = [c for c in path.curves if not c.closed]
    assert pieces, "a level through the hole must come out open"
    bnd = np.unique(holed.edges[holed.edge_faces[:, 1] < 0])
    for c in pieces:
        assert 0.0 < c.s < 1.0
        ends = c.cc[[0, -1]]
        d = np.linalg.norm(holed.V[bnd][None, :, :] - ends[:, None, :], axis=2).min(axis=1)
        ev = holed.V[holed.edges]
        edge_len = np.linalg.norm(ev[:, 0] - ev[:, 1], axis=1).max()
        assert np.all(d <= edge_len)  # the ends are on boundary edges of the hole
    rep = verify_path(holed, path)
    assert rep.cc_on_mesh <= 1e-6 and rep.cc_on_cone <= 1e-3 + 0.02 * E
    assert rep.max_gouge <= E and rep.max_material_left <= H + E


def test_float32_noise_on_the_boundary_loops(tube):
    """Hub/tip loops exactly on cone 1/2 but stored as float32 with 5 µm noise: the first and
    last curves are still the boundary loops (s = 0 and s = 1, one closed curve each)."""
    V, F, c1, c2 = tube
    rng = np.random.default_rng(2)
    Vn = V.astype(np.float32).astype(np.float64) + rng.normal(0.0, 5e-6, V.shape)
    mesh = TriMesh.from_arrays(Vn, F)
    path = _gen(mesh, c1, c2)
    first = [c for c in path.curves if c.s == 0.0]
    last = [c for c in path.curves if c.s == 1.0]
    assert len(first) == 1 and len(last) == 1 and first[0].closed and last[0].closed
