"""Scenes of the bpy-side tests: the demo blade imported from an STL and set up for a machine
(:func:`radial_demo_paths`). Not collected by pytest (no ``test_`` prefix)."""

import numpy as np

from tests.support.mesh_files import write_binary_stl


def radial_demo_paths(demo, tmp_path, *, chord=0.1, cone2=None, generate=True):
    """A fresh scene with the demo blade (imported from an STL) set up for a machine: cone 1
    above the hub fillet (reachable on A ≤ 110°), cone 2 the demo's tip cone unless given,
    Ø12 ball, cusp 0.5, the axis near radial (radial tilt 75°), no verify; the paths
    generated. Returns (blade object, scene settings)."""
    import bpy

    from blisk_cam.blender import objects as blender_io

    bpy.ops.wm.read_factory_settings(use_empty=True)
    stl = write_binary_stl(tmp_path / "blade.stl", demo.blade_vertices, demo.blade_faces)
    blade = blender_io.import_mesh_file(stl)
    s = bpy.context.scene.blisk_cam
    s.blade = blade
    s.cone1 = (170.0, -25.0, 185.0, 35.0)
    s.cone2 = demo.tip_cone.as_list() if cone2 is None else cone2
    s.tool_diameter, s.cusp, s.chord = 12.0, 0.5, chord
    s.axis_mode, s.radial_tilt, s.verify = "RADIAL", np.radians(75.0), False
    if generate:
        assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    return blade, s
