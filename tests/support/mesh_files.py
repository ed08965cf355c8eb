"""Mesh files written from arrays for the tests and benchmarks (binary/ASCII STL, OBJ,
ASCII/binary PLY), a reader of binary STL used only as a test oracle, an order-independent
comparison of triangle soups, small surfaces to write or search (a piece of a cone, an
icosphere, a piece of a cylinder), and the sample points of the passes' sample tree."""

from __future__ import annotations

from pathlib import Path

import numpy as np

_STL_RECORD = np.dtype(
    [("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")]
)


def sample_surface(nu=5, nv=4):
    """A small curved open surface in mm (a piece of a cone at r ≈ 180–250 mm, like a blade
    region), float32-exact coordinates. Returns V (n, 3) float64, F (m, 3) int64."""
    u = np.linspace(-0.1, 0.12, nu)
    v = np.linspace(0.0, 1.0, nv)
    uu, vv = np.meshgrid(u, v)
    r = 180.25 + 70.125 * vv + 0.5 * np.sin(7.0 * uu)
    z = 0.375 + 42.5 * vv + 3.0 * uu
    V = np.stack([r * np.cos(uu), r * np.sin(uu), z], axis=-1).reshape(-1, 3)
    V = V.astype(np.float32).astype(np.float64)
    idx = np.arange(nu * nv).reshape(nv, nu)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)
    return V, F


def cylinder_sheet(radius, turn, n_turn, half_height, n_height):
    """An open piece of the cylinder of ``radius`` mm about the z axis: ``n_turn`` vertex
    columns over the angles 0 … ``turn`` radians, ``n_height`` rows over z = ±``half_height``
    mm, two triangles a cell. Returns V (n_turn · n_height, 3) float64, F (m, 3) int64."""
    th, z = np.meshgrid(np.linspace(0.0, turn, n_turn),
                        np.linspace(-half_height, half_height, n_height), indexing="ij")
    V = np.column_stack([radius * np.cos(th.ravel()), radius * np.sin(th.ravel()), z.ravel()])
    i, j = np.meshgrid(np.arange(n_turn - 1), np.arange(n_height - 1), indexing="ij")
    a = (i * n_height + j).ravel()
    F = np.vstack([np.column_stack([a, a + n_height, a + n_height + 1]),
                   np.column_stack([a, a + n_height + 1, a + 1])])
    return V, F


def flat_grid(half, step=0.5):
    """A flat square grid in the plane z = 0 over x, y = −``half`` … ``half`` mm at ``step`` mm,
    two triangles a cell. Returns V (n², 3) float64, F (2 (n − 1)², 3) int64."""
    x, y = np.meshgrid(np.arange(-half, half + step, step), np.arange(-half, half + step, step))
    n = x.shape[0]
    V = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1))
    a = (i * n + j).ravel()
    F = np.vstack([np.column_stack([a, a + 1, a + n + 1]), np.column_stack([a, a + n + 1, a + n])])
    return V, F


def sample_points(mesh):
    """The points of the passes' sample tree in its id order (``paths.probe_samples``): the
    vertices, the edge midpoints and the face centroids of ``mesh`` (a ``TriMesh``), (n, 3)
    mm, computed here independently of it."""
    e, T = mesh.edges, mesh.V[mesh.F]
    return np.vstack([mesh.V, 0.5 * (mesh.V[e[:, 0]] + mesh.V[e[:, 1]]),
                      ((T[:, 0] + T[:, 1]) + T[:, 2]) / 3.0])


def icosphere(subdiv):
    """A unit icosphere by repeated midpoint subdivision of the icosahedron: closed, wound
    outward. Returns V (n, 3) float64 on the unit sphere, F (m, 3) int64, m = 20·4^subdiv."""
    g = (1 + 5**0.5) / 2
    V = np.array([[-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0], [0, -1, g], [0, 1, g],
                  [0, -1, -g], [0, 1, -g], [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1]], float)
    F = np.array([[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9],
                  [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2],
                  [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10],
                  [8, 6, 7], [9, 8, 1]], dtype=np.int64)
    for _ in range(subdiv):
        e = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(e, axis=0, return_inverse=True)
        # (numpy 2.0–2.1 give return_inverse the input's shape: ravel first)
        mid = len(V) + inv.ravel().reshape(3, -1).T  # midpoints of (01, 12, 20)
        V = np.vstack([V, V[uniq].mean(1)])
        a, b, c = F.T
        m01, m12, m20 = mid.T
        F = np.vstack([np.stack(x, 1) for x in ((a, m01, m20), (b, m12, m01), (c, m20, m12),
                                                 (m01, m12, m20))])
    return V / np.linalg.norm(V, axis=1, keepdims=True), F


