"""Run the Blisk CAM command line inside a Blender binary.

    blender -b --python scripts/blender_cli.py -- demo --out DIR
    blender -b --python scripts/blender_cli.py -- paths --mesh blade.stl ... --out paths.json

Takes the arguments after ``--`` and calls ``blisk_cam.cli.main`` with them, then exits with
its status. Uses the installed and enabled extension (``bl_ext.<repository>.blisk_cam``) or a
legacy add-on ``blisk_cam`` when Blender has one; otherwise puts this repository's root on
``sys.path`` and imports the package from the source tree. (Also works with a plain Python
that has the ``bpy`` module: ``python scripts/blender_cli.py -- demo --out DIR``.)
"""

import importlib
import sys
from pathlib import Path


def _arguments(argv):
    return argv[argv.index("--") + 1 :] if "--" in argv else []


def _installed_package():
    """The name of an enabled Blisk CAM add-on/extension module, or None."""
    try:
        import bpy

        names = list(bpy.context.preferences.addons.keys())
    except Exception:  # no bpy, or no preferences in this context
        return None
    for name in names:
        if name == "blisk_cam" or name.endswith(".blisk_cam"):
            return name
    return None


def _cli_main():
    package = _installed_package()
    if package is None:
        try:
            importlib.import_module("blisk_cam")
            package = "blisk_cam"
        except ImportError:
            repo_root = Path(__file__).resolve().parents[1]
            sys.path.insert(0, str(repo_root))
            package = "blisk_cam"
    return importlib.import_module(f"{package}.cli.main").main


def run(argv=None):
    """Run the CLI on the arguments after ``--`` in ``argv`` (default ``sys.argv``)."""
    args = _arguments(sys.argv if argv is None else argv)
    try:
        main = _cli_main()
    except Exception as exc:  # one line, like the CLI's own errors
        print(f"blisk_cam: error: cannot import Blisk CAM: {exc}", file=sys.stderr, flush=True)
        return 3
    return main(args)


if __name__ == "__main__":
    status = run()
    sys.stdout.flush()
    sys.stderr.flush()
    sys.exit(status)
