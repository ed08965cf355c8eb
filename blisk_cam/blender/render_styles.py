"""How the objects of a collision-checked result look in a preview (for that render only; the
scene is restored after it): what a report needs to show, and nothing that hides the blade.

* the **neighbour blades** (``blisk_cam_role`` "neighbour") are cut away where they would hide
  the subject: every face nearer to the camera than a section plane across the view through
  the subject's median depth, and every face in front of the subject where it covers it in
  the picture, and the scraps this leaves (pieces under a tenth of the blade's area); the
  rest (the far side of the channel) stays, and the cut-away part is drawn as a thin light
  outline of its border;
* the **tool assembly** at the worst pose ("tool_assembly") is drawn as a light outline: its
  two silhouette lines along the axis and a ring at each shoulder of its profile;
* the **pose points** ("poses" with a ``collision_status`` attribute) become markers of
  5 px radius in the status colours for the corrected and the unresolved poses; the clear
  poses are not marked (they are the paths: a marker per pose covered a fifth of the blade
  at 480 × 270);
* the **path tubes** are made thin against the spacing of the passes in the picture (12 % of
  it, 1.5 to 6 px wide), so the blade shows between them.

Sizes are in pixels of the picture at the depth of the framed objects (``px``, Blender units
per pixel there).
"""

from __future__ import annotations

import bpy
import numpy as np

from ..core.display import COLLISION_STATUS_NAMES, COLLISION_STATUS_RGBA
from .objects import colored_material

__all__ = ["NEIGHBOUR_STYLES", "ASSEMBLY_STYLES", "POSE_STYLES", "style_neighbours",
           "style_assembly", "style_poses", "thin_path_tubes", "pass_spacing",
           "pose_status_counts"]

NEIGHBOUR_STYLES = ("cut", "hidden", "full")
ASSEMBLY_STYLES = ("outline", "hidden", "full")
POSE_STYLES = ("status", "full")
#: the cut-away outline, the assembly outline (RGBA)
CUT_OUTLINE_RGBA = (0.62, 0.62, 0.66, 1.0)
ASSEMBLY_OUTLINE_RGBA = (0.55, 0.68, 1.0, 1.0)
#: marker radius (pixels) of the corrected and unresolved poses
STATUS_MARKER_PX = 5.0
#: tube width of the paths: this share of the pass spacing, clamped to [lo, hi] pixels
TUBE_SHARE, TUBE_MIN_PX, TUBE_MAX_PX = 0.12, 1.5, 6.0


def _shown(ob, role):
    return (ob.get("blisk_cam_role") == role and not ob.hide_render and ob.visible_get())


def _triangles(ob):
    """World vertices (n, 3) and triangles (m, 3) of a mesh object's base mesh."""
    me = ob.data
    me.calc_loop_triangles()
    co = np.empty(len(me.vertices) * 3, dtype=np.float64)
    me.vertices.foreach_get("co", co)
    tri = np.empty(len(me.loop_triangles) * 3, dtype=np.int64)
    me.loop_triangles.foreach_get("vertices", tri)
    m = np.array(ob.matrix_world, dtype=np.float64)
    return co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3], tri.reshape(-1, 3)


def _to_camera(cam, pts):
    """(x/d, y/d, d): picture-plane coordinates and depth of world points."""
    m = np.array(cam.matrix_world, dtype=np.float64)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    local = (pts - m[:3, 3]) @ rot
    d = -local[:, 2]
    safe = np.where(d > 1e-12, d, 1e-12)
    return local[:, 0] / safe, local[:, 1] / safe, d


def _mesh_object(scene, name, V, F, rgba, temporary, material_name=None):
    me = bpy.data.meshes.new(name)
    me.from_pydata(V.tolist(), [], F.tolist())
    me.materials.append(colored_material(material_name or name, rgba))
    ob = bpy.data.objects.new(name, me)
    scene.collection.objects.link(ob)
    temporary.append(ob)
    return ob


