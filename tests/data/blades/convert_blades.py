#!/usr/bin/env python3
"""Convert published NASA Rotor 37 / Rotor 67 blade tables into triangle meshes.

Inputs (copied verbatim from github.com/F18/CFFC, data/NASA_Rotors/, commit
6ec83660edb221b85b151d6e14447516c8fba4f4, snapshot HEAD b21b009b4f2ce528bbe8d8267face2aeb6fff8f8):
  rotor37geometry.dat   AGARD-AR-355 "Table IV NASA Rotor 37 Blade Geometry":
                        13 stream surfaces x 100 points, columns J Z R THETA1 THETA2,
                        Z,R in cm, THETA in radians; J=1 is the leading edge, J=100 the
                        trailing edge (THETA1==THETA2 there).  Surface 1 = hub/blade
                        intersection, 12 = blade tip section, 13 = blade/shroud intersection.
  rotor37hub-shroud.dat "Table V" hub and shroud (casing) meridional lines, cm.
  rotor67geometry.dat   NASA (Wood/Strazisar) Rotor 67 export, 14 stream surfaces x 110
                        points, arrays axial, r*theta (upper surface), tangential thickness,
                        radius, all in FEET; JLE=16, JTE=85; surface 1 = hub, 13 = blade tip
                        section, 14 = casing.

Output frame: rotation axis = +Z, x = r cos(theta), y = r sin(theta), z = axial coordinate
of the source table (flow in +z).  Units: millimetres.

Only numpy is needed (matplotlib for the optional preview, render_blades.py).
Run: python convert_blades.py   (reads ./source/*.dat, writes into this directory)
"""
import json
import os
import re

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.environ.get("BLADE_SRC", os.path.join(HERE, "source"))  # verbatim copies of the three .dat files
OUT = HERE


# ----------------------------------------------------------------------------- parsing
def parse_r37(path):
    """Return Z, R, T1, T2 arrays of shape (13, 100) in cm / rad."""
    secs, cur = [], None
    with open(path) as f:
        for line in f:
            if "SURFACE NUMBER" in line:
                cur = []
                secs.append(cur)
                continue
            tok = line.split()
            if cur is not None and len(tok) == 5 and re.match(r"^\d+$", tok[0]):
                cur.append([float(t) for t in tok[1:]])
    a = np.array(secs)  # (ns, np, 4)
    return a[..., 0], a[..., 1], a[..., 2], a[..., 3]


def parse_r37_hub_shroud(path):
    txt = open(path).read()
    out = {}
    for name in ("Zhub", "Rhub", "Zshroud", "Rshroud"):
        m = re.search(r"\b%s\s*\n\s*(\d+) points\s*\n(.*?)(?:\n\s*\n|\Z)" % name, txt, re.S)
        n = int(m.group(1))
        vals = np.array([float(v) for v in m.group(2).split()])
        assert vals.size == n, (name, vals.size, n)
        out[name] = vals
    return out


def parse_r67(path):
    """Return dict with JM, NS, NB, JLE, JTE and per-surface arrays (feet)."""
    lines = open(path).read().splitlines()
    i = next(k for k, l in enumerate(lines) if l.strip().startswith("JM") and "NS" in l and k > 60)
    jm, ns, nb, jle, jte = (int(v) for v in lines[i + 1].split())
    surfs = []
    k = i + 2
    while len(surfs) < ns:
        assert "Surface number" in lines[k], lines[k]
        k += 1
        arrs = []
        for _ in range(4):
            k += 1  # title line
            scale = float(lines[k].split()[0]); k += 1
            vals = []
            while len(vals) < jm:
                vals += [float(v) for v in lines[k].split()]
                k += 1
            arrs.append(np.array(vals) * scale)
        surfs.append(dict(axial=arrs[0], rtheta=arrs[1], thick=arrs[2], radius=arrs[3]))
    return dict(JM=jm, NS=ns, NB=nb, JLE=jle, JTE=jte, surfaces=surfs)


