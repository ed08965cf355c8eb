"""The Blender objects of a job's run (issue 24, the Operations panel): one collection per
operation with its paths (as Generate Paths draws a blade's: :mod:`.path_objects`), all under
"Blisk CAM – Operations" and replaced together on every Generate All; and the stock after the
selected operation (:mod:`.stock_objects`, the "Blisk CAM – Stock" collection).

The stocks of the last run (the part's deviation and the remaining stock's skin after every
operation: arrays, mm) are kept in memory for the session, per scene, so that selecting an
operation shows the stock after it without running anything; they are not saved in the .blend
(after a reload, Generate All again).
"""

from __future__ import annotations

import types

import bpy

from .objects import ensure_collection
from .path_objects import _remove_collection_tree, write_path_objects
from .stock_objects import COLLECTION as STOCK_COLLECTION
from .stock_objects import write_stock_objects

__all__ = ["OPERATIONS_COLLECTION", "KEY_OPERATION", "operation_collections",
           "operation_label", "show_operation_stock", "stored_stocks",
           "write_operation_results"]

#: the parent collection of every operation's collection
OPERATIONS_COLLECTION = "Blisk CAM – Operations"
#: custom property on an operation's collection: the operation's uid
KEY_OPERATION = "blisk_cam_operation"

#: scene name → {operation uid: stock figures} (module docstring)
_STOCKS: dict[str, dict[int, dict]] = {}


def operation_label(position: int, name: str) -> str:
    """How an operation's objects are named: ``"Op 2 hub"`` (``position`` 1-based)."""
    return f"Op {position} {name}"


def write_operation_results(scene, results: list) -> dict:
    """Replace the previous run's collections by one per operation of ``results`` (dicts:
    ``uid``, ``label``, ``path`` (core ToolPath), ``stock`` (dict: V, F, deviation, tolerance,
    skin_V, skin_F, summary)); remembers the stocks. Returns {uid: collection}."""
    parent = bpy.data.collections.get(OPERATIONS_COLLECTION)
    if parent is not None:
        _remove_collection_tree(parent)
    parent = ensure_collection(OPERATIONS_COLLECTION, scene.collection)
    holder = types.SimpleNamespace(users_collection=[parent])  # stands in for a blade
    out = {}
    for r in results:
        holder.name = r["label"]
        objs = write_path_objects(scene, holder, r["path"], scene.blisk_cam)
        objs["collection"][KEY_OPERATION] = int(r["uid"])
        out[int(r["uid"])] = objs["collection"]
    _STOCKS[scene.name] = {int(r["uid"]): r["stock"] for r in results}
    return out


def operation_collections() -> dict:
    """{operation uid: collection} of the last run."""
    parent = bpy.data.collections.get(OPERATIONS_COLLECTION)
    if parent is None:
        return {}
    return {c[KEY_OPERATION]: c for c in parent.children if KEY_OPERATION in c}


def stored_stocks(scene) -> dict:
    """{operation uid: stock figures} of the scene's last run (this session)."""
    return _STOCKS.get(scene.name, {})


def show_operation_stock(scene) -> bool:
    """Show the stock after the scene's selected operation (replacing the Stock collection);
    False (nothing changed) when that operation has no result in this session."""
    settings = getattr(scene, "blisk_cam", None)
    if settings is None or not 0 <= settings.operation_index < len(settings.operations):
        return False
    op = settings.operations[settings.operation_index]
    s = stored_stocks(scene).get(op.uid)
    if s is None:
        return False
    summary = dict(s["summary"], operation=op.name)
    write_stock_objects(scene, s["V"], s["F"], s["deviation"], s["tolerance"], s["skin_V"],
                        s["skin_F"], summary)
    coll = bpy.data.collections.get(STOCK_COLLECTION)
    if coll is not None:
        coll[KEY_OPERATION] = int(op.uid)
    return True
