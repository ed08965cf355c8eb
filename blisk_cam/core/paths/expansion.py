"""CC-curve expansion: the next LMC ratio from the cusp height (paper 001 §3.2, Eqs. 11–15),
predicted from the strip width and then corrected by measuring the scallop actually left.

Prediction. Eq. 12–13 give the strip width ``d`` on the surface for a ball of radius ρ, a
cusp height ``h`` and the normal curvature κ of the surface along the side direction
``k = f × n``. Eq. 11 turns the side step ``k d`` into a change of ``s``; on a mesh that is the
surface gradient of the morph field: ``Δs_j = |∇_S s| d_j`` (∇_S s is along ``k``), and Eq. 14
takes the minimum over the CC points (we take a low percentile: one noisy curvature on a
scanned mesh must not halve the step of a whole pass — the measurement below is the guard).

Correction (ARCHITECTURE.md, math notes). The prediction is first order. We measure the
scallop between the two passes — the material left at surface points on intermediate LMCs,
``dist(p, swept centres) − ρ``, with the ridge between the two balls located per column by
linear interpolation of each ball's material-left between neighbouring levels — and correct
``Δs`` (secant on ``H ∝ Δs²`` inside a bracket) so that the maximum is close to ``h`` and
never above it.
"""

from __future__ import annotations

import numpy as np

from ..errors import ToleranceError
from ..geometry.mesh import TriMesh
from ..kernels import knn as compiled_knn
from ..kernels import lift as compiled_lift
from ..kernels import polyline as compiled_polyline
from ..runtime import workers

__all__ = [
    "strip_width",
    "face_gradient_and_curvature",
    "PolylineDistance",
    "measure_cusp",
    "cusp_side_a",
    "cusp_with_b",
]


def strip_width(radius, cusp, kappa):
    """Strip width on the surface between two passes of a ball (paper 001 Eq. 13).

    Derived in the normal section along ``k``: a surface circle of signed curvature κ
    (κ > 0 convex, < 0 concave, radius R = 1/|κ|), ball centres at distance R ± ρ from its
    centre, the cusp at R ± h; the law of cosines gives the half-angle φ/2 between the two
    centres and ``d = R φ``. κ → 0 gives the flat case ``d = 2 sqrt(2ρh − h²)``.
    A concave surface tighter than the ball (R ≤ ρ) cannot be finished by it: width 0.

    Parameters
    ----------
    radius : float, mm (ρ)
    cusp : float, mm (h), 0 < h < ρ
    kappa : (k,) float, 1/mm

    Returns
    -------
    d : (k,) float, mm
    """
    rho, h = float(radius), float(cusp)
    kappa = np.asarray(kappa, dtype=np.float64)
    flat = 2.0 * np.sqrt(max(2.0 * rho * h - h * h, 0.0))
    d = np.full(kappa.shape, flat)
    R = np.where(np.abs(kappa) > 1e-9, 1.0 / np.maximum(np.abs(kappa), 1e-300), np.inf)
    convex = (kappa > 1e-9) & np.isfinite(R)
    if np.any(convex):
        Rc = R[convex]
        a, b = Rc + rho, Rc + h
        cos_half = (a * a + b * b - rho * rho) / (2 * a * b)
        d[convex] = Rc * 2.0 * np.arccos(np.clip(cos_half, -1.0, 1.0))
    concave = (kappa < -1e-9) & np.isfinite(R)
    if np.any(concave):
        Rc = R[concave]
        a, b = Rc - rho, Rc - h
        ok = a > 1e-9
        cos_half = np.where(ok, (a * a + b * b - rho * rho) / (2 * np.where(ok, a, 1) * b), 1.0)
        d[concave] = np.where(ok, Rc * 2.0 * np.arccos(np.clip(cos_half, -1.0, 1.0)), 0.0)
    return d


def face_gradient_and_curvature(mesh: TriMesh, values, faces=None):
    """Per-face surface gradient of a vertex scalar field and the normal curvature along it.

    The gradient of the linear interpolant is ``Σ_i v_i (n × e_i) / (2A)`` with ``e_i`` the
    edge opposite corner ``i``. The curvature along the unit gradient direction ``u`` comes
    from the linearly interpolated vertex normals: ``κ_u = u · (∂n/∂u)`` (> 0 convex for
    outward normals).

    Parameters
    ----------
    mesh : TriMesh
    values : (n,) float — finite at the vertices of the faces of interest
    faces : (q,) int, optional — only these faces (default all)

    Returns
    -------
    grad : (q, 3) float — per-face gradient (1/mm for s)
    kappa : (q,) float, 1/mm — normal curvature along the gradient direction

    Compiled when installed (the same floats, one call); :func:`_face_gradient_and_curvature`
    is the numpy reference.
    """
    got = compiled_lift.face_gradient_curvature(
        mesh.V, mesh.F, mesh.face_normals, mesh.face_areas, mesh.vertex_normals, values,
        np.arange(len(mesh.F)) if faces is None else faces)
    return got if got is not None else _face_gradient_and_curvature(mesh, values, faces)


