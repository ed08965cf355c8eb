"""What a preview says besides the scene: the title line, the legends (a colour ramp, or named
swatches such as the collision statuses) in a black band at the top, and a scale bar on a dark
plate at the bottom left.

They are objects in front of the preview camera (children of it, in its local frame: x right,
y up, −z forward), just beyond its near clip, sized in *pixels of the picture* so that text
stays readable at any resolution: a text line is 4.5 % of the picture's height but never less
than :data:`MIN_LINE_PX`; the scale label's glyphs are at least 12 px high from a height of
260 px on (its font :data:`MIN_SCALE_FONT_PX`, at most a tenth of the height), and the bar's
length is a round number of mm that takes about a fifth of the width at the depth of the
framed objects.
"""

from __future__ import annotations

from dataclasses import dataclass

import bpy

__all__ = ["Legend", "header_share", "overlay_objects", "text_objects"]

#: one text row of the header, in pixels: 4.5 % of the height, at least this
MIN_LINE_PX = 14.0
#: the smallest font size (pixels) of a header text and of the scale label (the scale label
#: at most a tenth of the height); the scale label's digits measure 17 px at 26 px
MIN_FONT_PX = 11.0
MIN_SCALE_FONT_PX = 26.0
#: an estimate of the default font's mean advance per character, in em (for the layout)
CHAR_EM = 0.52
#: name prefix of every overlay object (tests and clean-up find them by it)
PREFIX = "Blisk CAM render "


@dataclass(frozen=True)
class Legend:
    """What colours mean, drawn as one row under the title.

    ``title`` e.g. "pass ratio s"; either a ramp — ``colors`` RGBA per swatch, left to right,
    ``low`` and ``high`` the labels at the two ends ("0 hub", "1 tip") — or named swatches:
    ``entries`` (label, RGBA) pairs, each drawn as a swatch followed by its label ("clear 634"),
    on the title's row."""

    title: str
    colors: tuple = ()
    low: str = ""
    high: str = ""
    entries: tuple = ()

    def rows(self, width_px=None) -> float:
        """Header rows it takes: one, or two for a ramp too wide for one row of a picture
        ``width_px`` wide (its title above the swatches)."""
        if self.entries:
            return 1.2 * (1 + max(r for r, _ in _entry_layout(self, width_px)))
        if width_px is None:
            return 2.2
        usable = width_px - 2.0 * _line_px(width_px * 9.0 / 16.0)
        return 2.2 if _ramp_row_px(self, width_px) > usable else 1.2


def _line_px(height):
    return max(0.045 * float(height), MIN_LINE_PX)


def _font_px(height):
    return max(0.6 * _line_px(height), MIN_FONT_PX)


def _entry_layout(lg, width_px):
    """(row, x in pixels from the left margin) of a named-swatch legend's title and of each
    swatch, wrapped onto further rows where a row would leave the picture."""
    if width_px is None:
        width_px = 1e9
    h = width_px * 9.0 / 16.0
    line, font = _line_px(h), _font_px(h)
    usable = width_px - 1.2 * line
    out, row = [(0, 0.0)], 0
    x = CHAR_EM * font * (len(lg.title) + 1) if lg.title else 0.0
    for label, _ in lg.entries:
        size = 0.8 * line + 0.25 * line + CHAR_EM * font * len(label)
        if x + size > usable and x > 0:
            row, x = row + 1, 0.0
        out.append((row, x))
        x += size + 0.8 * line
    return out


def _ramp_row_px(lg, width_px):
    """Width (pixels) of a ramp legend on one row (title, low label, swatches, high label)
    in a picture ``width_px`` wide with the usual 16:9 height."""
    h = width_px * 9.0 / 16.0
    line, font = _line_px(h), _font_px(h)
    chars = len(lg.title) + 1 + 0.85 * (len(lg.low) + len(lg.high) + 1)
    return 0.6 * line + CHAR_EM * font * chars + 0.9 * line * len(lg.colors) + 0.6 * line


