"""Render the README's collision example (NASA Rotor 37, Ø12 ball, radial tilt 88°, 36 blades,
the stated holder, avoid) as Blender's Render Preview shows it after Check Collisions.

    python scripts/render_collision_example.py OUT.png [--resolution 1280 720]
        [--cusp 0.05] [--engine WORKBENCH] [--colors 256]

Runs in a Python with the ``bpy`` module (``.venv/bpy45/bin/python``) from the repository's
root: the blade is imported, the sidebar settings are those of the README command, then
Generate Paths, Check Collisions (avoid) and Render Preview run as a user would run them. The
add-on is unregistered before the process exits (bpy 4.5 hangs otherwise). With ``--colors``
the picture is written as an indexed PNG of that many colours (k-means on the pixels), which
keeps the README's pictures under 400 KB.
"""

import argparse
import struct
import sys
import time
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BLADE = ROOT / "tests" / "data" / "blades" / "rotor37_blade_extended_open.stl"


def _chunk(kind, data):
    return (struct.pack(">I", len(data)) + kind + data
            + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


def indexed_png(rgb, colors):
    """PNG bytes of an (h, w, 3) uint8 picture reduced to ``colors`` (≤ 256) colours: k-means
    on a sample of the pixels, each pixel mapped to its nearest centre."""
    import numpy as np
    from scipy.cluster.vq import kmeans2
    from scipy.spatial import cKDTree

    h, w, _ = rgb.shape
    px = rgb.reshape(-1, 3).astype(np.float64)
    rng = np.random.default_rng(0)
    sample = px[rng.choice(len(px), size=min(len(px), 60000), replace=False)]
    centres, _ = kmeans2(sample, min(colors, 256), minit="++", seed=1, iter=20)
    _, idx = cKDTree(centres).query(px)
    palette = np.clip(np.round(centres), 0, 255).astype(np.uint8)
    rows = np.concatenate([np.zeros((h, 1), np.uint8), idx.astype(np.uint8).reshape(h, w)],
                          axis=1)  # filter type 0 per row
    return (b"\x89PNG\r\n\x1a\n"
            + _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 3, 0, 0, 0))
            + _chunk(b"PLTE", palette.tobytes())
            + _chunk(b"IDAT", zlib.compress(rows.tobytes(), 9))
            + _chunk(b"IEND", b""))


def _quantize(path, colors):
    """Rewrite the PNG at ``path`` as an indexed PNG of ``colors`` colours."""
    import bpy
    import numpy as np

    from blisk_cam.core.files import write_atomic

    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        w, h = img.size
        px = np.empty(w * h * img.channels, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    rgb = np.round(px.reshape(h, w, -1)[::-1, :, :3] * 255.0).astype(np.uint8)
    write_atomic(path, indexed_png(rgb, colors))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--resolution", type=int, nargs=2, default=(1280, 720))
    ap.add_argument("--cusp", type=float, default=0.05)
    ap.add_argument("--engine", default="WORKBENCH")
    ap.add_argument("--colors", type=int, default=0, help="write an indexed PNG (≤ 256)")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    import math

    import bpy

    import blisk_cam
    from blisk_cam.blender.objects import import_mesh_file

    bpy.ops.wm.read_factory_settings(use_empty=True)
    blisk_cam.register()
    try:
        t0 = time.perf_counter()
        blade = import_mesh_file(BLADE)
        s = bpy.context.scene.blisk_cam
        s.blade = blade
        s.cone1 = (177.5329, -1.7189, 187.9971, 45.0476)
        s.cone2 = (252.5327, 4.3172, 243.7368, 36.2274)
        s.tool_type, s.tool_diameter = "BALL", 12.0
        s.cusp, s.chord, s.verify = args.cusp, 0.05, False
        s.axis_mode, s.radial_tilt, s.lead = "RADIAL", math.radians(88.0), math.radians(5.0)
        s.mode, s.blade_count, s.safety = "AVOID", 36, 0.5
        s.max_tilt = math.radians(89.0)
        s.holder = "36 4 120 4 120 10 160 10"
        assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
        assert bpy.ops.blisk_cam.check_collisions() == {"FINISHED"}
        t1 = time.perf_counter()
        out = Path(args.out).resolve()
        bpy.ops.blisk_cam.render_preview(filepath=str(out), resolution=tuple(args.resolution),
                                         engine=args.engine)
        if args.colors:
            _quantize(out, args.colors)
        print(f"paths and collisions {t1 - t0:.1f} s, preview {time.perf_counter() - t1:.1f} s")
    finally:
        blisk_cam.unregister()


if __name__ == "__main__":
    main()
