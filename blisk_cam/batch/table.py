"""Summary tables as CSV and Markdown (rows of dicts, the columns named)."""

from __future__ import annotations

import csv
import io

__all__ = ["table_csv", "table_markdown"]


def _cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.6g}"
    return " ".join(str(v).split())


def table_csv(rows, columns) -> str:
    """CSV text: a header of ``columns``, one line per row (missing values empty)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in columns])
    return buf.getvalue()


def table_markdown(rows, columns) -> str:
    """A Markdown table of the same cells (``|`` escaped)."""
    def esc(s):
        return s.replace("|", "\\|")

    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(esc(_cell(r.get(c))) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"
