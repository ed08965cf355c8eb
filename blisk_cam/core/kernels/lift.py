"""The lifts of :mod:`blisk_cam.core.paths.passes`, compiled: the fixed-point lift of
:func:`~blisk_cam.core.paths.passes._fixed_point_lift` (the same point–triangle distances
operation for operation, the same steps: λ is the numpy reference's to the last bit), the
facet lift with its candidate faces, the probe samples' candidate faces and the shortfall on
them, and the per-face gradient and curvature of the side-step prediction — each the numpy
reference's floats bit for bit, the GIL released."""

from __future__ import annotations

import numpy as np

from .backend import extension, kernel

__all__ = ["candidate_shortfall", "face_gradient_curvature", "facet_lift", "fixed_point_lift",
           "intrusion_probes", "probe_candidates"]


def fixed_point_lift(V, F, cand, p, n, lam, consts, steps: int, threads: int):
    """(q,) λ (mm) after up to ``steps`` fixed-point steps for points ``p`` and unit normals
    ``n`` (q, 3) from ``lam`` (q,), on the candidate faces ``cand`` (q, c) of the mesh V, F
    (−1 padding); ``consts`` = (ρ, tolerance, gain, plane slack) mm. None when the numpy
    kernels run."""
    ext = extension()
    if ext is None:
        return None
    c = np.ascontiguousarray
    return ext.fixed_point_lift(
        c(V, dtype=np.float64), c(F, dtype=np.int64), c(cand, dtype=np.int64),
        c(p, dtype=np.float64), c(n, dtype=np.float64), c(lam, dtype=np.float64),
        tuple(float(x) for x in consts), int(steps), max(1, int(threads)))


def facet_lift(mesh_arrays, table, D, DN, edge, seg, closed: bool, consts, steps: int,
               threads: int):
    """(q,) λ (mm) of :meth:`blisk_cam.core.paths.passes._Generator.facet_lift` for the
    points ``D`` with unit normals ``DN`` (q, 3) on the segments ``seg`` (q,) of a level whose
    points lie on the mesh edges ``edge`` (k,) — the facet planes of the segment's two edges,
    then the fixed-point lift on the faces around their corners where a plane is penetrated.
    ``mesh_arrays`` = (V (n, 3), F (m, 3), edges (e, 2), edge_faces (e, 2), face_normals
    (m, 3)); ``table`` = the vertex–face table's (ptr, face); ``consts`` = (ρ, facet
    tolerance, lift tolerance, gain, plane slack) mm. None when the numpy kernels run."""
    fn = kernel("facet_lift")
    if fn is None:
        return None
    c = np.ascontiguousarray
    V, F, E, EF, FN = mesh_arrays
    ptr, face = table[:2]
    if face.dtype not in (np.int32, np.int64):
        face = face.astype(np.int64)
    return fn(
        c(V, dtype=np.float64), c(F, dtype=np.int64), c(E, dtype=np.int64),
        c(EF, dtype=np.int64), c(FN, dtype=np.float64), c(ptr, dtype=np.int64), c(face),
        c(D, dtype=np.float64), c(DN, dtype=np.float64), c(edge, dtype=np.int64),
        c(seg, dtype=np.int64), bool(closed), tuple(float(x) for x in consts), int(steps),
        max(1, int(threads)))


def probe_candidates(ids, n_vertices: int, n_faces: int, edge_faces, table, threads: int):
    """(q, c) int64 ``_unique_per_row(_probe_faces(ids))`` of
    :class:`blisk_cam.core.paths.passes._Generator`: the faces holding the probe samples
    ``ids`` (q, k) (vertices, edge midpoints, face centroids; −1 none), each row descending
    without repeats, −1 padded; None when the numpy kernels run."""
    fn = kernel("probe_candidates")
    if fn is None:
        return None
    ptr, face = table[:2]
    if face.dtype not in (np.int32, np.int64):
        face = face.astype(np.int64)
    c = np.ascontiguousarray
    return fn(c(ids, dtype=np.int64), int(n_vertices), int(n_faces),
              c(edge_faces, dtype=np.int64), c(ptr, dtype=np.int64), c(face),
              max(1, int(threads)))


def candidate_shortfall(V, F, cand, centres, rho: float, threads: int):
    """(q,) ρ − the least exact distance (mm) from the ball centres (q, 3) to their candidate
    faces ``cand`` (q, w) of V, F (−1 padding), as ``passes._pose_shortfall`` computes it;
    None when the numpy kernels run."""
    fn = kernel("candidate_shortfall")
    if fn is None:
        return None
    c = np.ascontiguousarray
    return fn(c(V, dtype=np.float64), c(F, dtype=np.int64),
              c(cand, dtype=np.int64), c(centres, dtype=np.float64),
              float(rho), max(1, int(threads)))


def face_gradient_curvature(V, F, face_normals, face_areas, vertex_normals, values, faces):
    """(grad (q, 3), κ (q,)) of :func:`blisk_cam.core.paths.expansion.face_gradient_and_curvature`
    for the faces ``faces`` (q,) of V, F with its unit face normals, areas (mm²) and unit
    vertex normals, the vertex field ``values`` (n,); None when the numpy kernels run."""
    fn = kernel("face_gradient_curvature")
    if fn is None:
        return None
    c = np.ascontiguousarray
    return fn(
        c(V, dtype=np.float64), c(F, dtype=np.int64), c(face_normals, dtype=np.float64),
        c(face_areas, dtype=np.float64), c(vertex_normals, dtype=np.float64),
        c(values, dtype=np.float64), c(faces, dtype=np.int64))


def intrusion_probes(D, DN, lam, rho: float, spacing: float):
    """(probe (p,) int64 ascending, their ball centres (p, 3) mm) of
    :meth:`blisk_cam.core.paths.passes._Generator.intrusion_lift`: the points where the arc
    length of the centres ``D + (ρ + λ) DN`` (q, 3) crosses every ``spacing`` mm, and the last
    point. None when the numpy kernels run, q = 0 or the arc length is not finite."""
    fn = kernel("intrusion_probes")
    if fn is None:
        return None
    c = np.ascontiguousarray
    return fn(c(D, dtype=np.float64), c(DN, dtype=np.float64),
              c(lam, dtype=np.float64), float(rho), float(spacing))
