"""The blisk as a part: axis, blade count N, the blade surface, the hub surface and the
meridional envelope the stock is cut around (paper 003 §5: the whole process starts from a
forged disk that holds the envelope of the part).

A :class:`BliskPart` is built three ways:

* :func:`part_from_demo` — the parametric demo blisk (:mod:`.blisk`);
* :func:`part_from_blade` — one blade mesh and a hub profile (r, z polyline, e.g. a CSV);
* :func:`split_blisk_mesh` — a whole-blisk mesh split into hub and blades.

Splitting a whole blisk: the hub is the set of *faces of revolution* about the axis — a face
whose normal lies in the meridional plane (|n · e_θ| small) and whose vertices lie on one
revolved (r, z) profile within a tolerance; the profile is fitted to those candidate faces of
the mesh parts (connected components) that wrap around the axis. Every other face is a blade
face. The blade count comes from the rotational symmetry of the blade faces: the Fourier
series of their area over the angle θ has non-zero harmonics only at multiples of N, so N is
the greatest common divisor of the significant harmonics (and the mesh is not periodic when
harmonics off those multiples carry weight). Blade faces are then grouped by angular sector
(connected components of blade faces, each to the pitch 2π/N it lies in).

Units: mm, radians. Angles θ about the axis follow :meth:`..geometry.axis.Axis.angular_frame`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import PartError
from ..geometry.axis import Axis
from ..geometry.closest import segment_distance2_2d
from ..geometry.mesh import triangle_normals
from .blisk import DemoBlisk

__all__ = ["BliskPart", "BliskSplit", "blade_count_from_symmetry", "part_from_blade",
           "part_from_demo", "read_rz_csv", "split_blisk_mesh", "theta_about"]

TWO_PI = 2.0 * math.pi


def theta_about(points, axis: Axis):
    """(r, θ, z) of (n, 3) points about ``axis``: mm, radians in (−π, π], mm (θ from the
    axis' angular frame e1 toward e2)."""
    e1, e2, d = axis.angular_frame()
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3) - axis.o
    x, y, z = p @ e1, p @ e2, p @ d
    return np.hypot(x, y), np.arctan2(y, x), z


