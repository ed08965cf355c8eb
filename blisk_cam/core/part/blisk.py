"""Parametric compressor blisk: hub cone, N blades, hub fillet, round LE/TE, scan-like meshes.

The demo blisk is the test object of the whole pipeline: a blade whose hub and tip boundaries
lie *exactly* on two known cones (paper 001, Zhang, Hu & Tang 2015, §2.1 and Fig. 2: the
hub is a cone and the blade tip is trimmed by another cone), with thin round leading and
trailing edges (the hard case for the forward step) and an optional hub fillet (paper 001,
§4 and Fig. 11(b): a fillet of radius r_b ≥ the ball radius r_t, with cone 1 on the hub so
that the first CC curve is the fillet/hub boundary).

Construction (units mm and radians; blisk axis +Z through the origin):

* **Span.** A blade point has parameters (u, v). ``v`` in [0, 1] is the span: the point lies
  on the linear morphing cone (LMC) at ratio ``s = v`` between the hub cone (cone 1) and the
  tip cone (cone 2), paper 001 Eqs. 1–4: its meridional position is
  ``A(v) + t (B(v) − A(v))``. The rows ``v = 0`` and ``v = 1`` therefore lie on the two cones
  by construction (to float64 round-off, ~1e-13 mm).
* **Section.** At span ``v`` the airfoil is drawn in the *developed plane* of the LMC (the
  cone unrolled isometrically; x along the generatrix A→B, y along +θ, origin at the stacking
  point). The camber line is a circular arc (chord ``c``, camber angle ``φ``, stagger ``γ``
  measured from the generatrix direction toward +θ, chord midpoint at the stacking point).
  The section is the envelope of the circles of radius ρ(σ) centred on the camber line
  (σ = camber arc length), closed by the end circles: its leading and trailing edges are
  exact circular arcs of radii ``le_radius`` and ``te_radius`` tangent to the sides, and
  "thickness" is the diameter 2ρ of the inscribed circle. The thickness law is a cubic,
  ρ(ξ) = R_le (1 − ξ) + R_te ξ + a ξ (1 − ξ)(1 + k (ξ − ½)), ξ = σ / L, with its maximum at
  ``max_thickness_position`` (exact when R_le = R_te).
* **Twist and lean.** Chord, stagger, camber and maximum thickness vary linearly with ``v``.
  Lean tilts the stacking line toward +θ: at height h above the hub the stacking point is
  turned by ``tan(lean) h / r`` about the axis.
* **Fillet.** Optional circular flare of the section near the hub: at height d above the hub
  cone (measured at the camber point, d = v H(t) with H the hub-to-tip distance), the circle
  radius grows by ρ_f − sqrt(ρ_f² − (ρ_f − d)²) for d < ρ_f, so the blade surface meets the
  hub tangentially. It only thickens sections: the row v = 0 stays on cone 1.
  The flare is a circle of radius ρ_f in (height above the hub, offset in the LMC plane); where
  the blade wall is not normal to the hub (the span runs radially while the hub cone leans
  14°, plus lean and twist) that circle is sheared into an ellipse, whose tightest concave
  principal radius is smaller than ρ_f: measured 5.73 mm for ρ_f = 8 mm (beside the trailing
  edge, v ≈ 0.035) and 7.18 mm for ρ_f = 10 mm (test_demo). A ball of radius ρ fits the
  whole fillet only if ρ ≤ ≈ 0.72 ρ_f.
* **Mesh.** One open tube per blade: a periodic grid ``n_u × n_v`` (u around the section:
  LE arc, suction-or-pressure side, TE arc, other side; v hub → tip), two triangles per cell,
  normals out of the material. Points are concentrated at LE/TE (a dense arc around each edge
  plus a cosine-stretched chordwise spacing on the sides) and, with the fillet, uniformly in
  arc length around the fillet. The hub is a separate strip of the hub cone.
* **Resolution.** ``resolution = k`` gives ``n_u = 2 (n_a + n_s)`` with ``n_a = max(6,
  round(50 k))`` points per edge arc and ``n_s = max(12, round(150 k))`` per side, and
  ``n_v = max(8, round(125 k)) + 1`` rows: 2 n_u (n_v − 1) ≈ 100 000 k² triangles
  (k = 0.316 → 10 k, k = 1 → 100 k, k = 4.5 → 2.03 M; see :func:`blade_triangle_count`).
* **Scan-like mode.** Jittered parameter grid (each node moved along the surface by up to
  ``scan_jitter / 2`` of its smaller neighbouring grid spacing, in u and in v), random
  diagonals, a fraction of cells split with a vertex close to an edge (sliver "cap"
  triangles), and Gaussian noise of standard deviation
  ``scan_noise`` along the normal on every vertex not on the hub/tip boundary (except where
  it would push a vertex across a cone). Boundary vertices stay exactly on the cones.
  Deterministic for ``seed``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from ..errors import ConeError
from ..geometry.axis import Axis
from ..geometry.mesh import triangle_normals
from ..geometry.vectors import cross2, rotate_about
from .blisk_params import (
    _SIDE_STRETCH,
    TWO_PI,
    DemoParameterError,
    DemoParams,
    _fail,
    blade_grid_shape,
)
from .cones import Cone, MorphingCones

__all__ = ["DemoBlisk", "make_demo_blisk"]

#: the demo blisk's axis direction (its blades are copies about z)
_Z = (0.0, 0.0, 1.0)


def _atan_over(w):
    """arctan(w) / w, stable at w = 0."""
    small = np.abs(w) < 1e-4
    safe = np.where(small, 1.0, w)
    return np.where(small, 1.0 - w * w / 3.0, np.arctan(safe) / safe)


def _side_map(f):
    """Chordwise stretching [0, 1] → [0, 1]: uniform + cosine mix, dense at both ends."""
    return (1.0 - _SIDE_STRETCH) * f + _SIDE_STRETCH * 0.5 * (1.0 - np.cos(np.pi * f))


# ---------------------------------------------------------------------------------- model
class _BladeModel:
    """The exact blade surface P(u, v) (vectorised) for one set of parameters.

    u in [0, 4): segment floor(u) = 0 LE arc, 1 side "−" (σ: 0 → L), 2 TE arc,
    3 side "+" (σ: L → 0); v in [0, 1] the span (LMC ratio).
    """

    def __init__(self, p: DemoParams, mc: MorphingCones):
        self.p = p
        self.mc = mc
        c1, c2 = mc.cone1, mc.cone2
        d = c1.p2 - c1.p1
        d = d / np.linalg.norm(d)
        q = [float(cross2(d, qq - c1.p1)) for qq in (c2.p1, c2.p2)]
        sgn = 1.0 if q[0] > 0 else -1.0
        # H(t): distance of the tip-line point at generatrix parameter t from the hub line
        self.H0, self.H1 = sgn * q[0], sgn * q[1]
        self.H_stack = self.H0 + p.stack_position * (self.H1 - self.H0)
        # thickness-law constants
        m = p.max_thickness_position
        self.k3 = (1.0 - 2.0 * m) / (0.5 - 3.0 * m + 3.0 * m * m)
        self.b_peak = m * (1.0 - m) * (1.0 + self.k3 * (m - 0.5))
        self.rho_f = p.fillet_radius if p.fillet else 0.0

    # ---- span laws
    def _lerp(self, a, b, v):
        return a + (b - a) * v

    def section(self, u, v):
        """Developed-plane section data at parameters (u, v), all (k,) arrays."""
        p = self.p
        u = np.asarray(u, dtype=np.float64)
        v = np.asarray(v, dtype=np.float64)
        u, v = np.broadcast_arrays(u, v)
        gam = self._lerp(p.stagger_hub, p.stagger_tip, v)
        phi = self._lerp(p.camber_hub, p.camber_tip, v)
        chord = self._lerp(p.chord_hub, p.chord_tip, v)
        tmax = self._lerp(p.max_thickness_hub, p.max_thickness_tip, v)
        L = chord / np.sinc(phi / TWO_PI)  # camber arc length
        a_in = gam + 0.5 * phi  # camber tangent angle at the LE (turns by −φ to the TE)
        kap = -phi / L
        # LMC frame at v
        A, B = self.mc.generatrix(v)
        D = B - A
        ln = np.hypot(D[..., 0], D[..., 1])
        e_r, e_z = D[..., 0] / ln, D[..., 1] / ln
        M_r = A[..., 0] + p.stack_position * D[..., 0]
        M_z = A[..., 1] + p.stack_position * D[..., 1]
        theta_ref = math.tan(p.lean) * v * self.H_stack / M_r
        # u → segment, fraction, camber arc length σ
        uu = np.mod(u, 4.0)
        seg = np.clip(np.floor(uu).astype(np.int64), 0, 3)
        f = uu - seg
        side = (seg == 1) | (seg == 3)
        fs = np.where(seg == 3, 1.0 - f, f)
        sigma = np.where(side, L * _side_map(fs), np.where(seg == 0, 0.0, L))
        # camber point and tangent (unit speed in σ)
        ang = a_in + kap * sigma
        half = a_in + 0.5 * kap * sigma
        sc = sigma * np.sinc(kap * sigma / TWO_PI)
        cx = -0.5 * chord * np.cos(gam) + sc * np.cos(half)
        cy = -0.5 * chord * np.sin(gam) + sc * np.sin(half)
        tx, ty = np.cos(ang), np.sin(ang)
        # radius of the circle family: thickness law + fillet flare
        xi = sigma / L
        m = p.max_thickness_position
        amp = 0.5 * tmax - (p.le_radius * (1.0 - m) + p.te_radius * m)
        cub = 1.0 + self.k3 * (xi - 0.5)
        b = xi * (1.0 - xi) * cub
        db = (1.0 - 2.0 * xi) * cub + self.k3 * xi * (1.0 - xi)
        rho = p.le_radius * (1.0 - xi) + p.te_radius * xi + amp * b / self.b_peak
        drho = (p.te_radius - p.le_radius + amp * db / self.b_peak) / L
        if self.rho_f > 0.0:
            rf = self.rho_f
            dm_c, _, r_c = self._undevelop(cx, cy, M_r, e_r)
            t_c = p.stack_position + dm_c / ln
            Hc = self.H0 + t_c * (self.H1 - self.H0)
            dh = v * Hc  # height of the camber point above the hub cone
            inside = dh < rf
            root = np.sqrt(np.maximum(rf * rf - (rf - dh) ** 2, 0.0))
            rho = rho + np.where(inside, rf - root, 0.0)
            # d(height)/dσ = v (H1 − H0)/len · dΔm/dσ, dΔm/dσ = ((r_ref + e_r x) T_x + e_r y T_y)/r
            ddm = ((M_r + e_r * cx) * tx + e_r * cy * ty) / r_c
            dd = v * (self.H1 - self.H0) / ln * ddm
            ok = inside & (dh > 0.0)
            dg = np.where(ok, -(rf - dh) / np.where(ok, root, 1.0), 0.0)
            drho = drho + dg * dd
        # point in the developed plane
        s = np.sqrt(np.maximum(1.0 - drho * drho, 0.0))
        nx, ny = -ty, tx
        sgn = np.where(seg == 1, -1.0, 1.0)
        ox_side = -drho * tx + sgn * s * nx
        oy_side = -drho * ty + sgn * s * ny
        beta_c = np.arccos(np.clip(-drho, -1.0, 1.0))  # contact angle from T
        beta = np.where(
            seg == 0,
            beta_c + f * (TWO_PI - 2.0 * beta_c),
            -beta_c + f * 2.0 * beta_c,
        )
        cb, sb = np.cos(beta), np.sin(beta)
        ox_arc = cb * tx + sb * nx
        oy_arc = cb * ty + sb * ny
        ox = np.where(side, ox_side, ox_arc)
        oy = np.where(side, oy_side, oy_arc)
        x = cx + rho * ox
        y = cy + rho * oy
        return {
            "x": x, "y": y, "cx": cx, "cy": cy, "tx": tx, "ty": ty, "rho": rho,
            "drho": drho, "side": side, "seg": seg, "sigma": sigma,
            "M_r": M_r, "M_z": M_z, "e_r": e_r, "e_z": e_z, "ln": ln, "theta_ref": theta_ref,
            "v": v,
        }  # fmt: skip

    @staticmethod
    def _undevelop(x, y, r_ref, e_r):
        """Developed plane of the cone (origin at radius r_ref, x along the generatrix of
        radial slope e_r, y along +θ) → (Δm along the generatrix, Δθ, r). Isometric, exact
        for cones, cylinders (e_r = 0) and disks (e_r = ±1)."""
        bb = r_ref + e_r * x
        ey = e_r * y
        r = np.hypot(bb, ey)
        dtheta = (y / bb) * _atan_over(ey / bb)
        dm = (2.0 * r_ref * x + e_r * (x * x + y * y)) / (r + r_ref)
        return dm, dtheta, r

    def to_3d(self, sec, x=None, y=None):
        """3-D points (k, 3) of developed-plane points (default: the section points)."""
        x = sec["x"] if x is None else x
        y = sec["y"] if y is None else y
        dm, dth, _ = self._undevelop(x, y, sec["M_r"], sec["e_r"])
        r = sec["M_r"] + dm * sec["e_r"]
        z = sec["M_z"] + dm * sec["e_z"]
        th = sec["theta_ref"] + dth
        return np.stack([r * np.cos(th), r * np.sin(th), z], axis=-1)

    def points(self, u, v, chunk: int = 262144):
        """(k, 3) surface points at flat parameter arrays u, v (evaluated in chunks)."""
        u = np.asarray(u, dtype=np.float64).ravel()
        v = np.asarray(v, dtype=np.float64).ravel()
        out = np.empty((len(u), 3))
        for s in range(0, len(u), chunk):
            out[s : s + chunk] = self.to_3d(self.section(u[s : s + chunk], v[s : s + chunk]))
        return out

    def meridional_theta(self, sec):
        """(m along the LMC generatrix from A(v), θ) of the section points."""
        dm, dth, _ = self._undevelop(sec["x"], sec["y"], sec["M_r"], sec["e_r"])
        return self.p.stack_position * sec["ln"] + dm, sec["theta_ref"] + dth

    # ---- grid parameters
    def u_nodes(self, n_a: int, n_s: int) -> np.ndarray:
        fa = np.arange(n_a) / n_a
        fs = np.arange(n_s) / n_s
        return np.concatenate([fa, 1.0 + fs, 2.0 + fa, 3.0 + fs])

    def v_nodes(self, n_v: int) -> np.ndarray:
        if self.rho_f <= 0.0:
            return np.linspace(0.0, 1.0, n_v)
        rf, H = self.rho_f, self.H_stack
        arc = 0.5 * math.pi * rf
        step = (H - rf + arc) / (n_v - 1)
        n_f = int(min(max(2, round(arc / step)), n_v - 3))
        psi = np.linspace(0.0, 0.5 * math.pi, n_f + 1)
        v_f = rf / H * (1.0 - np.cos(psi))
        v_rest = np.linspace(rf / H, 1.0, n_v - n_f)[1:]
        out = np.concatenate([v_f, v_rest])
        out[-1] = 1.0
        return out


# ---------------------------------------------------------------------------------- checks
def _check_geometry(model: _BladeModel, pitch: float) -> None:
    """Reject parameter sets whose blades are not valid solids or intersect their neighbours."""
    p = model.p
    if p.fillet and p.fillet_radius > 0.4 * min(model.H0, model.H1):
        _fail(
            "fillet_radius",
            p.fillet_radius,
            f"3 ≤ fillet_radius ≤ 0.4·blade height = {0.4 * min(model.H0, model.H1):.6g} mm",
        )
    n_a, n_s = 40, 160
    u = model.u_nodes(n_a, n_s)
    v = np.linspace(0.0, 1.0, 17)
    uu, vv = np.meshgrid(u, v)
    sec = model.section(uu, vv)
    if np.any(sec["M_r"] + sec["e_r"] * sec["x"] <= 0.05 * sec["M_r"]):
        raise DemoParameterError(
            "demo parameters chord_hub/chord_tip, hub_cone/tip_cone: the blade section reaches "
            "the apex of a morphing cone (allowed: sections that stay on the cone side of the "
            "apex); reduce the chords or make the cone generatrices less steep"
        )
    if np.max(np.abs(sec["drho"])) >= 0.9:
        raise DemoParameterError(
            "demo parameters max_thickness_hub/max_thickness_tip, fillet_radius: the thickness "
            "changes too fast along the chord (allowed |dρ/dσ| < 0.9); reduce them or increase "
            "chord_hub/chord_tip"
        )
    # sides regular: consecutive points advance along the camber tangent
    for lo, hi in ((n_a, n_a + n_s), (2 * n_a + n_s, 2 * (n_a + n_s))):
        dx = np.diff(sec["x"][:, lo:hi], axis=1)
        dy = np.diff(sec["y"][:, lo:hi], axis=1)
        adv = dx * sec["tx"][:, lo : hi - 1] + dy * sec["ty"][:, lo : hi - 1]
        if lo > n_a:
            adv = -adv
        if np.any(adv <= 0.0):
            raise DemoParameterError(
                "demo parameters camber_hub/camber_tip: the section sides fold over (camber "
                "too strong for the thickness; allowed: sides advancing along the camber line); "
                "reduce the camber or the thicknesses"
            )
    # neighbour blades (rotated by the pitch) must not intersect: θ width of every
    # meridional slice of every section below 0.95 pitch
    m, th = model.meridional_theta(sec)
    m1, th1 = np.roll(m, -1, axis=1), np.roll(th, -1, axis=1)
    for j in range(len(v)):
        levels = np.linspace(m[j].min(), m[j].max(), 120)[1:-1]
        a, b = m[j][:, None] - levels, m1[j][:, None] - levels
        cross = (a * b <= 0.0) & (a != b)
        w = np.where(cross, a / np.where(cross, a - b, 1.0), 0.0)
        tc = th[j][:, None] + w * (th1[j] - th[j])[:, None]
        width = np.max(np.where(cross, tc, -np.inf), axis=0) - np.min(
            np.where(cross, tc, np.inf), axis=0
        )
        wmax = float(np.max(width))
        if wmax > 0.95 * pitch:
            raise DemoParameterError(
                f"demo parameter blade_count = {p.blade_count}: neighbouring blades would "
                f"intersect: at span v = {v[j]:.3g} the section is {math.degrees(wmax):.3g}° "
                f"wide circumferentially, the pitch 2π/N is {math.degrees(pitch):.3g}° "
                "(allowed: width < 95 % of the pitch); reduce blade_count, the thicknesses, "
                "fillet_radius or the stagger"
            )


# ---------------------------------------------------------------------------------- result


@dataclass(frozen=True, eq=False)
class DemoBlisk:
    """A generated demo blisk: blade 0 and the hub strip as arrays, with the true cones.

    Attributes
    ----------
    blade_vertices : (n, 3) float64, mm — blade 0 (an open tube, hub and tip open)
    blade_faces : (m, 3) int64 — counter-clockwise seen from outside (normals out of the metal)
    hub_vertices : (h, 3) float64, mm — a strip of the hub cone under blade 0 and its
        neighbours (:meth:`hub_blade_indices`), exactly on the hub cone
    hub_faces : (g, 3) int64 — normals toward the blades (away from the axis by default)
    axis : Axis — +Z through the origin
    hub_cone : Cone — cone 1, the hub; the blade's hub boundary lies on it
    tip_cone : Cone — cone 2; the blade's tip boundary lies on it
    blade_count : int
    params : DemoParams
    blade_uv : (n, 2) float64 — surface parameters (u in [0, 4), v in [0, 1]) of each blade
        vertex; v is the LMC ratio (paper 001) of the exact surface point (before noise)
    grid_shape : (n_v, n_u) — the structured grid behind the blade (before sliver vertices)
    """

    blade_vertices: np.ndarray
    blade_faces: np.ndarray
    hub_vertices: np.ndarray
    hub_faces: np.ndarray
    axis: Axis
    hub_cone: Cone
    tip_cone: Cone
    blade_count: int
    params: DemoParams
    blade_uv: np.ndarray
    grid_shape: tuple[int, int]
    _model: _BladeModel = field(repr=False)

    @property
    def pitch(self) -> float:
        """Blade pitch 2π/N, radians."""
        return TWO_PI / self.blade_count

    @property
    def morphing_cones(self) -> MorphingCones:
        """The LMC family between ``hub_cone`` (s = 0) and ``tip_cone`` (s = 1)."""
        return self._model.mc

    @property
    def n_blade_triangles(self) -> int:
        return len(self.blade_faces)

    def surface_points(self, u, v) -> np.ndarray:
        """Exact (noise-free) blade-0 surface points at parameters (u, v).

        Parameters
        ----------
        u : array-like, u in [0, 4) (periodic): [0, 1) LE arc, [1, 2) one side LE → TE,
            [2, 3) TE arc, [3, 4) other side TE → LE
        v : array-like, span in [0, 1] (the LMC ratio; 0 on the hub cone, 1 on the tip cone)

        Returns
        -------
        (k, 3) float64, mm
        """
        u, v = np.broadcast_arrays(np.asarray(u, float), np.asarray(v, float))
        return self._model.points(u.ravel(), v.ravel())

    def blade(self, i: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Blade ``i`` (mod N): blade 0 turned by ``i`` pitches about the axis.

        Returns
        -------
        V : (n, 3) float64, mm (a new array), F : (m, 3) int64 (the shared ``blade_faces``)
        """
        i = int(i) % self.blade_count
        if i == 0:
            return self.blade_vertices.copy(), self.blade_faces
        V = rotate_about(self.blade_vertices, _Z, i * self.pitch, form="coordinate")
        return V, self.blade_faces

    def blade_instances(self, indices=None) -> list[tuple[np.ndarray, np.ndarray]]:
        """Several blades as ``[(V_i, F), ...]``; ``indices=None`` means all N blades
        (N copies of the vertex array: mind the memory at high resolution)."""
        if indices is None:
            indices = range(self.blade_count)
        return [self.blade(i) for i in indices]

    def hub_blade_indices(self) -> list[int]:
        """Blades standing on the hub strip: all for a full ring, else |i| ≤ (pitches − 1)/2."""
        if self.params.hub_pitches >= self.blade_count:
            return list(range(self.blade_count))
        k = int(math.floor((self.params.hub_pitches - 1.0) / 2.0 + 1e-9))
        return list(range(-k, k + 1))

    def combined(self, indices=None, *, hub: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """One (V, F) for display: the hub strip and the given blades (default: those on it)."""
        if indices is None:
            indices = self.hub_blade_indices()
        parts = [(self.hub_vertices, self.hub_faces)] if hub else []
        parts += self.blade_instances(indices)
        if not parts:
            return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
        offs = np.cumsum([0] + [len(V) for V, _ in parts[:-1]])
        V = np.concatenate([V for V, _ in parts])
        F = np.concatenate([F + o for (_, F), o in zip(parts, offs, strict=True)])
        return V, F.astype(np.int64, copy=False)


# ---------------------------------------------------------------------------------- build
def _grid_faces(n_u: int, n_v: int, flip_diag=None) -> np.ndarray:
    """Two triangles per cell of the periodic (in u) grid; corners CCW in (u, v)."""
    i = np.arange(n_u)
    j = np.arange(n_v - 1)[:, None]
    a = (j * n_u + i).ravel()
    b = (j * n_u + (i + 1) % n_u).ravel()
    c = ((j + 1) * n_u + (i + 1) % n_u).ravel()
    d = ((j + 1) * n_u + i).ravel()
    t1 = np.stack([a, b, c], axis=1)
    t2 = np.stack([a, c, d], axis=1)
    if flip_diag is not None:
        t1 = np.where(flip_diag[:, None], np.stack([a, b, d], axis=1), t1)
        t2 = np.where(flip_diag[:, None], np.stack([b, c, d], axis=1), t2)
    F = np.empty((2 * len(a), 3), dtype=np.int64)
    F[0::2] = t1
    F[1::2] = t2
    return F


def _vertex_normals(V, F):
    fn = triangle_normals(V, F)
    acc = np.zeros_like(V)
    for k in range(3):
        for c in range(3):
            acc[:, c] += np.bincount(F[:, k], weights=fn[:, c], minlength=len(V))
    ln = np.linalg.norm(acc, axis=1)
    return acc / np.where(ln > 0, ln, 1.0)[:, None]


def _build_blade(model: _BladeModel, p: DemoParams):
    n_v, n_u, n_a, n_s = blade_grid_shape(p.resolution)
    u0 = model.u_nodes(n_a, n_s)
    v0 = model.v_nodes(n_v)
    n_cells = n_u * (n_v - 1)
    if not p.scan_like:
        uu = np.broadcast_to(u0, (n_v, n_u)).ravel()
        vv = np.broadcast_to(v0[:, None], (n_v, n_u)).ravel()
        F = _grid_faces(n_u, n_v)
        uv = np.stack([uu, vv], axis=1)
        V = model.points(uu, vv)
        return V, F, uv, (n_v, n_u)
    rng = np.random.default_rng(p.seed)
    J = p.scan_jitter
    # all random draws first, in a fixed order, so that e.g. the noise level does not
    # change the triangulation
    ju = rng.uniform(-1.0, 1.0, (n_v, n_u))
    jv = rng.uniform(-1.0, 1.0, (n_v, n_u))
    diag = rng.integers(0, 2, n_cells).astype(bool)
    sliver = rng.random(n_cells) < p.scan_sliver_fraction
    sl_edge = rng.integers(0, 4, n_cells)
    sl_frac = rng.uniform(0.35, 0.65, n_cells)
    sl_off = rng.uniform(0.02, 0.08, n_cells)
    # jittered parameters: each node within ± J/2 of its smaller neighbouring gap (order kept)
    gap_u = np.diff(np.concatenate([u0, [4.0]]))
    half_u = 0.5 * np.minimum(gap_u, np.roll(gap_u, 1))
    uu = np.mod(u0[None, :] + J * ju * half_u[None, :], 4.0)
    gap_v = np.diff(v0)
    half_v = np.zeros(n_v)
    half_v[1:-1] = 0.5 * np.minimum(gap_v[:-1], gap_v[1:])
    vv = v0[:, None] + J * jv * half_v[:, None]  # rows 0 and n_v − 1 stay on the cones
    uu, vv = uu.ravel(), vv.ravel()
    F = _grid_faces(n_u, n_v, diag)
    # sliver cells: a vertex close to one edge, fan of four triangles
    cells = np.nonzero(sliver)[0]
    extra_uv = np.zeros((0, 2))
    if len(cells):
        jj, ii = cells // n_u, cells % n_u
        corners = np.stack(
            [jj * n_u + ii, jj * n_u + (ii + 1) % n_u, (jj + 1) * n_u + (ii + 1) % n_u,
             (jj + 1) * n_u + ii], axis=1,
        )  # fmt: skip
        # unwrap u across the seam so the cell is a proper quadrilateral in (u, v)
        cu = uu[corners]
        cu = np.where(cu - cu[:, :1] > 2.0, cu - 4.0, cu)
        cu = np.where(cu - cu[:, :1] < -2.0, cu + 4.0, cu)
        cv = vv[corners]
        k0 = sl_edge[cells]
        k1 = (k0 + 1) % 4
        rows = np.arange(len(cells))
        fr = sl_frac[cells]
        eu = (1 - fr) * cu[rows, k0] + fr * cu[rows, k1]
        ev = (1 - fr) * cv[rows, k0] + fr * cv[rows, k1]
        off = sl_off[cells]
        eu = np.mod(eu + off * (cu.mean(axis=1) - eu), 4.0)
        ev = ev + off * (cv.mean(axis=1) - ev)
        extra_uv = np.stack([eu, ev], axis=1)
        e_idx = n_u * n_v + rows
        fan = np.concatenate(
            [np.stack([corners[:, q], corners[:, (q + 1) % 4], e_idx], axis=1) for q in range(4)]
        )
        keep = np.ones(len(F), dtype=bool)
        keep[2 * cells] = False
        keep[2 * cells + 1] = False
        F = np.concatenate([F[keep], fan])
    uv = np.concatenate([np.stack([uu, vv], axis=1), extra_uv])
    V = model.points(uv[:, 0], uv[:, 1])
    noise = rng.standard_normal(len(V))
    if p.scan_noise > 0.0:
        interior = (uv[:, 1] > 0.0) & (uv[:, 1] < 1.0)
        N = _vertex_normals(V, F)
        noisy = V + (p.scan_noise * noise * interior)[:, None] * N
        # a vertex that the noise would carry across a cone (the first rows of a fillet are
        # micrometres above the hub) keeps its exact position: the blade stays between them
        s = model.mc.ratio_of_points(noisy, Axis())
        crossed = interior & ~((s > 0.0) & (s < 1.0))
        noisy[crossed] = V[crossed]
        V = noisy
    return V, F, uv, (n_v, n_u)


def _outward_sign(model: _BladeModel) -> float:
    """+1 if triangles CCW in (u, v) have outward normals, else −1 (one probe point)."""
    eps = 1e-4
    u = np.array([3.5, 3.5 + eps, 3.5 - eps, 3.5, 3.5])
    v = np.array([0.5, 0.5, 0.5, 0.5 + eps, 0.5 - eps])
    sec = model.section(u, v)
    P = model.to_3d(sec)
    n = np.cross(P[1] - P[2], P[3] - P[4])
    C = model.to_3d(sec, sec["cx"], sec["cy"])
    return 1.0 if float(n @ (P[0] - C[0])) > 0.0 else -1.0


def _build_hub(model: _BladeModel, p: DemoParams, blade_V, blade_uv, pitch):
    hub = model.mc.cone1
    P1, P2 = hub.p1, hub.p2
    D = P2 - P1
    ln = float(np.linalg.norm(D))
    foot = blade_V[blade_uv[:, 1] == 0.0]
    rf = np.hypot(foot[:, 0], foot[:, 1])
    t_foot = ((rf - P1[0]) * D[0] + (foot[:, 2] - P1[1]) * D[1]) / ln**2
    ext = p.hub_extension / ln
    t_lo = min(0.0, float(t_foot.min())) - ext
    t_hi = max(1.0, float(t_foot.max())) + ext
    th_foot = np.unwrap(np.arctan2(foot[:, 1], foot[:, 0]))
    th_c = 0.5 * (th_foot.min() + th_foot.max())
    r_mid = float(P1[0] + 0.5 * D[0])
    # the feet of blades |i| ≤ (pitches − 1)/2 and hub_extension beyond them
    width = (
        float(np.ptp(th_foot))
        + (p.hub_pitches - 1.0) * pitch
        + 2.0 * p.hub_extension / max(float(rf.min()), 1.0)
    )
    full = p.hub_pitches >= p.blade_count or width >= 0.999 * TWO_PI
    if full:
        width = TWO_PI
    spacing = 1.5 / min(p.resolution, 3.0)  # mm (the hub is for display and collisions)
    n_t = max(4, math.ceil((t_hi - t_lo) * ln / spacing)) + 1
    n_th = max(8, math.ceil(width * max(r_mid, 1.0) / spacing))
    t = np.linspace(t_lo, t_hi, n_t)
    if full:
        th = th_c + np.arange(n_th) * (TWO_PI / n_th)
        per = n_th
    else:
        th = th_c - 0.5 * width + np.arange(n_th + 1) * (width / n_th)
        per = None
    r = P1[0] + t * D[0]
    z = P1[1] + t * D[1]
    if np.any(r < 0):
        raise DemoParameterError(
            f"demo parameter hub_extension = {p.hub_extension!r}: the hub strip would cross "
            "the axis (allowed: r ≥ 0 along the strip); reduce it or make hub_cone less steep"
        )
    R, TH = np.meshgrid(r, th, indexing="ij")
    Z = np.broadcast_to(z[:, None], R.shape)
    V = np.stack([R * np.cos(TH), R * np.sin(TH), Z], axis=-1).reshape(-1, 3)
    n_c = len(th)
    i = np.arange(n_t - 1)[:, None]
    j = np.arange(n_c if per else n_c - 1)
    jn = (j + 1) % n_c
    a = (i * n_c + j).ravel()
    b = ((i + 1) * n_c + j).ravel()
    c = ((i + 1) * n_c + jn).ravel()
    d = (i * n_c + jn).ravel()
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)]).astype(np.int64)
    # (t, θ) cell normal ∝ (−e_z, e_r) in the meridional plane (×r); flip so that it points
    # toward the tip cone (out of the hub material)
    e = D / ln
    n_m = np.array([-e[1], e[0]])
    toward_tip = model.mc.cone2.p1 + 0.5 * (model.mc.cone2.p2 - model.mc.cone2.p1) - (P1 + 0.5 * D)
    # a, b, c = (t, θ), (t+, θ), (t+, θ+): normal ∝ ∂t × ∂θ
    if float(n_m @ toward_tip) < 0.0:
        F = F[:, ::-1].copy()
    return V, F