def _face_gradient_and_curvature(mesh: TriMesh, values, faces=None):
    """The numpy reference of :func:`face_gradient_and_curvature` (same parameters)."""
    sel = slice(None) if faces is None else np.asarray(faces)
    V, F = mesh.V, mesh.F[sel]
    fn = mesh.face_normals[sel]
    area2 = mesh.face_areas[sel] * 2.0
    inv = np.where(area2 > 0, 1.0 / np.where(area2 > 0, area2, 1.0), 0.0)
    vals = np.asarray(values, dtype=np.float64)
    vals = np.where(np.isfinite(vals), vals, 0.0)
    vn = mesh.vertex_normals
    grad = np.zeros((len(F), 3))
    jac = np.zeros((len(F), 3, 3))  # d n_a / d x_b
    for i in range(3):
        e = V[F[:, (i + 2) % 3]] - V[F[:, (i + 1) % 3]]  # edge opposite corner i (ccw)
        g = np.cross(fn, e) * inv[:, None]  # gradient of the hat function of corner i
        grad += vals[F[:, i]][:, None] * g
        jac += vn[F[:, i]][:, :, None] * g[:, None, :]
    gl = np.linalg.norm(grad, axis=1)
    u = grad / np.where(gl > 0, gl, 1.0)[:, None]
    kappa = np.einsum("ia,iab,ib->i", u, jac, u)
    return grad, kappa


