"""Profile generatrices and the linear morphing revolution surfaces (LMRS) between two of them.

Paper 001 §4.2 (Fig. 12): when the hub (or the tip) is not a cone but a general surface of
revolution SR-1 (SR-2), the morphing cones become *linear morphing revolution surfaces*:
"the entire mathematics is the same except that both l_1 and l_2 are now curves instead of
lines". We take the generatrices as polylines in the meridional half-plane (a
:class:`Profile`; a :class:`.cones.Cone` is the two-point case) and derive:

* **Common parameter.** Eqs. 1–3 interpolate points of l_1 and l_2 at the same parameter t.
  For polylines P (hub) and Q (tip) we use the normalised arc length u ∈ [0, 1] of each and
  resample both at the union of their vertex parameters u_0 < … < u_m (inserting collinear
  vertices does not change either curve). The generatrix at ratio ``s`` is then the polyline

      G_s = {(1 − s) P_j + s Q_j},  j = 0 … m,

  revolved about the axis, extended linearly beyond its first and last vertex (as a cone is
  the whole line through P1, P2). For m = 1 this is exactly the LMC of Eq. 3.

* **Strips.** The *morph rays* R_j = {P_j + s (Q_j − P_j)} do not depend on s, so the plane is
  cut into strips, and on strip j (between R_j and R_j+1) the family is the bilinear patch

      X(s, λ) = (1 − s)((1 − λ) P_j + λ P_j+1) + s((1 − λ) Q_j + λ Q_j+1):

  on it G_s is the single segment A_j(s) → A_j+1(s), A_j(s) = (1 − s) P_j + s Q_j.

* **Morph field** (the ratio of the LMRS through a point X): find the strip by a vectorised
  binary search over the rays (which side of R_j the point lies on), then solve
  D_j(s) × (X − A_j(s)) = 0, D_j = A_j+1 − A_j — quadratic in s exactly as for two cones
  (:meth:`.cones.MorphingCones.ratio`) — and keep the root whose segment parameter λ lies on
  the segment. O(n log m), no Python loop over points.

* **Signed distance** f_s(X): the distance from X to the extended polyline G_s, positive
  toward generatrix 2 (on a segment's interior the line distance D̂ × (X − A), at a vertex the
  distance to the vertex signed by the angle-bisecting pseudo-normal).

* **Monotone sweep.** The map (s, λ) ↦ X must be one-to-one on the region, see
  :func:`.cones.check_monotone_sweep` (Jacobian sign at the patch corners), plus the two
  generatrices must not cross and the first and last rays must not cross anything.

Units: mm; meridional coordinates ``r`` ≥ 0 from the axis, ``z`` along it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConeError
from ..geometry.axis import Axis, meridional
from ..geometry.vectors import cross2
from .cones import Cone, MorphingCones, check_monotone_sweep

__all__ = [
    "MorphingProfiles",
    "Profile",
    "as_profile",
    "morph_between",
    "generatrix_rows",
]

#: points × segments handled per vectorised block (bounds the temporary arrays' size)
_BLOCK = 1 << 20
#: slack on the segment parameter λ when deciding which strip a point belongs to
_LAM_EPS = 1e-9


# --------------------------------------------------------------------------- polylines
def _segments_intersect(a0, a1, b0, b1):
    """Whether segments a0→a1 and b0→b1 (broadcastable (..., 2) arrays) intersect or touch."""
    da = a1 - a0
    db = b1 - b0
    o1 = cross2(da, b0 - a0)
    o2 = cross2(da, b1 - a0)
    o3 = cross2(db, a0 - b0)
    o4 = cross2(db, a1 - b0)
    hit = (o1 * o2 <= 0) & (o3 * o4 <= 0)
    # all four zero: collinear; then they meet only if their projections overlap
    col = (o1 == 0) & (o2 == 0) & (o3 == 0) & (o4 == 0)
    if np.any(col):
        L2 = np.maximum(np.einsum("...j,...j->...", da, da), 1e-300)
        t0 = np.einsum("...j,...j->...", b0 - a0, da) / L2
        t1 = np.einsum("...j,...j->...", b1 - a0, da) / L2
        overlap = (np.maximum(t0, t1) >= 0) & (np.minimum(t0, t1) <= 1)
        hit = np.where(col, overlap, hit)
    return hit


def _self_crossing(V):
    """First pair (i, j) of non-adjacent segments of the polyline V (k, 2) that meet, or None."""
    k = len(V) - 1
    if k < 3:
        return None
    i, j = np.triu_indices(k, 2)
    hit = _segments_intersect(V[i], V[i + 1], V[j], V[j + 1])
    if np.any(hit):
        n = int(np.argmax(hit))
        return int(i[n]), int(j[n])
    return None


def _validated_vertices(points) -> np.ndarray:
    """(k, 2) float64 vertices of a profile, or ConeError naming what is wrong."""
    try:
        V = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise ConeError(
            f"a profile is a list of (r, z) points in mm; could not read it: {err}"
        ) from err
    if V.size == 0:
        raise ConeError("a profile needs at least two (r, z) points, got none")
    if V.ndim != 2 or V.shape[1] != 2:
        raise ConeError(
            f"a profile is a list of (r, z) points in mm, got an array of shape {V.shape}"
        )
    if len(V) < 2:
        raise ConeError(f"a profile needs at least two (r, z) points, got {len(V)}")
    if not np.all(np.isfinite(V)):
        bad = int(np.nonzero(~np.all(np.isfinite(V), axis=1))[0][0])
        raise ConeError(
            f"profile point {bad} is {V[bad].tolist()}: all coordinates must be finite numbers"
        )
    if np.any(V[:, 0] < 0):
        bad = int(np.nonzero(V[:, 0] < 0)[0][0])
        raise ConeError(
            f"profile point {bad} has r = {V[bad, 0]} < 0: r is the distance from the axis and "
            "must be ≥ 0"
        )
    seg = np.linalg.norm(np.diff(V, axis=0), axis=1)
    scale = max(float(np.abs(V).max()), 1.0)
    if np.any(seg <= 1e-12 * scale):
        bad = int(np.nonzero(seg <= 1e-12 * scale)[0][0])
        raise ConeError(
            f"profile points {bad} and {bad + 1} coincide ({V[bad].tolist()}); remove the "
            "repeated point"
        )
    chord = V[-1] - V[0]
    clen = float(np.linalg.norm(chord))
    if clen <= 1e-9 * scale:
        raise ConeError(
            "the profile's first and last points coincide (a closed curve); a generatrix is an "
            "open curve from one end of the region to the other"
        )
    # a surface of revolution that the blade crosses once: the polyline advances along its
    # chord (this makes it, and its linear extensions, a graph over the chord: no self-crossing)
    adv = np.diff(V, axis=0) @ (chord / clen)
    if np.any(adv <= 0):
        pair = _self_crossing(V) if len(V) <= 2000 else None
        if pair is not None:
            raise ConeError(
                f"the profile crosses itself (segments {pair[0]} and {pair[1]}); give the points "
                "in order along the generatrix, without loops"
            )
        bad = int(np.nonzero(adv <= 0)[0][0])
        raise ConeError(
            f"the profile turns back at point {bad + 1} ({V[bad + 1].tolist()}): a generatrix must "
            "advance from its first toward its last point (each segment with a positive component "
            "along the chord first → last), so that the blade crosses the surface once"
        )
    return V


def _polyline_signed_distance(V, x):
    """Signed distance (mm) from points to the polyline V extended linearly at both ends.

    Positive on the left of the direction of travel V_0 → V_last (like
    :meth:`.cones.Cone.signed_distance`). On the interior of a segment (or of an end extension)
    the value is the line distance D̂ × (X − V_j); where the nearest point is a vertex, it is
    the distance to that vertex signed by the bisecting pseudo-normal of the two segments.

    Parameters
    ----------
    V : (m, 2) float, mm, m ≥ 2
    x : (n, 2) float, mm

    Returns
    -------
    d : (n,) float, mm
    """
    V = np.asarray(V, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64).reshape(-1, 2)
    a = V[:-1]
    d = np.diff(V, axis=0)
    L2 = np.einsum("ij,ij->i", d, d)
    u = d / np.sqrt(L2)[:, None]
    nrm = np.stack([-u[:, 1], u[:, 0]], axis=1)  # left unit normals
    k = len(d)
    lo = np.zeros(k)
    hi = np.ones(k)
    lo[0], hi[-1] = -np.inf, np.inf
    out = np.empty(len(x))
    step = max(1, _BLOCK // k)
    for i0 in range(0, len(x), step):
        xx = x[i0:i0 + step]
        w = xx[:, None, :] - a[None]  # (b, k, 2)
        lam = np.clip((w[..., 0] * d[:, 0] + w[..., 1] * d[:, 1]) / L2, lo, hi)
        dr = w[..., 0] - lam * d[:, 0]
        dz = w[..., 1] - lam * d[:, 1]
        dist2 = dr * dr + dz * dz
        j = np.argmin(dist2, axis=1)
        rows = np.arange(len(xx))
        lj = lam[rows, j]
        line = cross2(u[j], xx - a[j])
        at_start = (lj <= 0.0) & (j > 0)
        at_end = (lj >= 1.0) & (j < k - 1)
        pn = nrm[j].copy()
        pn[at_start] += nrm[j[at_start] - 1]
        pn[at_end] += nrm[j[at_end] + 1]
        sgn = np.sign(dr[rows, j] * pn[:, 0] + dz[rows, j] * pn[:, 1])
        vtx = np.sqrt(dist2[rows, j]) * sgn
        out[i0:i0 + step] = np.where(at_start | at_end, vtx, line)
    return out


def _arc_parameter(V):
    """(m,) normalised arc length of the vertices of a polyline, 0 … 1."""
    c = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(V, axis=0), axis=1))])
    return c / c[-1]


def _resample(V, u_new, snap: float = 0.0):
    """The polyline V (m, 2) evaluated at normalised arc-length parameters u_new (q,).
    A parameter within ``snap`` of one of V's own vertex parameters gives that vertex exactly
    (so merging nearly equal parameters of two curves never moves a curve's corner)."""
    u = _arc_parameter(V)
    if snap > 0:
        k = np.clip(np.searchsorted(u, u_new), 1, len(u) - 1)
        near = np.where(np.abs(u[k - 1] - u_new) <= np.abs(u[k] - u_new), k - 1, k)
        u_new = np.where(np.abs(u[near] - u_new) <= snap, u[near], u_new)
    return np.stack([np.interp(u_new, u, V[:, 0]), np.interp(u_new, u, V[:, 1])], axis=1)


def _rz_arrays(r, z):
    r = np.asarray(r, dtype=np.float64)
    z = np.asarray(z, dtype=np.float64)
    r, z = np.broadcast_arrays(r, z)
    return r.shape, np.stack([r.ravel(), z.ravel()], axis=1)


# --------------------------------------------------------------------------- Profile
@dataclass(frozen=True)
class Profile:
    """A generatrix polyline in the meridional half-plane: the surface of revolution (hub or
    tip) it sweeps about the axis. The first and last segments extend linearly beyond the end
    points (as a cone is the whole line through P1, P2); the points mark the region of interest.

    Attributes
    ----------
    points : tuple of (r, z) float pairs, mm, at least two, r ≥ 0. The polyline must advance
        along its chord (first → last point) — then it cannot cross itself and the blade
        crosses the surface once. A :class:`.cones.Cone` is the two-point case
        (:meth:`from_cone`).
    """

    points: tuple

    def __post_init__(self):
        V = _validated_vertices(self.points)
        object.__setattr__(self, "points", tuple((float(r), float(z)) for r, z in V))

    # --- construction and conversion ---------------------------------------------------
    @classmethod
    def from_list(cls, values) -> Profile:
        """From ``[[r, z], ...]`` (mm), as in the paths JSON."""
        return cls(values)

    def as_list(self) -> list[list[float]]:
        """``[[r, z], ...]`` (mm)."""
        return [[r, z] for r, z in self.points]

    @classmethod
    def from_cone(cls, cone: Cone) -> Profile:
        """The two-point profile P1 → P2 of a cone."""
        return cls(((cone.r1, cone.z1), (cone.r2, cone.z2)))

    def to_cone(self) -> Cone:
        """The least-squares straight cone of this profile: the total-least-squares line of
        the polyline sampled uniformly along its arc length (so dense vertex clusters do not
        dominate), as the segment spanning the projections of the first and last points."""
        V = self.vertices
        if len(V) == 2:
            return Cone(V[0, 0], V[0, 1], V[1, 0], V[1, 1])
        pts = _resample(V, np.linspace(0.0, 1.0, max(200, 4 * len(V))))
        c = pts.mean(axis=0)
        d = np.linalg.svd(pts - c, full_matrices=False)[2][0]
        if d @ (V[-1] - V[0]) < 0:
            d = -d
        a = c + ((V[0] - c) @ d) * d
        b = c + ((V[-1] - c) @ d) * d
        for end in (a, b):
            if end[0] < 0 and abs(d[0]) > 1e-12:
                end[:] = end + (-end[0] / d[0]) * d  # clip at the axis along the line
        return Cone(float(a[0]), float(a[1]), float(b[0]), float(b[1]))

    def reversed(self) -> Profile:
        """The same curve traversed from the last point to the first."""
        return Profile(self.points[::-1])

    # --- geometry --------------------------------------------------------------------------
    @property
    def vertices(self) -> np.ndarray:
        """(k, 2) float, mm: the points as rows (r, z)."""
        return np.array(self.points, dtype=np.float64)

    @property
    def p1(self) -> np.ndarray:
        """(2,) the first point."""
        return np.array(self.points[0])

    @property
    def p2(self) -> np.ndarray:
        """(2,) the last point."""
        return np.array(self.points[-1])

    @property
    def length(self) -> float:
        """Arc length of the polyline between its end points (mm)."""
        return float(np.linalg.norm(np.diff(self.vertices, axis=0), axis=1).sum())

    def signed_distance(self, r, z):
        """Signed meridional distance (mm) of points (r, z) to the extended polyline, positive
        on the left of the direction first → last point (as :meth:`.cones.Cone.signed_distance`).
        Shapes: ``r``, ``z`` broadcastable arrays (or scalars); the result has their shape."""
        shape, x = _rz_arrays(r, z)
        return _polyline_signed_distance(self.vertices, x).reshape(shape)

    def project(self, r, z):
        """Closest points on the extended polyline to meridional points; returns (r', z')."""
        shape, x = _rz_arrays(r, z)
        V = self.vertices
        a = V[:-1]
        d = np.diff(V, axis=0)
        L2 = np.einsum("ij,ij->i", d, d)
        k = len(d)
        lo, hi = np.zeros(k), np.ones(k)
        lo[0], hi[-1] = -np.inf, np.inf
        out = np.empty_like(x)
        step = max(1, _BLOCK // k)
        for i0 in range(0, len(x), step):
            xx = x[i0:i0 + step]
            w = xx[:, None, :] - a[None]
            lam = np.clip((w[..., 0] * d[:, 0] + w[..., 1] * d[:, 1]) / L2, lo, hi)
            q = a[None] + lam[..., None] * d[None]
            dist2 = np.sum((xx[:, None, :] - q) ** 2, axis=2)
            j = np.argmin(dist2, axis=1)
            out[i0:i0 + step] = q[np.arange(len(xx)), j]
        return out[:, 0].reshape(shape), out[:, 1].reshape(shape)


def as_profile(generatrix) -> Profile:
    """A :class:`Profile` from a Profile or a :class:`.cones.Cone` (its two-point profile)."""
    if isinstance(generatrix, Profile):
        return generatrix
    if isinstance(generatrix, Cone):
        return Profile.from_cone(generatrix)
    raise ConeError(
        f"a hub or tip generatrix must be a Cone or a Profile, got {type(generatrix).__name__}"
    )


# --------------------------------------------------------------------------- the morph
@dataclass(frozen=True)
class MorphingProfiles:
    """The linear morphing revolution surfaces (LMRS) between ``cone1`` (s = 0) and
    ``cone2`` (s = 1), two :class:`Profile` generatrices (paper 001 §4.2; see the module
    docstring for the derivation). The interface is that of :class:`.cones.MorphingCones`
    (``ratio``, ``ratio_of_points``, ``f``, ``polyline``, ``segment_lines``, ``sign``,
    ``cone1``/``cone2``), so the slicer, the generator and the verifier take either.
    ``cone1``/``cone2`` keep their type (a :class:`.cones.Cone` takes part as its two-point
    profile).

    The constructor normalises and checks the pair:

    * if the profiles run in opposite directions (their chords first → last point point
      away from each other) ``cone2`` is reversed;
    * they must not be the same curve, must not cross or touch, and the family must sweep the
      region between them monotonically (:func:`.cones.check_monotone_sweep`); otherwise
      ConeError names the problem.

    The field is oriented so that ``f_s > 0`` on the cone-2 side of the surface at ``s``.
    """

    cone1: Profile | Cone
    cone2: Profile | Cone

    def __post_init__(self):
        g1, g2 = self.cone1, self.cone2
        VP, VQ = as_profile(g1).vertices, as_profile(g2).vertices
        if float((VP[-1] - VP[0]) @ (VQ[-1] - VQ[0])) < 0:
            g2 = Cone(g2.r2, g2.z2, g2.r1, g2.z1) if isinstance(g2, Cone) else g2.reversed()
            object.__setattr__(self, "cone2", g2)
            VQ = VQ[::-1]
        scale = max(float(np.abs(np.vstack([VP, VQ])).max()), 1.0)
        # common parameter: the union of both vertex sets' normalised arc lengths
        # (parameters closer than 1e-9 are merged; each curve keeps its own vertex there)
        u = np.union1d(_arc_parameter(VP), _arc_parameter(VQ))
        u = u[np.concatenate([[True], np.diff(u) > 1e-9])]
        u[-1] = 1.0
        Pm, Qm = _resample(VP, u, 1e-9), _resample(VQ, u, 1e-9)
        if np.allclose(Pm, Qm, atol=1e-9 * scale, rtol=0):
            raise ConeError(
                "cone 1 and cone 2 are the same profile; move the tip generatrix away from the hub"
            )
        i, j = np.meshgrid(np.arange(len(VP) - 1), np.arange(len(VQ) - 1), indexing="ij")
        hit = _segments_intersect(VP[i], VP[i + 1], VQ[j], VQ[j + 1])
        if np.any(hit):
            a, b = np.argwhere(hit)[0]
            raise ConeError(
                "cone 1 and cone 2 cross (or touch) inside the region: hub segment "
                f"{VP[a].tolist()}→{VP[a + 1].tolist()} meets tip segment "
                f"{VQ[b].tolist()}→{VQ[b + 1].tolist()} (mm); the surfaces between them would "
                "intersect: move the generatrices apart so that they do not cross"
            )
        jsign = check_monotone_sweep(Pm, Qm)
        # the first and last morph rays close the region: they must not cross each other nor
        # the generatrices (only their own end points touch them)
        m = len(u)
        r0a, r0b = Pm[0], Qm[0]
        r1a, r1b = Pm[-1], Qm[-1]
        fold = bool(_segments_intersect(r0a, r0b, r1a, r1b))
        if m > 2:
            for chain in (Pm, Qm):  # segments not ending at the ray's own end points
                fold |= bool(np.any(_segments_intersect(r0a, r0b, chain[1:-1], chain[2:])))
                fold |= bool(np.any(_segments_intersect(r1a, r1b, chain[:-2], chain[1:-1])))
        if fold:
            raise ConeError(
                "cone 1 and cone 2 cross inside the region: the segment joining their first "
                f"points ({Pm[0].tolist()}→{Qm[0].tolist()}) or their last points "
                f"({Pm[-1].tolist()}→{Qm[-1].tolist()}) crosses a generatrix or the other, so the "
                "morphing surfaces fold over; trim or extend the generatrices so that their ends "
                "correspond"
            )
        object.__setattr__(self, "_P", Pm)
        object.__setattr__(self, "_Q", Qm)
        object.__setattr__(self, "_u", u)
        object.__setattr__(self, "_jsign", jsign)
        # the morph rays as lines a r + b z + c, ≥ 0 on the side of increasing u:
        # jsign · E_j × (X − P_j) with E_j = Q_j − P_j
        E = Qm - Pm
        rays = (-jsign * E[:, 1], jsign * E[:, 0], jsign * cross2(Pm, E))
        object.__setattr__(self, "_rays", rays)
        # f > 0 toward Q: Q on the left of P's direction ⇔ dP × E > 0 ⇔ J = E × dP < 0
        object.__setattr__(self, "_sign", -jsign)

    # --- the family ----------------------------------------------------------------------
    @property
    def sign(self) -> float:
        """+1 when generatrix 2 lies on the left of generatrix 1's direction, else −1."""
        return self._sign  # type: ignore[attr-defined]

    @property
    def n_segments(self) -> int:
        """Number of segments of every generatrix of the family (after resampling)."""
        return len(self._u) - 1  # type: ignore[attr-defined]

    @property
    def parameters(self) -> np.ndarray:
        """(m + 1,) the common normalised arc-length parameters u_j of the vertices."""
        return self._u.copy()  # type: ignore[attr-defined]

    def polyline(self, s):
        """Vertices of the generatrix at ratio ``s``: (m + 1, 2) for a scalar ``s``,
        (k, m + 1, 2) for (k,) ``s``; G_s = (1 − s) P_j + s Q_j (mm). ``generatrix`` is the
        same method (unlike :meth:`.cones.MorphingCones.generatrix`, which returns the end
        points A(s), B(s) as a pair; ``polyline`` is the common interface)."""
        s = np.asarray(s, dtype=np.float64)[..., None, None]
        return (1.0 - s) * self._P + s * self._Q  # type: ignore[attr-defined]

    generatrix = polyline

    def profile_at(self, s: float) -> Profile:
        """The generatrix at ratio ``s`` as a :class:`Profile`."""
        return Profile(self.polyline(float(s)))

    def segment_lines(self, s: float) -> np.ndarray:
        """(m, 3) float: (α, β, γ) per segment of G_s with α r + β z + γ the signed distance
        to that segment's line, positive toward generatrix 2, (α, β) unit."""
        G = self.polyline(float(s))
        d = np.diff(G, axis=0)
        d = d / np.linalg.norm(d, axis=1)[:, None]
        a = G[:-1]
        sg = self.sign
        return np.stack(
            [-d[:, 1] * sg, d[:, 0] * sg, (d[:, 1] * a[:, 0] - d[:, 0] * a[:, 1]) * sg], axis=1
        )

    def f(self, s: float, r, z):
        """Signed meridional distance (mm) of points (r, z) to the LMRS at ``s`` (+ toward
        generatrix 2). ``r``, ``z`` broadcastable; the result has their shape."""
        shape, x = _rz_arrays(r, z)
        return (self.sign * _polyline_signed_distance(self.polyline(float(s)), x)).reshape(shape)

    # --- the morph field -------------------------------------------------------------------
    def segment_of(self, r, z):
        """Index j (0 … m − 1) of the strip between the morph rays R_j and R_j+1 that each
        meridional point lies in, found by a vectorised binary search on the side of the rays
        (O(n log m)). Exact inside the region; outside it the rays' lines are extended.
        A point of the LMRS at any ``s`` in strip j lies on segment j of G_s."""
        shape, x = _rz_arrays(r, z)
        ra, rb, rc = self._rays  # type: ignore[attr-defined]
        xr, xz = x[:, 0], x[:, 1]
        k = self.n_segments
        lo = np.zeros(len(x), dtype=np.int64)
        hi = np.full(len(x), k - 1, dtype=np.int64)
        for _ in range(int(np.ceil(np.log2(max(k, 1)))) + 1):
            act = lo < hi
            if not np.any(act):
                break
            mid = (lo + hi + 1) // 2
            after = ra[mid] * xr + rb[mid] * xz + rc[mid] >= 0
            lo = np.where(act & after, mid, lo)
            hi = np.where(act & ~after, mid - 1, hi)
        return lo.reshape(shape)

    def _solve_on_strip(self, x, j):
        """Ratio s of the point x (n, 2) assuming it lies in strip j (n,): the root of the
        quadratic D_j(s) × (x − A_j(s)) = 0 whose segment parameter λ is on the segment
        (extended for the end strips), preferring s in [0, 1]. Returns s, λ, ok (n,)."""
        P, Q = self._P, self._Q  # type: ignore[attr-defined]
        k = self.n_segments
        p1, q1 = P[j], Q[j]
        d1 = P[j + 1] - p1
        d2 = Q[j + 1] - q1
        da = q1 - p1
        dd = d2 - d1
        w = x - p1
        k0 = cross2(d1, w)
        k1 = cross2(dd, w) - cross2(d1, da)
        k2 = -cross2(dd, da)
        disc = k1 * k1 - 4.0 * k2 * k0
        sq = np.sqrt(np.maximum(disc, 0.0))
        q = -0.5 * (k1 + np.copysign(sq, k1))
        with np.errstate(divide="ignore", invalid="ignore"):
            roots = (np.where(q != 0, k0 / q, np.nan), np.where(k2 != 0, q / k2, np.nan))
        lo = np.where(j == 0, -np.inf, 0.0) - _LAM_EPS
        hi = np.where(j == k - 1, np.inf, 1.0) + _LAM_EPS
        best = None
        for s in roots:
            s = np.where(disc >= 0, s, np.nan)
            D = d1 + s[:, None] * dd
            A = p1 + s[:, None] * da
            with np.errstate(divide="ignore", invalid="ignore"):
                lam = np.einsum("ij,ij->i", x - A, D) / np.einsum("ij,ij->i", D, D)
            fin = np.isfinite(s) & np.isfinite(lam)
            valid = fin & (lam >= lo) & (lam <= hi)
            score = np.where(fin, 2 * valid + ((s >= -_LAM_EPS) & (s <= 1 + _LAM_EPS)), -1)
            if best is None:
                best = (s, lam, valid, score)
            else:
                b = score > best[3]
                cand = (s, lam, valid, score)
                best = tuple(np.where(b, new, old) for new, old in zip(cand, best, strict=True))
        s, lam, valid, _ = best
        return s, lam, valid

    def ratio(self, r, z):
        """The morph field: the ratio ``s`` of the LMRS through each meridional point.

        Strip by binary search over the morph rays, then the closed-form quadratic of that
        strip (module docstring); a point whose root falls off its strip's segment moves to the
        neighbouring strip (up to three times), and the few that still have none are solved on
        every strip, keeping the root nearest to [0, 1]. Points on no surface of the family
        get ±inf on the side they lie (as :meth:`.cones.MorphingCones.ratio`).

        Parameters
        ----------
        r, z : (n,) float, mm

        Returns
        -------
        s : (n,) float
        """
        shape, x = _rz_arrays(r, z)
        k = self.n_segments
        j = self.segment_of(x[:, 0], x[:, 1])
        s, lam, ok = self._solve_on_strip(x, j)
        for _ in range(3):
            move = ~ok & (((lam < 0) & (j > 0)) | ((lam > 1) & (j < k - 1)))
            if not np.any(move):
                break
            idx = np.nonzero(move)[0]
            j[idx] += np.where(lam[idx] < 0, -1, 1)
            s[idx], lam[idx], ok[idx] = self._solve_on_strip(x[idx], j[idx])
        left = np.nonzero(~ok)[0]
        if len(left):
            xl = x[left]
            best = np.full(len(left), np.nan)
            gap = np.full(len(left), np.inf)
            for jj in range(k):
                sj, _, vj = self._solve_on_strip(xl, np.full(len(left), jj))
                g = np.where(vj, np.abs(sj - np.clip(sj, 0.0, 1.0)), np.inf)
                better = g < gap
                best = np.where(better, sj, best)
                gap = np.where(better, g, gap)
            none = ~np.isfinite(gap)
            if np.any(none):
                side = self.f(0.0, xl[none, 0], xl[none, 1])
                best[none] = np.where(side > 0, np.inf, -np.inf)
            s[left] = best
        return s.reshape(shape)

    def ratio_of_points(self, points, axis: Axis):
        """Morph field at (n, 3) points (mm)."""
        r, z = meridional(points, axis)
        return self.ratio(r, z)


def morph_between(generatrix1, generatrix2):
    """The morphing family between a hub and a tip generatrix: :class:`.cones.MorphingCones`
    when both are cones (closed form, the paper's LMC), else :class:`MorphingProfiles` (LMRS,
    a cone taking part as its two-point profile)."""
    if isinstance(generatrix1, Cone) and isinstance(generatrix2, Cone):
        return MorphingCones(generatrix1, generatrix2)
    for g in (generatrix1, generatrix2):
        as_profile(g)  # ConeError unless a Cone or a Profile
    return MorphingProfiles(generatrix1, generatrix2)


def generatrix_rows(generatrix, rows: int, extend: float) -> np.ndarray:
    """(k, 2) meridional points (r, z), mm, of a generatrix from its first to its last point,
    lengthened by ``extend`` mm at both ends along the end segments (r clamped ≥ 0). A
    ``Cone`` gives ``rows + 1`` evenly spaced points (a straight line: exact); a ``Profile``
    its vertices, each segment split into ``ceil(rows / segments)`` steps."""
    if isinstance(generatrix, Cone):
        P = np.array([generatrix.p1, generatrix.p2], dtype=np.float64)
        per = rows
    else:
        P = np.asarray(generatrix.vertices, dtype=np.float64).copy()
        per = max(1, -(-rows // (len(P) - 1)))
    if extend:
        for end, nb in ((0, 1), (-1, -2)):
            u = P[end] - P[nb]
            P[end] = P[end] + extend * u / np.linalg.norm(u)
    t = np.arange(per) / per
    rz = np.concatenate([(1.0 - t)[:, None] * a + t[:, None] * b
                         for a, b in zip(P[:-1], P[1:], strict=True)] + [P[-1:]])
    rz[:, 0] = np.maximum(rz[:, 0], 0.0)
    return rz
