"""Fixtures for the tests that run inside Blender (the bpy wheel, 4.5 and 5.2).

- Blender's user files (preferences, extension repositories, caches) go to a temporary
  directory for the session (``BLENDER_USER_RESOURCES``), never the developer's home.
- Every test starts from factory settings with an empty scene.
- At the end of the session every registered Blisk CAM add-on is disabled/unregistered:
  bpy 4.5 hangs at process exit while add-on operator or panel classes are still registered
  (``tests/blender/test_extension.py::test_session_end_unregisters_addon`` checks this hook).
"""

import os
import shutil
import sys
import tempfile

# Must be set before bpy is imported: Blender reads it once at start-up.
_OWN_USER_RESOURCES = None
if "BLENDER_USER_RESOURCES" not in os.environ:
    _OWN_USER_RESOURCES = tempfile.mkdtemp(prefix="blisk_cam_blender_user_")
    os.environ["BLENDER_USER_RESOURCES"] = _OWN_USER_RESOURCES

import bpy  # noqa: E402
import pytest  # noqa: E402


@pytest.fixture(autouse=True)
def factory_reset():
    """Factory settings and an empty scene before each test.

    This also disables add-ons enabled through ``addon_utils`` (extensions) and drops
    repositories added to the preferences; classes registered by a direct ``register()`` call
    stay registered (the session hook below handles those).
    """
    bpy.ops.wm.read_factory_settings(use_empty=True)
    yield


@pytest.fixture(scope="module")
def addon():
    """The add-on registered directly for one test module (unregistered at its end; a module
    may override this with a narrower scope)."""
    import blisk_cam

    was = blisk_cam.is_registered()
    if not was:
        blisk_cam.register()
    yield
    if not was:
        blisk_cam.unregister()


@pytest.fixture(scope="module")
def demo():
    """The demo blade at resolution 0.3 (9k triangles) and its true cones (arrays only)."""
    from blisk_cam.core.part.blisk import make_demo_blisk

    return make_demo_blisk(resolution=0.3)


def _is_blisk_cam_module(name):
    return name == "blisk_cam" or name.endswith(".blisk_cam")


def unregister_blisk_cam():
    """Disable every enabled Blisk CAM extension and unregister direct registrations.

    Returns the list of module names it acted on. Safe to call at any time.
    """
    import addon_utils

    done = []
    for addon in list(bpy.context.preferences.addons):
        if _is_blisk_cam_module(addon.module):
            addon_utils.disable(addon.module, default_set=True)
            done.append(addon.module)
    for name, module in list(sys.modules.items()):
        if not _is_blisk_cam_module(name) or module is None:
            continue
        is_registered = getattr(module, "is_registered", None)
        if callable(is_registered) and is_registered():
            module.unregister()
            done.append(name)
    return done


def pytest_sessionfinish(session, exitstatus):
    unregister_blisk_cam()
    if _OWN_USER_RESOURCES is not None:
        shutil.rmtree(_OWN_USER_RESOURCES, ignore_errors=True)