# ----------------------------------------------------------------------------- geometry
class ColumnSpline:
    """Natural cubic spline through rings Y[k] (shape (n, L, 3)) at common params t[k];
    can be evaluated with a different parameter per column (per ring point).
    Outside [t0, t_{n-1}] it extrapolates linearly with the end slope."""

    def __init__(self, t, Y):
        self.t = np.asarray(t, float); self.Y = np.asarray(Y, float)
        n = len(t); h = np.diff(self.t); self.h = h
        Yf = self.Y.reshape(n, -1)
        A = np.zeros((n, n)); rhs = np.zeros_like(Yf)
        A[0, 0] = A[-1, -1] = 1.0
        for i in range(1, n - 1):
            A[i, i - 1] = h[i - 1]; A[i, i] = 2 * (h[i - 1] + h[i]); A[i, i + 1] = h[i]
            rhs[i] = 6 * ((Yf[i + 1] - Yf[i]) / h[i] - (Yf[i] - Yf[i - 1]) / h[i - 1])
        self.M = np.linalg.solve(A, rhs).reshape(self.Y.shape)
        self.d0 = (self.Y[1] - self.Y[0]) / h[0] - h[0] * self.M[1] / 6
        self.d1 = (self.Y[-1] - self.Y[-2]) / h[-1] + h[-1] * self.M[-2] / 6

    def __call__(self, tq):
        """tq: scalar or (L,) -> (L, 3)."""
        t, Y, M = self.t, self.Y, self.M
        L = Y.shape[1]
        tq = np.broadcast_to(np.asarray(tq, float), (L,))
        i = np.clip(np.searchsorted(t, tq) - 1, 0, len(t) - 2)
        cols = np.arange(L)
        h = self.h[i][:, None]
        a = ((t[i + 1] - tq) / self.h[i])[:, None]; b = 1 - a
        y = (a * Y[i, cols] + b * Y[i + 1, cols]
             + ((a ** 3 - a) * M[i, cols] + (b ** 3 - b) * M[i + 1, cols]) * h ** 2 / 6)
        lo = tq < t[0]; hi = tq > t[-1]
        y[lo] = Y[0, lo] + (tq[lo] - t[0])[:, None] * self.d0[lo]
        y[hi] = Y[-1, hi] + (tq[hi] - t[-1])[:, None] * self.d1[hi]
        return y


def build_rings(Z, R, T1, T2):
    """(ns, m) cylindrical side tables -> rings (ns, 2m-2, 3) of (z, r, theta):
    side 1 LE->TE then side 2 TE->LE (LE/TE points shared)."""
    s1 = np.stack([Z, R, T1], -1)
    s2 = np.stack([Z, R, T2], -1)
    return np.concatenate([s1, s2[:, -2:0:-1]], axis=1)


def cyl_to_xyz(rings):
    z, r, th = rings[..., 0], rings[..., 1], rings[..., 2]
    return np.stack([r * np.cos(th), r * np.sin(th), z], -1)


def loft(P, m, cap_hub=True, cap_tip=True):
    """P: (ns, L, 3) closed rings, L = 2m-2.  Returns V (ns*L,3), F (nt,3)."""
    ns, L, _ = P.shape
    V = P.reshape(-1, 3)
    idx = np.arange(ns * L).reshape(ns, L)
    a = idx[:-1]; b = np.roll(idx[:-1], -1, axis=1)
    c = np.roll(idx[1:], -1, axis=1); d = idx[1:]
    F = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3),
                        np.stack([a, c, d], -1).reshape(-1, 3)])
    caps = []
    def side_idx(ring):
        s1 = idx[ring, :m]
        s2 = np.concatenate([[idx[ring, 0]], idx[ring, L - np.arange(1, m - 1)], [idx[ring, m - 1]]])
        return s1, s2
    for ring, flag in ((0, cap_hub), (ns - 1, cap_tip)):
        if not flag:
            continue
        s1, s2 = side_idx(ring)
        tri = []
        for j in range(m - 1):
            A_, B_, C_, D_ = s1[j], s1[j + 1], s2[j + 1], s2[j]
            if j == 0:
                tri.append([A_, B_, C_])
            elif j == m - 2:
                tri.append([A_, B_, D_])
            else:
                tri += [[A_, B_, C_], [A_, C_, D_]]
        tri = np.array(tri)
        caps.append(tri[:, ::-1] if ring == 0 else tri)  # wind opposite to the adjacent side faces
    if caps:
        F = np.concatenate([F] + caps)
    return V, F


def signed_volume(V, F):
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0