def make_demo_blisk(params: DemoParams | None = None, **overrides) -> DemoBlisk:
    """Generate the demo blisk (blade 0, hub strip, true cones).

    Parameters
    ----------
    params : DemoParams, optional — defaults to ``DemoParams()``
    **overrides : fields of :class:`DemoParams` to replace, e.g. ``resolution=0.3,
        scan_like=True``

    Returns
    -------
    DemoBlisk

    Raises
    ------
    DemoParameterError (a :class:`BliskCamError`) naming the bad parameter and its allowed
    range, also for combinations (blades intersecting their neighbours, folded sections);
    ConeError-derived messages are re-raised as DemoParameterError naming the cone.

    Notes
    -----
    Cost (2-core machine, numpy 1.26): about 0.4 s per million blade triangles in clean mode
    and 1 s in scan-like mode (vectorised numpy, evaluated in chunks; no per-vertex Python
    loops). ``resolution=4.5`` (2.02 M triangles) takes about 0.8 s / 2 s.
    """
    names = {f.name for f in fields(DemoParams)}
    unknown = sorted(set(overrides) - names)
    if unknown:
        raise DemoParameterError(
            f"unknown demo parameter(s) {', '.join(unknown)}; allowed: {', '.join(sorted(names))}"
        )
    if params is None:
        params = DemoParams(**overrides)
    elif not isinstance(params, DemoParams):
        raise DemoParameterError(
            f"demo parameter params must be a DemoParams (allowed: DemoParams or None), got "
            f"{type(params).__name__}"
        )
    elif overrides:
        params = replace(params, **overrides)
    p = params
    try:
        mc = MorphingCones(Cone(*p.hub_cone), Cone(*p.tip_cone))
    except ConeError as err:
        raise DemoParameterError(
            f"demo parameters hub_cone/tip_cone: {err} (allowed: two cones that do not cross "
            "between their end points)"
        ) from None
    hub_mid = 0.5 * (mc.cone1.r1 + mc.cone1.r2)
    tip_mid = 0.5 * (mc.cone2.r1 + mc.cone2.r2)
    if not tip_mid > hub_mid:
        raise DemoParameterError(
            f"demo parameters hub_cone/tip_cone: the tip cone (mean r {tip_mid:.6g} mm) must be "
            f"farther from the axis than the hub cone (mean r {hub_mid:.6g} mm) (allowed: "
            "tip cone outside the hub cone)"
        )
    model = _BladeModel(p, mc)
    if model.H0 <= 0 or model.H1 <= 0:
        raise DemoParameterError(
            "demo parameters hub_cone/tip_cone: the cones cross (allowed: tip cone outside the "
            "hub cone)"
        )
    pitch = TWO_PI / p.blade_count
    _check_geometry(model, pitch)
    V, F, uv, shape = _build_blade(model, p)
    if _outward_sign(model) < 0.0:
        F = F[:, ::-1].copy()
    HV, HF = _build_hub(model, p, V, uv, pitch)
    return DemoBlisk(
        blade_vertices=V,
        blade_faces=F,
        hub_vertices=HV,
        hub_faces=HF,
        axis=Axis(),
        hub_cone=mc.cone1,
        tip_cone=mc.cone2,
        blade_count=p.blade_count,
        params=p,
        blade_uv=uv,
        grid_shape=shape,
        _model=model,
    )
