"""The folder of a per-blade run read back: what became of every blade and the paths of those
that passed.

A per-blade run (``python -m blisk_cam batch`` with a ``blades`` job, on a cluster or
``--serial``) leaves in its job folder one paths JSON per planned blade (``blade_<k>.json``)
and the table of every blade (``blades.csv``: ``blade``, ``status`` "ok"/"failed", the
figures, ``detail`` = why a blade failed). :func:`read_blade_results` turns that folder into
the :class:`.per_blade.BladeOutcome` list a run in this process gives, so the Blender side
shows a run made elsewhere exactly like its own.

Units: mm (the paths JSON's).
"""

from __future__ import annotations

import csv
from pathlib import Path

from ..errors import BliskCamError
from ..toolpath.paths_io import read_paths_json
from .per_blade import BladeOutcome

__all__ = ["BLADE_TABLE", "find_results_folder", "read_blade_results"]

#: the table of a per-blade run's job folder
BLADE_TABLE = "blades.csv"


def find_results_folder(folder) -> Path:
    """The job folder holding ``blades.csv``: ``folder`` itself, or its one sub-folder that
    does (the batch's ``--out DIR`` with a single ``blades`` job). BliskCamError naming what
    is missing otherwise."""
    p = Path(folder).expanduser()
    if not p.is_dir():
        raise BliskCamError(f"{p} is not a folder: choose the output folder of a per-blade "
                            "run (the one holding blades.csv)")
    if (p / BLADE_TABLE).is_file():
        return p
    found = sorted(q.parent for q in p.glob(f"*/{BLADE_TABLE}"))
    if len(found) == 1:
        return found[0]
    if len(found) > 1:
        raise BliskCamError(f"{p} holds {len(found)} per-blade runs "
                            f"({', '.join(q.name for q in found)}); choose one of them")
    raise BliskCamError(f"{p} holds no {BLADE_TABLE}: choose the job folder a per-blade run "
                        "wrote (batch --out DIR/<job name>)")


def read_blade_results(folder) -> list[BladeOutcome]:
    """Every blade of a per-blade run's folder, in blade order.

    Parameters
    ----------
    folder : path — the job folder (or the batch ``--out`` folder with one ``blades`` job)

    Returns
    -------
    list of BladeOutcome — ``ok`` from the table's status; ``path`` read from
    ``blade_<k>.json`` for the blades that passed (a passed blade without its file is
    reported failed, naming the file); ``reason`` the table's detail for the others;
    ``figures`` the table's row. BliskCamError for a table that is not a per-blade one.
    """
    root = find_results_folder(folder)
    table = root / BLADE_TABLE
    with open(table, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    if not rows or not {"blade", "status"} <= set(rows[0]):
        raise BliskCamError(f"{table} is not the table of a per-blade run (no blade and "
                            "status columns)")
    out = []
    for row in rows:
        try:
            k = int(row["blade"])
        except (TypeError, ValueError):
            raise BliskCamError(f"{table}: blade number {row['blade']!r} is not a number") \
                from None
        figures = {key: value for key, value in row.items() if key is not None}
        if row["status"] != "ok":
            reason = (row.get("detail") or "").strip() or f"blade {k}: {row['status']}"
            out.append(BladeOutcome(k, False, reason, None, figures))
            continue
        file = root / f"blade_{k}.json"
        if not file.is_file():
            out.append(BladeOutcome(k, False, f"blade {k}: passed, but {file.name} is missing "
                                    "from the folder", None, figures))
            continue
        out.append(BladeOutcome(k, True, None, read_paths_json(file), figures))
    return sorted(out, key=lambda o: o.index)