def write_stl(path, V, F, header=b"blade"):
    tri = V[F].astype(np.float32)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    ln = np.linalg.norm(n, axis=1, keepdims=True); ln[ln == 0] = 1
    rec = np.zeros(len(F), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"] = n / ln; rec["v"] = tri
    with open(path, "wb") as f:
        f.write(header[:80].ljust(80, b" "))
        f.write(np.uint32(len(F)).tobytes())
        f.write(rec.tobytes())


def write_ply(path, V, F, comment=""):
    with open(path, "wb") as f:
        hdr = ["ply", "format binary_little_endian 1.0"]
        hdr += ["comment " + c for c in comment.splitlines() if c]
        hdr += ["element vertex %d" % len(V), "property double x", "property double y",
                "property double z", "element face %d" % len(F),
                "property list uchar int vertex_indices", "end_header"]
        f.write(("\n".join(hdr) + "\n").encode())
        f.write(V.astype("<f8").tobytes())
        rec = np.zeros(len(F), dtype=[("n", "u1"), ("i", "<i4", 3)])
        rec["n"] = 3; rec["i"] = F
        f.write(rec.tobytes())


def fit_line(z, r):
    """Least-squares r = a + b z; returns a, b, max |residual|."""
    b, a = np.polyfit(z, r, 1)
    return a, b, float(np.max(np.abs(r - (a + b * z))))


def mesh_stats(V, F):
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, cnt = np.unique(e, axis=0, return_counts=True)
    tri = V[F]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return dict(vertices=int(len(V)), triangles=int(len(F)),
                bbox_min=[round(float(v), 4) for v in V.min(0)],
                bbox_max=[round(float(v), 4) for v in V.max(0)],
                boundary_edges=int((cnt == 1).sum()), nonmanifold_edges=int((cnt > 2).sum()),
                min_triangle_area_mm2=float(area.min()), surface_area_mm2=round(float(area.sum()), 3))


# ----------------------------------------------------------------------------- drivers
def line_r(cone, z):
    a, b = cone["_ab"]
    return a + b * z


def make_outputs(name, rc_src, m, scale, meta, casing_zr, hub_line_pts, casing_line_pts,
                 tip_trim=None, sub=4):
    """rc_src: (ns, L, 3) published rings (z, r, theta) in source units; scale -> mm.
    tip_trim: None (last ring is the blade tip) or (z_mm, r_mm, clearance_mm) casing polyline:
    the tip ring is then placed between the last two rings where the blade is `clearance`
    (normal to the casing) inside the casing line."""
    rc = rc_src.copy(); rc[..., :2] *= scale
    P = cyl_to_xyz(rc)
    n, L, _ = rc.shape
    # chord-length-like parameter between rings (mean point distance, mm)
    t = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=-1).mean(1))])
    spl = ColumnSpline(t, rc)
    checks = {}
    if tip_trim is None:
        t_tip = np.full(L, t[-1])
    else:
        zc, rcas, clr = tip_trim
        slope = np.gradient(rcas, zc)
        def g(tt):
            y = spl(tt)
            return y[:, 1] - (np.interp(y[:, 0], zc, rcas) - clr * np.sqrt(1 + np.interp(y[:, 0], zc, slope) ** 2))
        lo = np.full(L, t[-2]); hi = np.full(L, t[-1])
        assert (g(lo) < 0).all() and (g(hi) > 0).all()
        for _ in range(60):
            mid = 0.5 * (lo + hi); gm = g(mid)
            lo = np.where(gm < 0, mid, lo); hi = np.where(gm < 0, hi, mid)
        t_tip = 0.5 * (lo + hi)
        checks["tip_trim"] = dict(clearance_mm=clr, max_abs_residual_mm=float(np.abs(g(t_tip)).max()),
                                  tip_ring_fraction_between_last_two_surfaces=[
                                      round(float(((t_tip - t[-2]) / (t[-1] - t[-2])).min()), 4),
                                      round(float(((t_tip - t[-2]) / (t[-1] - t[-2])).max()), 4)])
    # ring parameter lists (each entry: per-column parameter array of length L)
    n_body = n - 1  # rings 0..n-2 are kept as published; the last ring is the tip (published or trimmed)
    sec_params = [np.full(L, t[k]) for k in range(n_body)] + [t_tip]
    ref_params = []
    for k in range(n_body):
        t_next = t_tip if k == n_body - 1 else np.full(L, t[k + 1])
        for s in range(sub):
            ref_params.append(t[k] + s / sub * (t_next - t[k]))
    ref_params.append(t_tip)
    hub_ring = spl(sec_params[0]); tip_ring = spl(sec_params[-1])
    zmin = float(min(hub_ring[:, 0].min(), tip_ring[:, 0].min(), rc[:n_body, :, 0].min()))
    zmax = float(max(hub_ring[:, 0].max(), tip_ring[:, 0].max(), rc[:n_body, :, 0].max()))
    margin = 2.0
    cz, cr = np.asarray(casing_zr[0]) * scale, np.asarray(casing_zr[1]) * scale
    cones = {}
    for key, zz, rr, desc in (
            ("hub", hub_ring[:, 0], hub_ring[:, 1], "least-squares line through the blade's hub section (r,z)"),
            ("tip", tip_ring[:, 0], tip_ring[:, 1], "least-squares line through the blade's tip section (r,z)"),
            ("casing", cz, cr, "least-squares line through the casing (shroud) section of the data (r,z), for reference")):
        a, b, res = fit_line(zz, rr)
        za, zb = float(np.min(zz)) - margin, float(np.max(zz)) + margin
        cones[key] = dict(
            description=desc + "; P1/P2 at the section's axial extent +- %.1f mm" % margin,
            P1_xyz_mm=[round(a + b * za, 4), 0.0, round(za, 4)],
            P2_xyz_mm=[round(a + b * zb, 4), 0.0, round(zb, 4)],
            P1_rz_mm=[round(a + b * za, 4), round(za, 4)],
            P2_rz_mm=[round(a + b * zb, 4), round(zb, 4)],
            r_of_z_mm="r = %.6f + %.6f * z" % (a, b),
            slope_angle_deg_atan_dr_dz=round(float(np.degrees(np.arctan(b))), 4),
            max_fit_residual_mm=round(res, 4), fitted_points=int(len(zz)), _ab=(a, b))
    for key, pts in (("hub", hub_line_pts), ("casing", casing_line_pts)):
        zz = np.asarray(pts[0]) * scale; rr = np.asarray(pts[1]) * scale
        c = cones[key]
        sel = (zz >= c["P1_rz_mm"][1]) & (zz <= c["P2_rz_mm"][1])
        if sel.any():
            c["max_dev_of_published_line_within_P1P2_mm"] = round(float(np.max(np.abs(rr[sel] - line_r(c, zz[sel])))), 4)
        c["published_line_rz_mm"] = [[round(float(r), 4), round(float(z), 4)] for r, z in zip(rr, zz)]
    # extension lengths so that the extended blade pierces the hub / tip cones everywhere
    ext_hub = float(np.ceil(2 * cones["hub"]["max_fit_residual_mm"]) + 2)
    ext_tip = float(np.ceil(2 * cones["tip"]["max_fit_residual_mm"]) + 2)
    nh, nt = int(np.ceil(ext_hub)), int(np.ceil(ext_tip))
    ext_params = ([np.full(L, t[0] - ext_hub * (nh - k) / nh) for k in range(nh)] + ref_params
                  + [t_tip + ext_tip * (k + 1) / nt for k in range(nt)])
    results = {}
    variants = (("sections", sec_params, (True, False)), ("refined", ref_params, (True, False)),
                ("extended", ext_params, (False,)))
    for tag, params, caps in variants:
        RC = np.array([spl(tp) for tp in params])
        PP = cyl_to_xyz(RC)
        # section sanity: side 1 and side 2 must not cross (tangential thickness > 0 off LE/TE)
        jj = np.arange(1, m - 1)
        tth = RC[:, jj, 1] * (RC[:, jj, 2] - RC[:, L - jj, 2]) * meta.get("_side_sign", 1.0)
        checks.setdefault("min_tangential_thickness_mm", {})[tag] = round(float(tth.min()), 5)
        assert tth.min() > 0, (name, tag, tth.min())
        if tag == "extended":
            hub_e, tip_e = RC[0], RC[-1]
            hz = np.asarray(hub_line_pts[0]) * scale; hr = np.asarray(hub_line_pts[1]) * scale
            checks["extended_mesh"] = dict(
                hub_extension_mm=ext_hub, tip_extension_mm=ext_tip,
                min_depth_below_hub_cone_mm=round(float((line_r(cones["hub"], hub_e[:, 0]) - hub_e[:, 1]).min()), 4),
                min_depth_below_published_hub_line_mm=round(float((np.interp(hub_e[:, 0], hz, hr) - hub_e[:, 1]).min()), 4),
                min_height_above_tip_cone_mm=round(float((tip_e[:, 1] - line_r(cones["tip"], tip_e[:, 0])).min()), 4))
        for capped in caps:
            V, F = loft(PP, m, capped, capped)
            Vc, Fc = loft(PP, m, True, True)
            vol = signed_volume(Vc, Fc)
            if vol < 0:
                F = F[:, ::-1]; vol = -vol
            fn = "%s_blade_%s_%s" % (name, tag, "closed" if capped else "open")
            write_stl(os.path.join(OUT, fn + ".stl"), V, F,
                      header=("%s blade surface, mm, rotation axis +Z, %s" % (name, tag)).encode())
            if tag != "sections":
                write_ply(os.path.join(OUT, fn + ".ply"), V, F,
                          comment="%s blade surface (%s), units mm, rotation axis +Z" % (name, tag))
            st = mesh_stats(V, F)
            if capped:
                st["volume_mm3"] = round(float(vol), 3)
            st["rings"] = int(PP.shape[0]); st["points_per_ring"] = int(PP.shape[1])
            results[fn] = st
    # published section points (mm)
    with open(os.path.join(OUT, "%s_sections_mm.csv" % name), "w") as f:
        f.write("section,side,j,x_mm,y_mm,z_mm,r_mm,theta_rad\n")
        for k in range(n):
            for i in range(L):
                side, j = (1, i) if i < m else (2, L - i)
                x, y, z = P[k, i]
                f.write("%d,%d,%d,%.6f,%.6f,%.6f,%.6f,%.8f\n" % (k + 1, side, j + 1, x, y, z, rc[k, i, 1], rc[k, i, 2]))
    for c in cones.values():
        c.pop("_ab")
    meta = dict(meta); meta.pop("_side_sign", None)
    meta.update(units="mm", rotation_axis="Z; x = r cos(theta), y = r sin(theta), z = axial (flow towards +z)",
                meridional_plane="cone points P1,P2 are given in the theta = 0 half-plane, i.e. (x=r, y=0, z); "
                                 "each cone is the surface of revolution of segment P1-P2 about the Z axis",
                blade_axial_extent_mm=[round(zmin, 4), round(zmax, 4)],
                blade_radial_extent_mm=[round(float(hub_ring[:, 1].min()), 4), round(float(tip_ring[:, 1].max()), 4)],
                cones=cones, checks=checks, meshes=results,
                mesh_variants={
                    "sections": "published sections lofted linearly (ring = side1 LE->TE + side2 TE->LE); 'closed' = hub and tip caps",
                    "refined": "%d natural-cubic-spline rings (in z, r, theta; chord-length parameter) inserted between "
                               "consecutive sections; published sections kept exactly" % (sub - 1),
                    "extended": "refined surface extrapolated linearly (spline end slope) %.0f mm below the hub section and "
                                "%.0f mm beyond the tip section, open, for trimming by the hub/tip cones in CAM" % (ext_hub, ext_tip)})
    with open(os.path.join(OUT, "%s_blade.json" % name), "w") as f:
        json.dump(meta, f, indent=2)
    return meta


