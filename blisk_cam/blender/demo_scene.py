"""The demo scene: the parametric blisk as Blender objects (blade, neighbours,
hub), its axis and cones, and the view the demo preview is rendered from.
"""

from __future__ import annotations

import contextlib
import math

from ..core.geometry.axis import angular_span
from ..core.geometry.vectors import rotate_about

__all__ = ["build_demo_scene"]


# --- demo --------------------------------------------------------------------------------
def build_demo_scene(scene=None, *, blades=3, demo=None):
    """Build the demo blisk in the current scene; returns a dict of the objects created.

    Objects (collection "Blisk CAM Demo"): "Blade" (the one to machine), "Blade ±k"
    (neighbours), "Hub", "Cone 1 (hub)", "Cone 2 (tip)" and "Blisk Axis" (an Empty, local
    Z = axis). Sets ``scene.blisk_cam`` when the add-on is registered. The scene's length
    unit becomes millimetres (scale 0.001: one Blender unit stays one mm).
    """
    import bpy
    import numpy as np

    from ..core.geometry.axis import meridional
    from .objects import arrays_to_object, axis_to_object, cone_to_object, ensure_collection

    if demo is None:
        from ..core.part.blisk import make_demo_blisk

        demo = make_demo_blisk()
    scene = scene or bpy.context.scene
    units = scene.unit_settings
    units.system = "METRIC"
    units.scale_length = 0.001  # Blender's millimetre preset: 1 BU shown as 1 mm
    units.length_unit = "MILLIMETERS"
    axis = demo.axis
    coll = ensure_collection("Blisk CAM Demo", scene.collection)
    Vb = np.asarray(demo.blade_vertices, dtype=np.float64)
    Fb = np.asarray(demo.blade_faces, dtype=np.int64)
    pitch = 2.0 * math.pi / max(int(demo.blade_count), 1)

    objs = {}
    objs["blade"] = arrays_to_object(
        "Blade", Vb, Fb, coll, color=(0.85, 0.62, 0.30, 1.0), smooth=False
    )
    # neighbours alternate +1, -1, +2, ... so that the machined blade stays in the middle
    offsets = []
    for k in range(1, blades):
        offsets.append((k + 1) // 2 if k % 2 else -(k // 2))
    for k in offsets:
        if hasattr(demo, "blade"):  # core.part.blisk: blade i = blade 0 turned by i pitches
            Vk, Fk = demo.blade(k)
        else:
            Vk, Fk = rotate_about(Vb, axis.d, k * pitch, axis.o, form="outer"), Fb
        objs[f"blade{k:+d}"] = arrays_to_object(
            f"Blade {k:+d}", Vk, Fk, coll, color=(0.62, 0.64, 0.68, 1.0)
        )
    Vh = np.asarray(demo.hub_vertices, dtype=np.float64)
    Fh = np.asarray(demo.hub_faces, dtype=np.int64)
    if len(Fh):
        objs["hub"] = arrays_to_object("Hub", Vh, Fh, coll, color=(0.42, 0.44, 0.48, 1.0))

    # cones over the angular range of the blades shown, a little wider
    mean, half = angular_span(Vb, axis)
    lo = min(offsets, default=0) * pitch + mean - half - 0.35 * pitch
    hi = max(offsets, default=0) * pitch + mean + half + 0.35 * pitch
    r, _ = meridional(Vb, axis)
    extent = float(r.max() - r.min()) if len(r) else 10.0
    # Cone 1 coincides with the hub surface: show it as a wire grid (a fill would z-fight);
    # cone 2 as a see-through surface with its grid.
    for key, name, cone, color, fill in (
        ("cone1", "Cone 1 (hub)", demo.hub_cone, (0.1, 0.45, 1.0, 0.3), False),
        ("cone2", "Cone 2 (tip)", demo.tip_cone, (1.0, 0.4, 0.1, 0.3), True),
    ):
        length = math.hypot(cone.r2 - cone.r1, cone.z2 - cone.z1)
        objs[key] = cone_to_object(
            name, cone, axis, coll, theta=(lo, hi), segments=48, rows=6,
            extend=0.1 * max(length, 0.1 * extent), color=color,
            wire=0.006 * extent, fill=fill,
        )
    z = (Vb - axis.o) @ axis.d
    z_range = (float(z.min()) - 0.3 * extent, float(z.max()) + 0.3 * extent)
    # the axis as an Empty (local Z = axis; what the "Axis" setting takes). It lies far inside
    # the hub, outside the sector view, so no rendering rod (axis_to_object kind="ROD").
    objs["axis"] = axis_to_object("Blisk Axis", axis, coll, kind="EMPTY", z_range=z_range)

    settings = getattr(scene, "blisk_cam", None)
    if settings is not None:
        with contextlib.suppress(AttributeError, TypeError, ValueError):
            settings.blade = objs["blade"]
            settings.axis_object = objs["axis"]
            settings.cone1 = demo.hub_cone.as_list()
            settings.cone2 = demo.tip_cone.as_list()
    return objs


def demo_view_direction(demo, *, turn=0.35, elevation=0.9):
    """A 3/4 view of the demo blade: from outside the blisk, ``turn`` radians around the axis
    from the blade's mean angle and ``elevation`` radians up toward the axis direction."""
    import numpy as np

    e1, e2, d = demo.axis.angular_frame()
    mean, _ = angular_span(np.asarray(demo.blade_vertices, dtype=np.float64), demo.axis)
    a = mean + turn
    radial = math.cos(a) * e1 + math.sin(a) * e2
    return tuple(math.cos(elevation) * radial + math.sin(elevation) * d)
