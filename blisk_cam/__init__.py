"""Blisk CAM: 5-axis finishing tool paths for blisk blades (linear morphing cones).

This module only registers the add-on. Importing ``blisk_cam`` (or ``blisk_cam.core``) does
not import ``bpy``: the Blender-side modules are imported inside :func:`register`, so the
geometry core can be used and tested in a plain Python process.

Installed as an extension the package is imported as ``bl_ext.<repository>.blisk_cam``, hence
relative imports only.

Every registering module (``properties`` and the ``operators``, ``panels``, ``gizmos``
subpackages) exposes one explicit ``CLASSES`` list and may define ``register()`` /
``unregister()`` for what is not a class (scene properties, handlers, key maps). Property
groups come first; everything is unregistered in reverse order.
"""

__all__ = ["__version__", "register", "unregister"]

from .core.version import __version__

# (kind, object) in the order they were registered: ("class", cls) or ("hook", module).
_registered = []


def _modules():
    from . import gizmos, operators, panels, properties

    # Property groups first: operators and panels refer to scene.blisk_cam.
    return (properties, operators, panels, gizmos)


def register():
    """Register all classes, then each module's ``register()`` hook."""
    import bpy

    if _registered:  # already registered (e.g. a second enable): start clean
        unregister()
    try:
        for module in _modules():
            for cls in module.CLASSES:
                bpy.utils.register_class(cls)
                _registered.append(("class", cls))
            hook = getattr(module, "register", None)
            if hook is not None:
                hook()
                _registered.append(("hook", module))
    except Exception:
        # Leave nothing half-registered behind (bpy 4.5 can hang at exit otherwise).
        unregister()
        raise


def unregister():
    """Undo :func:`register` in reverse order. Safe to call when nothing is registered."""
    import bpy

    errors = []
    while _registered:
        kind, obj = _registered.pop()
        try:
            if kind == "class":
                bpy.utils.unregister_class(obj)
            else:
                obj.unregister()
        except Exception as exc:  # keep going: unregister as much as possible
            errors.append(f"{getattr(obj, '__name__', obj)}: {exc}")
    if errors:
        raise RuntimeError("Blisk CAM: unregister failed for " + "; ".join(errors))


def is_registered():
    """True while classes of this add-on are registered (used by tests and the batch CLI)."""
    return bool(_registered)
