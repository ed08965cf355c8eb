"""The Blender objects of a per-blade run: one output collection per blade that passed.

Collection ``"Blisk CAM – per blade (<source>)"`` in the scene's master collection holds, for
every blade k that passed, the same output collection the Generate operator writes
(:func:`.path_objects.write_path_objects`) under the blade name ``"Blade k"``: collection
``"Blisk CAM – Blade k"`` with ``"Blade k CC paths"``, ``"Blade k tool tips"``, the poses,
the cones and the paths JSON (so Export Paths / Export NC work on it like on a generated
blade). The failed blades get no objects; their numbers and reasons are kept on the parent
collection (JSON in ``blisk_cam_per_blade``) for the panel. A new per-blade run (or Load
Results) replaces the previous per-blade result as a whole (and the Generate output of an
object that happens to be named "Blade k"); the scan object is never modified.

Coordinates: the paths are in mm, objects in Blender units (``mm / mm_per_blender_unit``).
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import bpy

from . import path_objects as output

__all__ = ["KEY_PER_BLADE", "blade_name", "clear_per_blade", "per_blade_summary",
           "write_per_blade"]

#: key of the parent collection's summary (JSON: source, blade_count, shown, failed)
KEY_PER_BLADE = "blisk_cam_per_blade"


def blade_name(k: int) -> str:
    """The blade name of blade k's output: ``"Blade k"``."""
    return f"Blade {int(k)}"


def _parents():
    return [c for c in bpy.data.collections if KEY_PER_BLADE in c]


def clear_per_blade() -> bool:
    """Remove the per-blade result (every blade's output collection and paths JSON, and the
    parent collection). True if there was one."""
    parents = _parents()
    for parent in parents:
        summary = json.loads(parent[KEY_PER_BLADE])
        for k in summary.get("shown", []):
            output.clear_path_objects(blade_name(k))
        for child in list(parent.children):
            parent.children.unlink(child)
        bpy.data.collections.remove(parent)
    return bool(parents)


def write_per_blade(scene, source: str, outcomes, settings=None) -> dict:
    """Show a per-blade run: the path of every blade that passed as its own output collection.

    Parameters
    ----------
    scene : bpy.types.Scene
    source : str — what the blades came from (the scan object's name, or the folder)
    outcomes : list of core ``BladeOutcome`` (``core.process.per_blade``) — ``ok`` with a
        ``path`` are shown, the others listed as failed
    settings : scene.blisk_cam (display options), default ``scene.blisk_cam``

    Returns
    -------
    dict — the summary kept on the parent collection: ``source``, ``blade_count``,
    ``shown`` (blade numbers), ``failed`` (list of [k, reason]), and ``collection``
    """
    settings = settings if settings is not None else scene.blisk_cam
    clear_per_blade()
    parent = bpy.data.collections.new(f"{output.COLLECTION_PREFIX}per blade ({source})")
    scene.collection.children.link(parent)
    # the stand-in "blade" write_path_objects places the output beside: only its name and
    # collections are read (the outputs are named "Blade k", no object is needed)
    shown, failed = [], []
    for o in sorted(outcomes, key=lambda o: o.index):
        if o.ok and o.path is not None and o.path.curves:
            stand_in = SimpleNamespace(name=blade_name(o.index), users_collection=[parent])
            output.clear_path_objects(stand_in.name)  # a generated blade of the same name
            output.write_path_objects(scene, stand_in, o.path, settings)
            shown.append(int(o.index))
        else:
            failed.append([int(o.index), o.reason or f"blade {o.index}: no path"])
    summary = {"source": source, "blade_count": len(outcomes), "shown": shown,
               "failed": failed}
    parent[KEY_PER_BLADE] = json.dumps(summary)
    return {**summary, "collection": parent}


def per_blade_summary() -> dict | None:
    """The summary of the per-blade result in the file (see :func:`write_per_blade`), or
    None."""
    for parent in _parents():
        try:
            return json.loads(parent[KEY_PER_BLADE])
        except (TypeError, ValueError):
            continue
    return None