@dataclass
class BliskPart:
    """A blisk: one blade (the others are its copies turned by k · 2π/N), the hub, the envelope.

    Attributes
    ----------
    axis : Axis
    blade_count : int — N ≥ 1
    blade_vertices : (n, 3) float, mm — blade 0
    blade_faces : (m, 3) int64 — normals out of the metal
    hub_profile : (k, 2) float, mm — the hub generatrix (r, z), ordered along z (the hub is its
        revolution; material lies below it, toward the axis)
    hub_vertices : (h, 3) float, mm, hub_faces (g, 3) int64 — the hub as faces (may be a strip
        under blade 0 only); revolved from the profile when the part was built from one
    envelope : (q, 2) float, mm — closed meridional polygon (r, z) holding the whole part (hub
        down to a bore, blades up to their tip), counter-clockwise, not repeated at the end
    sector_start : float, rad — θ where the pitch sector of blade 0 begins: the sector
        [sector_start, sector_start + 2π/N) holds blade 0's mean angle at its middle
    """

    axis: Axis
    blade_count: int
    blade_vertices: np.ndarray
    blade_faces: np.ndarray
    hub_profile: np.ndarray
    hub_vertices: np.ndarray
    hub_faces: np.ndarray
    envelope: np.ndarray
    sector_start: float

    def __post_init__(self):
        if int(self.blade_count) < 1:
            raise PartError(f"blade count must be at least 1, got {self.blade_count}")
        self.blade_count = int(self.blade_count)
        self.hub_profile = _checked_profile(self.hub_profile, "hub profile")

    @property
    def pitch(self) -> float:
        """2π/N, radians."""
        return TWO_PI / self.blade_count

    def hub_r(self, z) -> np.ndarray:
        """(k,) hub radius (mm) at axial positions ``z`` (the profile held flat beyond its
        ends)."""
        P = self.hub_profile
        return np.interp(np.asarray(z, float), P[:, 1], P[:, 0])

    def part_mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Blade 0 and the hub faces of its sector as one mesh: V (n, 3) mm, F (m, 3) int64
        and (m,) bool True on hub faces. The mesh the deviation map is measured on."""
        r, th, z = theta_about(self.hub_vertices[self.hub_faces].mean(axis=1), self.axis)
        rel = np.mod(th - self.sector_start, TWO_PI)
        keep = rel < self.pitch if self.blade_count > 1 else np.ones(len(rel), bool)
        HF = self.hub_faces[keep]
        used, inv = np.unique(HF, return_inverse=True)
        HV = self.hub_vertices[used]
        HF = inv.reshape(-1, 3) + len(self.blade_vertices)
        V = np.vstack([self.blade_vertices, HV])
        F = np.vstack([self.blade_faces, HF]).astype(np.int64)
        hub = np.zeros(len(F), bool)
        hub[len(self.blade_faces):] = True
        return V, F, hub


# ------------------------------------------------------------------------------ builders
def _checked_profile(P, what: str) -> np.ndarray:
    P = np.asarray(P, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 2 or len(P) < 2 or not np.all(np.isfinite(P)):
        raise PartError(f"{what} must be at least two finite (r, z) points in mm, got shape "
                        f"{P.shape}")
    if np.any(P[:, 0] < 0):
        raise PartError(f"{what}: r must be ≥ 0 mm (a radius), got {P[:, 0].min():g}")
    P = P[np.argsort(P[:, 1], kind="stable")]
    if np.any(np.diff(P[:, 1]) <= 0):
        raise PartError(f"{what}: z must be distinct (the hub is r(z), one radius per axial "
                        "position); give the points along the axis")
    return P


def read_rz_csv(path) -> np.ndarray:
    """(k, 2) (r, z) points in mm from a text file: one ``r, z`` per line (comma, semicolon or
    white space), ``#`` comments, blank lines skipped. PartError naming the file and line."""
    path = Path(path).expanduser()
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise PartError(f"profile file {path} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PartError(f"cannot read profile file {path}: {exc}") from None
    pts = []
    for number, line in enumerate(text.splitlines(), 1):
        fields = [f for f in re.split(r"[,;\s]+", line.split("#", 1)[0].strip()) if f]
        if not fields:
            continue
        try:
            values = [float(f) for f in fields]
        except ValueError:
            values = []
        if len(values) != 2 or not all(math.isfinite(v) for v in values):
            raise PartError(f"profile file {path}, line {number}: expected two numbers 'r, z' "
                            f"in mm, got '{line.strip()}'")
        pts.append(values)
    if len(pts) < 2:
        raise PartError(f"profile file {path}: needs at least two 'r, z' lines, got {len(pts)}")
    return np.asarray(pts)


def _top_envelope(axis, hub_profile, blade_V, blade_F, bore_depth: float,
                  z_step: float = 1.0):
    """As :func:`_envelope` but per station ``z_step`` mm apart: the largest radius of the
    blade's triangles whose axial extent meets the station ± one step, the hub elsewhere.

    A triangle's largest radius is at a vertex (r is convex), and a point of the blade between
    two stations lies on a triangle that meets both stations' windows, so the polygon, linear
    between stations, contains the whole blade — also where a long triangle leaves a station
    without any vertex near it (Rotor 37's tip: blade points stood up to 14.5 mm above the
    nearest-vertex version).
    """
    r, _, z = theta_about(blade_V, axis)
    F = np.asarray(blade_F, np.int64)
    z_lo = min(float(hub_profile[0, 1]), float(z.min()))
    z_hi = max(float(hub_profile[-1, 1]), float(z.max()))
    n = max(2, int(math.ceil((z_hi - z_lo) / z_step)) + 1)
    zs = np.linspace(z_lo, z_hi, n)
    h = zs[1] - zs[0]
    hub = np.interp(zs, hub_profile[:, 1], hub_profile[:, 0])
    top = hub.copy()
    if len(F):
        zf, rf = z[F], r[F].max(axis=1)
        lo = np.clip(np.ceil((zf.min(axis=1) - z_lo) / h - 1.0 - 1e-9).astype(int), 0, n - 1)
        hi = np.clip(np.floor((zf.max(axis=1) - z_lo) / h + 1.0 + 1e-9).astype(int), 0, n - 1)
        count = hi - lo + 1
        first = np.repeat(np.cumsum(count) - count, count)
        station = np.repeat(lo, count) + (np.arange(int(count.sum())) - first)
        np.maximum.at(top, station, np.repeat(rf, count))
    else:
        np.maximum.at(top, np.clip(np.round((z - z_lo) / h).astype(int), 0, n - 1), r)
    bore = max(0.0, float(hub.min()) - bore_depth)
    ring = [[bore, z_hi], [bore, z_lo]] + [[t, zz] for t, zz in zip(top, zs, strict=True)]
    return np.asarray(ring, dtype=np.float64)


def _sector_start(axis, blade_V, pitch):
    _, th, _ = theta_about(blade_V, axis)
    mean = math.atan2(np.sin(th).mean(), np.cos(th).mean())
    return float(mean - 0.5 * pitch)


def _revolved_hub(axis, profile, sector_start, pitch, spacing: float = 1.0):
    """Hub faces revolved from ``profile`` over one pitch (triangles, normals away from the
    axis side of the profile, i.e. out of the hub material)."""
    e1, e2, d = axis.angular_frame()
    rmax = float(profile[:, 0].max())
    n_th = max(4, int(math.ceil(pitch * max(rmax, 1.0) / spacing)))
    seg = np.hypot(*np.diff(profile, axis=0).T)
    ts = [profile[:1]]
    for a, b, s in zip(profile[:-1], profile[1:], seg, strict=True):
        k = max(1, int(math.ceil(s / spacing)))
        ts.append(a + (b - a) * (np.arange(1, k + 1) / k)[:, None])
    rz = np.vstack(ts)
    th = sector_start + pitch * np.arange(n_th + 1) / n_th
    radial = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2
    V = (axis.o + rz[:, 1, None, None] * d + rz[:, 0, None, None] * radial[None]).reshape(-1, 3)
    k = len(th)
    i = np.arange(len(rz) - 1)[:, None]
    j = np.arange(k - 1)[None, :]
    a, b, c, dd = (i * k + j).ravel(), (i * k + j + 1).ravel(), ((i + 1) * k + j + 1).ravel(), \
        ((i + 1) * k + j).ravel()
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, dd], 1)]).astype(np.int64)
    # z grows with i, θ with j: (∂θ × ∂z) points away from the axis for a cylinder
    return V, F


