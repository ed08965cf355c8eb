"""Global collision detection between the posed tool assembly and the blisk (paper 004 §2).

Obstacles (:class:`Obstacles`): the target blade, its neighbours — the blade turned about the
blisk axis by ±k·360°/N, k = 1..``neighbours`` — and any extra meshes (hub, whole blisk,
fixture), each a named triangle mesh.

Tool (:class:`~.tool_assembly.ToolAssembly`): the **flute** (the :class:`~.cutter.Cutter`'s own
convex shape, from the tip to the assembly's flute length) and the **body** (the union of the
frustums of the holder profile above it). Clearance of a pose (mm, signed):

    clearance = min( dist(body, every obstacle incl. the target blade),
                     dist(flute, every obstacle except the target blade) )

capped at ``safety + 5`` mm (never NaN). A pose collides when clearance < ds (paper 004 Eq. 9:
the paper compares the point–axis distance L of Eq. 7 with R2 + ds; here the distance from
the obstacle to the tool *surface* is compared with ds, which is the same test for its
cylindrical handle, and holds for tapers and shoulders too).

**Distances to triangles, not to points.** Paper 004 §2.1 discretises the blade into points
(Eqs. 2–8), which misses a collision between the points of a coarse mesh. Here every part is a
convex solid of revolution S (one frustum of the profile, or the cutter), whose signed distance
sd_S(x) is exact and convex in x (it only depends on the meridional coordinates (ρ, z) of x, in
which S is a convex polygon, or the cutter's convex outline). The minimum of sd_S over a
triangle T is found exactly as follows:

* the three vertices and, along each edge, the minimum of the convex function sd_S by golden
  section with a convexity bound: the secant through the bracket's two probes, extended,
  bounds sd_S from below outside them, and the secants through each probe and its bracket
  end bound it between them; an edge stops once that bound is within 10⁻⁹ mm of its best
  value (at most 40 steps: 0.618⁴⁰ ≈ 4·10⁻⁹ of the edge), or above the pose's best so far
  (it cannot hold the minimum);
* the interior: with n the triangle's unit normal and y± the support points of S in the
  directions ±n (closed form for frustums and for the cutter's profile), if S lies entirely on
  one side of the triangle's plane the closest point of the plane to S is the support point's
  foot: when that foot lies inside T, the interior minimum is its plane distance (exact, and
  T's minimum: its edges are not searched), otherwise that distance bounds sd_S over T. If
  the plane cuts S and the point of the segment y⁻y⁺ on the plane lies inside T, T intersects
  S (its depth is taken there). A minimum on the interior with S on both sides of the plane is
  impossible unless T intersects S.

Positive clearances are therefore exact to ~10⁻⁹ mm. Negative values (penetration) are the
deepest signed distance found among those candidates and the feet on T's plane of the
part's axis points (exact when a cylinder's side cuts a plane; otherwise an estimate that
is ≤ 0 whenever T meets the part). Once a pose is known to penetrate, its search is a beam
(the 8 nodes per level with the deepest representative points) and only its 16 triangles
with the deepest centroids are refined (the depth is an estimate there anyway; the
centroids count too, so the figure stays below the bound that showed the penetration), and
a pose whose lower bound is ≥ ds + 1 mm descends as a beam of its 8 most promising nodes
and refines its 8 most promising triangles: exact to ~10⁻⁹ mm where it matters (below
ds + 1 mm), within the gap between the bounds (about the local triangle size) above.

**Neighbours by turning the poses.** The neighbours are rigid copies of the blade (turned by
±k·360°/N about the blisk axis), and distances are invariant under the rotation: one
triangle tree over the blade serves every copy, each queried with the poses turned back by
the copy's angle (tip and axis by −k·360°/N); the contact point and normal found are turned
forward again. Extra obstacles (and a neighbour that is not an exact copy) share a second
tree. Building the tree is then a fifth of the work for ±2 neighbours.

**Culling** (paper 004 §2.2, Eqs. 3–6 project the handle to cull points; here a bounding
volume hierarchy of the triangles replaces the projection): triangles are sorted along a
Morton curve of their centroids; an implicit 4-ary tree over that order (leaves of 8
triangles) carries a bounding box and one representative triangle point per node. A
frontier of (pose, node) pairs descends the tree for every part and copy: the lower bound of
a node is ``sd_S(centre) − radius`` (sd_S is 1-Lipschitz; radius of the box's sphere) and,
for the frustums on small nodes, the tangent plane of the convex sd_S at the centre,
``sd_S(c) − Σ |∇sd_S(c)_i| h_i`` over the box of half-sizes h, and for a triangle the same
plane at its centroid over its three vertices — far tighter where a shank runs along a
surface. The upper bound of the pose's clearance is the smallest ``sd_S`` of any
representative point met so far (a point on an obstacle), and a pair survives only while
its lower bound is at most that upper bound (and the cap). Only the surviving triangles are
refined exactly. Poses are processed in chunks, in threads (numpy releases the GIL).

Units mm and radians. numpy/scipy only.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from .cones import Axis
from .cutter import Cutter, as_cutter
from .errors import CollisionError
from .tool_assembly import ToolAssembly

__all__ = [
    "CollisionScene",
    "Detection",
    "Obstacle",
    "Obstacles",
    "PART_BODY",
    "PART_FLUTE",
    "detect_collisions",
    "rotate_about_axis",
    "split_faces",
]

PART_FLUTE, PART_BODY = 0, 1
PART_NAMES = ("flute", "body")
#: how far beyond ds the clearance is measured before it is capped, mm
CAP_MARGIN = 5.0
_LEAF = 8
#: children per node of the triangle tree
_BRANCH = 4
_GOLDEN_STEPS = 40
#: an edge's search stops once its convexity bound is this close to its best value, mm
_EDGE_TOL = 1e-9
_CHUNK = 1024
#: triangles refined per pose once the pose is known to penetrate (depth estimate)
_PENETRATION_PAIRS = 16
#: poses whose lower bound is this far above ds (mm) refine only _FAR_PAIRS triangles
_FAR_MARGIN = 1.0
_FAR_PAIRS = 8
_FAR_BEAM = 8
#: nodes kept per level for a pose known to penetrate (its depth is an estimate)
_DEEP_BEAM = 8
_REP_FACTOR = 4.0
_GRAD_RADIUS = 2.0


# ====================================================================== obstacles
def rotate_about_axis(points, axis: Axis, angle: float) -> np.ndarray:
    """(n, 3) points turned by ``angle`` (rad, right-handed about ``axis.d``) about the blisk
    axis (Rodrigues' formula)."""
    o = np.asarray(axis.o, dtype=np.float64)
    return (np.asarray(points, dtype=np.float64) - o) @ _rotation_matrix(axis, angle).T + o


def split_faces(V, F, mask):
    """Split a triangle mesh by a per-triangle mask: ((V, F) of the masked triangles,
    (V, F) of the others), each with only the vertices it uses (renumbered); the second is
    None when every triangle is masked."""
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (len(F),):
        raise CollisionError(f"face mask has {mask.shape} entries for {len(F)} triangles")

    def part(sel):
        used, inv = np.unique(F[sel].ravel(), return_inverse=True)
        return V[used], inv.reshape(-1, 3).astype(np.int64)

    return part(mask), (part(~mask) if np.any(~mask) else None)


def _mesh_arrays(name, V, F):
    try:
        V = np.asarray(V, dtype=np.float64)
        F = np.asarray(F, dtype=np.int64)
    except (TypeError, ValueError):
        raise CollisionError(f"obstacle {name!r}: vertices and faces must be numeric arrays") \
            from None
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3:
        raise CollisionError(f"obstacle {name!r}: need vertices (n, 3) and triangles (m, 3), got "
                             f"{V.shape} and {F.shape}")
    if len(F) == 0:
        raise CollisionError(f"obstacle {name!r} has no triangles; leave it out")
    if not np.all(np.isfinite(V)):
        raise CollisionError(f"obstacle {name!r} has NaN or infinite coordinates")
    if F.min() < 0 or F.max() >= len(V):
        raise CollisionError(f"obstacle {name!r}: face indices out of range 0..{len(V) - 1}")
    return V, F


@dataclass(frozen=True)
class Obstacle:
    """A named triangle mesh: V (n, 3) float64 mm, F (m, 3) int64."""

    name: str
    V: np.ndarray = field(repr=False)
    F: np.ndarray = field(repr=False)

    @property
    def n_triangles(self) -> int:
        return int(len(self.F))


@dataclass(frozen=True)
class Obstacles:
    """The target blade (index 0), its neighbours, then the extra meshes.

    Attributes
    ----------
    meshes : tuple of Obstacle — ``meshes[0]`` is the target blade
    axis : Axis — the blisk axis the neighbours are turned about
    blade_count : int — N ≥ 2
    neighbours : int — copies per side
    """

    meshes: tuple
    axis: Axis
    blade_count: int
    neighbours: int

    @classmethod
    def build(cls, blade_V, blade_F, axis: Axis, blade_count: int, neighbours: int = 2,
              extra=(), *, check_extra: bool = True) -> Obstacles:
        """The target blade, its ±k·360°/N copies (k = 1..neighbours) and ``extra``
        obstacles: an iterable of ``(name, V, F)`` or :class:`Obstacle`.

        Raises
        ------
        CollisionError — blade count < 2, neighbours < 0 or so many that the copies wrap
        around onto each other (2 · neighbours + 1 > blade count), bad arrays, an extra
        obstacle that contains or coincides with the blade (:meth:`check_extras`)."""
        try:
            n = int(blade_count)
        except (TypeError, ValueError):
            raise CollisionError(f"blade count must be an integer ≥ 2, got {blade_count!r}") \
                from None
        if n != blade_count or n < 2:
            raise CollisionError(f"blade count must be an integer ≥ 2 (the blades on the blisk), "
                                 f"got {blade_count!r}")
        try:
            k = int(neighbours)
        except (TypeError, ValueError):
            raise CollisionError(f"neighbours must be an integer ≥ 0, got {neighbours!r}") \
                from None
        if k != neighbours or k < 0:
            raise CollisionError(f"neighbours (blades checked on each side) must be an integer "
                                 f"≥ 0, got {neighbours!r}")
        if 2 * k + 1 > n:
            raise CollisionError(
                f"{k} neighbours per side need {2 * k + 1} blades but the blisk has {n}: the "
                f"copies would wrap around onto each other; use at most {(n - 1) // 2} "
                "neighbours per side")
        V, F = _mesh_arrays("blade", blade_V, blade_F)
        meshes = [Obstacle("blade", V, F)]
        pitch = 2.0 * math.pi / n
        for j in range(1, k + 1):
            for sign, tag in ((1, "+"), (-1, "-")):
                meshes.append(Obstacle(f"blade {tag}{j}", rotate_about_axis(V, axis,
                                                                           sign * j * pitch), F))
        names = {m.name for m in meshes}
        for e in extra:
            if isinstance(e, Obstacle):
                ob = e
            else:
                try:
                    name, EV, EF = e
                except (TypeError, ValueError):
                    raise CollisionError("extra obstacles must be (name, vertices, faces) "
                                         "triples") from None
                ob = Obstacle(str(name), *_mesh_arrays(str(name), EV, EF))
            if ob.name in names:
                raise CollisionError(f"two obstacles are named {ob.name!r}; give each a name")
            names.add(ob.name)
            meshes.append(ob)
        out = cls(tuple(meshes), axis, n, k)
        if check_extra:
            out.check_extras()
        return out

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.meshes]

    @property
    def n_triangles(self) -> int:
        return int(sum(m.n_triangles for m in self.meshes))

    @property
    def extra_start(self) -> int:
        """Index of the first extra obstacle."""
        return 1 + 2 * self.neighbours

    def summary(self) -> dict:
        return {"names": self.names, "triangles": [m.n_triangles for m in self.meshes],
                "blade_count": self.blade_count, "neighbours": self.neighbours}

    def check_extras(self, samples: int = 24) -> None:
        """Refuse an extra obstacle that coincides with the blade's faces (shares its surface:
        the blade would collide with itself) or, closed, contains the blade's vertices.

        Raises CollisionError naming the obstacle and the way out."""
        blade = self.meshes[0]
        Vb = blade.V
        scale = float(np.linalg.norm(Vb.max(0) - Vb.min(0)))
        rng = np.random.default_rng(0)
        pick = Vb[rng.choice(len(Vb), size=min(samples, len(Vb)), replace=False)]
        for ob in self.meshes[self.extra_start:]:
            pts = np.vstack([ob.V, ob.V[ob.F].mean(axis=1)])
            d, _ = cKDTree(pts).query(Vb)
            same = np.mean(d <= 1e-6 * max(scale, 1.0))
            if same > 0.1:
                raise CollisionError(
                    f"obstacle {ob.name!r} contains the blade's own faces ({100 * same:.0f} % of "
                    "the blade's vertices lie on it), so every pose would collide: remove the "
                    "blade's faces from it (or select only the blade faces as the blade)")
            if _closed(ob.F):
                w = _winding_numbers(ob.V, ob.F, pick)
                inside = np.mean(np.abs(w) > 0.5)
                if inside > 0.5:
                    raise CollisionError(
                        f"obstacle {ob.name!r} is a closed mesh that contains the blade "
                        f"({100 * inside:.0f} % of the sampled blade vertices lie inside it), so "
                        "every pose would collide: remove the blade's faces and volume from it, "
                        "or give the hub/fixture without the blade")


