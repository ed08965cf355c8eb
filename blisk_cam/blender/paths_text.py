"""The paths JSON kept in a Blender Text datablock, as text: broken into short lines (a Text is
quadratic in the length of a line) and read back, and the verdict appended in place. The
datablock itself is :mod:`.path_objects`' (``"Blisk CAM – <blade>.json"``)."""

from __future__ import annotations

import json

from ..core.errors import BliskCamError
from ..core.toolpath.paths_io import path_to_dict

__all__ = ["TEXT_LINE", "from_text_lines", "paths_json_text", "replace_last_character",
           "text_lines", "to_text_lines"]


def to_text_lines(json_text: str) -> str:
    r"""The one-line JSON broken after every point (``"], ["`` → ``"],\n["``) for the Text
    datablock: Blender's Text is quadratic in the length of a line (a 1 MB line takes
    minutes) and fast with many short lines; a line still longer than :data:`TEXT_LINE`
    characters is broken further (:func:`_wrapped`). ``json.dumps`` output holds no raw
    newline, so removing every newline gives the JSON back (with ``"],["`` between points)."""
    if "\n" in json_text:
        raise BliskCamError("internal: the paths JSON to store holds a raw newline")
    lines = json_text.replace("], [", "],\n[").split("\n")
    return "\n".join(_wrapped(x) if len(x) > TEXT_LINE else x for x in lines)


#: the longest line the Text datablock is given: lists that are not lists of points (the
#: per-pose ``move`` names, 130 000 characters on Rotor 37, 0.8 s in ``from_string``) are
#: broken after a ``", "`` every this many characters (a newline inserted, nothing replaced:
#: removing the newlines gives what the point breaks alone give)
TEXT_LINE = 1000


def _wrapped(line: str) -> str:
    """``line`` with a newline after the last ``", "`` before every :data:`TEXT_LINE`
    characters (after exactly that many where there is none)."""
    out, start = [], 0
    while len(line) - start > TEXT_LINE:
        cut = line.rfind(", ", start, start + TEXT_LINE)
        cut = cut + 2 if cut > start else start + TEXT_LINE
        out.append(line[start:cut])
        start = cut
    out.append(line[start:])
    return "\n".join(out)


def from_text_lines(stored: str) -> str:
    return stored.replace("\n", "")


def text_lines(json_text: str) -> tuple[str, str]:
    """(the Text datablock's content for ``json_text``, what :func:`stored_paths_json` then
    returns). No bpy: a worker thread makes them for ``write_path_objects(text=...)``."""
    lines = to_text_lines(json_text)
    return lines, from_text_lines(lines)


def paths_json_text(path) -> str:
    """The paths JSON of ``path`` as text: byte for byte what ``write_paths_json`` writes."""
    return json.dumps(path_to_dict(path), allow_nan=False)


def replace_last_character(text, tail: str) -> bool:
    """Replace the Text's last character (the stored JSON's closing brace) by ``tail`` (broken
    into lines as :func:`to_text_lines` does): milliseconds where rewriting the whole Text
    takes a tenth of a second. False (nothing changed) when the Text does not end with "}"."""
    n = len(text.lines) - 1
    body = text.lines[n].body if n >= 0 else ""
    if not body.endswith("}"):
        return False
    text.cursor_set(n, character=len(body) - 1)
    text.cursor_set(n, character=len(body), select=True)
    text.write(to_text_lines(tail))
    return True
