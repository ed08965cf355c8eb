"""Viewport gizmos: the two cone gizmos with handles on P1, P2, Q1, Q2 and the live LMC preview.

- :mod:`.cone_frame` — the math (cone end points ↔ handle matrices, constraints, draw
  geometry); pure numpy, importable without Blender.
- :mod:`.lmc_preview` — the cached mesh/slicer of the live preview; pure numpy.
- :mod:`.cone_gizmos` — the Blender side (gizmo types, the gizmo group, handlers).

``CLASSES``, ``register`` and ``unregister`` are looked up lazily so that importing this
package (e.g. ``blisk_cam.gizmos.cone_frame`` in a plain Python process) does not import bpy.
"""


def __getattr__(name):
    if name == "CLASSES":
        from .cone_gizmos import CLASSES

        return CLASSES
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def register():
    """Handlers of the gizmo module (classes are registered from ``CLASSES``)."""
    from . import cone_gizmos

    cone_gizmos.register()


def unregister():
    from . import cone_gizmos

    cone_gizmos.unregister()
