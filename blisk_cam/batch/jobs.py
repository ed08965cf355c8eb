"""The jobs file (``JOBS.toml``) → jobs, each a list of tasks for the workers.

::

    [defaults]                 # optional: merged under every job's arguments
    tool = "ball"
    tool-diameter = 10

    [[job]]
    name = "r37"               # a folder DIR/r37 holds its outputs
    command = "paths"          # a single command: its flags without the dashes
    mesh = "rotor37.stl"       # relative paths are relative to JOBS.toml
    cusp = 0.05
    verify = true              # a flag without a value: true

    [[job]]
    name = "scan"
    command = "blades"         # per-blade paths of a whole-blisk scan (one task per blade)
    mesh = "scan.stl"
    neighbours = 1             # scanned neighbours per side checked for collisions
    collisions = "avoid"
    machine = "ac-trunnion"    # with post: one NC program, a section per blade
    post = "apt"

    [[job]]
    name = "study"
    command = "sweep"          # every combination of the lists (one task each)
    mesh = "blade.stl"
    blade-count = 24
    tool-diameter = [8, 10, 12]
    lead = [0, 10]             # degrees
    tilt = [0, 5]
    holder-length = [40, 60]   # mm from the tip to the holder face

Angles are degrees and lengths mm, as on the command line. A job's *hash* (its command, its
arguments and the bytes of every input file it names) decides whether a re-run may skip it.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..core.errors import BliskCamError
from ..core.files import file_sha256
from ..core.version import __version__

__all__ = ["COMMANDS", "Job", "JobsError", "Task", "load_jobs", "argv_of"]

#: job commands: the single commands run as they are, and the two batch-only ones
COMMANDS = ("paths", "nc", "simulate", "blades", "sweep")
#: argument names that name an input file (hashed with the job)
INPUT_KEYS = ("mesh", "obstacle", "cone1-profile", "cone2-profile", "paths", "program",
              "stock", "part", "hub-profile", "machine")
#: argument names that name an output file of a single command: given a bare file name, the
#: file lands in the job's folder (default name when the job does not give one)
OUTPUT_KEYS = ("out", "nc", "report", "blend", "preview", "deviation", "stock-mesh",
               "save-stock")
DEFAULT_OUT = {"paths": "paths.json", "nc": "program.nc", "simulate": "simulation.json"}
#: the sweep's axes: argument → what the summary calls it
SWEEP_AXES = ("tool-diameter", "lead", "tilt", "holder-length")


class JobsError(BliskCamError):
    """A bad jobs file (names the job and the key)."""


@dataclass
class Task:
    """One unit of work for a worker.

    job : str — the job's name; key : str — unique in the batch ("scan/blade-3");
    kind : "command" | "blade" | "sweep"; payload : dict — picklable inputs
    """

    job: str
    key: str
    kind: str
    payload: dict


@dataclass
class Job:
    """One job of the file: its name, command, arguments (TOML values, relative paths made
    absolute), the input files it reads and its hash."""

    name: str
    command: str
    args: dict
    inputs: list = field(default_factory=list)
    hash: str = ""


def _job_hash(command: str, args: dict, inputs) -> str:
    files = {str(p): file_sha256(p) for p in inputs if p.is_file()}
    text = json.dumps({"version": __version__, "command": command, "args": args,
                       "files": files}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _resolve(value, base: Path):
    if isinstance(value, list):
        return [_resolve(v, base) for v in value]
    p = Path(str(value)).expanduser()
    return str(p if p.is_absolute() else (base / p).resolve())


def load_jobs(filename) -> list[Job]:
    """The jobs of a TOML file. JobsError naming the job and the problem: unreadable file,
    no jobs, a job without a name or with an unknown command, two jobs of one name, an input
    file that does not exist."""
    path = Path(filename).expanduser()
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise JobsError(f"jobs file {path} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise JobsError(f"cannot read jobs file {path}: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise JobsError(f"jobs file {path} is not valid TOML: {exc}") from None
    base = path.resolve().parent
    defaults = data.get("defaults", {})
    raw = data.get("job", [])
    unknown = sorted(set(data) - {"defaults", "job"})
    if unknown:
        raise JobsError(f"jobs file {path}: unknown table(s) {', '.join(unknown)}; use "
                        "[defaults] and [[job]]")
    if not isinstance(raw, list) or not raw:
        raise JobsError(f"jobs file {path} has no jobs; add [[job]] tables with a name and a "
                        f"command ({', '.join(COMMANDS)})")
    jobs, seen = [], set()
    for i, entry in enumerate(raw, 1):
        name = str(entry.get("name", "")).strip()
        if not name or "/" in name or name.startswith("."):
            raise JobsError(f"job {i} needs a name (a folder name: no '/', not starting with "
                            f"'.'), got {entry.get('name')!r}")
        if name in seen:
            raise JobsError(f"two jobs are named {name!r}; give each its own name")
        seen.add(name)
        command = entry.get("command")
        if command not in COMMANDS:
            raise JobsError(f"job {name!r}: command must be one of {', '.join(COMMANDS)}, got "
                            f"{command!r}")
        args = {**defaults, **{k: v for k, v in entry.items() if k not in ("name", "command")}}
        inputs = []
        for key in INPUT_KEYS:
            if key not in args:
                continue
            if key == "machine" and not str(args[key]).lower().endswith(".toml"):
                continue  # a preset name
            if key == "stock" and str(args[key]).split(":")[0] in ("allowance", "envelope"):
                continue  # a blank made from the part
            args[key] = _resolve(args[key], base)
            for f in args[key] if isinstance(args[key], list) else [args[key]]:
                if not Path(f).exists():
                    raise JobsError(f"job {name!r}: {key} {f} not found")
                inputs.append(Path(f))
        for key in OUTPUT_KEYS:
            v = args.get(key)
            if v is not None and (not isinstance(v, str) or os.path.basename(v) != v):
                raise JobsError(f"job {name!r}: {key} must be a bare file name (outputs land "
                                f"in DIR/{name}/), got {v!r}")
        if command != "sweep":
            for key, v in args.items():
                if isinstance(v, list) and key != "obstacle":
                    raise JobsError(f"job {name!r}: {key} is a list; lists are for "
                                    f"command = \"sweep\" ({', '.join(SWEEP_AXES)})")
        jobs.append(Job(name, command, args, inputs, _job_hash(command, args, inputs)))
    return jobs


def argv_of(command: str, args: dict, drop=()) -> list[str]:
    """The command line of ``command`` with ``args`` ({flag without dashes: value}; true →
    the bare flag, false → left out, a list → one value each or, for ``obstacle``, the
    flag repeated)."""
    argv = [command]
    for key, value in args.items():
        if key in drop or value is False or value is None:
            continue
        flag = f"--{key}"
        if value is True:
            argv.append(flag)
        elif key == "obstacle":
            for v in value if isinstance(value, list) else [value]:
                argv += [flag, str(v)]
        elif isinstance(value, list):
            argv += [flag, *map(str, value)]
        else:
            argv += [flag, str(value)]
    return argv


def sweep_points(args: dict) -> list[dict]:
    """Every combination of the sweep's list-valued axes (:data:`SWEEP_AXES`), as the
    arguments of one set-up each (scalars stay)."""
    axes = [k for k in SWEEP_AXES if isinstance(args.get(k), list)]
    for k, v in args.items():
        if isinstance(v, list) and k not in SWEEP_AXES and k != "obstacle":
            raise JobsError(f"sweep: {k} is a list but only {', '.join(SWEEP_AXES)} are swept")
    out = []
    for values in itertools.product(*(args[k] for k in axes)):
        out.append({**args, **dict(zip(axes, values, strict=True))})
    return out