def _normals(V, F):
    """Unit normals of the triangles (NaN for a degenerate or non-finite one)."""
    V, F = np.asarray(V), np.asarray(F)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    with np.errstate(invalid="ignore", divide="ignore"):
        return n / np.linalg.norm(n, axis=1, keepdims=True)


def write_binary_stl(path, V, F, header=b"binary STL written by the Blisk CAM tests") -> Path:
    """Write (V (n, 3) mm, F (m, 3)) as a binary STL (float32, unit facet normals); returns
    the path."""
    V, F = np.asarray(V), np.asarray(F)
    rec = np.zeros(len(F), dtype=_STL_RECORD)
    rec["normal"] = _normals(V, F)
    rec["v"] = V[F]
    with open(path, "wb") as fh:
        fh.write(header.ljust(80, b" ")[:80])
        fh.write(np.uint32(len(F)).tobytes())
        fh.write(rec.tobytes())
    return Path(path)


def _f32(x):
    """repr of a float32 value: parses back to exactly the same float32."""
    return repr(float(np.float32(x)))


def write_ascii_stl(path, V, F, bad=None) -> Path:
    """ASCII STL; ``bad`` replaces the text of the second coordinate of the first vertex."""
    lines = ["solid test"]
    for k, (tri, n) in enumerate(zip(V[F], _normals(V, F), strict=True)):
        lines.append(f"  facet normal {n[0]:e} {n[1]:e} {n[2]:e}")
        lines.append("    outer loop")
        for j, p in enumerate(tri):
            y = bad if (bad is not None and k == 0 and j == 0) else _f32(p[1])
            lines.append(f"      vertex {_f32(p[0])} {y} {_f32(p[2])}")
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append("endsolid test")
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


def write_obj(path, V, F, bad=None) -> Path:
    """OBJ; ``bad`` replaces the text of the second coordinate of the second vertex."""
    lines = ["# OBJ written by the Blisk CAM tests", "o sample"]
    for i, p in enumerate(V):
        y = bad if (bad is not None and i == 1) else _f32(p[1])
        lines.append(f"v {_f32(p[0])} {y} {_f32(p[2])}")
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


def write_ply(path, V, F, binary=False) -> Path:
    """ASCII or binary little-endian PLY (float32 vertices, int32 triangle lists)."""
    header = [
        "ply",
        "format binary_little_endian 1.0" if binary else "format ascii 1.0",
        f"element vertex {len(V)}",
        "property float x",
        "property float y",
        "property float z",
        f"element face {len(F)}",
        "property list uchar int vertex_indices",
        "end_header",
    ]
    with open(path, "wb") as fh:
        fh.write(("\n".join(header) + "\n").encode())
        if binary:
            fh.write(np.ascontiguousarray(V, dtype="<f4").tobytes())
            faces = np.zeros(len(F), dtype=[("n", "u1"), ("i", "<i4", (3,))])
            faces["n"] = 3
            faces["i"] = F
            fh.write(faces.tobytes())
        else:
            body = [f"{_f32(x)} {_f32(y)} {_f32(z)}" for x, y, z in V]
            body += [f"3 {a} {b} {c}" for a, b, c in F]
            fh.write(("\n".join(body) + "\n").encode())
    return Path(path)


def stl_triangles(path):
    """Triangles (m, 3, 3) float64 of a binary STL (a test oracle, independent of the
    readers under test)."""
    data = Path(path).read_bytes()
    n = int.from_bytes(data[80:84], "little")
    rec = np.frombuffer(data, dtype=_STL_RECORD, count=n, offset=84)
    return rec["v"].astype(np.float64)


def canonical_triangles(T):
    """Triangles (m, 3, 3) in a canonical order: each one cyclically rotated to start at its
    lexicographically smallest corner (orientation kept), then the list sorted."""
    T = np.asarray(T, dtype=np.float64)
    out = []
    for tri in T:
        corners = [tuple(p) for p in tri]
        k = min(range(3), key=lambda i: corners[i])
        out.append(tuple(corners[k:] + corners[:k]))
    out.sort()
    return np.array(out, dtype=np.float64).reshape(-1, 3, 3)


def assert_same_triangles(V, F, T_expected, atol=1e-4):
    """The triangles of (V, F) equal ``T_expected`` (m, 3, 3) as oriented sets."""
    got = canonical_triangles(np.asarray(V)[np.asarray(F)])
    want = canonical_triangles(T_expected)
    assert got.shape == want.shape, f"{got.shape[0]} triangles, expected {want.shape[0]}"
    np.testing.assert_allclose(got, want, rtol=0, atol=atol)
