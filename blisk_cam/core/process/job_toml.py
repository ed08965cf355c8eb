"""The job file's text from its tables (the inverse of ``tomllib.load`` for what a job holds):
the Blender Operations panel's Export Job writes with it what ``process JOB.toml`` reads
(:func:`.job.load_job`).

A job's tables are plain: tables of text, whole numbers, finite numbers, booleans, lists of
these, one level of sub-table (``[part.demo]``) and the arrays of tables ``[[tool]]`` and
``[[operation]]``. Anything else is refused (BliskCamError naming the key) rather than written
in a form the reader would not give back.
"""

from __future__ import annotations

import json
import math
import re

from ..errors import BliskCamError

__all__ = ["job_toml", "toml_value"]

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k) -> str:
    if not isinstance(k, str) or not k:
        raise BliskCamError(f"job key {k!r}: keys are non-empty text")
    return k if _BARE.match(k) else json.dumps(k, ensure_ascii=False)


def toml_value(v, key: str = "value") -> str:
    """One TOML value: text (a basic string), bool, int, finite float or a list of these."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise BliskCamError(f"job key {key!r}: {v} is not a finite number")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # JSON string escapes are TOML's
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x, key) for x in v) + "]"
    raise BliskCamError(f"job key {key!r}: cannot write {v!r} ({type(v).__name__}) in a job "
                        "file")


def _body(table: dict, head: str) -> tuple[list, list]:
    """Lines of the plain keys of ``table``; the sub-tables as (header, table) pairs."""
    lines, subs = [], []
    for k, v in table.items():
        if v is None:
            continue  # not given: the reader's default
        if isinstance(v, dict):
            subs.append((f"{head}.{_key(k)}", v))
        else:
            lines.append(f"{_key(k)} = {toml_value(v, k)}")
    return lines, subs


def job_toml(data: dict, header: str = "") -> str:
    """The text of a job file holding ``data`` (module docstring); ``header``: comment lines
    at the top. ``None`` values are left out (the reader's default)."""
    out = [f"# {ln}" for ln in header.splitlines()]
    plain, _ = _body({k: v for k, v in data.items()
                      if not isinstance(v, (dict, list)) or (
                          isinstance(v, list) and not any(isinstance(x, dict) for x in v))},
                     "")
    out += plain
    for k, v in data.items():
        if isinstance(v, dict):
            pending = [(_key(k), v)]
            while pending:
                head, table = pending.pop(0)
                lines, subs = _body(table, head)
                out += ["", f"[{head}]", *lines]
                pending.extend(subs)
        elif isinstance(v, list) and any(isinstance(x, dict) for x in v):
            for item in v:
                if not isinstance(item, dict):
                    raise BliskCamError(f"job key {k!r}: a list mixing tables and values")
                lines, subs = _body(item, _key(k))
                if subs:
                    raise BliskCamError(f"job [[{k}]]: sub-tables are not part of a job")
                out += ["", f"[[{_key(k)}]]", *lines]
    return "\n".join(out).lstrip("\n") + "\n"
