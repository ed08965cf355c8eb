"""The final verdict of a job (issue 24, acceptance 1): after the last operation, the material
left on the blades, the hub and the fillets must be at most the finishing tolerance (cusp +
chord) and no gouge deeper than the chord — everywhere except zones named as unreachable, each
with its area.

Measured on the stock the last operation left, per face of the part mesh (blade 0 and the hub
of its pitch sector, :meth:`..part.model.BliskPart.part_mesh`): the deviation at the face's
centroid along its normal out of the metal (:func:`..stock.deviation.deviation_map`, + left,
− gouge). The stock is radial dexels of resolution ``res``; a face is judged only where the
grid resolves the part itself, by the test the per-operation verdicts use
(:func:`..stock.deviation.resolved_points`): the part's own solid cast on the stock's own rays
(the "ideal" stock, what a program that never cuts into the part leaves at best on that grid)
measured the same way must show less than the gouge tolerance of material, and hold the map's
samples at the tolerance's depth below the face (the grid's ray crosses the part there). Thin
edges the grid's rays miss or clip are reported as *unresolved*, with their area, not judged:
a cut near a thin edge takes the whole ray there. Hub faces buried under the blade are not
part of the surface.

Bounds (mm): a face lies in the *contact region* of a finishing operation (kinds
:data:`FINISHING_KINDS`; roughing and semi-finishing leave stock on purpose) when its centroid
lies within w = sqrt(2 ρ (cusp + chord)) of one of the operation's contact points (CC points,
densified to 0.5 mm along the passes and turned to the blades on either side, ρ the cutter's
radius): a ball touching the surface at a point leaves at most cusp + chord within w of it on
a flat or concave surface. There the bound is b = cusp + chord + res of that operation (its scallop
estimate where hub finishing measured one, else its cusp; the stock resolution because the map
is good to it); outside every contact region the largest finishing bound. Gouge tolerance: the
largest finishing chord + res (or the job's ``gouge_tolerance``).

Zones: connected sets (faces sharing a vertex, of one surface class) of faces whose left exceeds
their bound, or whose gouge exceeds the tolerance. Each is named by its surface (hub; blade 0's
fillet; its +θ / −θ side, the convex one — of larger median mean curvature — the suction side;
its leading or trailing edge, the flow running toward +z of the axis so the leading edge is the
blade's lower-z end), its radius, axial and height-above-hub ranges, its area (mm², the sum
of its faces' areas) and why:

* ``not machined`` — no finishing operation plans contacts there (the nearest contacts of
  each finishing operation are given, and the operation that would cover it: fillet
  finishing's layers for the fillet, blade finishing's hub cone lowered for the blade sides
  below its lowest contacts, hub finishing for the hub, blade finishing elsewhere);
* ``unreachable`` — contacts are planned there but every one of them collides (the tool body
  within the safety, left unresolved by the collision check): the tool cannot reach;
* ``failed`` — a finishing operation plans clear contacts there and the stock still keeps more
  than the bound; or any gouge beyond the tolerance.

The verdict's ``status``: "failed" when a zone failed; else "incomplete" when a zone is not
machined (a deliberately partial job — roughing alone, the blades without the fillet — reads
so: nothing wrong with what was cut, but not the whole part); else "passed" (``passed``: the
status is "passed"; the unreachable zones are allowed, named with their areas). Lengths mm,
areas mm².
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..geometry.mesh import TriMesh, triangle_normals
from ..geometry.vectors import rotate_about
from ..hub.channel import root_loop
from ..hub.fillet import face_principal_curvatures
from ..hub.surface import HubSurface
from ..part.model import BliskPart, theta_about
from ..stock.blank import stock_from_allowance
from ..stock.deviation import deviation_map, resolved_points, surface_distance
from ..toolpath.types import STATUS_UNRESOLVED

__all__ = ["FINISHING_KINDS", "JobVerdict", "OperationContacts", "Zone", "face_frame",
           "job_verdict", "job_verdict_dict", "job_verdict_lines"]

#: the kinds whose contacts finish the surface (their bound applies where they touch)
FINISHING_KINDS = ("blade_finish", "hub_finish", "fillet_finish")
#: contact points are densified to this spacing along each pass (mm)
CONTACT_STEP = 0.5


@dataclass
class OperationContacts:
    """One finishing operation as the verdict sees it: ``index``, ``name``; ``cc`` (k, 3)
    contact points of its planned passes (blade 0's / gap 0's frame); ``colliding`` (k,) bool
    — the pose at that contact collides (unresolved); ``radius`` mm (the ball's, the corner's
    of a bull nose); ``cusp``, ``chord`` mm."""

    index: int
    name: str
    cc: np.ndarray
    colliding: np.ndarray
    radius: float
    cusp: float
    chord: float
    kind: str = ""

    @classmethod
    def from_path(cls, index: int, name: str, path, kind: str = "") -> OperationContacts:
        """The contacts of a planned :class:`..toolpath.types.ToolPath` (its curves' CC
        points, densified; the collision status per pose where the path was checked);
        ``kind`` the operation's kind (:data:`FINISHING_KINDS`)."""
        pts, hit = [], []
        for c in path.curves:
            cc = np.asarray(c.cc, float)
            st = np.zeros(len(cc), bool)
            if c.collision is not None and "status" in c.collision:
                st = np.asarray(c.collision["status"]) == STATUS_UNRESOLVED
            if len(cc) == 0:
                continue
            P = np.vstack([cc, cc[:1]]) if c.closed else cc
            S = np.concatenate([st, st[:1]]) if c.closed else st
            seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
            n = np.maximum(1, np.ceil(seg / CONTACT_STEP).astype(int))
            for a in range(len(seg)):
                t = (np.arange(n[a]) / n[a])[:, None]
                pts.append(P[a] + t * (P[a + 1] - P[a]))
                hit.append(np.full(n[a], bool(S[a] and S[a + 1])))
            pts.append(P[-1:])
            hit.append(S[-1:])
        cc = np.vstack(pts) if pts else np.zeros((0, 3))
        tool = path.tool
        radius = float(tool.r) if getattr(tool, "r", 0.0) else float(tool.radius)
        cusp = float(path.stats.get("scallop_estimate_mm", path.cusp)) if path.stats else float(
            path.cusp)
        return cls(index, name, cc, np.concatenate(hit) if hit else np.zeros(0, bool),
                   radius, cusp, float(path.chord), kind)