def part_from_demo(demo: DemoBlisk, bore_depth: float = 10.0) -> BliskPart:
    """The part of a :class:`~.blisk.DemoBlisk`: blade 0, its hub strip, the hub cone as the
    profile (over the strip's axial extent)."""
    r, _, z = theta_about(demo.hub_vertices, demo.axis)
    c = demo.hub_cone
    zs = np.array([z.min(), z.max()])
    t = (zs - c.z1) / (c.z2 - c.z1)
    profile = np.stack([c.r1 + t * (c.r2 - c.r1), zs], 1)
    pitch = TWO_PI / demo.blade_count
    return BliskPart(demo.axis, demo.blade_count, demo.blade_vertices,
                     np.asarray(demo.blade_faces, np.int64), profile, demo.hub_vertices,
                     np.asarray(demo.hub_faces, np.int64),
                     _top_envelope(demo.axis, profile, demo.blade_vertices, demo.blade_faces,
                                   bore_depth),
                     _sector_start(demo.axis, demo.blade_vertices, pitch))


def part_from_blade(blade_V, blade_F, hub_profile, blade_count: int, axis: Axis | None = None,
                    bore_depth: float = 10.0) -> BliskPart:
    """The part of one blade mesh and a hub profile (r, z) mm; the hub faces are the profile
    revolved over blade 0's pitch sector."""
    axis = axis or Axis()
    if int(blade_count) < 1:
        raise PartError(f"blade count must be at least 1, got {blade_count}")
    profile = _checked_profile(hub_profile, "hub profile")
    V = np.asarray(blade_V, np.float64)
    F = np.asarray(blade_F, np.int64)
    pitch = TWO_PI / int(blade_count)
    start = _sector_start(axis, V, pitch)
    HV, HF = _revolved_hub(axis, profile, start, pitch)
    return BliskPart(axis, int(blade_count), V, F, profile, HV, HF,
                     _top_envelope(axis, profile, V, F, bore_depth), start)