def _legends(legend):
    if legend is None:
        return []
    if isinstance(legend, Legend):
        return [legend]
    return [lg for lg in legend if lg is not None and (lg.colors or lg.entries)]


def header_share(resolution, title, legend) -> float:
    """Share of the picture's height the header band takes (0 without title and legend)."""
    legends = _legends(legend)
    if not title and not legends:
        return 0.0
    rows = (1.3 if title else 0.0) + sum(lg.rows(resolution[0]) for lg in legends) + 0.4
    return min(rows * _line_px(resolution[1]) / float(resolution[1]), 0.6)


def _flat_material(name, rgba):
    """A matte material for the overlay: no specular highlight (Workbench puts a grey sheen
    on a camera-facing flat, which lifted a black band to 0.24 grey)."""
    from .objects import colored_material

    mat = colored_material(name, rgba)
    mat.specular_intensity = 0.0
    mat.roughness = 1.0
    mat.metallic = 0.0
    return mat


def _text(name, body, size, rgba, cam, loc, align="LEFT"):
    cu = bpy.data.curves.new(name, "FONT")
    cu.body = body
    cu.size = size
    cu.align_x = align
    cu.align_y = "BOTTOM"
    cu.materials.append(_flat_material(f"Blisk CAM render text {tuple(rgba)}", rgba))
    ob = bpy.data.objects.new(name, cu)
    ob.parent = cam
    ob.location = loc
    return ob


def _rect(name, w, h, rgba, cam, loc):
    me = bpy.data.meshes.new(name)
    me.from_pydata([(0, 0, 0), (w, 0, 0), (w, h, 0), (0, h, 0)], [], [(0, 1, 2, 3)])
    me.materials.append(_flat_material(f"Blisk CAM render swatch {tuple(rgba)}", rgba))
    ob = bpy.data.objects.new(name, me)
    ob.parent = cam
    ob.location = loc
    return ob


def text_objects(scene=None):
    """The overlay's text objects in the scene (name → body): for tests and reports."""
    scene = scene or bpy.context.scene
    return {ob.name: ob.data.body for ob in scene.objects
            if ob.type == "FONT" and ob.name.startswith(PREFIX)}