@dataclass
class Zone:
    """A connected set of faces beyond the bound (module docstring). ``faces``: indices into
    the part mesh; ``status``: "not machined", "unreachable" or "failed"; ``what``: "left" or
    "gouge";
    ``surface``; ``area_mm2``; ranges (min, max) ``r_mm``, ``z_mm``, ``height_mm`` (above the
    hub); ``worst_mm`` (largest left or gouge); ``reason``; ``cover`` (not machined: the
    operation that would cover it, else "")."""

    faces: np.ndarray
    status: str
    what: str
    surface: str
    area_mm2: float
    r_mm: tuple
    z_mm: tuple
    height_mm: tuple
    worst_mm: float
    reason: str
    cover: str = ""


@dataclass
class JobVerdict:
    """The final verdict: ``passed`` (``status`` "passed"), ``status`` ("passed", "incomplete":
    zones not machined, none failed, "failed"); ``zones`` (failed, not machined, unreachable,
    each largest first); the bounds; the areas (mm²)
    judged, unresolved and of the whole surface; per-face figures for tests and maps:
    ``left`` (n_faces,) mm (NaN: not judged), ``bound`` (n_faces,) mm, ``covered`` (n_faces,)
    index of the operation whose clear contacts cover the face (−1: none)."""

    passed: bool
    zones: list
    gouge_tolerance: float
    bounds: dict
    resolution: float
    area_surface_mm2: float
    area_unresolved_mm2: float
    max_gouge_mm: float
    unresolved_by_surface: dict = field(default_factory=dict)
    status: str = "passed"
    left: np.ndarray = field(repr=False, default=None)
    bound: np.ndarray = field(repr=False, default=None)
    covered: np.ndarray = field(repr=False, default=None)


def face_frame(part: BliskPart):
    """The part mesh (V, F, hub mask), its face centroids, unit face normals out of the metal
    (hub faces turned away from the axis) and face areas (mm²)."""
    V, F, hub = part.part_mesh()
    n2 = triangle_normals(V, F)
    ln = np.linalg.norm(n2, axis=1)
    N = n2 / np.maximum(ln, 1e-300)[:, None]
    C = V[F].mean(axis=1)
    rel = C - part.axis.o
    radial = rel - (rel @ part.axis.d)[:, None] * part.axis.d
    flip = hub & (np.einsum("ij,ij->i", N, radial) < 0)
    N[flip] *= -1.0
    return V, F, hub, C, N, 0.5 * ln