# ------------------------------------------------------------------------------ splitting
@dataclass
class BliskSplit:
    """What :func:`split_blisk_mesh` found.

    Attributes
    ----------
    part : BliskPart
    blade_count : int — N found from the symmetry
    hub_faces : (h,) int64 — input face indices of the hub
    blade_faces : (b,) int64 — input face indices of all blades
    sector : (m,) int64 — per input face, its blade's sector 0..N−1 (−1 on hub faces)
    """

    part: BliskPart
    blade_count: int
    hub_faces: np.ndarray
    blade_faces: np.ndarray
    sector: np.ndarray


def _components(F, n_vertices):
    """(count, (m,) label) of the faces' connected parts (faces sharing a vertex): the
    bipartite face–vertex graph's components, read on the faces."""
    m = len(F)
    rows = np.repeat(np.arange(m), 3)
    A = coo_matrix((np.ones(3 * m, np.int8), (rows, m + F.ravel())),
                   shape=(m + n_vertices, m + n_vertices))
    _, lab = connected_components(A, directed=False)
    seen = np.zeros(int(lab.max()) + 1, bool)
    seen[lab[:m]] = True
    renum = np.cumsum(seen) - 1
    return int(seen.sum()), renum[lab[:m]]


def _weld_ids(V, step: float) -> np.ndarray:
    """(n,) one id per distinct vertex position (coordinates rounded to ``step`` mm)."""
    key = np.round(V / step).astype(np.int64)
    key -= key.min(axis=0)
    span = key.max(axis=0) + 1
    if float(span[0]) * float(span[1]) * float(span[2]) < 2.0**62:
        packed = (key[:, 0] * span[1] + key[:, 1]) * span[2] + key[:, 2]
        _, ids = np.unique(packed, return_inverse=True)
    else:
        _, ids = np.unique(key, axis=0, return_inverse=True)
    return ids.reshape(-1)


def blade_count_from_symmetry(theta, weight, bins: int = 1 << 14, max_harmonic: int = 720,
                              significant: float = 0.05) -> tuple[int, float]:
    """The rotational symmetry order of a weighted set of angles.

    The Fourier coefficients of an N-periodic distribution over θ vanish except at multiples
    of N: N = gcd of the harmonics m ≥ 1 whose magnitude exceeds ``significant`` × the
    largest. Returns (N, off), ``off`` the largest magnitude at a harmonic that is not a
    multiple of N relative to the largest (≈ 0 for a periodic set; N = 1 when nothing is
    significant or the gcd is 1).
    """
    h = np.bincount(np.floor(np.mod(theta, TWO_PI) / TWO_PI * bins).astype(np.int64) % bins,
                    weights=weight, minlength=bins)
    H = np.abs(np.fft.rfft(h))[1:max_harmonic + 1]
    top = float(H.max()) if len(H) else 0.0
    if top <= 0:
        return 1, 0.0
    sig = np.nonzero(H >= significant * top)[0] + 1
    n = int(np.gcd.reduce(sig))
    m = np.arange(1, len(H) + 1)
    off = H[(m % n) != 0]
    return n, float(off.max() / top) if len(off) else 0.0