def _lines_object(scene, name, polylines, radius, rgba, temporary):
    """Thin tubes along (k, 3) world polylines (a curve object), for this render."""
    cu = bpy.data.curves.new(name, "CURVE")
    cu.dimensions = "3D"
    cu.bevel_depth = radius
    cu.bevel_resolution = 0
    for p in polylines:
        if len(p) < 2:
            continue
        sp = cu.splines.new("POLY")
        sp.points.add(len(p) - 1)
        co = np.ones((len(p), 4))
        co[:, :3] = p
        sp.points.foreach_set("co", co.ravel())
    cu.materials.append(colored_material(f"Blisk CAM render {name}", rgba))
    ob = bpy.data.objects.new(name, cu)
    scene.collection.objects.link(ob)
    temporary.append(ob)
    return ob


def _border_edges(F):
    """(k, 2) vertex pairs of the edges used by one triangle of ``F``."""
    if len(F) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(e, axis=0, return_counts=True)
    return keys[counts == 1]


def _subject_depth(cam, subject_pts, grid=(128, 72)):
    """A coarse depth map of the subject in the picture: per cell the nearest subject depth
    (inf where there is none), dilated by one cell; and the picture-plane box it covers."""
    from scipy import ndimage

    x, y, d = _to_camera(cam, subject_pts)
    ok = d > 0
    x, y, d = x[ok], y[ok], d[ok]
    box = (x.min(), x.max(), y.min(), y.max())
    gx, gy = grid
    ix = np.clip(((x - box[0]) / max(box[1] - box[0], 1e-12) * gx).astype(int), 0, gx - 1)
    iy = np.clip(((y - box[2]) / max(box[3] - box[2], 1e-12) * gy).astype(int), 0, gy - 1)
    depth = np.full((gx, gy), np.inf)
    np.minimum.at(depth, (ix, iy), d)
    return ndimage.minimum_filter(depth, size=3, mode="nearest"), box


def style_neighbours(scene, cam, subject_pts, px, style, saved, temporary):
    """Apply a :data:`NEIGHBOUR_STYLES` style to the neighbour blades for one render.
    Returns the number of neighbour faces kept (all of them for "full")."""
    if style not in NEIGHBOUR_STYLES:
        raise ValueError(f"neighbour style must be one of {', '.join(NEIGHBOUR_STYLES)}, "
                         f"got {style!r}")
    obs = [ob for ob in scene.objects if ob.type == "MESH" and _shown(ob, "neighbour")]
    if style == "full" or not obs:
        return sum(len(ob.data.polygons) for ob in obs)
    for ob in obs:
        saved.set(ob, "hide_render", True)
    if style == "hidden" or len(subject_pts) == 0:
        return 0
    depth, box = _subject_depth(cam, subject_pts)
    # the section plane: across the view through the subject's median depth
    plane = float(np.median(_to_camera(cam, subject_pts)[2]))
    gx, gy = depth.shape
    kept_total, outline = 0, []
    for ob in obs:
        V, F = _triangles(ob)
        if len(F) == 0:
            continue
        x, y, d = _to_camera(cam, V[F].mean(axis=1))
        # nearer to the camera than the section plane: cut
        cut = d < plane
        # in front of the subject where it covers it in the picture: cut
        inside = (x >= box[0]) & (x <= box[1]) & (y >= box[2]) & (y <= box[3])
        ix = np.clip(((x - box[0]) / max(box[1] - box[0], 1e-12) * gx).astype(int), 0, gx - 1)
        iy = np.clip(((y - box[2]) / max(box[3] - box[2], 1e-12) * gy).astype(int), 0, gy - 1)
        ahead = depth[ix, iy]
        cut |= inside & np.isfinite(ahead) & (d < ahead)
        cut |= _scraps(V, F, ~cut)
        keep = F[~cut]
        kept_total += len(keep)
        if len(keep):
            rgba = (0.55, 0.55, 0.58, 1.0)
            if ob.data.materials and ob.data.materials[0] is not None:
                rgba = tuple(ob.data.materials[0].diffuse_color)
            _mesh_object(scene, f"{ob.name} (cut)", V, keep, rgba, temporary,
                         material_name=ob.data.materials[0].name if ob.data.materials
                         and ob.data.materials[0] is not None else None)
        border = _border_edges(F[cut])
        outline.extend(V[border])
    if outline:
        _lines_object(scene, "neighbour cut outline", outline, 0.5 * px, CUT_OUTLINE_RGBA,
                      temporary)
    return kept_total


