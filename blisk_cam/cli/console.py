"""Messages that never end a run: stdout and stderr replace what their encoding cannot write.

Windows gives a redirected stream (a pipe, a log file, a scheduler's capture) the ANSI code
page, cp1252 in Western Europe and the Americas, which has "Ø", "°" and "µ" but no "≈", "θ"
or "ρ". Printing one of those raised UnicodeEncodeError, and the command ended as an internal
error after its work was done and before its output was reported. A console window is
written in UTF-8 by Python itself and is not affected, nor is any UTF-8 stream.
"""

from __future__ import annotations

import codecs
import sys

__all__ = ["never_fail_on_encoding"]


#: error handlers that write something for any character (Python gives stderr
#: "backslashreplace"; stdout gets "strict", or "surrogateescape" on some hosts: both raise)
_NEVER_RAISE = ("replace", "backslashreplace", "xmlcharrefreplace", "namereplace", "ignore")


def never_fail_on_encoding() -> None:
    """Reconfigure ``sys.stdout`` and ``sys.stderr``, where they encode in other than UTF-8
    and would raise, to print "?" for a character their encoding lacks."""
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        encoding = getattr(stream, "encoding", None)
        if reconfigure is None or not encoding or getattr(stream, "errors", "") in _NEVER_RAISE:
            continue
        try:
            if codecs.lookup(encoding).name == "utf-8":
                continue
        except LookupError:
            pass
        reconfigure(errors="replace")
