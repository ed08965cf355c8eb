"""Issue 28 row 12: no test asserts a duration (a loaded machine fails it: 1.74 s > 1.0 s in
``test_million_triangles_in_bulk_under_a_second``). Figures live in ``bench/*.py`` scripts that
print. Checked on the source: in every function of ``tests/``, no ``assert`` uses a value
computed from a clock (``time.perf_counter``, ``time.time``, ``time.monotonic``,
``time.process_time`` and their ``_ns`` forms)."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
CLOCKS = {"perf_counter", "time", "monotonic", "process_time", "perf_counter_ns", "time_ns",
          "monotonic_ns", "process_time_ns"}


def _calls_clock(node) -> bool:
    for n in ast.walk(node):
        if isinstance(n, ast.Call):
            f = n.func
            if (isinstance(f, ast.Attribute) and f.attr in CLOCKS and isinstance(f.value, ast.Name)
                    and f.value.id == "time"):
                return True
    return False


def _names(node) -> set[str]:
    return {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}


def timed_assertions(tree) -> list[str]:
    """``function:line`` of every assert that uses a clock-derived value."""
    out = []
    for fn in ast.walk(tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)) or not _calls_clock(fn):
            continue
        tainted: set[str] = set()
        for _ in range(4):  # values derived from derived values
            for n in ast.walk(fn):
                if isinstance(n, (ast.Assign, ast.AugAssign, ast.AnnAssign)) and n.value:
                    if _calls_clock(n.value) or _names(n.value) & tainted:
                        targets = n.targets if isinstance(n, ast.Assign) else [n.target]
                        for t in targets:
                            tainted |= _names(t)
        for n in ast.walk(fn):
            if isinstance(n, ast.Assert) and (_calls_clock(n.test) or _names(n.test) & tainted):
                out.append(f"{fn.name}:{n.lineno}")
    return out


def test_the_check_finds_a_timed_assertion():
    src = ("import time\ndef test_x():\n    t0 = time.perf_counter()\n    f()\n"
           "    dt = time.perf_counter() - t0\n    best = min(9, dt)\n    assert best < 1.0\n")
    assert timed_assertions(ast.parse(src)) == ["test_x:7"]
    ok = ("import time\ndef test_y():\n    t0 = time.perf_counter()\n    n = f()\n"
          "    print(time.perf_counter() - t0)\n    assert n == 3\n")
    assert timed_assertions(ast.parse(ok)) == []


def test_no_test_asserts_a_duration():
    found = []
    for f in sorted(TESTS.rglob("*.py")):
        if f.name == Path(__file__).name:
            continue
        found += [f"{f.relative_to(TESTS)}:{x}" for x in
                  timed_assertions(ast.parse(f.read_text(encoding="utf-8")))]
    assert not found, f"timed assertions (move the figure to bench/): {found}"
