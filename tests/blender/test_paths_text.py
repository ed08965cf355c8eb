"""Issue 21 (panel speed): the paths JSON is kept in a Text datablock in lines of at most
``TEXT_LINE`` characters (Blender's Text is quadratic in a line's length), and reading it back
gives what breaking after every point alone gave."""

import json

import bpy

from blisk_cam.blender import path_objects as output


def test_long_lists_are_broken_into_short_lines_and_read_back_unchanged():
    # a per-pose list of move names (the line that was 130 000 characters on Rotor 37), a
    # flat list of numbers, a list of points and a string longer than a line without ", "
    d = {"move": ["cut"] * 4000 + ["rapid"], "s": [0.125 * k for k in range(3000)],
         "tip": [[1.5, -2.0, 3.25]] * 500, "note": "x" * 2500}
    js = json.dumps(d, allow_nan=False)
    lines, stored = output.text_lines(js)
    widths = [len(x) for x in lines.split("\n")]
    assert max(widths) <= output.TEXT_LINE and len(widths) > len(js) // output.TEXT_LINE
    # the stored form is the JSON with "], [" → "],[" (only newlines were added)
    assert stored == js.replace("], [", "],[") and json.loads(stored) == d
    text = bpy.data.texts.new("paths.json")
    text.from_string(lines)
    assert text.as_string().replace("\n", "") == stored