def _closed(F) -> bool:
    e = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, cnt = np.unique(e, axis=0, return_counts=True)
    return bool(np.all(cnt == 2))


def _winding_numbers(V, F, P, chunk: int = 200_000) -> np.ndarray:
    """(k,) generalised winding numbers of points P (k, 3) w.r.t. the triangle mesh
    (solid angles, Van Oosterom & Strackee); ≈ ±1 inside a closed mesh, 0 outside."""
    out = np.zeros(len(P))
    for s in range(0, len(F), chunk):
        A, B, C = (V[F[s:s + chunk, i]] for i in range(3))
        for j, p in enumerate(P):
            a, b, c = A - p, B - p, C - p
            la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
            num = np.einsum("ij,ij->i", a, np.cross(b, c))
            den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc
                   + np.einsum("ij,ij->i", b, c) * la + np.einsum("ij,ij->i", c, a) * lb)
            out[j] += 2.0 * np.arctan2(num, den).sum()
    return out / (4.0 * math.pi)


# ====================================================================== parts
def _seg_d2(px, py, ax, ay, bx, by):
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    qx, qy = px - ax, py - ay
    t = np.clip((qx * dx + qy * dy) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    ex, ey = qx - t * dx, qy - t * dy
    return ex * ex + ey * ey


def _seg_near(px, py, ax, ay, bx, by):
    """(squared distance, nearest x, nearest y) from 2-D points to the segment a → b."""
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    t = np.clip(((px - ax) * dx + (py - ay) * dy) / (dd if dd > 0 else 1.0), 0.0, 1.0)
    qx, qy = ax + t * dx, ay + t * dy
    ex, ey = px - qx, py - qy
    return ex * ex + ey * ey, qx, qy


class _Frustum:
    """A solid frustum of the body: the revolution of the trapezoid (0, z0), (r0, z0),
    (r1, z1), (0, z1) (mm)."""

    kind = PART_BODY

    def __init__(self, z0, r0, z1, r1):
        self.z0, self.r0, self.z1, self.r1 = map(float, (z0, r0, z1, r1))
        self.rmax = max(self.r0, self.r1)

    def radius_at(self, z):
        t = np.clip((z - self.z0) / (self.z1 - self.z0), 0.0, 1.0)
        return self.r0 + t * (self.r1 - self.r0)

    def sd_rz(self, rho, z):
        z0, r0, z1, r1 = self.z0, self.r0, self.z1, self.r1
        if r0 == r1:  # a cylinder: closed form
            dr = rho - r0
            dz = np.maximum(z0 - z, z - z1)
            out = np.hypot(np.maximum(dr, 0.0), np.maximum(dz, 0.0))
            return np.where((dr > 0) | (dz > 0), out, np.maximum(dr, dz))
        d2 = _seg_d2(rho, z, 0.0, z0, r0, z0)
        d2 = np.minimum(d2, _seg_d2(rho, z, r0, z0, r1, z1))
        d2 = np.minimum(d2, _seg_d2(rho, z, r1, z1, 0.0, z1))
        inside = (z >= z0) & (z <= z1) & (rho <= self.radius_at(z))
        d = np.sqrt(d2)
        return np.where(inside, -d, d)

    def sd_grad_rz(self, rho, z):
        """(sd, ∂sd/∂ρ, ∂sd/∂z) at meridional points (k,): the gradient is the unit vector
        from the nearest boundary point (away from it outside, toward it inside); (0, 0)
        where the point is on the boundary (no gradient: the caller falls back)."""
        z0, r0, z1, r1 = self.z0, self.r0, self.z1, self.r1
        if r0 == r1:  # a cylinder: closed form
            dr = rho - r0
            dlo, dhi = z0 - z, z - z1
            dz = np.maximum(dlo, dhi)
            er, ez = np.maximum(dr, 0.0), np.maximum(dz, 0.0)
            out = np.hypot(er, ez)
            outside = out > 0
            inv = np.divide(1.0, out, out=np.zeros_like(out), where=outside)
            radial = dr >= dz
            gz = np.where(outside, ez * inv, ~radial)
            return (np.where(outside, out, np.maximum(dr, dz)),
                    np.where(outside, er * inv, radial), np.where(dlo > dhi, -gz, gz))
        best = None
        for a0, b0, a1, b1 in ((0.0, z0, r0, z0), (r0, z0, r1, z1), (r1, z1, 0.0, z1)):
            d2, qr, qz = _seg_near(rho, z, a0, b0, a1, b1)
            if best is None:
                best = [d2, qr, qz]
            else:
                closer = d2 < best[0]
                best = [np.where(closer, d2, best[0]), np.where(closer, qr, best[1]),
                        np.where(closer, qz, best[2])]
        d2, qr, qz = best
        inside = (z >= z0) & (z <= z1) & (rho <= self.radius_at(z))
        d = np.sqrt(d2)
        sgn = np.where(inside, -1.0, 1.0)
        inv = np.where(d > 1e-12, sgn / np.where(d > 1e-12, d, 1.0), 0.0)
        return sgn * d, (rho - qr) * inv, (z - qz) * inv

    def support_rz(self, s, c):
        """Meridional (ρ, z) of the support point in the direction with radial part s ≥ 0 and
        axial part c."""
        first = self.r0 * s + self.z0 * c >= self.r1 * s + self.z1 * c
        return np.where(first, self.r0, self.r1), np.where(first, self.z0, self.z1)


class _Flute:
    """The cutter's cutting part up to the flute length (exact convex shape, :mod:`.cutter`)."""

    kind = PART_FLUTE

    def __init__(self, cutter: Cutter, flute_length: float):
        try:
            self.cutter = replace(cutter, h=float(flute_length))
        except Exception as err:  # ToolError: flute shorter than the corner
            raise CollisionError(f"flute length {flute_length:g} mm is impossible for the "
                                 f"cutter: {err}") from None
        g = self.cutter._g
        self.z0, self.z1 = 0.0, float(flute_length)
        self.rmax = float(g["T"][0])
        self._g = g

    def sd_rz(self, rho, z):
        return self.cutter.signed_distance_rz(rho, z)

    def support_rz(self, s, c):
        cu, g = self.cutter, self._g
        th = np.arctan2(s, -c)  # angle of the direction from −axis, in [0, π]
        th_c = np.clip(th, g["th_lo"], g["th_hi"])
        rho = np.where(th < g["th_lo"], 0.0, cu.e + cu.r * np.sin(th_c))
        z = np.where(th < g["th_lo"], 0.0, cu.f - cu.r * np.cos(th_c))
        top = th > g["th_hi"]
        return np.where(top, g["T"][0], rho), np.where(top, g["T"][1], z)


def _posed_sd(part, X, tip, axis):
    dv = X - tip
    z = np.einsum("ij,ij->i", dv, axis)
    rr = np.einsum("ij,ij->i", dv, dv) - z * z
    return part.sd_rz(np.sqrt(np.maximum(rr, 0.0)), z)


def _posed_sd_grad(part, X, tip, axis):
    """(sd (k,), gradient (k, 3) or None, valid (k,) bool) of the posed part at points X:
    the gradient of the convex sd, where the part provides it (frustums) and it exists
    (off the axis and off the part's boundary). By convexity sd(x) ≥ sd(X) + g·(x − X)
    for every x."""
    if not hasattr(part, "sd_grad_rz"):
        return _posed_sd(part, X, tip, axis), None, None
    sd, dv, al, be, valid = _posed_sd_ab(part, X, tip, axis)
    return sd, al[:, None] * dv + be[:, None] * axis, valid


def _posed_sd_ab(part, X, tip, axis):
    """(sd, dv = X − tip, α, β, valid): the gradient of the posed part's sd at X is
    α dv + β axis (∂sd/∂ρ along the unit radial (dv − z axis)/ρ, ∂sd/∂z along the axis)."""
    dv = X - tip
    z = np.einsum("ij,ij->i", dv, axis)
    rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", dv, dv) - z * z, 0.0))
    sd, gr, gz = part.sd_grad_rz(rho, z)
    valid = (rho > 1e-9) & ((gr != 0.0) | (gz != 0.0))
    al = gr / np.where(valid, rho, 1.0)
    return sd, dv, al, gz - al * z, valid


def _box_bound(part, c, tip, axis, r, h):
    """(k,) lower bound of the posed part's sd over boxes (centre c, half-sizes h (k, 3),
    sphere radius r): the larger of sd(c) − r and the tangent plane of the convex sd at c
    over the box, sd(c) − Σ |∇sd(c)_i| h_i."""
    sd, dv, al, be, valid = _posed_sd_ab(part, c, tip, axis)
    s = np.abs(al * dv[:, 0] + be * axis[:, 0]) * h[:, 0]
    s += np.abs(al * dv[:, 1] + be * axis[:, 1]) * h[:, 1]
    s += np.abs(al * dv[:, 2] + be * axis[:, 2]) * h[:, 2]
    return np.maximum(sd - r, np.where(valid, sd - s, -np.inf))


def _posed_support(part, v, tip, axis):
    """(k, 3) support points of the posed part in directions v (k, 3)."""
    c = np.einsum("ij,ij->i", v, axis)
    perp = v - c[:, None] * axis
    s = np.linalg.norm(perp, axis=1)
    ref = np.where((np.abs(axis[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    any_perp = np.cross(axis, ref)
    any_perp /= np.linalg.norm(any_perp, axis=1)[:, None]
    u = np.where((s > 1e-12)[:, None], perp / np.maximum(s, 1e-300)[:, None], any_perp)
    rho, z = part.support_rz(s, c)
    return tip + z[:, None] * axis + rho[:, None] * u


# ====================================================================== triangle tree
def _morton(P):
    lo, hi = P.min(0), P.max(0)
    q = ((P - lo) / np.maximum(hi - lo, 1e-12).max() * 1023).astype(np.uint64)

    def spread(x):
        x = x & np.uint64(0x3FF)
        x = (x | (x << np.uint64(16))) & np.uint64(0x30000FF)
        x = (x | (x << np.uint64(8))) & np.uint64(0x300F00F)
        x = (x | (x << np.uint64(4))) & np.uint64(0x30C30C3)
        x = (x | (x << np.uint64(2))) & np.uint64(0x9249249)
        return x

    return spread(q[:, 0]) | (spread(q[:, 1]) << np.uint64(1)) | (spread(q[:, 2]) << np.uint64(2))


class _TriTree:
    """Triangles in Morton order with an implicit binary tree of bounding spheres (see the
    module docstring)."""

    def __init__(self, V, F, owner):
        """V (n, 3) float mm, F (m, 3) int triangles, owner (m,) int obstacle per
        triangle."""
        V = np.ascontiguousarray(V, dtype=np.float64)
        cen = (V[F[:, 0]] + V[F[:, 1]] + V[F[:, 2]]) / 3.0
        order = np.argsort(_morton(cen), kind="stable")
        Fo = F[order]
        self.A, self.B, self.C = V[Fo[:, 0]], V[Fo[:, 1]], V[Fo[:, 2]]
        self.owner = owner[order]
        self.cen = cen[order]
        r2 = None
        for x in (self.A, self.B, self.C):
            e = x - self.cen
            q = np.einsum("ij,ij->i", e, e)
            r2 = q if r2 is None else np.maximum(r2, q)
        self.rad = np.sqrt(r2)
        n = len(self.A)
        self.n = n
        lo = np.minimum(np.minimum(self.A, self.B), self.C)
        hi = np.maximum(np.maximum(self.A, self.B), self.C)
        starts = np.arange(0, n, _LEAF)
        llo = np.minimum.reduceat(lo, starts, axis=0)
        lhi = np.maximum.reduceat(hi, starts, axis=0)
        rep = self.cen[starts]
        levels = [(llo, lhi, rep)]
        while len(levels[-1][0]) > 1:
            lo_, hi_, rp = levels[-1]
            s = np.arange(0, len(lo_), _BRANCH)  # a node's children: _BRANCH consecutive
            levels.append((np.minimum.reduceat(lo_, s, axis=0),
                           np.maximum.reduceat(hi_, s, axis=0), rp[s]))
        levels = levels[::-1]  # root first
        self.levels = [(0.5 * (lo_ + hi_), 0.5 * np.linalg.norm(hi_ - lo_, axis=1), rp,
                        0.5 * (hi_ - lo_)) for lo_, hi_, rp in levels]
        self.counts = [len(x[0]) for x in self.levels]
        u, v = self.B - self.A, self.C - self.A
        nrm = np.empty_like(u)  # u × v (np.cross is several times slower)
        nrm[:, 0] = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
        nrm[:, 1] = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
        nrm[:, 2] = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
        ln = np.sqrt(np.einsum("ij,ij->i", nrm, nrm))
        self.ok = ln > 1e-14 * np.maximum(self.rad, 1e-300) ** 2
        self.nrm = nrm / np.where(ln > 0, ln, 1.0)[:, None]

    def candidates(self, part, tips, axes, ub, pid=None, far=np.inf):
        """(query index, triangle index, centroid distance) of the pairs that may hold the
        part's minimum over the tree's triangles.

        ``tips``, ``axes`` (v, 3): the queries — poses expressed in the tree's frame (a
        neighbour blade is queried with the pose turned back onto the blade, see
        :class:`CollisionScene`); ``pid`` (v,) the pose of each query (default: the query
        itself), indexing ``ub`` (m,), which is lowered in place to upper bounds of the poses'
        clearances (shared by all queries of a pose). Returns (P (k,) query index, T (k,)
        triangle index, sdc (k,) the part's signed distance at T's centroid).

        Two beams (best-first by a bound, then cut to a fixed width per query and level):

        * a pose whose nodes all have lower bounds ≥ ``far`` (mm; certainly clear) keeps its
          ``_FAR_BEAM`` nodes with the smallest lower bound (its figure is then bounded,
          not exact);
        * a pose known to penetrate (bound < 0) keeps its ``_DEEP_BEAM`` nodes with the
          deepest representative point (a node's representative is its first child's, so
          the node that gave the bound stays, down to the triangle whose centroid it is:
          the pose's reported clearance stays at most that bound)."""
        m = len(tips)
        if pid is None:
            pid = np.arange(m)
        P = np.arange(m)
        N = np.zeros(m, dtype=np.int64)
        beam = np.isfinite(far)
        grad = hasattr(part, "sd_grad_rz")
        for li, (c, r, rep, h) in enumerate(self.levels):
            t, a = tips[P], axes[P]
            if grad and r[0] < _GRAD_RADIUS:
                lb = _box_bound(part, c[N], t, a, r[N], h[N])
            else:
                lb = _posed_sd(part, c[N], t, a) - r[N]
            keep = lb <= ub[pid[P]]
            P, N, t, a = P[keep], N[keep], t[keep], a[keep]
            if len(P) == 0:
                return P, N, np.zeros(0), np.zeros(0)
            lb = lb[keep]
            depth = None
            if r[0] < _REP_FACTOR * part.rmax + 8.0:  # nodes small enough for their points to help
                srep = _posed_sd(part, rep[N], t, a)
                np.minimum.at(ub, pid[P], srep)
                keep = lb <= ub[pid[P]]
                P, N, lb, srep = P[keep], N[keep], lb[keep], srep[keep]
                depth = srep
            if beam and len(P) > _DEEP_BEAM * 4:
                starts, sizes = _groups(P)  # P stays grouped by query (sorted)
                deep = ub[pid[P[starts]]] < 0
                width = np.where(deep, _DEEP_BEAM,
                                 np.where(np.minimum.reduceat(lb, starts) >= far, _FAR_BEAM, 0))
                cut = (width > 0) & (sizes > width)
                if np.any(cut):
                    P, N = _beam(P, N, lb, depth, ub[pid[P]], sizes, cut, deep, width)
            if li + 1 < len(self.levels):
                nxt = self.counts[li + 1]
                P = np.repeat(P, _BRANCH)
                N = (_BRANCH * N[:, None] + np.arange(_BRANCH)).ravel()
                ok = N < nxt
                P, N = P[ok], N[ok]
        # leaves → triangles
        P = np.repeat(P, _LEAF)
        T = (_LEAF * N[:, None] + np.arange(_LEAF)).ravel()
        ok = T < self.n
        P, T = P[ok], T[ok]
        cen = self.cen[T]
        sdc, g, valid = _posed_sd_grad(part, cen, tips[P], axes[P])
        np.minimum.at(ub, pid[P], sdc)
        lb = sdc - self.rad[T]
        if g is not None:  # the tangent plane of the convex sd at the centroid, over T
            lin = np.minimum(np.minimum(np.einsum("ij,ij->i", g, self.A[T] - cen),
                                        np.einsum("ij,ij->i", g, self.B[T] - cen)),
                             np.einsum("ij,ij->i", g, self.C[T] - cen))
            lb = np.where(valid, np.maximum(lb, sdc + lin), lb)
        keep = lb <= ub[pid[P]]
        return P[keep], T[keep], sdc[keep], lb[keep]


def _beam(P, N, lb, depth, ubp, sizes, cut, deep, width):
    """Keep the ``width`` best nodes of every query group that is ``cut`` (P sorted, so the
    groups are runs; the other groups stay whole, and P stays sorted). Best: the node whose
    representative gave the pose's bound ``ubp`` first (for a deep query, the deepest
    representatives first), then the smallest lower bound ``lb``."""
    inc = np.repeat(cut, sizes)
    ci = np.nonzero(inc)[0]
    key = lb[ci]
    if depth is not None:
        dq = depth[ci]
        key = np.where(np.repeat(deep, sizes)[ci], np.where(dq < 0, dq - 1e3, key),
                       np.where(dq <= ubp[ci] + 1e-12, -2e3, key))
    kmin = key.min()
    span = float(key.max() - kmin) + 1.0
    ci = ci[np.argsort(P[ci] * span + (key - kmin))]  # one float key: group, then key
    cs, csz = _groups(P[ci])
    rank = np.arange(len(ci)) - np.repeat(cs, csz)
    keep = ~inc
    keep[ci[rank < np.repeat(width[cut], csz)]] = True
    return P[keep], N[keep]


def _groups(P):
    """(starts, sizes) of the runs of equal values in the non-empty sorted array P."""
    starts = np.concatenate([[0], np.flatnonzero(P[1:] != P[:-1]) + 1])
    return starts, np.diff(np.append(starts, len(P)))


def _inside_tri(q, A, B, C, n):
    def side(p0, p1):
        return np.einsum("ij,ij->i", np.cross(p1 - p0, q - p0), n)

    return (side(A, B) >= 0) & (side(B, C) >= 0) & (side(C, A) >= 0)


def _edge_minima(part, E0, D, t, a, f0, f1, P, ub, tol=_EDGE_TOL):
    """Minimum of the posed part's signed distance along each edge E0 + x D, x ∈ [0, 1]
    (arrays per edge, (k, 3); f0, f1 (k,) the values at the ends), by golden section on
    the convex function, with the convexity bound of the bracket: the secant through the
    two probes, extended, bounds f below outside them, and the secants through each probe
    and its bracket end bound it between them. An edge stops once that lower bound is
    above its pose's upper bound ``ub[P]`` (it cannot hold the pose's minimum; ``ub`` (m,)
    is lowered in place by the values found) or within ``tol`` (mm) of its best value,
    at most ``_GOLDEN_STEPS`` steps (0.618⁴⁰ ≈ 4·10⁻⁹ of the edge).

    Returns (value (k,), x (k,)) — the best value found and where; an edge stopped by the
    bound returns a value ≥ its minimum that is above its pose's final minimum."""
    k = len(E0)
    val = np.minimum(f0, f1)
    xv = np.where(f0 <= f1, 0.0, 1.0)
    g = _GOLDEN
    lo, hi = np.zeros(k), np.ones(k)
    flo, fhi = f0.copy(), f1.copy()
    x1, x2 = np.full(k, 1.0 - g), np.full(k, g)
    v1 = _posed_sd(part, E0 + x1[:, None] * D, t, a)
    v2 = _posed_sd(part, E0 + x2[:, None] * D, t, a)
    idx = np.arange(k)
    for step in range(_GOLDEN_STEPS + 1):
        left = v1 <= v2
        up = np.where(left, v1, v2)
        xu = np.where(left, x1, x2)
        better = up < val[idx]
        val[idx[better]] = up[better]
        xv[idx[better]] = xu[better]
        np.minimum.at(ub, P[idx], up)
        # convexity lower bound of f over [lo, hi]
        s12 = (v2 - v1) / (x2 - x1)
        b_left = np.minimum(v1, v1 - s12 * (x1 - lo))
        b_right = np.minimum(v2, v2 + s12 * (hi - x2))
        sa = (v1 - flo) / (x1 - lo)
        sb = (fhi - v2) / (hi - x2)
        den = sa - sb
        xi = np.clip((v2 - sb * x2 - v1 + sa * x1) / np.where(den != 0, den, 1.0), x1, x2)
        mid = np.minimum(np.minimum(np.maximum(v1, v2 + sb * (x1 - x2)),
                                    np.maximum(v1 + sa * (x2 - x1), v2)),
                         np.where(den != 0, np.maximum(v1 + sa * (xi - x1), v2 + sb * (xi - x2)),
                                  np.inf))
        bound = np.minimum(np.minimum(b_left, b_right), mid)
        go = (bound <= ub[P[idx]]) & (val[idx] - bound > tol)
        if step == _GOLDEN_STEPS or not np.any(go):
            break
        if not np.all(go):
            idx, lo, hi, flo, fhi, x1, x2, v1, v2, left = (
                z[go] for z in (idx, lo, hi, flo, fhi, x1, x2, v1, v2, left))
        # left: [lo, x2] keeps x1 as its upper probe; right: [x1, hi] keeps x2 as its lower
        hi, fhi = np.where(left, x2, hi), np.where(left, v2, fhi)
        lo, flo = np.where(left, lo, x1), np.where(left, flo, v1)
        nx1 = hi - g * (hi - lo)
        nx2 = lo + g * (hi - lo)
        xn = np.where(left, nx1, nx2)
        fn = _posed_sd(part, E0[idx] + xn[:, None] * D[idx], t[idx], a[idx])
        x1, v1, x2, v2 = (np.where(left, nx1, x2), np.where(left, fn, v2),
                          np.where(left, x1, nx2), np.where(left, v1, fn))
    return val, xv


_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


# long on purpose: the bounded-error distance refinement of candidate pairs in one vectorised loop
def _refine(part, A, B, C, nrm, ok, tip, axis, P=None, ub=None):
    """Exact minimum (k,) of the posed part's signed distance over triangles (A, B, C), and
    the (k, 3) triangle point where it is taken (module docstring).

    With ``P`` (k,) pose index per pair and ``ub`` (m,) upper bounds of the poses'
    clearances (lowered in place), work that cannot beat a pose's bound is skipped: cheap
    candidates first (vertices, the interior), then only the edges whose Lipschitz lower
    bound (f0 + f1 − L) / 2 reaches the bound are searched, and after 12 golden steps only
    those whose bracket bound max(f1, f2) − (hi − lo) L still does. A pair so skipped
    returns a value ≥ its true minimum that is above the pose's final minimum."""
    k = len(A)
    if P is None:
        P = np.arange(k)
        ub = np.full(k, np.inf)
    best = np.full(k, np.inf)
    where = np.zeros((k, 3))

    def offer(val, pts, sel=None):
        nonlocal best, where
        if sel is None:
            better = val < best
            best = np.where(better, val, best)
            where = np.where(better[:, None], pts, where)
        else:  # sel may repeat a pair (its three edges): the smallest value per pair
            order = np.lexsort((val, sel))
            first = np.ones(len(order), bool)
            first[1:] = sel[order][1:] != sel[order][:-1]
            o = order[first]
            better = val[o] < best[sel[o]]
            best[sel[o][better]] = val[o][better]
            where[sel[o][better]] = pts[o][better]

    fv = [_posed_sd(part, X, tip, axis) for X in (A, B, C)]
    for X, f in zip((A, B, C), fv, strict=True):
        offer(f, X)
    # interior: support points along ±n
    n = nrm
    ym = _posed_support(part, -n, tip, axis)
    yp = _posed_support(part, n, tip, axis)
    hm = np.einsum("ij,ij->i", ym - A, n)
    hp = np.einsum("ij,ij->i", yp - A, n)
    above = ok & (hm > 0)
    q = ym - hm[:, None] * n
    hit = above & _inside_tri(q, A, B, C, n)
    offer(np.where(hit, hm, np.inf), q)
    below = ok & (hp < 0)
    q = yp - hp[:, None] * n
    hit_b = below & _inside_tri(q, A, B, C, n)
    offer(np.where(hit_b, -hp, np.inf), q)
    # the part on one side of T's plane: its distance to the plane bounds sd over all of T
    # (edges included); with the foot inside T that bound is T's minimum itself
    plane_lb = np.where(above, hm, np.where(below, -hp, -np.inf))
    solved = hit | hit_b
    cuts = np.nonzero(ok & ~above & ~below)[0]
    if len(cuts):
        c_ = cuts
        Ac, Bc, Cc, nc, tc, ac = A[c_], B[c_], C[c_], n[c_], tip[c_], axis[c_]
        w = -hm[c_] / np.where(hp[c_] - hm[c_] > 0, hp[c_] - hm[c_], 1.0)
        q = ym[c_] + w[:, None] * (yp[c_] - ym[c_])
        hit = _inside_tri(q, Ac, Bc, Cc, nc)
        offer(np.where(hit, _posed_sd(part, q, tc, ac), np.inf), q, c_)
        # penetration candidates: where the axis line crosses the plane, and the feet on the
        # plane of the axis points at the part's bottom, middle and top, inside T
        na = np.einsum("ij,ij->i", nc, ac)
        good = np.abs(na) > 1e-9
        tl = np.einsum("ij,ij->i", Ac - tc, nc) / np.where(good, na, 1.0)
        q = tc + tl[:, None] * ac
        hit = good & _inside_tri(q, Ac, Bc, Cc, nc)
        offer(np.where(hit, _posed_sd(part, q, tc, ac), np.inf), q, c_)
        for zz in (part.z0, 0.5 * (part.z0 + part.z1), part.z1):
            M = tc + zz * ac
            q = M - np.einsum("ij,ij->i", M - Ac, nc)[:, None] * nc
            hit = _inside_tri(q, Ac, Bc, Cc, nc)
            offer(np.where(hit, _posed_sd(part, q, tc, ac), np.inf), q, c_)
    np.minimum.at(ub, P, best)
    # edges: golden section on the convex sd along each edge, pruned by the bounds
    E0 = np.vstack([A, B, C])
    D = np.vstack([B, C, A]) - E0
    F0 = np.concatenate(fv)
    F1 = np.concatenate([fv[1], fv[2], fv[0]])
    L = np.linalg.norm(D, axis=1)
    PP = np.tile(P, 3)
    lb3 = np.maximum(0.5 * (F0 + F1 - L), np.tile(plane_lb, 3))
    act = np.nonzero((lb3 <= ub[PP]) & ~np.tile(solved, 3))[0]
    if len(act):
        val, x = _edge_minima(part, E0[act], D[act], np.tile(tip, (3, 1))[act],
                              np.tile(axis, (3, 1))[act], F0[act], F1[act], PP[act], ub)
        pair = np.tile(np.arange(k), 3)[act]
        offer(val, E0[act] + x[:, None] * D[act], pair)
    np.minimum.at(ub, P, best)
    return best, where


# ====================================================================== detection
@dataclass
class Detection:
    """Per-pose collision figures.

    Attributes
    ----------
    clearance : (m,) float, mm — signed clearance (< 0: penetration depth), capped at
        ``cap`` for poses with nothing closer
    obstacle : (m,) int — index into ``Obstacles.meshes`` of the nearest obstacle (−1: none
        within the cap)
    part : (m,) int8 — ``PART_FLUTE`` (0) or ``PART_BODY`` (1), −1 for none
    point : (m, 3) float, mm — the closest point on the obstacle (NaN for none)
    normal : (m, 3) float — unit normal of the obstacle triangle holding ``point``, turned
        toward the tool axis (NaN for none)
    safety : float, mm — ds
    cap : float, mm
    """

    clearance: np.ndarray
    obstacle: np.ndarray
    part: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    safety: float
    cap: float

    @property
    def colliding(self) -> np.ndarray:
        """(m,) bool: clearance < ds."""
        return self.clearance < self.safety

    def __len__(self) -> int:
        return len(self.clearance)


class _Copies:
    """One triangle tree and the rigid copies of it that are obstacles: the blade and its
    neighbours (copy c is the blade turned by ``angles[c]`` about the blisk axis), or the
    extra meshes (one copy, the identity; each triangle's owner is its obstacle).

    A copy is queried by turning the poses back onto the tree (tip and axis by −angle):
    distances are invariant under the rotation, so one tree over the blade serves every
    neighbour, and the contact point and normal found are turned forward again."""

    def __init__(self, tree: _TriTree, axis: Axis, angles, obstacles, blade: bool):
        self.tree = tree
        self.blade = blade
        self.o = np.asarray(axis.o, dtype=np.float64)
        self.obst = np.asarray(obstacles, dtype=np.int64)  # obstacle index per copy
        self.R = np.stack([_rotation_matrix(axis, a) for a in angles])  # (c, 3, 3)
        self.identity = not blade

    @property
    def n_copies(self) -> int:
        return len(self.R)

    def queries(self, tips, axes):
        """(tips (c·m, 3), axes (c·m, 3), pose (c·m,), copy (c·m,)) of every pose turned back
        onto the tree for each copy, copy-major (copy c's queries are rows c·m … c·m + m)."""
        m = len(tips)
        if self.identity:
            return tips, axes, np.arange(m), np.zeros(m, dtype=np.int64)
        rel = tips - self.o
        tq = np.concatenate([rel @ R for R in self.R]) + self.o  # Rᵀ x, row-wise
        aq = np.concatenate([axes @ R for R in self.R])
        c = len(self.R)
        return tq, aq, np.tile(np.arange(m), c), np.repeat(np.arange(c), m)

    def obstacle(self, cid, T):
        """(k,) obstacle index of triangle T (k,) of copy cid (k,)."""
        return self.tree.owner[T] if self.identity else self.obst[cid]

    def to_world(self, cid, points, normals):
        """Points and normals (k, 3) found on copy cid (k,) in the tree's frame, turned
        onto the copy."""
        if self.identity:
            return points, normals
        R = self.R[cid]
        return (np.einsum("kij,kj->ki", R, points - self.o) + self.o,
                np.einsum("kij,kj->ki", R, normals))


def _rotation_matrix(axis: Axis, angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` (rad) about the direction ``axis.d`` (Rodrigues), the
    matrix of :func:`rotate_about_axis` (about the origin ``axis.o``)."""
    d = np.asarray(axis.d, dtype=np.float64)
    c, s = math.cos(angle), math.sin(angle)
    K = np.array([[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]])
    return c * np.eye(3) + s * K + (1.0 - c) * np.outer(d, d)


def _copy_angle(obstacles: Obstacles, i: int):
    """The angle (rad) by which ``obstacles.meshes[i]`` is the blade turned about the axis,
    or None when it is not (exactly) such a copy."""
    blade, ob = obstacles.meshes[0], obstacles.meshes[i]
    j = (i + 1) // 2
    angle = (1 if i % 2 else -1) * j * 2.0 * math.pi / obstacles.blade_count
    if ob.F.shape != blade.F.shape or ob.V.shape != blade.V.shape or \
            not (ob.F is blade.F or np.array_equal(ob.F, blade.F)):
        return None
    # the copies of Obstacles.build are bit for bit these; others within rounding
    turned = rotate_about_axis(blade.V, obstacles.axis, angle)
    if not np.array_equal(turned, ob.V):
        scale = max(1.0, float(np.abs(blade.V - obstacles.axis.o).max()))
        if float(np.abs(turned - ob.V).max()) > 1e-12 * scale:
            return None
    return angle


def _obstacle_groups(obstacles: Obstacles):
    """[_Copies]: the blade with the neighbours that are its rotated copies, then one group
    over every other obstacle (the extra meshes, and any neighbour given as its own mesh)."""
    meshes = obstacles.meshes
    angles, idx, other = [0.0], [0], []
    for i in range(1, len(meshes)):
        a = _copy_angle(obstacles, i) if i < obstacles.extra_start else None
        if a is None:
            other.append(i)
        else:
            angles.append(a)
            idx.append(i)
    blade = meshes[0]
    tree = _TriTree(blade.V, blade.F, np.zeros(blade.n_triangles, dtype=np.int64))
    groups = [_Copies(tree, obstacles.axis, angles, idx, blade=True)]
    if other:
        base = np.cumsum([0] + [len(meshes[i].V) for i in other])
        V = np.concatenate([meshes[i].V for i in other])
        F = np.concatenate([meshes[i].F + b for i, b in zip(other, base, strict=False)])
        owner = np.concatenate([np.full(meshes[i].n_triangles, i, dtype=np.int64)
                                for i in other])
        groups.append(_Copies(_TriTree(V, F, owner), obstacles.axis, [0.0], [-1],
                              blade=False))
    return groups


class CollisionScene:
    """Obstacles, cutter and assembly with the triangle trees built once (reused by the
    avoidance iterations).

    Parameters
    ----------
    obstacles : Obstacles
    cutter : Cutter (or anything :func:`.cutter.as_cutter` reads)
    assembly : ToolAssembly
    """

    def __init__(self, obstacles: Obstacles, cutter, assembly: ToolAssembly):
        if not isinstance(assembly, ToolAssembly):
            raise CollisionError("collision check needs a ToolAssembly (flute length, holder "
                                 "profile, safety)")
        self.obstacles = obstacles
        self.cutter = as_cutter(cutter)
        self.assembly = assembly
        self.safety = float(assembly.safety)
        self.cap = self.safety + CAP_MARGIN
        self.flute = _Flute(self.cutter, assembly.flute_length)
        self.body = [_Frustum(*f) for f in assembly.frustums()]
        self._groups = _obstacle_groups(obstacles)

    def parts(self, flute_on_target: bool = False):
        """[(part, groups)]: the flute against the non-target obstacles (against all with
        ``flute_on_target``), the body frustums against all; ``groups`` is a list of
        (:class:`_Copies`, first copy) — the flute skips copy 0 of the blade (the target blade
        itself) unless ``flute_on_target``."""
        skip = 0 if flute_on_target else 1
        fl = [(g, skip if g.blade else 0) for g in self._groups
              if not g.blade or g.n_copies > skip]
        out = [(self.flute, fl)] if fl else []
        return out + [(f, [(g, 0) for g in self._groups]) for f in self.body]

    # long on purpose: candidates of every part and obstacle group, the per-pose pruning and the
    # exact refinement share the per-pose bounds; split, they would pass a dozen arrays around
    def _chunk(self, tips, axes, flute_on_target=False):
        m = len(tips)
        ub = np.full(m, self.cap)
        queries = {id(g): g.queries(tips, axes) for g in self._groups}
        cand = []
        for part, groups in self.parts(flute_on_target):
            for g, first in groups:
                tq, aq, pid, cid = (x[first * m:] for x in queries[id(g)])
                P, T, sdc, lb = g.tree.candidates(part, tq, aq, ub, pid,
                                                  far=self.safety + _FAR_MARGIN)
                if len(P):
                    cand.append((part, g, tq[P], aq[P], pid[P], cid[P], T, sdc, lb))
        best = np.full(m, self.cap)
        obst = np.full(m, -1, dtype=np.int64)
        kind = np.full(m, -1, dtype=np.int8)
        pt = np.full((m, 3), np.nan)
        nr = np.full((m, 3), np.nan)
        for part, g, tq, aq, P, cid, T, sdc, lb in cand:
            tree = g.tree
            keep = lb <= ub[P]
            tq, aq, P, cid, T, sdc, lb = (x[keep] for x in (tq, aq, P, cid, T, sdc, lb))
            if len(P) == 0:
                continue
            # a pose already known to penetrate (bound < 0) needs a depth, not the exact
            # deepest point: only its _PENETRATION_PAIRS triangles with the deepest centroids
            # are refined (a flat obstacle across a cap would otherwise tie over thousands of
            # them), and the centroid itself is offered (the pose's figure stays ≤ its bound)
            # ... and a pose whose lower bound is ≥ ds + _FAR_MARGIN is certainly clear:
            # only its _FAR_PAIRS most promising triangles are refined (its figure is then
            # within the bounds' gap, about the local triangle size, of the exact one)
            deep = ub[P] < 0
            bound = sdc <= ub[P] + 1e-12  # the centroid that gave the pose's bound: kept
            order = np.lexsort((np.where(deep, sdc, np.where(bound, -np.inf, lb)), P))
            tq, aq, P, cid, T, sdc, lb, deep = (x[order] for x in
                                                (tq, aq, P, cid, T, sdc, lb, deep))
            starts, sizes = _groups(P)
            start = np.repeat(starts, sizes)
            rank = np.arange(len(P)) - start
            far = np.minimum.reduceat(lb, starts)[np.repeat(np.arange(len(starts)), sizes)] \
                >= self.safety + _FAR_MARGIN
            keep = ~(deep | far) | (rank < np.where(deep, _PENETRATION_PAIRS, _FAR_PAIRS))
            beamed = (deep | far)[keep]
            tq, aq, P, cid, T, sdc = (x[keep] for x in (tq, aq, P, cid, T, sdc))
            d, w = _refine(part, tree.A[T], tree.B[T], tree.C[T], tree.nrm[T], tree.ok[T],
                           tq, aq, P, ub)
            cen = beamed & (sdc < d)
            d = np.where(cen, sdc, d)
            w = np.where(cen[:, None], tree.cen[T], w)
            order = np.lexsort((d, P))
            first = np.ones(len(P), bool)
            first[1:] = P[order][1:] != P[order][:-1]
            sel = order[first]
            sel = sel[d[sel] < best[P[sel]]]
            Ps, Ts, ws, ts, as_ = P[sel], T[sel], w[sel], tq[sel], aq[sel]
            best[Ps] = d[sel]
            obst[Ps] = g.obstacle(cid[sel], Ts)
            kind[Ps] = part.kind
            nn = tree.nrm[Ts]
            foot = ts + np.einsum("ij,ij->i", ws - ts, as_)[:, None] * as_
            side = np.einsum("ij,ij->i", nn, foot - ws)
            nn = np.where((side < 0)[:, None], -nn, nn)
            pt[Ps], nr[Ps] = g.to_world(cid[sel], ws, nn)
        return best, obst, kind, pt, nr

    def detect(self, tips, axes, *, chunk: int = _CHUNK, workers: int | None = None,
               progress=None, flute_on_target: bool = False) -> Detection:
        """Clearance of every pose (module docstring).

        Parameters
        ----------
        tips : (m, 3) float, mm — tool tip (CL) points
        axes : (m, 3) float — unit tool axes (tip → spindle)
        flute_on_target : bool — the flute counts against the target blade too (poses that do
            not cut it, e.g. rapids: there a touch of the flute is a gouge)
        chunk : int — poses per work unit
        workers : int or None — threads (default: up to 2)
        progress : callable(fraction) or None

        Returns
        -------
        Detection
        """
        tips = np.ascontiguousarray(tips, dtype=np.float64).reshape(-1, 3)
        axes = np.asarray(axes, dtype=np.float64).reshape(-1, 3)
        if len(axes) != len(tips):
            raise CollisionError(f"{len(tips)} tips but {len(axes)} axes")
        ln = np.linalg.norm(axes, axis=1)
        if not (np.all(np.isfinite(tips)) and np.all(np.isfinite(ln)) and np.all(ln > 0)):
            raise CollisionError("poses with NaN coordinates or zero tool axes cannot be checked")
        axes = axes / ln[:, None]
        m = len(tips)
        out = (np.full(m, self.cap), np.full(m, -1, np.int64), np.full(m, -1, np.int8),
               np.full((m, 3), np.nan), np.full((m, 3), np.nan))
        if m == 0:
            return Detection(*out, self.safety, self.cap)
        spans = [(s, min(s + chunk, m)) for s in range(0, m, chunk)]
        nw = workers or min(2, os.cpu_count() or 1)
        done = 0

        def work(span):
            s, e = span
            return span, self._chunk(tips[s:e], axes[s:e], flute_on_target)

        if nw > 1 and len(spans) > 1:
            with ThreadPoolExecutor(nw) as ex:
                results = ex.map(work, spans)
                for (s, e), res in results:
                    for o, r in zip(out, res, strict=True):
                        o[s:e] = r
                    done += e - s
                    if progress is not None:
                        progress(done / m)
        else:
            for span in spans:
                (s, e), res = work(span)
                for o, r in zip(out, res, strict=True):
                    o[s:e] = r
                done += e - s
                if progress is not None:
                    progress(done / m)
        return Detection(*out, self.safety, self.cap)


def detect_collisions(obstacles: Obstacles, cutter, assembly: ToolAssembly, tips, axes,
                      **kw) -> Detection:
    """Clearance of every pose against the obstacles (builds a :class:`CollisionScene`; reuse
    a scene for repeated checks). See :meth:`CollisionScene.detect`."""
    return CollisionScene(obstacles, cutter, assembly).detect(tips, axes, **kw)
