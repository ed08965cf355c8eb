"""The Blender objects of a stock simulation (issue 22): the part mesh coloured by deviation
and the remaining stock of one sector, in the collection "Blisk CAM – Stock" (replaced on
every run; the user's objects are never touched).

Colours (per vertex, colour attribute ``deviation_color``; the deviation itself, mm, in the
float attribute ``deviation``): blue = gouge beyond the tolerance (deviation < −tolerance),
green = within the tolerance (|deviation| ≤ tolerance), red = material left beyond it;
grey where the deviation is not measured (NaN: hub vertices buried under the blade) or not
judged (below the stock's resolution: the reading may be the grid's; the attribute
``deviation`` still holds it). The stock skin takes the colour of the nearest part vertex.
"""

from __future__ import annotations

import json

import bpy
import numpy as np

from .objects import arrays_to_object, ensure_collection, mm_per_blender_unit

__all__ = ["COLLECTION", "DEVIATION_RGBA", "KEY_STOCK_SUMMARY", "deviation_colors",
           "stock_summary", "write_stock_objects"]

#: the collection of the simulation's objects
COLLECTION = "Blisk CAM – Stock"
#: the scene property holding the last summary (JSON)
KEY_STOCK_SUMMARY = "blisk_cam_stock_summary"
#: legend: (label, RGBA)
DEVIATION_RGBA = {
    "gouge": (0.05, 0.25, 1.0, 1.0),
    "within": (0.1, 0.8, 0.2, 1.0),
    "left": (1.0, 0.1, 0.05, 1.0),
    "unmeasured": (0.5, 0.5, 0.5, 1.0),
}
PART_NAME = "Blisk CAM part deviation"
STOCK_NAME = "Blisk CAM remaining stock"


def deviation_colors(dev, tolerance: float) -> np.ndarray:
    """(n, 4) float32 RGBA of deviations ``dev`` (n,) mm against ``tolerance`` mm (module
    docstring: blue gouge, green within, red left, grey NaN)."""
    dev = np.asarray(dev, np.float64)
    out = np.empty((len(dev), 4), np.float32)
    out[:] = DEVIATION_RGBA["unmeasured"]
    ok = np.isfinite(dev)
    tol = float(tolerance)
    out[ok & (dev < -tol)] = DEVIATION_RGBA["gouge"]
    out[ok & (np.abs(dev) <= tol)] = DEVIATION_RGBA["within"]
    out[ok & (dev > tol)] = DEVIATION_RGBA["left"]
    return out


def _attribute_material(name):
    """A material whose base colour is the ``deviation_color`` attribute (EEVEE, Cycles);
    the viewport colour is neutral."""
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    if mat.node_tree is None and bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    if tree is not None:
        bsdf = next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
        attr = next((n for n in tree.nodes if n.type == "ATTRIBUTE"), None)
        if bsdf is not None and attr is None:
            attr = tree.nodes.new("ShaderNodeAttribute")
            attr.attribute_name = "deviation_color"
            tree.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def _coloured(name, V, F, dev, tolerance, coll, f, judged=None):
    ob = arrays_to_object(name, V, F, coll, mm_per_unit=f)
    mesh = ob.data
    dev = np.asarray(dev, np.float64)
    a = mesh.attributes.new("deviation", "FLOAT", "POINT")
    a.data.foreach_set("value", dev.astype(np.float32))
    shown = dev if judged is None else np.where(np.asarray(judged, bool), dev, np.nan)
    c = mesh.attributes.new("deviation_color", "FLOAT_COLOR", "POINT")
    c.data.foreach_set("color", deviation_colors(shown, tolerance).ravel())
    mesh.attributes.active_color = c
    mesh.materials.append(_attribute_material("Blisk CAM deviation"))
    ob["blisk_cam_role"] = "stock"
    return ob


def _remove_previous(coll):
    stale = list(coll.objects)
    if stale:
        data = [ob.data for ob in stale if ob.data is not None]
        bpy.data.batch_remove(stale)
        orphans = [d for d in data if d.users == 0]
        if orphans:
            bpy.data.batch_remove(orphans)


def write_stock_objects(scene, V, F, dev, tolerance, stock_V, stock_F, summary: dict,
                        judged=None) -> dict:
    """Replace the objects of the last simulation: the part (V (n, 3) mm, F (m, 3), ``dev``
    (n,) mm) and the remaining stock skin (``stock_V``, ``stock_F``, mm), both coloured by
    deviation against ``tolerance`` mm (grey where ``judged`` (n,) bool is False); the
    summary kept on the scene. Returns ``{"part": object, "stock": object}``."""
    from scipy.spatial import cKDTree

    f = mm_per_blender_unit(scene)
    coll = ensure_collection(COLLECTION, scene.collection)
    _remove_previous(coll)
    part = _coloured(PART_NAME, V, F, dev, tolerance, coll, f, judged)
    stock = None
    if len(stock_F):
        dev = np.asarray(dev, np.float64)
        ok = np.isfinite(dev)
        sdev = np.full(len(stock_V), np.nan)
        sjudged = None
        if ok.any():
            _, k = cKDTree(np.asarray(V)[ok]).query(stock_V)
            sdev = dev[ok][k]
            sjudged = None if judged is None else np.asarray(judged, bool)[ok][k]
        stock = _coloured(STOCK_NAME, stock_V, stock_F, sdev, tolerance, coll, f, sjudged)
    scene[KEY_STOCK_SUMMARY] = json.dumps(summary, allow_nan=False, default=float)
    return {"part": part, "stock": stock}


def stock_summary(scene) -> dict | None:
    """The summary of the scene's last simulation, or None."""
    text = scene.get(KEY_STOCK_SUMMARY) if scene is not None else None
    if not text:
        return None
    try:
        out = json.loads(text)
    except ValueError:
        return None
    return out if isinstance(out, dict) else None