def _scraps(V, F, kept, share=0.1):
    """(m,) bool: the kept faces that form pieces (connected through their vertices) of
    less than ``share`` of the whole mesh's area: strips left between the two cuts."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    out = np.zeros(len(F), dtype=bool)
    idx = np.nonzero(kept)[0]
    if len(idx) == 0:
        return out
    t = V[F]
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    k = F[idx]
    rows = np.concatenate([k[:, 0], k[:, 1]])
    cols = np.concatenate([k[:, 1], k[:, 2]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(V), len(V)))
    _, label = connected_components(graph, directed=False)
    piece = label[k[:, 0]]
    piece_area = np.bincount(piece, weights=area[idx])
    out[idx] = piece_area[piece] < share * area.sum()
    return out


def _assembly_profile(ob):
    """(z, rho) polyline of a revolved tool assembly in its own frame (tip at 0, axis +Z):
    per height the largest radius, both radii at a shoulder (two rings at one height)."""
    co = np.empty(len(ob.data.vertices) * 3, dtype=np.float64)
    ob.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    z, rho = np.round(co[:, 2], 6), np.round(np.hypot(co[:, 0], co[:, 1]), 6)
    prof = np.unique(np.stack([z, rho], axis=1), axis=0)  # sorted by z, then rho
    # per height keep the smallest and the largest radius (an axis point has rho 0)
    out = []
    for zz in np.unique(prof[:, 0]):
        r = prof[prof[:, 0] == zz, 1]
        r = r[r > 1e-9] if np.any(r > 1e-9) else r
        out.extend([(zz, r.min()), (zz, r.max())] if r.max() - r.min() > 1e-6 else
                   [(zz, r.max())])
    return np.array(out)


def style_assembly(scene, cam, px, style, saved, temporary):
    """Apply an :data:`ASSEMBLY_STYLES` style to the tool assembly for one render."""
    if style not in ASSEMBLY_STYLES:
        raise ValueError(f"assembly style must be one of {', '.join(ASSEMBLY_STYLES)}, "
                         f"got {style!r}")
    obs = [ob for ob in scene.objects if ob.type == "MESH" and _shown(ob, "tool_assembly")]
    if style == "full":
        return
    for ob in obs:
        saved.set(ob, "hide_render", True)
        if style == "hidden" or len(ob.data.vertices) == 0:
            continue
        m = np.array(ob.matrix_world, dtype=np.float64)
        scale = np.linalg.norm(m[:3, :3], axis=0)
        ex, ey, a = (m[:3, k] / scale[k] for k in range(3))
        tip = m[:3, 3]
        prof = _assembly_profile(ob)
        z, rho = prof[:, 0] * scale[2], prof[:, 1] * scale[0]
        view = np.array(cam.matrix_world.translation) - tip
        side = np.cross(a, view)
        side = side / np.linalg.norm(side) if np.linalg.norm(side) > 0 else ex
        lines = [tip + np.outer(z, a) + sign * np.outer(rho, side) for sign in (1.0, -1.0)]
        # rings at the shoulders (the profile turns by more than 20°) and at the top
        seg = np.diff(np.stack([z, rho], axis=1), axis=0)
        ang = np.arctan2(seg[:, 1], seg[:, 0])
        turn = np.abs(np.diff(ang)) > np.radians(20.0)
        rings = list(np.nonzero(turn)[0] + 1) + [len(z) - 1]
        t = np.linspace(0.0, 2.0 * np.pi, 49)
        for i in rings[-12:]:
            if rho[i] > 0:
                lines.append(tip + z[i] * a + rho[i] * (np.outer(np.cos(t), ex)
                                                        + np.outer(np.sin(t), ey)))
        _lines_object(scene, "tool assembly outline", lines, 0.6 * px,
                      ASSEMBLY_OUTLINE_RGBA, temporary)


def pose_status_counts(ob) -> np.ndarray | None:
    """Poses per collision status (clear, corrected, unresolved) of a pose point cloud, or
    None without the ``collision_status`` attribute."""
    attr = ob.data.attributes.get("collision_status") if ob.type == "MESH" else None
    if attr is None:
        return None
    vals = np.zeros(len(ob.data.vertices), dtype=np.int32)
    attr.data.foreach_get("value", vals)
    return np.bincount(np.clip(vals, 0, 2), minlength=3)


_OCTA_V = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)],
                   dtype=np.float64)
_OCTA_F = np.array([(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5),
                    (3, 1, 5), (0, 3, 5)], dtype=np.int64)


def style_poses(scene, px, style, saved, temporary):
    """Apply a :data:`POSE_STYLES` style to the checked pose points for one render: markers
    for the corrected and unresolved poses, none for the clear ones."""
    if style not in POSE_STYLES:
        raise ValueError(f"pose style must be one of {', '.join(POSE_STYLES)}, got {style!r}")
    if style == "full":
        return
    for ob in [o for o in scene.objects if o.type == "MESH" and _shown(o, "poses")]:
        attr = ob.data.attributes.get("collision_status")
        if attr is None:
            continue
        n = len(ob.data.vertices)
        vals = np.zeros(n, dtype=np.int32)
        attr.data.foreach_get("value", vals)
        co = np.empty(n * 3, dtype=np.float64)
        ob.data.vertices.foreach_get("co", co)
        m = np.array(ob.matrix_world, dtype=np.float64)
        tips = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
        saved.set(ob, "hide_render", True)
        for k, (label, rgba) in enumerate(zip(COLLISION_STATUS_NAMES, COLLISION_STATUS_RGBA,
                                              strict=True)):
            p = tips[vals == k]
            if len(p) == 0 or k == 0:
                continue
            r = STATUS_MARKER_PX * px
            V = (p[:, None, :] + r * _OCTA_V[None]).reshape(-1, 3)
            F = (_OCTA_F[None] + 6 * np.arange(len(p))[:, None, None]).reshape(-1, 3)
            _mesh_object(scene, f"{ob.name} {label} markers", V, F, rgba, temporary,
                         material_name=f"Blisk CAM collision {label}")


def pass_spacing(curves, max_points=4000) -> float | None:
    """Median distance (Blender units) from a point of one spline of ``curves`` to the
    nearest point of another spline: the spacing of the passes; None with fewer than two
    splines."""
    from scipy.spatial import cKDTree

    pts, ids = [], []
    for ob in curves:
        m = np.array(ob.matrix_world, dtype=np.float64)
        for sp in ob.data.splines:
            co = np.empty(len(sp.points) * 4, dtype=np.float64)
            sp.points.foreach_get("co", co)
            p = co.reshape(-1, 4)[:, :3] @ m[:3, :3].T + m[:3, 3]
            pts.append(p)
            ids.append(np.full(len(p), len(ids)))
    if len(pts) < 2:
        return None
    P, I = np.concatenate(pts), np.concatenate(ids)
    tree = cKDTree(P)
    pick = np.arange(0, len(P), max(1, len(P) // max_points))
    k = min(64, len(P))
    dist, idx = tree.query(P[pick], k=k)
    other = I[idx] != I[pick][:, None]
    has = other.any(axis=1)
    if not np.any(has):
        return None
    first = np.argmax(other, axis=1)
    return float(np.median(dist[has, first[has]]))


def thin_path_tubes(curves, px, saved):
    """Set the tube radius of the path ``curves`` for one render: 12 % of the pass spacing
    wide, 1.5 to 6 pixels (a curve without bevel does not render). Returns the radius."""
    curves = [ob for ob in curves if ob.type == "CURVE" and not ob.hide_render]
    if not curves:
        return None
    spacing = pass_spacing(curves)
    width = TUBE_SHARE * spacing if spacing else TUBE_MIN_PX * px
    width = min(max(width, TUBE_MIN_PX * px), TUBE_MAX_PX * px)
    for ob in curves:
        saved.set(ob.data, "bevel_depth", 0.5 * width)
    return 0.5 * width
