"""The Windows zip in Windows Blender (the bpy wheel) under Wine, as a user installs it:
through the extension API into a new user repository, enabled; then the compiled kernels and
scipy must be the ones Blender installed from the zip, a demo path planned on the compiled
kernels must equal the numpy kernels' float for float, and the add-on must uninstall and
leave nothing registered. Exit status 0 when all holds, 1 with the failed check otherwise.

    wine python.exe install_check.py ZIP     (scripts/wine/windows_check.sh runs it)

Windows cannot delete a loaded DLL: the uninstall reports "Failed to remove" for the
extension's .pyd files, which Blender removes at its next start. That is expected.
"""

import importlib
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np

REPO = "blisk_cam_wine_check"
MODULE = f"bl_ext.{REPO}.blisk_cam"


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what, flush=True)
    if not ok:
        raise SystemExit(1)


def main(zip_path):
    import addon_utils  # Blender's own module: importable once bpy is

    print(f"Blender {bpy.app.version_string}, Python {sys.version.split()[0]} on {sys.platform}")
    repos = bpy.context.preferences.extensions.repos
    directory = Path(tempfile.mkdtemp()) / "repo"
    repos.new(name="Blisk CAM Wine check", module=REPO, custom_directory=str(directory),
              source="USER")
    done = bpy.ops.extensions.package_install_files(filepath=zip_path, repo=REPO,
                                                    enable_on_install=True)
    check(done == {"FINISHED"}, f"installed {Path(zip_path).name} through the extension API")
    try:
        check(MODULE in {a.module for a in bpy.context.preferences.addons}, "enabled")
        check(hasattr(bpy.types.Scene, "blisk_cam"), "registered (Scene.blisk_cam)")
        site = Path(bpy.utils.user_resource("EXTENSIONS")) / ".local" / "lib"
        backend = importlib.import_module(MODULE + ".core.kernels.backend")
        ext = backend.extension()
        check(ext is not None and backend.backend_name().startswith("compiled"),
              f"kernels: {backend.backend_name()}")
        check(Path(ext.__file__).is_relative_to(site), f"... loaded from {Path(ext.__file__)}")
        import scipy

        check(Path(scipy.__file__).is_relative_to(site), f"scipy {scipy.__version__} from the zip")
        blisk = importlib.import_module(MODULE + ".core.part.blisk")
        mesh = importlib.import_module(MODULE + ".core.geometry.mesh")
        finish = importlib.import_module(MODULE + ".core.process.blade_finish")
        runtime = importlib.import_module(MODULE + ".core.runtime")
        d = blisk.make_demo_blisk(resolution=0.5)
        req = finish.PathRequest(axis=d.axis, cone1=d.hub_cone, cone2=d.tip_cone, cusp=0.2,
                                 chord=0.05)
        with runtime.parallel(2):
            a = finish.plan_paths(mesh.TriMesh.from_arrays(d.blade_vertices, d.blade_faces),
                                  req).path
        with backend.numpy_only():
            b = finish.plan_paths(mesh.TriMesh.from_arrays(d.blade_vertices, d.blade_faces),
                                  req).path
        check(a.stats["kernels"].startswith("compiled") and b.stats["kernels"] == "numpy",
              f"planned on {a.stats['kernels']} and on {b.stats['kernels']}")
        same = all(np.array_equal(getattr(x, k), getattr(y, k))
                   for x, y in zip(a.curves, b.curves, strict=True)
                   for k in ("cc", "tip", "axis"))
        check(a.n_poses == b.n_poses and same,
              f"the same {a.n_poses} poses on both (contact points, tips and axes)")
    finally:
        addon_utils.disable(MODULE, default_set=True)
        index = next(i for i, r in enumerate(repos) if r.module == REPO)
        done = bpy.ops.extensions.package_uninstall(repo_index=index, pkg_id="blisk_cam")
        repos.remove(repos[index])
    check(done == {"FINISHED"} and not hasattr(bpy.types.Scene, "blisk_cam"),
          "uninstalled, nothing registered")


if __name__ == "__main__":
    main(sys.argv[1])