def split_blisk_mesh(V, F, blade_count: int | None = None, axis: Axis | None = None, *,
                     tolerance: float = 0.05, normal_angle: float = math.radians(2.0),
                     bore_depth: float = 10.0) -> BliskSplit:
    """Split a whole-blisk mesh into hub faces and blades; find N.

    Parameters
    ----------
    V : (n, 3) float, mm; F : (m, 3) int — the whole blisk (any weld state)
    blade_count : int or None — the user's N, checked against the symmetry (None: trust it)
    axis : Axis — default +Z through the origin
    tolerance : float, mm — how far a hub vertex may lie from the fitted revolved profile
    normal_angle : float, rad — how far a hub face's normal may turn out of the meridional
        plane

    Returns
    -------
    BliskSplit

    Raises
    ------
    PartError — no hub found; the blades are not rotationally periodic; N does not match
    """
    axis = axis or Axis()
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or len(F) == 0:
        raise PartError("the blisk mesh must be (n, 3) vertices and (m, 3) triangles, "
                        f"got {V.shape} and {F.shape}")
    # weld coincident corners (STL gives three per triangle) so parts are connected
    weld = _weld_ids(V, max(tolerance * 1e-3, 1e-9))
    Fw = weld[F]
    ncomp, comp = _components(Fw, int(weld.max()) + 1)
    N2 = triangle_normals(V, F)
    area = 0.5 * np.linalg.norm(N2, axis=1)
    n = N2 / np.maximum(2.0 * area, 1e-300)[:, None]
    cen = V[F].mean(axis=1)
    r, th, z = theta_about(cen, axis)
    e1, e2, d = axis.angular_frame()
    e_th = -np.sin(th)[:, None] * e1 + np.cos(th)[:, None] * e2
    candidate = np.abs(np.einsum("ij,ij->i", n, e_th)) <= math.sin(normal_angle)
    # parts that wrap around the axis and are mostly faces of revolution hold the hub
    occ_bins = 360
    occ = np.zeros((ncomp, occ_bins), bool)
    _, thv, _ = theta_about(V[F].reshape(-1, 3), axis)
    b = np.floor(np.mod(thv, TWO_PI) / TWO_PI * occ_bins).astype(int) % occ_bins
    occ[np.repeat(comp, 3), b] = True
    occupancy = occ.mean(axis=1)
    cand_area = np.bincount(comp, weights=area * candidate, minlength=ncomp)
    comp_area = np.bincount(comp, weights=area, minlength=ncomp)
    frac = cand_area / np.maximum(comp_area, 1e-300)
    hubby = (frac >= 0.5) & (occupancy >= 0.5 * occupancy.max())
    if not hubby.any() and ncomp == 1:
        hubby[:] = True  # one welded part: classify face by face
    in_hub_part = hubby[comp]
    pick = candidate & in_hub_part
    if not pick.any():
        raise PartError("no hub found: no faces of revolution about the axis (normal in the "
                        "meridional plane) in a part that wraps around it; check the axis "
                        "(--axis) or give the hub as a profile (--hub-profile)")
    profile = _fit_profile(V, F[pick], axis, spacing=max(2.0, 40 * tolerance))
    dist = np.full(len(V), np.inf)
    near = np.unique(F[pick])
    dist[near] = _profile_distance(V[near], axis, profile)
    on_profile = (dist[F] <= tolerance).all(axis=1)
    hub = pick & on_profile
    if hub.sum() < 3:
        raise PartError("no hub found: the faces of revolution do not lie on one revolved "
                        f"profile within {tolerance:g} mm; raise the tolerance or give the hub "
                        "as a profile")
    blade = ~hub
    if not blade.any():
        raise PartError("the mesh has a hub but no blades (every face is a face of revolution)")
    # blades: connected parts of blade faces (a scan's blades differ a little, each turned,
    # bent or repaired: only harmonics up to a few times the number of blade-sized parts
    # are asked, so that small differences between blades do not read as a lower symmetry)
    bf = np.nonzero(blade)[0]
    nb, bcomp = _components(Fw[bf], int(weld.max()) + 1)
    w = area[bf]
    part_area = np.bincount(bcomp, weights=w, minlength=nb)
    blade_parts = int(np.count_nonzero(part_area >= 0.5 * part_area.max()))
    n_found, off = blade_count_from_symmetry(
        th[blade], area[blade],
        max_harmonic=4 * blade_parts if blade_parts >= 2 else 720)
    if n_found < 2 or off > 0.25:
        raise PartError("the blades are not rotationally periodic about the axis (no N-fold "
                        f"symmetry found; strongest off-period harmonic {off:.0%}); check the "
                        "axis and that every blade is in the mesh")
    if blade_count is not None and int(blade_count) != n_found:
        raise PartError(f"the mesh has {n_found}-fold symmetry but the blade count given is "
                        f"{int(blade_count)}; give --blade-count {n_found} or check the mesh")
    pitch = TWO_PI / n_found
    hub_occ = np.zeros(occ_bins, bool)
    hub_occ[np.floor(np.mod(th[hub], TWO_PI) / TWO_PI * occ_bins).astype(int) % occ_bins] = True
    if hub_occ.mean() < 0.9 / n_found:
        raise PartError("no hub found: the faces of revolution cover "
                        f"{360 * hub_occ.mean():.0f}° about the axis, less than one blade pitch "
                        f"({360 / n_found:.1f}°); give the hub as a profile (--hub-profile)")
    # each blade part to its pitch sector; blade 0 is the blade-sized part nearest θ = 0 (not
    # the largest: a repaired or damaged blade must not renumber the others)
    cs = np.bincount(bcomp, weights=w * np.cos(th[bf]), minlength=nb)
    sn = np.bincount(bcomp, weights=w * np.sin(th[bf]), minlength=nb)
    th_c = np.arctan2(sn, cs)
    sized = np.nonzero(part_area >= 0.5 * part_area.max())[0]
    first = int(sized[np.argmin(np.abs(th_c[sized]))])
    start = float(th_c[first] - 0.5 * pitch)
    k = np.floor(np.mod(th_c - start, TWO_PI) / pitch).astype(int) % n_found
    sector = np.full(len(F), -1, np.int64)
    sector[bf] = k[bcomp]
    sec_area = np.bincount(sector[bf], weights=w, minlength=n_found)
    if sec_area.min() < 0.5 * sec_area.max():  # a missing blade; a repaired one may differ
        raise PartError("the blades are not rotationally periodic: the blade area per pitch "
                        f"sector ranges {sec_area.min():.1f}–{sec_area.max():.1f} mm² over "
                        f"the {n_found} sectors; check that every blade is in the mesh")
    f0 = bf[sector[bf] == 0]
    used, inv = np.unique(F[f0], return_inverse=True)
    hub_f = np.nonzero(hub)[0]
    hused, hinv = np.unique(F[hub_f], return_inverse=True)
    part = BliskPart(axis, n_found, V[used], inv.reshape(-1, 3).astype(np.int64), profile,
                     V[hused], hinv.reshape(-1, 3).astype(np.int64),
                     _top_envelope(axis, profile, V[used], inv.reshape(-1, 3), bore_depth), start)
    return BliskSplit(part, n_found, hub_f, bf, sector)