class PolylineDistance:
    """Exact distance from points to a set of polylines (ball-centre paths).

    Candidate segments come from a KD-tree over points resampled along the polylines
    (spacing ``resample``); the distance is then exact to the candidates' segments.

    Parameters
    ----------
    polylines : list of ((k, 3) float, closed bool)
    resample : float, mm
    """

    def __init__(self, polylines, resample: float = 0.25, k: int = 6):
        a_list, b_list = [], []
        for pts, closed in polylines:
            pts = np.asarray(pts, dtype=np.float64)
            if len(pts) == 0:
                continue
            q = np.vstack([pts, pts[:1]]) if closed and len(pts) > 2 else pts
            if len(q) == 1:
                q = np.vstack([q, q])
            a_list.append(q[:-1])
            b_list.append(q[1:])
        if not a_list:
            raise ValueError("PolylineDistance needs at least one non-empty polyline")
        self.a = np.vstack(a_list)
        self.b = np.vstack(b_list)
        # per segment once, not per candidate (the same products, so the same distances)
        self.ab = self.b - self.a
        L2 = np.einsum("sj,sj->s", self.ab, self.ab)
        self.L2 = np.where(L2 > 0, L2, 1.0)
        L = np.linalg.norm(self.b - self.a, axis=1)
        n = np.maximum(1, np.ceil(L / resample).astype(np.int64))
        seg = np.repeat(np.arange(len(L)), n)
        start = np.repeat(np.cumsum(n) - n, n)
        u = (np.arange(len(seg)) - start + 0.5) / n[seg]
        samples = self.a[seg] + u[:, None] * (self.b[seg] - self.a[seg])
        self.seg_of_sample = seg
        self.samples = samples
        self._tree = None  # scipy's, made on first use
        self._ctree = None  # the compiled one, made on first use when installed
        self._memo: dict[int, tuple] = {}
        self.k = min(k, len(samples))

    @property
    def tree(self):
        """scipy's k-d tree of the samples (made on first use: the compiled kernels need it
        only for the rows they leave to it)."""
        if self._tree is None:
            from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

            self._tree = cKDTree(self.samples)
        return self._tree

    def __call__(self, points, near=None):
        """(q,) distances (mm) from (q, 3) points to the nearest polyline segment.

        near : (q, 3) float, optional — where to look for the candidate segments (default the
            points themselves). A surface point queried against ball-centre paths ρ away
            costs the KD-tree a search of radius ρ; its own would-be centre ``p + ρ n`` lies
            next to the nearest centres and is found at once. The distance is still exact to
            the candidates, so a poor hint can only overestimate it.
        """
        return self.many([points], [near])[0]

    def many(self, points_list, near_list=None):
        """The distances of several arrays of points (the levels of a trial), each as
        ``self(p, near=h)`` gives it (rows are measured independently: the same floats),
        with the arrays not memoised measured in one call (a trial measures five levels
        against a pass: one kernel call and one pass over the glue, not five).

        points_list : list of (k_i, 3) float; near_list : list of (k_i, 3) float or None
            (per level: its hint, see :meth:`__call__`), or None (no hints)
        Returns list of (k_i,) float, mm."""
        if near_list is None:
            near_list = [None] * len(points_list)
        out = [None] * len(points_list)
        todo = []  # (index, key array, points, hint)
        for i, (points, near) in enumerate(zip(points_list, near_list, strict=True)):
            p = np.asarray(points, dtype=np.float64)
            hint = p if near is None else np.asarray(near, dtype=np.float64)
            # the generator measures the same level against the same pass again (pass A's
            # own level in each trial of a step, and as pass B's last level of one step and
            # pass A's first of the next): the last few answers are kept, keyed by the same
            # point array, checked by value (an array changed in place is measured anew),
            # the least recently used dropped first (a step's trials keep A's level)
            memo = self._memo.pop(id(points), None)
            if memo is not None and np.array_equal(memo[0], p) and np.array_equal(memo[1], hint):
                self._memo[id(points)] = memo
                out[i] = memo[2].copy()
            else:
                todo.append((i, points, p, hint))
        if not todo:
            return out
        if len(todo) == 1:
            d_all = self._distance(todo[0][2], todo[0][3])
        else:
            d_all = self._distance(np.concatenate([t[2] for t in todo]),
                                   np.concatenate([t[3] for t in todo]))
        at = 0
        for i, points, p, hint in todo:
            d = d_all[at:at + len(p)].copy()
            at += len(p)
            if len(self._memo) >= 8:
                self._memo.pop(next(iter(self._memo)))
            self._memo[id(points)] = (p.copy(), hint.copy(), d.copy())
            out[i] = d
        return out

    def _distance(self, p, hint):
        """The compiled kernel's answer where it is installed (the rows it leaves, a tie at
        the k-th nearest sample, measured by :meth:`_distance_numpy`), else the numpy one:
        the same floats."""
        if len(p) == 0 or not compiled_polyline.available():
            return self._distance_numpy(p, hint)
        if self._ctree is None:
            self._ctree = compiled_knn.point_tree(self.samples, workers())
        d, rest = compiled_polyline.polyline_distance(
            self._ctree, p, hint, self.k, self.seg_of_sample, self.a, self.ab, self.L2,
            workers())
        if rest.any():
            d[rest] = self._distance_numpy(p[rest], hint[rest])
        return d

    def _distance_numpy(self, p, hint):
        """The reference: scipy's k nearest samples of each hint, their segments once
        each, the least exact distance."""
        _, idx = self.tree.query(hint, k=self.k)
        # the k nearest samples lie on a few segments (several samples each): each segment
        # once per point, the minimum over the rest would repeat its distance
        seg = np.sort(self.seg_of_sample[np.asarray(idx).reshape(len(p), -1)], axis=1)
        first = np.ones(seg.shape, dtype=bool)
        first[:, 1:] = seg[:, 1:] != seg[:, :-1]
        row, col = np.nonzero(first)
        seg = seg[row, col]
        ab = self.ab[seg]
        ap = p[row] - self.a[seg]
        t = np.clip(np.einsum("ij,ij->i", ap, ab) / self.L2[seg], 0.0, 1.0)
        d = ap - t[:, None] * ab
        d2 = np.einsum("ij,ij->i", d, d)
        return np.sqrt(np.minimum.reduceat(d2, np.flatnonzero(col == 0)))


def measure_cusp(level_points, dist_a, dist_b, radius: float, level_normals=None):
    """Largest scallop between two passes, from surface points on levels between them.

    Parameters
    ----------
    level_points : list of (k_i, 3) float — surface points on successive levels from pass A
        to pass B (first = pass A's own level, last = pass B's), each an exact mesh ∩ LMC
    dist_a, dist_b : callables, (q, 3) → (q,) distance to A's / B's ball-centre path (with
        an optional ``near=`` hint, see :class:`PolylineDistance`)
    radius : float, mm
    level_normals : list of (k_i, 3) float, optional — unit surface normals at the points;
        the candidate search then starts at ``p + ρ n`` (faster, same result)

    Returns
    -------
    cusp : float, mm — the maximum over the strip of ``min(d_A, d_B) − ρ``, the ridge being
        located per column (nearest point on the next level) where the two balls' material
        left, each interpolated linearly, are equal.
    """
    side_a = cusp_side_a(level_points, dist_a, radius, level_normals)
    return cusp_with_b(side_a, dist_b, radius)