def _classes(part: BliskPart, C, N, hub, fillet_radius):
    """Per face: class index into :data:`_CLASS_NAMES` and its height above the hub."""
    hs = HubSurface(part.hub_profile, part.axis)
    _, th, h = hs.coordinates(C)
    cls = np.zeros(len(C), np.int8)  # 0 hub
    blade = ~hub
    e_th = hs.tangential(th)
    side_plus = np.einsum("ij,ij->i", N, e_th) > 0
    # chordwise coordinate in the developed (r_ref θ, z) plane of the blade
    r, t, z = theta_about(C, part.axis)
    t0 = math.atan2(float(np.sin(t[blade]).mean()), float(np.cos(t[blade]).mean()))
    tt = np.mod(t - t0 + math.pi, 2 * math.pi) - math.pi
    r_ref = float(np.median(r[blade])) if blade.any() else 1.0
    X = np.stack([r_ref * tt, z], 1)
    B = X[blade]
    mu = B.mean(axis=0)
    _, _, vt = np.linalg.svd(B - mu, full_matrices=False)
    chord = vt[0] if vt[0][1] >= 0 else -vt[0]  # toward +z: leading → trailing edge
    s = (X - mu) @ chord
    edge = np.zeros(len(C), np.int8)  # 1 leading, 2 trailing
    hb = np.floor(h / 2.0).astype(int)
    for b in np.unique(hb[blade]):
        sel = blade & (hb == b)
        lo, hi = s[sel].min(), s[sel].max()
        span = max(hi - lo, 1e-9)
        e = max(1.5, 0.04 * span)
        edge[sel & (s < lo + e)] = 1
        edge[sel & (s > hi - e)] = 2
    # the suction side is the convex one: the larger median mean curvature (outward normals)
    # over the side's faces away from hub and edges
    nb = len(part.blade_faces)
    w = face_principal_curvatures(TriMesh.from_arrays(part.blade_vertices, part.blade_faces))
    mean_k = w[:, 0] + w[:, 2]
    mid = (edge[:nb] == 0) & (h[:nb] > 0.25 * float(h[:nb].max()))
    sp = mid & side_plus[:nb]
    sm = mid & ~side_plus[:nb]
    plus_is_suction = bool(sp.any() and sm.any()
                           and np.median(mean_k[sp]) > np.median(mean_k[sm]))
    fillet = blade & (h < (fillet_radius if fillet_radius else 0.0))
    cls[blade] = np.where(side_plus[blade], 2, 3)
    cls[blade & (edge == 1)] = 4
    cls[blade & (edge == 2)] = 5
    cls[fillet] = 1
    names = list(_CLASS_NAMES)
    names[2] += " (suction)" if plus_is_suction else " (pressure)"
    names[3] += " (pressure)" if plus_is_suction else " (suction)"
    return cls, h, names


_CLASS_NAMES = ("hub", "blade 0 fillet", "blade 0 +θ side", "blade 0 −θ side",
                "blade 0 leading edge", "blade 0 trailing edge")


def _near(C, contacts: OperationContacts, part: BliskPart, w: float):
    """(clear, colliding, distance) per centroid: within ``w`` of a clear / a colliding
    contact point (the contacts turned to blades −1, 0, +1), the distance to the nearest."""
    n = len(C)
    if len(contacts.cc) == 0:
        return np.zeros(n, bool), np.zeros(n, bool), np.full(n, np.inf)
    P = np.vstack([rotate_about(contacts.cc, part.axis.d, k * part.pitch, part.axis.o)
                   for k in (-1, 0, 1)])
    hit = np.tile(contacts.colliding, 3)
    d_all, _ = cKDTree(P).query(C, distance_upper_bound=1e9)
    clear = np.zeros(n, bool)
    coll = np.zeros(n, bool)
    if (~hit).any():
        d, _ = cKDTree(P[~hit]).query(C, distance_upper_bound=w)
        clear = np.isfinite(d)
    if hit.any():
        d, _ = cKDTree(P[hit]).query(C, distance_upper_bound=w)
        coll = np.isfinite(d)
    return clear, coll, d_all