def _fit_profile(V, F, axis, spacing: float) -> np.ndarray:
    """(k, 2) (r, z) polyline through the meridional points of faces ``F``: binned along
    their principal direction, the median r and z of each bin."""
    r, _, z = theta_about(V[np.unique(F)], axis)
    P = np.stack([r, z], 1)
    c = P.mean(axis=0)
    _, _, vt = np.linalg.svd(P - c, full_matrices=False)
    t = (P - c) @ vt[0]
    nb = max(1, int(math.ceil(np.ptp(t) / spacing)))
    idx = np.minimum(((t - t.min()) / max(np.ptp(t), 1e-12) * nb).astype(int), nb - 1)
    out = []
    for i in np.unique(idx):
        sel = idx == i
        out.append([np.median(P[sel, 0]), np.median(P[sel, 1])])
    # the ends: the extreme points themselves, so the profile covers the whole hub
    lo, hi = int(np.argmin(t)), int(np.argmax(t))
    pts = np.vstack([P[lo], np.asarray(out), P[hi]])
    pts = pts[np.argsort(pts[:, 1], kind="stable")]
    keep = np.concatenate([[True], np.diff(pts[:, 1]) > 1e-9])
    return pts[keep]


def _profile_distance(V, axis, profile) -> np.ndarray:
    """(n,) distance (mm) of each vertex to the revolved profile (meridional polyline)."""
    r, _, z = theta_about(V, axis)
    d2 = np.full(len(r), np.inf)
    for a, b in zip(profile[:-1], profile[1:], strict=True):
        d2 = np.minimum(d2, segment_distance2_2d(r, z, a[0], a[1], b[0], b[1]))
    return np.sqrt(d2)