def cusp_side_a(level_points, dist_a, radius: float, level_normals=None):
    """The part of :func:`measure_cusp` that pass B does not enter (the generator runs it
    beside the making of pass B): per level with points, (points (k, 3), search hint
    (k, 3) or None, material left by A ``d_A − ρ`` (k,) mm, and the column index (k,) int
    of the nearest of these points to each point of the previous level with points, or
    None for the first). Parameters as :func:`measure_cusp`'s."""
    full = [i for i, pts in enumerate(level_points) if len(pts)]
    nears = [None if level_normals is None else level_points[i] + radius * level_normals[i]
             for i in full]
    d = _distances(dist_a, [level_points[i] for i in full], nears)
    out = [None] * len(level_points)  # None breaks the columns, as an empty level does
    prev = None
    for i, near, di in zip(full, nears, d, strict=True):
        pts = level_points[i]
        if i == 0 or len(level_points[i - 1]) == 0:
            prev = None
        j = None if prev is None else _nearest_index(pts, prev)
        out[i] = (pts, near, di - radius, j)
        prev = pts
    return out


def cusp_with_b(side_a, dist_b, radius: float):
    """:func:`measure_cusp` from :func:`cusp_side_a`'s levels and B's distance."""
    full = [x for x in side_a if x is not None]
    d = iter(_distances(dist_b, [x[0] for x in full], [x[1] for x in full]))
    best = -np.inf
    prev = None
    for level in side_a:
        if level is None:
            prev = None
            continue
        pts, near, ma, j = level
        mb = next(d) - radius
        best = max(best, float(np.minimum(ma, mb).max()))
        if prev is not None:
            pma, pmb = prev
            # along the column ppts → pts[j]: (pma, pmb) → (ma[j], mb[j]), linear in λ
            ga = pma - pmb
            gb = ma[j] - mb[j]
            cross = (ga <= 0) & (gb >= 0) | (ga >= 0) & (gb <= 0)
            if cross.any():
                den = ga[cross] - gb[cross]
                lam = np.where(np.abs(den) > 0, ga[cross] / np.where(den != 0, den, 1.0), 0.5)
                lam = np.clip(lam, 0.0, 1.0)
                ridge = (1 - lam) * pma[cross] + lam * ma[j][cross]
                best = max(best, float(ridge.max()))
        prev = (ma, mb)
    return best


def _distances(dist, points_list, near_list):
    """``[dist(p) or dist(p, near=h)]`` per level (a hint None: none), in one call of
    :meth:`PolylineDistance.many` when ``dist`` is one (any other callable: level by level)."""
    many = getattr(dist, "many", None)
    if many is not None:
        return many(points_list, near_list)
    return [dist(p) if h is None else dist(p, near=h)
            for p, h in zip(points_list, near_list, strict=True)]


def _nearest_index(points, queries):
    """(q,) int: the nearest of ``points`` (n, 3) to each query (q, 3) — scipy's
    ``cKDTree(points).query(queries)[1]``; the compiled k-d tree's where it is installed
    (rows whose nearest two are at the same distance asked of scipy: its choice)."""
    if compiled_knn.available() and len(queries):
        tree = compiled_knn.point_tree(points, workers())
        return compiled_knn.nearest_k(tree, queries, 1, np.inf, workers(),
                                      ties=lambda Q: _scipy_nearest(points, Q)[:, None],
                                      in_order=True)[:, 0]
    return _scipy_nearest(points, queries)


def _scipy_nearest(points, queries):
    """(q,) int: the nearest of ``points`` (n, 3) to each query (q, 3) by scipy's k-d tree."""
    from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

    return cKDTree(points).query(queries)[1]


def check_tolerances(radius: float, cusp: float, chord: float):
    """Reject non-positive or absurd tool radius, cusp height and chord tolerance."""
    for name, v in (("tool radius", radius), ("cusp height", cusp), ("chord tolerance", chord)):
        if not (np.isfinite(v) and v > 0):
            raise ToleranceError(f"{name} must be a positive number of mm, got {v}")
    if cusp >= radius:
        raise ToleranceError(
            f"cusp height {cusp} mm is not smaller than the ball radius {radius} mm: a scallop "
            "that high is not a finishing tolerance; use a cusp height well below the radius"
        )
    if chord >= radius:
        raise ToleranceError(
            f"chord tolerance {chord} mm is not smaller than the ball radius {radius} mm; "
            "use a chord tolerance well below the radius"
        )
    if cusp < 1e-4 or chord < 1e-4:
        raise ToleranceError(
            f"cusp {cusp} mm / chord {chord} mm below 0.1 µm is beyond what a mesh or a machine "
            "can hold; use at least 0.0001 mm"
        )
