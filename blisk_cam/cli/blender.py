"""The commands' Blender side (the only ``cli`` module that imports bpy): a
session with the add-on registered, the operators run as a user would,
.blend and preview outputs, the ``demo`` command.
"""

from __future__ import annotations

import contextlib
import re
import time
from pathlib import Path

from ..blender.demo_scene import build_demo_scene, demo_view_direction
from ..core.errors import BliskCamError
from .flags import CliInternalError, UsageError

__all__ = ["run_operator"]


# --- Blender session ---------------------------------------------------------------------
def _import_bpy():
    try:
        import bpy
    except ImportError:
        raise BliskCamError(
            "this command needs Blender's Python module: pip install bpy (matching your "
            "Python), or run it in Blender: blender -b --python scripts/blender_cli.py -- ..."
        ) from None
    return bpy


@contextlib.contextmanager
def _blender_session(register_addon=True, *, required=False):
    """An empty factory scene; the add-on registered for the duration if it was not already
    (so that ``scene.blisk_cam`` and the operators exist and settings are saved in .blend
    files), and unregistered after. With ``required`` a failed registration is an error;
    otherwise the command goes on without the add-on. Yields the scene."""
    bpy = _import_bpy()
    from ..blender.objects import quiet_output

    with quiet_output():
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    registered_here = False
    if register_addon:
        from .. import is_registered, register

        if not is_registered():
            try:
                register()
                registered_here = True
            except Exception as exc:
                if required:
                    raise CliInternalError(
                        f"cannot register the Blisk CAM add-on: {type(exc).__name__}: {exc}"
                    ) from None
                print(f"note: add-on not registered ({type(exc).__name__}: {exc}); "
                      "settings are not stored in the .blend")
    if required and not hasattr(bpy.types.Scene, "blisk_cam"):
        raise CliInternalError("the Blisk CAM add-on is not registered in this Blender")
    try:
        yield bpy.context.scene
    finally:
        if registered_here:
            from .. import unregister

            unregister()


def _save_blend(bpy, path):
    from ..blender.objects import quiet_output

    path = Path(path).expanduser().resolve()
    path.parent.mkdir(parents=True, exist_ok=True)
    with quiet_output():
        try:
            bpy.ops.wm.save_as_mainfile(filepath=str(path), check_existing=False)
        except RuntimeError as exc:
            raise BliskCamError(f"cannot save {path}: {str(exc).strip()}") from None
    return path


def _cmd_demo(args):
    t0 = time.perf_counter()
    out = Path(args.out).expanduser().resolve()
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {args.out}: exists and is not a directory")
    bpy = _import_bpy()
    from ..core.part.blisk import make_demo_blisk

    demo = make_demo_blisk(resolution=args.mesh_resolution)
    out.mkdir(parents=True, exist_ok=True)
    with _blender_session(required=True) as scene:
        from ..blender import render

        objs = build_demo_scene(scene, blades=args.blades, demo=demo)
        settings = scene.blisk_cam
        settings.cusp, settings.chord = args.cusp, args.chord
        settings.verify = False
        if not args.no_paths:
            _paths_by_operators(bpy, scene, out / "paths.json")
            for key in ("cone1", "cone2"):  # the output collection shows the cones now: once
                bpy.data.objects.remove(objs.pop(key), do_unlink=True)
        # frame the sector; the axis (far inside the hub) is shown only where it falls in view
        shown = [o for k, o in objs.items() if k != "axis"]
        view = demo_view_direction(demo)
        scene.camera = render.frame_camera(
            scene, shown, view=view, resolution=tuple(args.resolution)
        )
        render.match_viewports_to_camera(scene.camera, objs["blade"])
        blend = _save_blend(bpy, out / "demo.blend")
        print(f"demo blend: {blend}")
        if not args.no_preview:
            _render_by_operator(
                bpy, out / "preview.png", args.engine, args.resolution,
                frame="SCENE", view=view, keep_camera=True,
            )
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return 0


def _engine_label(engine):
    return {"BLENDER_WORKBENCH": "Workbench", "CYCLES": "Cycles CPU"}.get(engine, engine)