def _under_blades(part: BliskPart, C) -> np.ndarray:
    """(n,) bool: the hub points ``C`` lie under blade 0 or a neighbour, its fillet included:
    inside the blade's root loop (where blade or fillet meets the hub) in the hub's (m, θ) plane,
    by the even-odd rule."""
    hs = HubSurface(part.hub_profile, part.axis)
    loop = root_loop(TriMesh.from_arrays(part.blade_vertices, part.blade_faces), hs)
    lm, lt, _ = hs.coordinates(loop)
    t0 = math.atan2(float(np.sin(lt).mean()), float(np.cos(lt).mean()))
    lt = t0 + np.mod(lt - t0 + math.pi, 2 * math.pi) - math.pi
    m, t, _ = hs.coordinates(C)
    out = np.zeros(len(C), bool)
    ax, ay = lm, lt
    bx, by = np.roll(lm, -1), np.roll(lt, -1)
    for k in (-1, 0, 1):  # the neighbours' loops: the same loop turned by ±pitch
        tk = t0 + k * part.pitch + np.mod(t - t0 - k * part.pitch + math.pi, 2 * math.pi) \
            - math.pi
        px, py = m[:, None], (tk - k * part.pitch)[:, None]
        crosses = (ay[None] > py) != (by[None] > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            xi = ax[None] + (py - ay[None]) * (bx - ax)[None] / (by - ay)[None]
        out |= (np.count_nonzero(crosses & (px < xi), axis=1) % 2) == 1
    return out


def _components(F, faces):
    """Connected components of ``faces`` (indices into F) sharing a vertex: labels (len)."""
    if len(faces) == 0:
        return np.zeros(0, int)
    sub = F[faces]
    used, inv = np.unique(sub, return_inverse=True)
    inv = inv.reshape(-1, 3)
    k = len(faces)
    rows = np.repeat(np.arange(k), 3)
    g = coo_matrix((np.ones(3 * k), (rows, k + inv.ravel())), shape=(k + len(used),) * 2)
    _, lab = connected_components(g, directed=False)
    return lab[:k]


def job_verdict(part: BliskPart, stock, contacts, *, resolution: float | None = None,
                gouge_tolerance: float | None = None,
                fillet_radius: float | None = None,
                cut_depth: float | None = None, solid=None) -> JobVerdict:
    """The final verdict on ``stock`` (the stock after the last operation) of the finishing
    operations' ``contacts`` ([OperationContacts]); see the module docstring.
    ``fillet_radius`` (mm): blade faces lower than it above the hub are named the fillet.
    ``cut_depth`` (mm): the deepest any operation's clean program cuts into the part (its
    chord less the allowance it leaves; default: the finishing operations' largest chord),
    for :func:`..stock.deviation.resolved_points`. ``solid``: the part cast on the stock's
    grid (``stock_from_allowance(part, 0, res, grid=stock)``) when the caller has it."""
    res = float(resolution if resolution is not None else stock.resolution)
    V, F, hub, C, N, area = face_frame(part)
    cusp_chord = [c.cusp + c.chord for c in contacts]
    b_default = (max(cusp_chord) if cusp_chord else 0.0) + res
    tol = float(gouge_tolerance if gouge_tolerance is not None else
                max([c.chord for c in contacts] + [0.0]) + res)
    if solid is None:
        solid = stock_from_allowance(part, 0.0, stock.resolution, grid=stock)
    surface = np.ones(len(F), bool)
    surface[hub] = ~_under_blades(part, C[hub])
    reach = max(2.0, 2.0 * b_default)
    dev = np.full(len(F), np.nan)
    ideal = np.full(len(F), np.nan)
    dev[surface] = deviation_map(stock, C[surface], N[surface], reach_out=reach,
                                 reach_in=reach)
    ideal[surface] = deviation_map(solid, C[surface], N[surface], reach_out=reach,
                                   reach_in=reach)
    if cut_depth is None:
        cut_depth = max([c.chord for c in contacts] + [0.0])
    resolved = surface & (ideal <= tol) & resolved_points(
        solid, C, N, tol, surface_distance(V, F[surface]), cut_depth=cut_depth)
    unresolved = surface & ~resolved
    bound = np.full(len(F), b_default)
    covered = np.full(len(F), -1)
    colliding = np.zeros(len(F), bool)
    nearest = []
    for k, c in enumerate(contacts):
        b = c.cusp + c.chord + res
        w = math.sqrt(2.0 * max(c.radius, 1e-9) * (c.cusp + c.chord))
        clear, coll, dist = _near(C, c, part, w)
        better = clear & ((covered < 0) | (b < bound))
        bound[better] = b
        covered[better] = k
        colliding |= coll
        nearest.append(dist)
    colliding &= covered < 0
    low = _lowest_blade_contact(part, contacts)
    left = np.where(resolved, dev, np.nan)
    over = resolved & (dev > bound)
    gouge = resolved & (dev < -tol)
    cls, h, names = _classes(part, C, N, hub, fillet_radius)
    r, _, z = theta_about(C, part.axis)
    zones = []
    # the faces of one surface class and one cover (clear contacts, colliding contacts only,
    # none) make a zone when connected
    cover = np.where(covered >= 0, 0, np.where(colliding, 1, 2))
    for what, mask in (("gouge", gouge), ("left", over)):
        for ci, cv in ((ci, cv) for ci in range(len(names)) for cv in range(3)):
            faces = np.flatnonzero(mask & (cls == ci) & (cover == cv))
            lab = _components(F, faces)
            for L in np.unique(lab):
                fz = faces[lab == L]
                zones.append(_zone(fz, what, names[ci], area, r, z, h, dev, covered, colliding,
                                   nearest, contacts, tol, bound, _would_cover(ci, h[fz], low)))
    order = {"failed": 0, "not machined": 1, "unreachable": 2}
    zones.sort(key=lambda zn: (order[zn.status], -zn.area_mm2))
    status = ("failed" if any(zn.status == "failed" for zn in zones) else
              "incomplete" if any(zn.status == "not machined" for zn in zones) else "passed")
    worst_gouge = float(max(0.0, -np.nanmin(left))) if np.isfinite(left).any() else 0.0
    return JobVerdict(
        passed=status == "passed", status=status, zones=zones,
        gouge_tolerance=tol,
        bounds={c.name: c.cusp + c.chord + res for c in contacts} | {"elsewhere": b_default},
        resolution=res, area_surface_mm2=float(area[surface].sum()),
        area_unresolved_mm2=float(area[unresolved].sum()), max_gouge_mm=worst_gouge,
        unresolved_by_surface={names[ci]: round(float(area[unresolved & (cls == ci)].sum()), 3)
                               for ci in range(len(names))
                               if (unresolved & (cls == ci)).any()},
        left=left, bound=bound, covered=covered)


def _lowest_blade_contact(part: BliskPart, contacts) -> float | None:
    """The lowest height (mm above the hub) of blade finishing's clear contacts on blade 0
    (None: no blade finishing)."""
    cc = [c.cc[~c.colliding] for c in contacts if c.kind == "blade_finish"]
    cc = [x for x in cc if len(x)]
    if not cc:
        return None
    _, _, h = HubSurface(part.hub_profile, part.axis).coordinates(np.vstack(cc))
    return float(h.min())


def _would_cover(ci: int, h, low: float | None) -> str:
    """The operation that would cover a zone not machined of surface class ``ci``
    (:data:`_CLASS_NAMES`) at heights ``h`` above the hub; ``low`` the lowest blade
    finishing contact's height."""
    if ci == 0:
        return "hub finishing (passes across the gap, extended past the edges)"
    if ci == 1:
        return ("fillet finishing's layers across the fillet (a fillet_finish operation's "
                "'scallop' with 'layers_top', or 'layers')")
    if ci in (2, 3) and low is not None and float(np.min(h)) < low:
        return (f"blade finishing's hub cone lower (cone1: its lowest contacts are {low:.1f} mm "
                "above the hub), or fillet finishing's layers up to it ('layers_top')")
    return "blade finishing"


def _zone(fz, what, surface, area, r, z, h, dev, covered, colliding, nearest, contacts, tol,
          bound, cover="") -> Zone:
    a = float(area[fz].sum())

    def rng(x):
        return round(float(x[fz].min()), 2), round(float(x[fz].max()), 2)
    if what == "gouge":
        worst = float(-dev[fz].min())
        status = "failed"
        reason = f"gouge {worst:.3f} mm deeper than the tolerance {tol:.3f} mm"
    else:
        worst = float(dev[fz].max())
        cov = covered[fz]
        if (cov >= 0).any():
            ops = sorted({int(k) for k in cov[cov >= 0]})
            status = "failed"
            reason = ("material left up to " + f"{worst:.3f} mm where "
                      + ", ".join(f"operation {contacts[k].index} ({contacts[k].name})"
                                  for k in ops)
                      + f" plans contacts (bound {float(bound[fz].max()):.3f} mm)")
        elif colliding[fz].all():
            status = "unreachable"
            reason = ("every contact planned here collides (the tool body within the "
                      "safety): the tool cannot reach")
        else:
            status = "not machined"
            near = ", ".join(f"operation {c.index} ({c.name}) {float(d[fz].min()):.1f} mm"
                             for c, d in zip(contacts, nearest, strict=True))
            reason = ("no finishing operation plans contacts here"
                      + (f"; nearest contacts: {near}" if near else "")
                      + f"; would be covered by {cover}")
    return Zone(faces=fz, status=status, what=what, surface=surface, area_mm2=a, r_mm=rng(r),
                z_mm=rng(z), height_mm=rng(h), worst_mm=worst, reason=reason,
                cover=cover if status == "not machined" else "")


def job_verdict_dict(v: JobVerdict, max_zones: int = 50) -> dict:
    """JSON-ready figures of the verdict (the ``max_zones`` largest zones listed, the rest
    counted)."""
    def zd(zn):
        return {"status": zn.status, "what": zn.what, "surface": zn.surface,
                "area_mm2": round(zn.area_mm2, 3), "faces": int(len(zn.faces)),
                "r_mm": list(zn.r_mm), "z_mm": list(zn.z_mm),
                "height_above_hub_mm": list(zn.height_mm), "worst_mm": round(zn.worst_mm, 4),
                "reason": zn.reason} | ({"would_be_covered_by": zn.cover} if zn.cover else {})
    unr = [zn for zn in v.zones if zn.status == "unreachable"]
    failed = [zn for zn in v.zones if zn.status == "failed"]
    nm = [zn for zn in v.zones if zn.status == "not machined"]
    return {"passed": bool(v.passed), "status": v.status, "bounds_mm": v.bounds,
            "gouge_tolerance_mm": v.gouge_tolerance, "resolution_mm": v.resolution,
            "max_gouge_mm": v.max_gouge_mm,
            "area_surface_mm2": round(v.area_surface_mm2, 3),
            "area_unresolved_mm2": round(v.area_unresolved_mm2, 3),
            "area_unresolved_by_surface_mm2": v.unresolved_by_surface,
            "area_unreachable_mm2": round(sum(zn.area_mm2 for zn in unr), 3),
            "area_not_machined_mm2": round(sum(zn.area_mm2 for zn in nm), 3),
            "area_failed_mm2": round(sum(zn.area_mm2 for zn in failed), 3),
            "zones": [zd(zn) for zn in v.zones[:max_zones]],
            "zones_not_listed": max(0, len(v.zones) - max_zones)}


def job_verdict_lines(v: JobVerdict, max_zones: int = 12) -> list[str]:
    """Lines for people: the verdict, then the zones (largest first)."""
    d = job_verdict_dict(v, max_zones)
    word = {"passed": "passed", "incomplete": "INCOMPLETE", "failed": "FAILED"}[v.status]
    out = [f"final verdict: {word} — material left ≤ the bound "
           f"({', '.join(f'{k} {b:.3f}' for k, b in v.bounds.items())} mm) and gouge ≤ "
           f"{v.gouge_tolerance:.3f} mm except {sum(zn.status == 'unreachable' for zn in v.zones)}"
           f" zone(s) named unreachable ({d['area_unreachable_mm2']:.1f} mm²); "
           f"{sum(zn.status == 'not machined' for zn in v.zones)} zone(s) not machined "
           f"({d['area_not_machined_mm2']:.1f} mm²); "
           f"{sum(zn.status == 'failed' for zn in v.zones)} failed zone(s) "
           f"({d['area_failed_mm2']:.1f} mm²); {d['area_unresolved_mm2']:.1f} mm² below the "
           "stock's resolution not judged"]
    for zn in v.zones[:max_zones]:
        out.append(f"  {zn.status} {zn.what}: {zn.surface}, {zn.area_mm2:.1f} mm², r "
                   f"{zn.r_mm[0]:.1f}–{zn.r_mm[1]:.1f} mm, z {zn.z_mm[0]:.1f}–{zn.z_mm[1]:.1f} "
                   f"mm, {zn.height_mm[0]:.1f}–{zn.height_mm[1]:.1f} mm above the hub, "
                   f"{'left' if zn.what == 'left' else 'gouge'} up to {zn.worst_mm:.3f} mm: "
                   f"{zn.reason}")
    if len(v.zones) > max_zones:
        out.append(f"  … and {len(v.zones) - max_zones} smaller zone(s) (summary.json)")
    return out
