"""Run only by ``test_extension.py::test_session_end_unregisters_addon`` (not collected
otherwise: the name does not match ``test_*.py``). Leaves the add-on registered on purpose:
the conftest session hook has to unregister it, or bpy 4.5 hangs at exit."""

import bpy


def test_leave_addon_registered():
    import blisk_cam

    blisk_cam.register()
    assert blisk_cam.is_registered()
    assert hasattr(bpy.types.Scene, "blisk_cam")
