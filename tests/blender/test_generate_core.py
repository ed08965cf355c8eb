"""The panel's Generate plans the core's path: the interactive run (the planning worker of
``operators/generate_paths.py``, stepped by its timer code) gives the very floats of
``core.process.blade_finish.plan_paths`` on the demo blade's own arrays (as Blender holds
them: float32 vertices) and the panel's request — the panel adds no check, weld or setting
of its own to the plan."""

import bpy
import numpy as np

from blisk_cam.blender import objects as blender_io
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.process.blade_finish import plan_paths
from blisk_cam.operators import generate_paths as gen_mod
from blisk_cam.operators.modal_job import ModalRunner


def test_the_panels_paths_are_the_cores_plan(addon, demo):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    blade = blender_io.arrays_to_object("Blade", demo.blade_vertices, demo.blade_faces)
    s = bpy.context.scene.blisk_cam
    s.blade = blade
    s.cone1, s.cone2 = demo.hub_cone.as_list(), demo.tip_cone.as_list()
    s.cusp, s.chord, s.verify = 0.5, 0.5, False
    runner = ModalRunner(gen_mod.BLISKCAM_OT_generate_paths, gen_mod.PathJob(bpy.context))
    runner.start(bpy.context)
    for _ in range(2000):
        result = runner.step(bpy.context)
        if result != {"RUNNING_MODAL"}:
            break
        runner._job.wait_plan(0.05)
    assert result == {"FINISHED"}, runner.reports
    job = runner._job
    assert job.request.cone1 == demo.hub_cone and job.request.cone2 == demo.tip_cone
    # the core on the blade's arrays as made, not as read back from Blender: Blender holds
    # vertices in float32, so the panel plans the float32-rounded blade (the mesh the user
    # sees), not the float64 arrays the object was made from
    V = demo.blade_vertices.astype(np.float32).astype(np.float64)
    assert np.array_equal(job.V, V) and np.array_equal(job.F, demo.blade_faces)
    ref = plan_paths(TriMesh.from_arrays(V, demo.blade_faces), job.request).path
    got = job.plan.path
    assert len(got.curves) == len(ref.curves) > 0
    for a, b in zip(got.curves, ref.curves, strict=True):
        for name in ("cc", "tip", "axis", "face", "flags"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert got.program is not None and ref.program is not None
    for name in ("tip", "axis", "move", "curve", "index", "flags"):  # the linked program
        np.testing.assert_array_equal(getattr(got.program, name), getattr(ref.program, name))