# --- paths -------------------------------------------------------------------------------
def run_operator(bpy, name, **kwargs):
    """Run ``bpy.ops.blisk_cam.<name>`` (EXEC, no file browser) with Blender's report output
    captured. An ERROR report becomes a :class:`BliskCamError` carrying the message (a
    :class:`CliInternalError` when the operator reported an internal error); returns the
    operator's result set."""
    from ..blender.objects import quiet_output
    from ..operators.common import INTERNAL_ERROR

    op = getattr(bpy.ops.blisk_cam, name)
    with quiet_output():
        try:
            return op("EXEC_DEFAULT", **kwargs)
        except RuntimeError as exc:
            message = str(exc).strip()
            error = message
        except TypeError as exc:  # a bad keyword: a bug in the caller
            raise CliInternalError(f"{name}: {exc}") from None
    message = error.removeprefix("Error:").strip()
    # a failed poll: "Operator bpy.ops.blisk_cam.<name>.poll() <poll message>"
    message = re.sub(r"^Operator bpy\.ops\.[\w.]+\.poll\(\)\s*(failed,)?\s*", "", message)
    if message.startswith(INTERNAL_ERROR):
        raise CliInternalError(message)
    raise BliskCamError(message or f"blisk_cam.{name} cannot run in this scene")


def _paths_by_operators(bpy, scene, out, *, fit=False, keep=(None, None)):
    """fit_cones (when ``fit``; a generatrix given in ``keep`` — core ``Cone`` or
    ``Profile`` — is put back afterwards) → generate_paths → export_paths, all by the
    operators; prints the fit and the summary. Returns the JSON's path."""
    from ..blender.settings import set_generatrix, summary

    s = scene.blisk_cam
    if fit:
        run_operator(bpy, "fit_cones")
        for k, given in ((1, keep[0]), (2, keep[1])):
            if given is not None:
                set_generatrix(s, k, given)

        def shown(k):
            text = getattr(s, f"profile{k}")
            if text:
                import json

                return f"profile of {len(json.loads(text))} points"
            return str([round(x, 4) for x in getattr(s, f"cone{k}")])

        print(
            f"fitted cones: cone1 {shown(1)} (residual {s.fit_residual1:.4f} mm), "
            f"cone2 {shown(2)} (residual {s.fit_residual2:.4f} mm)"
        )
    run_operator(bpy, "generate_paths")
    out = Path(out).expanduser().resolve()
    run_operator(bpy, "export_paths", filepath=str(out))
    print(f"wrote {out}: {summary(s)}")
    if s.stat_warnings:
        import json

        with open(out, encoding="utf-8") as fh:
            d = json.load(fh)
        for w in (d.get("stats", {}).get("warnings", []) or []) + d.get("warnings", []):
            print(f"warning: {w}")
    return out


def _render_by_operator(bpy, filepath, engine, resolution, **kwargs):
    """``blisk_cam.render_preview`` to ``filepath``; prints what it wrote."""
    from ..blender.render import resolve_engine

    path = Path(filepath).expanduser().resolve()
    t0 = time.perf_counter()
    run_operator(
        bpy, "render_preview", filepath=str(path), engine=engine,
        resolution=tuple(resolution), **kwargs,
    )
    label = _engine_label(resolve_engine(engine))
    print(f"preview:    {path} ({label}, {time.perf_counter() - t0:.1f} s)")
    return path


def _blender_outputs(args, V, F, req, plan, report):
    """--blend / --preview: the blade, the settings of the request and the path objects in a
    fresh scene (the same objects Generate Paths makes), saved and/or rendered."""
    bpy = _import_bpy()
    from ..blender import path_objects as output
    from ..blender.objects import arrays_to_object, axis_to_object
    from ..blender.settings import set_settings_from_request

    with _blender_session(required=True) as scene:
        units = scene.unit_settings
        units.system, units.scale_length, units.length_unit = "METRIC", 0.001, "MILLIMETERS"
        blade = arrays_to_object(Path(args.mesh).stem, V, F, scene.collection,
                                 color=(0.85, 0.62, 0.30, 1.0))
        s = scene.blisk_cam
        s.blade = blade
        if args.axis:
            s.axis_object = axis_to_object("Blisk Axis", args.axis_obj, kind="EMPTY")
        set_settings_from_request(s, req, fit=args.fit)
        output.write_path_objects(scene, blade, plan.path, s, verify=report)
        if plan.fit is not None:
            s.fit_residual1, s.fit_residual2 = plan.fit.residual1, plan.fit.residual2
        from ..blender.settings import store_statistics

        store_statistics(s, blade.name, plan.path, report,
                         float(plan.path.stats.get("seconds_wall", 0.0)))
        if args.blend:
            print(f"blend: {_save_blend(bpy, args.blend)}")
        if args.preview:
            _render_by_operator(bpy, args.preview, args.engine, (1280, 720))