def overlay_objects(scene, cam, resolution, *, title, legend, scale, on_object=None):
    """Title, legends and scale bar in front of ``cam``; linked to ``scene``, returned.

    ``legend`` a :class:`Legend` or a list of them (one header row each); ``scale`` None or
    (the bar's length in mm, mm per pixel at the framed objects' depth). ``on_object(ob)`` is
    called for each object made.
    """
    data = cam.data
    w, h = resolution
    # just beyond the near clip: in front of everything the camera sees (also of objects
    # that were not framed, e.g. cone outlines reaching toward the camera)
    depth = 1.02 * data.clip_start
    tan_big = 0.5 * data.sensor_width / data.lens
    tan_x, tan_y = (tan_big, tan_big * h / w) if w >= h else (tan_big * w / h, tan_big)
    hx, hy = depth * tan_x, depth * tan_y  # half the visible width/height at that depth
    px = 2.0 * hx / w  # one pixel at that depth
    oy = 2.0 * data.shift_y * tan_big * depth  # the lens shift moves the visible window up
    line = _line_px(h) * px
    font = _font_px(h) * px
    white = (1.0, 1.0, 1.0, 1.0)
    black = (0.0, 0.0, 0.0, 1.0)
    left, top = -hx + 0.6 * line, oy + hy - 1.25 * line
    legends = _legends(legend)
    out = []
    share = header_share(resolution, title, legends)
    if share:  # a black band behind the header (the studio light dims camera-facing text
        # to ~0.6 grey: black keeps it readable)
        band = share * 2.0 * hy
        out.append(_rect(PREFIX + "header", 2.0 * hx, band, black, cam,
                         (-hx, oy + hy - band, -1.01 * depth)))
    y = top
    if title:
        out.append(_text(PREFIX + "title", title, max(0.8 * line, MIN_FONT_PX * px), white,
                         cam, (left, y, -depth)))
        y -= 1.2 * line
    for i, lg in enumerate(legends):
        tag = f"legend {i} "
        if lg.entries:
            at = _entry_layout(lg, w)
            if lg.title:
                out.append(_text(PREFIX + tag + "title", lg.title, font, white, cam,
                                 (left, y, -depth)))
            sw, sh = 0.8 * line, 0.55 * line
            for k, ((label, rgba), (row, xp)) in enumerate(zip(lg.entries, at[1:],
                                                                strict=True)):
                x, yr = left + xp * px, y - 1.2 * line * row
                out.append(_rect(f"{PREFIX}{tag}swatch {k:02d}", sw, sh, tuple(rgba), cam,
                                 (x, yr, -depth)))
                ob = _text(f"{PREFIX}{tag}label {k:02d}", label, font, white, cam,
                           (x + sw + 0.25 * line, yr, -depth))
                ob["blisk_cam_swatch_rgba"] = [float(c) for c in rgba]
                out.append(ob)
            y -= 1.2 * line * (1 + at[-1][0])
            continue
        out.append(_text(PREFIX + tag + "title", lg.title, font, white, cam, (left, y, -depth)))
        one_row = lg.rows(w) < 2.0
        if one_row:
            x = left + CHAR_EM * font * (len(lg.title) + 1)
        else:
            y -= 0.9 * line
            x = left
        sw, sh = 0.9 * line, 0.55 * line
        if lg.low:
            out.append(_text(PREFIX + tag + "low", lg.low, 0.85 * font, white, cam,
                             (x, y + 0.05 * line, -depth)))
            x += CHAR_EM * 0.85 * font * (len(lg.low) + 1)
        for k, rgba in enumerate(lg.colors):
            out.append(_rect(f"{PREFIX}{tag}ramp {k:02d}", sw, sh, tuple(rgba), cam,
                             (x + k * sw, y, -depth)))
        x += len(lg.colors) * sw + 0.3 * line
        if lg.high:
            out.append(_text(PREFIX + tag + "high", lg.high, 0.85 * font, white, cam,
                             (x, y + 0.05 * line, -depth)))
        y -= 1.2 * line if one_row else 1.3 * line
    if scale is not None:
        out.extend(_scale_bar(cam, scale, h, px, left - 0.3 * line, oy - hy, depth))
    for ob in out:
        scene.collection.objects.link(ob)
        if on_object is not None:
            on_object(ob)
    return out


def _scale_bar(cam, scale, h, px, x0, bottom, depth):
    """Bar, label and the dark plate behind them, at the bottom left."""
    length, mm_per_px = scale
    bar = length / mm_per_px * px  # its length in the overlay's plane
    # at least MIN_SCALE_FONT_PX, but never more than a tenth of a small picture's height
    font = min(max(0.034 * h, MIN_SCALE_FONT_PX), 0.1 * h) * px
    label = f"{length:g} mm"
    pad = 0.45 * font
    thick = max(0.2 * font, 3.0 * px)
    text_w = CHAR_EM * font * len(label)
    plate_w = pad + bar + 0.5 * font + text_w + pad
    plate_h = font + 2.0 * pad
    y0 = bottom + 0.5 * font
    white = (1.0, 1.0, 1.0, 1.0)
    return [
        _rect(PREFIX + "scale plate", plate_w, plate_h, (0.0, 0.0, 0.0, 1.0), cam,
              (x0, y0, -1.01 * depth)),
        _rect(PREFIX + "scale bar", bar, thick, white, cam,
              (x0 + pad, y0 + pad + 0.05 * font, -depth)),
        _text(PREFIX + "scale label", label, font, white, cam,
              (x0 + pad + bar + 0.5 * font, y0 + pad, -depth)),
    ]
