"""Surface-driven passes in the floor band: the cutter driven by contact points on the blades'
allowance offset between the hub and the level above the floor.

In the band between the floor and the level above it the level staircase cannot finish the
walls at the allowance: on the floor the bull nose's corner rides on the hub fillet and keeps
its side off the wall above, and the contour passes of the wall levels touch each wall where
their tilt and tip radius put the tool first, not where the fillet needs it. These passes turn
the planning round: the **contact** is chosen first, the pose follows.

**Contacts.** Rows at heights h_j above the hub (every ``step`` mm over the band), stations z_i
along the channel: the wall point of blade 0 facing the channel (+θ) at (z_i, r = hub(z_i) +
h_j) is estimated from the cylinder sections (:class:`.region.Section`, the largest θ of the
section's points near z_i, interpolated between the two sections round r); a point the
allowance off it is projected onto the blade mesh (exact closest point c), and the contact
normal is the unit vector n from c to the query point (the normal of the allowance offset
surface at q = c + a n, exact for the mesh, also across its edges and vertices). Blade 1's
wall (facing −θ) is the same with the query turned back by the pitch onto blade 0.

**Poses.** For each contact and each side tilt φ = φ_m(z) + δ (φ_m the blades' mean camber
lean of :mod:`.axis`; δ tried from 0 outward), the tool axis a is the radial direction tilted
by the lead and φ, and the tip touching q with normal n is q − p(n, a), p the cutter's contact
point (:meth:`..tool.cutter.Cutter.contact`; once more with the radial direction at the tip,
which is where the axis is defined). The pose is admitted by exact measures, not by the
region's envelope (whose disc model, smeared over a tilted tool's heights, keeps a bull
nose's corner a millimetre off a fillet): :class:`FluteCheck` — the cutter's outline up to a
tool radius above its corner at least the allowance (− 0.01 mm) from both blades' faces and
the hub allowance from the hub profile; where a neighbouring facet of a concave fillet comes
nearer, the tip is moved along n by the shortfall and checked again — and the region's bounds
(:func:`.region.channel_bounds`) for the rest of the flute and the body. The first δ that
passes is taken; along a row the tilt is limited to ``max_turn`` per station and the poses
whose tilt changed are computed and checked again. A row is split where a pose fails, the tip
jumps more than ``max_jump`` mm, or the tool half-way along a move over a curved wall comes
nearer than the check allows; consecutive runs are joined at feed by a checked detour (up the
axis, across, down), else linked as separate pieces.

**Spacing.** Two contacts ``step`` apart in height on the allowance offset of a concave
fillet of radius R_f, touched by a corner of radius r_c < R_f, leave a cusp of at most
δ² / (8 ρ), 1/ρ = 1/r_c − 1/R_f (the two circles' relative curvature), δ the contacts' distance
along the surface (``step`` / sin α, α the surface's angle to the hub); a flank contact on a
wall leaves none between rows (the flank covers the wall above its contact). With ``step`` =
0.5 mm, a 1 mm corner in a 4.5 mm offset fillet: ≤ 0.04 mm where α ≥ 45°, ≤ 0.12 mm at the
fillet's lowest row — where the normal is within 35° of the axis and the level step cusp
s |n · a| (s = 2 mm) is above 1.6 mm.

Units mm, radians.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from ..geometry.axis import Axis
from ..geometry.closest import segment_distance2_2d
from ..geometry.distance import MeshDistance
from ..geometry.mesh import TriMesh
from ..part.model import theta_about
from ..tool.cutter import Cutter
from .axis import limit_turn, tilted_axes
from .patterns import Piece, drop_straight, runs_of

__all__ = ["BandPoses", "FluteCheck", "band_contacts", "band_pieces", "band_poses",
           "wall_theta"]


def wall_theta(sections, z, radii_q, upper: bool, half: float = 0.2) -> np.ndarray:
    """(m, n) θ (rad, relative to the sections' reference) of blade 0's wall facing +θ
    (``upper``: the largest θ of each section near a station) or −θ (the least), at the
    stations ``z`` (n,) and query radii ``radii_q`` (m, n): linear between the two sections
    round each radius, NaN where either has no point within ``half`` mm of the station."""
    z = np.asarray(z, float)
    rc = np.array([s.radius for s in sections])
    W = np.full((len(sections), len(z)), np.nan)
    for k, sec in enumerate(sections):
        if len(sec.z) == 0:
            continue
        a = np.searchsorted(sec.z, z - half, "left")
        b = np.searchsorted(sec.z, z + half, "right")
        has = b > a
        if not has.any():
            continue
        a, b = a[has], b[has]
        cnt = b - a
        idx = np.repeat(a - np.cumsum(cnt) + cnt, cnt) + np.arange(int(cnt.sum()))
        starts = np.cumsum(cnt) - cnt
        red = np.maximum if upper else np.minimum
        W[k, has] = red.reduceat(sec.theta[idx], starts)
    R = np.asarray(radii_q, float)
    j = np.clip(np.searchsorted(rc, R) - 1, 0, len(rc) - 2)
    t = (R - rc[j]) / (rc[j + 1] - rc[j])
    cols = np.broadcast_to(np.arange(len(z)), R.shape)
    out = (1 - t) * W[j, cols] + t * W[j + 1, cols]
    return np.where((t >= -1e-9) & (t <= 1 + 1e-9), out, np.nan)


def _turn(points, axis: Axis, angle: float) -> np.ndarray:
    """(k, 3) ``points`` turned by ``angle`` (rad) about ``axis``."""
    e1, e2, d = axis.angular_frame()
    q = np.asarray(points, float) - axis.o
    zc, x, y = q @ d, q @ e1, q @ e2
    c, s = math.cos(angle), math.sin(angle)
    return axis.o + np.outer(zc, d) + np.outer(c * x - s * y, e1) + np.outer(s * x + c * y, e2)


def _held(th, z, hold: float) -> np.ndarray:
    """(m, n) ``th`` with each row's NaN stations within ``hold`` mm of a finite one given
    the nearest finite value (beyond a leading or trailing edge: the query then finds the
    edge's nose)."""
    out = th.copy()
    for j in range(th.shape[0]):
        f = np.nonzero(np.isfinite(th[j]))[0]
        if len(f) == 0:
            continue
        pos = np.clip(np.searchsorted(f, np.arange(len(z))), 0, len(f) - 1)
        left = f[np.clip(pos - 1, 0, len(f) - 1)]
        right = f[pos]
        near = np.where(np.abs(z[left] - z) <= np.abs(z[right] - z), left, right)
        use = ~np.isfinite(th[j]) & (np.abs(z[near] - z) <= hold)
        out[j, use] = th[j, near[use]]
    return out


def band_contacts(V, F, axis: Axis, sections, theta_ref: float, pitch: float, z, hub_r,
                  heights, allowance: float, hold: float = 1.5):
    """The contacts of the rows (module docstring) on both walls: a list of two
    (q (m, n, 3), n (m, n, 3), ok (m, n)) — blade 0's wall facing +θ, then blade 1's facing
    −θ — over rows at ``heights`` (m,) mm above the hub radii ``hub_r`` (n,) at stations
    ``z`` (n,); q on the allowance offset, n its unit normal into the channel. Within
    ``hold`` mm beyond a wall's end (the edges' noses) the nearest station's wall angle is
    held for the query."""
    z = np.asarray(z, float)
    H = np.asarray(heights, float)
    R = np.asarray(hub_r, float)[None, :] + H[:, None]
    e1, e2, d = axis.angular_frame()
    dist = MeshDistance(TriMesh.from_arrays(np.asarray(V, float), np.asarray(F, np.int64)))
    out = []
    for upper in (True, False):
        th = _held(wall_theta(sections, z, R, upper), z, hold)
        ok = np.isfinite(th)
        # the query point the allowance off the estimated wall, into the channel
        thq = np.where(ok, th, 0.0) + (1.0 if upper else -1.0) * allowance / R + theta_ref
        zz = np.broadcast_to(z, R.shape)
        p = (axis.o + zz[..., None] * d + (R * np.cos(thq))[..., None] * e1
             + (R * np.sin(thq))[..., None] * e2).reshape(-1, 3)
        cp = dist.query(p)
        v = p - cp.point
        ln = np.linalg.norm(v, axis=1)
        nrm = v / np.maximum(ln, 1e-300)[:, None]
        nrm *= np.where(cp.sign < 0, -1.0, 1.0)[:, None]
        q = cp.point + allowance * nrm
        # the normal must face the channel side of this wall
        _, thc, _ = theta_about(cp.point, axis)
        tang = np.stack([-np.sin(thc), np.cos(thc), np.zeros_like(thc)], 1) @ \
            np.stack([e1, e2, d])
        facing = (nrm * tang).sum(axis=1) * (1.0 if upper else -1.0) > 0.0
        good = ok.ravel() & (ln > 1e-9) & facing
        if not upper:  # blade 1 is blade 0 turned by the pitch
            q = _turn(q, axis, pitch)
            nrm = _turn(nrm + axis.o, axis, pitch) - _turn(axis.o[None], axis, pitch)
        out.append((q.reshape(R.shape + (3,)), nrm.reshape(R.shape + (3,)),
                    good.reshape(R.shape)))
    return out


class BandPoses:
    """Poses of the rows of one wall: ``tip`` (m, n, 3), ``axis`` (m, n, 3), ``ok`` (m, n),
    ``side`` (m, n) the side tilt (rad), ``jump`` (m, n − 1) True where the tip moves more
    than the largest jump to the next."""

    __slots__ = ("tip", "axis", "ok", "side", "jump")

    def __init__(self, tip, axis, ok, side, jump):
        self.tip, self.axis, self.ok, self.side, self.jump = tip, axis, ok, side, jump


class FluteCheck:
    """The cutter's flute against the blades' allowance and the hub's: points on the
    cutter's outline (the bottom, the corner arc and the side up to the flute length every
    ``spacing`` mm, on rings of ``ring`` points: a ring's chord sags by R (1 − cos(π/ring)),
    0.009 mm for R = 4 and 48 points) against blade 0's surface (and blade 1's: the points
    turned back by the pitch) sampled every ``sample`` mm on its faces: a point's distance is
    taken to the tangent plane of its nearest sample (exact on a face; the curvature's error
    over a sample spacing is second order), and less the outline's ``sag`` (the ring's chord
    and the corner arc's: what the samples can miss, 0.015 mm for a Ø8 R1 bull nose) must be
    at least the allowance − ``tol``, so that the exact distance keeps the allowance − ``tol``
    − that second-order term (≤ 0.02 mm in all, 0.023 before the sag was counted); beside a
    convex edge of radius ρ the distance along the ring also rises by about
    s² / 2 · (1/R + 1/(ρ + a)) off its least (s the ring's step), so the ring is refined
    round each pose's nearest points (:meth:`FluteCheck._refined`, ≤ 0.009 mm then); the
    hub's by the exact distance to its profile (a polyline (r, z)) with the hub allowance.
    Up the side to ``height`` mm above the tip (None: the flute length); the tool above it
    is the caller's (the region's bounds with the table's rows above that height)."""

    def __init__(self, cutter: Cutter, V, F, axis: Axis, pitch: float, hub_profile,
                 allowance: float, hub_allowance: float, tol: float = 0.01,
                 spacing: float = 0.5, side_spacing: float = 1.0, ring: int = 48,
                 sample: float = 0.25, height: float | None = None):
        prof = cutter.profile(8)
        nb = max(2, int(cutter.e / spacing) + 1)
        rows = [np.stack([np.linspace(0.0, cutter.e, nb), np.zeros(nb)], 1), prof[1:-1]]
        top = float(prof[-2, 1])
        h_top = cutter.h if height is None else min(float(height), cutter.h)
        k = max(2, int(math.ceil((h_top - top) / side_spacing)) + 1)
        rows.append(np.stack([np.full(k, cutter.max_radius), np.linspace(top, h_top, k)], 1))
        self.prof = np.vstack(rows)
        self.phi = np.linspace(0.0, 2 * math.pi, ring, endpoint=False)
        # what the sampled outline can miss: a point of the surface of revolution between two
        # ring points lies up to ρ (1 − cos(π/ring)) nearer than their chord, one between two
        # points of the corner arc up to r − √(r² − (c/2)²) (c their distance); the lines
        # (bottom, side) miss nothing against a plane
        centre = np.array([cutter.e, cutter.f])
        on_arc = np.abs(np.linalg.norm(self.prof - centre, axis=1) - cutter.r) < 1e-9
        both = on_arc[:-1] & on_arc[1:] & (cutter.r > 0)
        chord = np.linalg.norm(np.diff(self.prof, axis=0), axis=1)[both]
        arc_sag = float((cutter.r - np.sqrt(np.maximum(cutter.r ** 2 - 0.25 * chord ** 2, 0.0))
                         ).max()) if both.any() else 0.0
        # round each pose's nearest points (within ``NEAR`` of its least) the ring is refined
        # ``REFINE`` times: a convex edge of radius ρ beside the cutter makes the distance
        # along the ring rise by about s² / 2 · (1/R + 1/(ρ + a)) off its least (s the arc from
        # it), up to 0.08 mm between 48 points on R = 4 at the allowance 0.5 (and ρ → 0), so
        # the ring's sag is the refined one's and the convex miss ≤ 0.009 mm
        self.ring = int(ring)
        self.sag = float(self.prof[:, 0].max()) * (
            1.0 - math.cos(math.pi / (ring * self.REFINE))) + arc_sag
        # the outline's points (row-major) of the rows up to the corner + R sin 30°
        low_h = cutter.f + cutter.max_radius * 0.5 + 1e-9
        self.n_low = int((self.prof[:, 1] <= low_h).sum()) * ring
        V, F = np.asarray(V, float), np.asarray(F, np.int64)
        A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        nrm = np.cross(B - A, C - A)
        ln = np.linalg.norm(nrm, axis=1)
        keep = ln > 1e-12
        A, B, C, nrm = A[keep], B[keep], C[keep], nrm[keep] / ln[keep][:, None]
        # samples on each face: a barycentric grid fine enough for its longest edge
        L = np.maximum.reduce([np.linalg.norm(B - A, axis=1), np.linalg.norm(C - B, axis=1),
                               np.linalg.norm(A - C, axis=1)])
        m = np.maximum(1, np.ceil(L / sample).astype(int))
        pts, nn = [], []
        for mm in np.unique(m):
            f = np.nonzero(m == mm)[0]
            i, j = np.meshgrid(np.arange(mm + 1), np.arange(mm + 1), indexing="ij")
            ok = i + j <= mm
            u, v = (i[ok] / mm)[None, :, None], (j[ok] / mm)[None, :, None]
            P = A[f][:, None] + u * (B - A)[f][:, None] + v * (C - A)[f][:, None]
            pts.append(P.reshape(-1, 3))
            nn.append(np.repeat(nrm[f], P.shape[1], axis=0))
        S, N = np.vstack(pts), np.vstack(nn)
        # blade 1: blade 0 turned by the pitch (one tree for both walls)
        o = axis.o
        self.S = np.vstack([S, _turn(S, axis, pitch)])
        self.N = np.vstack([N, _turn(N + o, axis, pitch) - _turn(o[None], axis, pitch)])
        self.tree = cKDTree(self.S)
        # the query's reach: a point farther than the allowance + 0.3 mm from every sample is
        # more than the allowance from the surface (samples at most ``sample`` / √3 from any
        # point of a face); the voxels (edge: the reach) within one voxel of a sample: a
        # point outside them is farther than the reach from every sample, and is not queried
        self.vox = float(allowance) + 0.3
        self.o = self.S.min(axis=0) - 2 * self.vox
        base = np.unique(self._keys(self.S))
        near = [base + self._key(di, dj, dk) for di in (-1, 0, 1) for dj in (-1, 0, 1)
                for dk in (-1, 0, 1)]
        self.keys = np.unique(np.concatenate(near))
        self.axis, self.pitch = axis, float(pitch)
        self.hub = np.asarray(hub_profile, float)
        self.a, self.ha, self.tol = float(allowance), float(hub_allowance), float(tol)

    REFINE = 3
    NEAR = 0.1

    @staticmethod
    def _uv(ax):
        ref = np.where(np.abs(ax[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
        u = np.cross(ax, ref)
        u /= np.linalg.norm(u, axis=1)[:, None]
        return u, np.cross(ax, u)

    def points(self, tip, ax):
        """(k, p, 3) points on the outline of the cutters at ``tip`` (k, 3), ``ax`` (k, 3)."""
        u, v = self._uv(ax)
        c, s = np.cos(self.phi), np.sin(self.phi)
        ring = c[None, :, None] * u[:, None] + s[None, :, None] * v[:, None]  # (k, q, 3)
        rho, h = self.prof[:, 0], self.prof[:, 1]
        P = (tip[:, None, None] + h[None, :, None, None] * ax[:, None, None]
             + rho[None, :, None, None] * ring[:, None])
        return P.reshape(len(tip), -1, 3)

    def clearance(self, tip, ax) -> np.ndarray:
        """(k,) the least of (distance to the hub − hub allowance) and (distance to a blade −
        allowance) over the outline's points, less the outline's ``sag`` (what the ring and
        the arc's chords can miss) (mm; ≥ −tol passes); the blades are not looked at where
        the hub already fails."""
        k = len(tip)
        out = np.full(k, np.inf)
        for c0 in range(0, k, 256):
            sl = slice(c0, min(k, c0 + 256))
            P = self.points(tip[sl], ax[sl])
            out[sl] = self._hub(P)
            live = np.nonzero(out[sl] - self.sag >= -self.tol)[0]
            if len(live):
                o = out[sl]
                o[live] = np.minimum(o[live], self._refined(tip[sl][live], ax[sl][live],
                                                            P[live]))
                out[sl] = o
        return out - self.sag

    def _refined(self, tip, ax, P) -> np.ndarray:
        """(k,) :meth:`_blades` of the outline points ``P`` (k, p, 3) of the poses, the ring
        refined :data:`REFINE` times round the points within :data:`NEAR` of each pose's
        least."""
        d = self._blade_points(P)
        best = d.min(axis=1)
        i, j = np.nonzero(d < best[:, None] + self.NEAR)
        if len(i) == 0 or self.REFINE < 2:
            return best
        row, q = np.divmod(j, self.ring)
        rho, h = self.prof[row, 0], self.prof[row, 1]
        u, v = self._uv(ax)
        step = 2 * math.pi / self.ring
        X, own = [], []
        for f in range(1, self.REFINE):
            for sgn in (-1.0, 1.0):
                ph = self.phi[q] + sgn * step * f / self.REFINE
                X.append(tip[i] + h[:, None] * ax[i] + rho[:, None] * (
                    np.cos(ph)[:, None] * u[i] + np.sin(ph)[:, None] * v[i]))
                own.append(i)
        dx = self._blade_points(np.vstack(X)[:, None, :])[:, 0]
        np.minimum.at(best, np.concatenate(own), dx)
        return best

    _K = 1 << 20

    def _key(self, i, j, k):
        return (np.asarray(i, np.int64) * self._K + j) * self._K + k

    def _keys(self, P) -> np.ndarray:
        ijk = np.floor((P - self.o) / self.vox).astype(np.int64)
        ijk = np.clip(ijk, 0, self._K - 1)
        return self._key(ijk[:, 0], ijk[:, 1], ijk[:, 2])

    def _blades(self, P) -> np.ndarray:
        return self._blade_points(P).min(axis=1)

    def _blade_points(self, P) -> np.ndarray:
        """(k, p) distance − allowance of each point of ``P`` (k, p, 3) to the blades (+inf
        beyond the reach)."""
        k, npt = P.shape[:2]
        flat = P.reshape(-1, 3)
        out = np.full(k * npt, np.inf)
        keys = self._keys(flat)
        pos = np.clip(np.searchsorted(self.keys, keys), 0, len(self.keys) - 1)
        cand = np.nonzero(self.keys[pos] == keys)[0]
        dd, ii = self.tree.query(flat[cand], distance_upper_bound=self.vox)
        sel = np.nonzero(np.isfinite(dd))[0]
        if len(sel):
            c = cand[sel]
            out[c] = np.einsum("ij,ij->i", flat[c] - self.S[ii[sel]], self.N[ii[sel]]) - self.a
        return out.reshape(k, npt)

    def _hub(self, P) -> np.ndarray:
        # only the rows of the outline that a tilt up to 30° brings near the hub
        k = P.shape[0]
        out = np.full(k, np.inf)
        low = P[:, :self.n_low].reshape(-1, 3)
        owner = np.repeat(np.arange(k), self.n_low)
        r, _, z = theta_about(low, self.axis)
        H = self.hub
        hr = np.interp(z, H[:, 1], H[:, 0])
        sel = np.nonzero(r < hr + self.ha + 1.0)[0]
        if len(sel):
            d2 = np.full(len(sel), np.inf)
            for a, b in zip(H[:-1], H[1:], strict=True):
                d2 = np.minimum(d2, segment_distance2_2d(r[sel], z[sel], a[0], a[1], b[0],
                                                         b[1]))
            d = np.where(r[sel] >= hr[sel], np.sqrt(d2), -np.sqrt(d2))
            np.minimum.at(out, owner[sel], d - self.ha)
        return out


def _poses(cutter: Cutter, axis: Axis, q, n, side, lead: float, check, body,
           nudges: int = 2):
    """Poses touching q (k, 3) with normals n at side tilts ``side`` (k,): (tip (k, 3),
    axis (k, 3), ok (k,)). ``check`` a :class:`FluteCheck`; ``body(tip, axis)`` → (k,) bool
    the body clear. Where the flute comes nearer than the allowance − tol elsewhere (a
    faceted concave fillet's neighbouring faces), the tip is moved along n by the shortfall
    and checked again (``nudges`` times)."""
    _, thq, _ = theta_about(q, axis)
    _, a = tilted_axes(axis, thq, lead, side)
    ok = np.einsum("ij,ij->i", n, a) > 1e-3
    nn = np.where(ok[:, None], n, a)
    tip = q + cutter.contact(nn, a)[0]
    _, tht, _ = theta_about(tip, axis)
    _, a = tilted_axes(axis, tht, lead, side)
    ok &= np.einsum("ij,ij->i", n, a) > 1e-3
    nn = np.where(ok[:, None], n, a)
    tip = q + cutter.contact(nn, a)[0]
    live = np.nonzero(ok)[0]
    for it in range(nudges + 1):
        if len(live) == 0:
            break
        c = check.clearance(tip[live], a[live])
        bad = c < -check.tol
        if it == nudges:
            ok[live[bad]] = False
            break
        tip[live[bad]] += (-c[bad] + 0.5 * check.tol)[:, None] * n[live[bad]]
        live = live[bad]
    live = np.nonzero(ok)[0]
    if len(live):
        ok[live] &= body(tip[live], a[live])
    return tip, a, ok


def band_poses(cutter: Cutter, axis: Axis, contacts, lean, lead: float, check, body, deltas,
               max_turn: float, max_jump: float = 1.0) -> BandPoses:
    """The poses of one wall's rows (module docstring): ``contacts`` (q, n, ok) of
    :func:`band_contacts`, ``lean`` (n,) the mean camber lean per station (rad), ``deltas``
    the side tilts tried about it (rad, the smallest |δ| first), ``check`` and ``body`` as in
    :func:`_poses`."""
    q, nrm, good = contacts
    m, n = good.shape
    lean2 = np.broadcast_to(np.asarray(lean, float), (m, n)).ravel()
    qf, nf = q.reshape(-1, 3), nrm.reshape(-1, 3)
    pick = lean2.copy()
    tip = np.zeros((m * n, 3))
    ax = np.tile(np.array([1.0, 0.0, 0.0]), (m * n, 1))
    todo = np.nonzero(good.ravel())[0]
    found = np.zeros(m * n, bool)
    for dl in sorted(deltas, key=abs):
        if len(todo) == 0:
            break
        side = lean2[todo] + dl
        t_, a_, ok = _poses(cutter, axis, qf[todo], nf[todo], side, lead, check, body)
        done = todo[ok]
        found[done] = True
        pick[done], tip[done], ax[done] = side[ok], t_[ok], a_[ok]
        todo = todo[~ok]
    found = found.reshape(m, n)
    side = pick.reshape(m, n).copy()
    for j in range(m):  # the bounded turn along each row, run by run
        for a0, b0 in runs_of(found[j]):
            side[j, a0:b0] = limit_turn(side[j, a0:b0], max_turn)
    ok = found.ravel().copy()
    # the poses whose tilt the limit changed, again (the others are the poses checked)
    f = np.nonzero(ok & (side.ravel() != pick))[0]
    if len(f):
        tip[f], ax[f], ok[f] = _poses(cutter, axis, qf[f], nf[f], side.ravel()[f], lead,
                                      check, body)
    tip, ax, ok = tip.reshape(m, n, 3), ax.reshape(m, n, 3), ok.reshape(m, n)
    # a row is split where the tip jumps (not one straight move along the wall) and where the
    # tool half-way along a move (tip and axis the means) comes nearer than the check allows
    # (a move's chord across a convex wall: an edge's nose)
    move = np.linalg.norm(np.diff(tip, axis=1), axis=2)
    jump = move > max_jump
    # a straight move between two poses touching a wall whose contact normals turn by ψ over
    # the move's length L leaves the wall's offset by about L ψ / 8 (the chord's sag on a
    # circle of radius L / ψ): only moves where that exceeds a quarter of the tolerance are
    # checked half-way
    psi = np.arccos(np.clip(np.einsum("ijk,ijk->ij", nrm[:, :-1], nrm[:, 1:]), -1.0, 1.0))
    curved = move * psi / 8.0 > 0.25 * check.tol
    pair = np.nonzero((ok[:, :-1] & ok[:, 1:] & ~jump & curved).ravel())[0]
    if len(pair):
        jj, ii = np.divmod(pair, n - 1)
        mt = 0.5 * (tip[jj, ii] + tip[jj, ii + 1])
        ma = ax[jj, ii] + ax[jj, ii + 1]
        ma /= np.linalg.norm(ma, axis=1)[:, None]
        bad = (check.clearance(mt, ma) < -check.tol) | ~body(mt, ma)
        jump[jj[bad], ii[bad]] = True
    return BandPoses(tip, ax, ok, side, jump)


def _detour(t0, a0, t1, a1, lift: float, step: float):
    """Poses (k, 3), (k, 3) from the pose (t0, a0) up its axis by ``lift`` mm, across to the
    pose (t1, a1) lifted the same and down to it, every ≤ ``step`` mm (tips on the straight
    segments, axes the normalised blend), the two end poses excluded."""
    pts = [t0, t0 + lift * a0, t1 + lift * a1, t1]
    axs = [a0, a0, a1, a1]
    tips, axes = [], []
    for i in range(3):
        p, q, u, v = pts[i], pts[i + 1], axs[i], axs[i + 1]
        k = max(1, int(math.ceil(np.linalg.norm(q - p) / step)))
        t = (np.arange(1, k + 1) / k)[:, None]
        tips.append(p + t * (q - p))
        a = (1 - t) * u + t * v
        axes.append(a / np.linalg.norm(a, axis=1)[:, None])
    return np.vstack(tips)[:-1], np.vstack(axes)[:-1]


def band_pieces(level: int, bp: BandPoses, outside, forward: bool, check=None, body=None,
                lift: float = 2.0, step: float = 0.5):
    """[Piece] of the rows of one wall, from the top row down, consecutive rows in opposite
    directions starting ``forward`` (toward +z); each row split where a pose fails or the tip
    jumps (round a leading or trailing edge the contacts of neighbouring stations lie far
    apart: a lone pose is reached down its axis — the footprints of a tool radius round
    poses a station apart overlap). With ``check`` (:class:`FluteCheck`) and ``body`` (as in
    :func:`_poses`), consecutive runs are joined at feed by a detour — up the axis by
    ``lift`` mm, across, down — where every pose of it, every ≤ ``step`` mm, passes both
    (the rows of a wall become a few pieces instead of a retract, rapid and approach each).
    Returns (pieces, forward) for what follows to continue from."""
    seq = []  # (row, station indices) in cutting order
    for j in range(bp.ok.shape[0] - 1, -1, -1):
        runs = []
        for a0, b0 in runs_of(bp.ok[j]):
            cuts = [a0] + [int(i) + a0 + 1 for i in np.nonzero(bp.jump[j, a0:b0 - 1])[0]] + [b0]
            runs.extend(zip(cuts[:-1], cuts[1:], strict=True))
        if not runs:
            continue
        if not forward:
            runs = runs[::-1]
        for a0, b0 in runs:
            seq.append((j, np.arange(a0, b0) if forward else np.arange(b0 - 1, a0 - 1, -1)))
        forward = not forward
    if not seq:
        return [], forward
    # the detours between consecutive runs, all checked at once
    joins = np.zeros(len(seq) - 1, bool)
    detours = []
    if check is not None and len(seq) > 1:
        owner, T, A = [], [], []
        for i in range(len(seq) - 1):
            (j0, i0), (j1, i1) = seq[i], seq[i + 1]
            t, a = _detour(bp.tip[j0, i0[-1]], bp.axis[j0, i0[-1]], bp.tip[j1, i1[0]],
                           bp.axis[j1, i1[0]], lift, step)
            detours.append((t, a))
            owner.append(np.full(len(t), i))
            T.append(t)
            A.append(a)
        owner, T, A = np.concatenate(owner), np.vstack(T), np.vstack(A)
        good = (check.clearance(T, A) >= -check.tol) & body(T, A)
        bad = np.zeros(len(seq) - 1, bool)
        np.logical_or.at(bad, owner, ~good)
        joins = ~bad
    pieces = []
    tips, axes, first = [], [], None
    for i, (j, idx) in enumerate(seq):
        if first is None:
            first = idx[0]
        if len(idx) > 1:
            idx = idx[drop_straight(bp.tip[j, idx], bp.axis[j, idx])]
        tips.append(bp.tip[j, idx])
        axes.append(bp.axis[j, idx])
        if i < len(joins) and joins[i]:
            tips.append(detours[i][0])
            axes.append(detours[i][1])
            continue
        t, a = np.vstack(tips), np.vstack(axes)
        if len(t) == 1:  # a lone pose: reached and left along its axis
            t, a = np.repeat(t, 2, axis=0), np.repeat(a, 2, axis=0)
        pieces.append(Piece(t, a, level, (bool(outside[first]), bool(outside[idx[-1]])),
                            band=True))
        tips, axes, first = [], [], None
    return pieces, forward