def main():
    # ---------------- Rotor 37
    Z, R, T1, T2 = parse_r37(os.path.join(SRC, "rotor37geometry.dat"))
    assert Z.shape == (13, 100), Z.shape
    assert np.allclose(T1[:, 0], T2[:, 0]) and np.allclose(T1[:, -1], T2[:, -1])
    hs = parse_r37_hub_shroud(os.path.join(SRC, "rotor37hub-shroud.dat"))
    blade = slice(0, 12)  # surfaces 1..12 = hub/blade intersection .. blade tip section
    rings = build_rings(Z[blade], R[blade], T1[blade], T2[blade])
    meta37 = dict(
        name="NASA Rotor 37 (transonic axial compressor rotor, inlet rotor of NASA Stage 37)",
        blade_count=36, design_speed_rpm=17188.7,
        source=dict(
            table="AGARD-AR-355 (1998) 'CFD Validation for Propulsion System Components', NASA Rotor 37 "
                  "test case: Table IV blade geometry + Table V hub/shroud coordinates (NASA Lewis data; "
                  "rotor design: Reid & Moore, NASA TP-1337, 1978)",
            repo="https://github.com/F18/CFFC",
            files=["data/NASA_Rotors/R37/rotor37geometry.dat", "data/NASA_Rotors/R37/rotor37hub-shroud.dat"],
            file_commit="6ec83660edb221b85b151d6e14447516c8fba4f4",
            snapshot_head="b21b009b4f2ce528bbe8d8267face2aeb6fff8f8",
            source_format="13 surfaces x 100 points: J Z R THETA1 THETA2; Z,R in cm, THETA in rad",
            license="hosting repository: GNU GPL v2 or later (CFFC, (C) 1999-2007 C.P.T. Groth / Univ. of Toronto). "
                    "The tables are NASA/AGARD-published test-case data (US Government work) that the repository "
                    "redistributes without a separate licence file; cite AGARD-AR-355 / NASA TP-1337."),
        sections_used="surfaces 1..12 (1 = hub/blade intersection, 12 = blade tip section); surface 13 "
                      "(blade/shroud intersection) only used for the casing cone",
        section_points="100 per side (J=1 LE .. J=100 TE; LE/TE points shared) -> 198 per ring",
        side_convention="THETA1 side first in each ring; THETA1 > THETA2 along the chord",
        tip_clearance_note="section 12 lies ~0.36 mm inside surface 13 (AGARD: 0.356 mm running clearance)")
    make_outputs("rotor37", rings, 100, 10.0, meta37, casing_zr=(Z[12], R[12]),
                 hub_line_pts=(hs["Zhub"], hs["Rhub"]), casing_line_pts=(hs["Zshroud"], hs["Rshroud"]))

    # ---------------- Rotor 67
    d = parse_r67(os.path.join(SRC, "rotor67geometry.dat"))
    j0, j1 = d["JLE"] - 1, d["JTE"]  # LE..TE inclusive, 70 points
    S = d["surfaces"]
    ZZ = np.array([s["axial"][j0:j1] for s in S]); RR = np.array([s["radius"][j0:j1] for s in S])
    U = np.array([s["rtheta"][j0:j1] for s in S]); TH = np.array([s["thick"][j0:j1] for s in S])
    assert np.allclose(TH[:, 0], 0) and np.allclose(TH[:, -1], 0)
    T1 = U / RR; T2 = (U - TH) / RR
    rings = build_rings(ZZ, RR, T1, T2)  # all 14 surfaces; the tip is trimmed below the casing
    m = j1 - j0
    ft = 304.8
    clr = 0.024 * 25.4
    meta67 = dict(
        name="NASA Rotor 67 (transonic axial fan rotor)", blade_count=d["NB"], design_speed_rpm=16043,
        source=dict(
            table="'ROTOR 67 GEOMETRY FOR EXPORT' (J.R. Wood / A.J. Strazisar, NASA Lewis, 6/21/91, re-run "
                  "1/15/92), consistent with NASA TP-2879 (Strazisar, Wood, Hathaway, Suder 1989) except "
                  "circular LE/TE and no axial shift",
            repo="https://github.com/F18/CFFC",
            files=["data/NASA_Rotors/R67/rotor67geometry.dat"],
            file_commit="6ec83660edb221b85b151d6e14447516c8fba4f4",
            snapshot_head="b21b009b4f2ce528bbe8d8267face2aeb6fff8f8",
            source_format="14 stream surfaces x 110 points (JLE=16, JTE=85): axial, r*theta (upper), "
                          "tangential thickness, radius; all in feet",
            license="hosting repository: GNU GPL v2 or later (CFFC). Data: NASA-published geometry "
                    "('for export', US Government work); no separate licence file; cite NASA TP-2879."),
        sections_used="surfaces 1..13 (1 = hub) plus a tip ring interpolated (spanwise spline) between "
                      "surfaces 13 and 14 where the blade is 0.024 in (0.61 mm) normal to the casing "
                      "(surface 14), as the file header prescribes",
        section_points="%d per side (J=%d..%d of %d; LE/TE shared) -> %d per ring" % (m, d["JLE"], d["JTE"], d["JM"], 2 * m - 2),
        side_convention="upper surface (r*theta as listed) first; lower = upper - tangential thickness")
    make_outputs("rotor67", rings, m, ft, meta67, casing_zr=(ZZ[13], RR[13]),
                 hub_line_pts=(S[0]["axial"], S[0]["radius"]),
                 casing_line_pts=(S[13]["axial"], S[13]["radius"]),
                 tip_trim=(S[13]["axial"] * ft, S[13]["radius"] * ft, clr))
    print("done")


if __name__ == "__main__":
    main()
