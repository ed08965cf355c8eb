"""The whole blisk as one job (paper 003 §5): a part, a stock, a machine and its posts, a tool
table and operations in order, each planned on the stock the previous one left.

The job file (TOML; lengths mm, angles degrees, speeds m/min and rpm, feeds mm and mm/min)::

    [part]
    source = "demo"                 # or a whole-blisk mesh, or a blade mesh + hub_profile
    # hub_profile = "hub.csv"       # (r, z) per line: source is then one blade
    blade_count = 24                # checked against the demo / the mesh's symmetry
    material = "Ti-6Al-4V"          # Ti-6Al-4V, Inconel 718, Al 7075, Al 6061
    [part.demo]                     # demo parameters (resolution, fillet, fillet_radius …)
    resolution = 0.3

    [stock]
    blank = "allowance:0.5"         # as `simulate --stock`: profile CSV, mesh, allowance:MM,
    resolution = 1.0                #   envelope:MM; the stock grid's resolution, mm
    # gouge_tolerance = 0.3         # mm (default: the operation's chord + the resolution)

    [machine]
    name = "ac-trunnion"            # preset or machine TOML
    posts = ["linuxcnc"]            # one program per post
    # max_spindle = 20000           # rpm: the spindle speed is capped here

    [[tool]]
    number = 1
    type = "ball"                   # ball, bull, flat, taper (DIN 66215, as the CLI's --tool)
    diameter = 12
    # corner_radius = 2  taper_angle = 3
    flutes = 2
    stick_out = 60                  # mm out of the holder (a shank to here, then the holder)
    # holder = "36 4 120 4 120 10 160 10"   # or the body profile itself, z r pairs from the tip
    coolant = "flood"               # flood or off

    [[operation]]
    name = "blade finish"
    kind = "blade_finish"           # blade_finish, semi_finish, hub_finish, fillet_finish
    tool = 1
    cusp = 0.05                     # the kind's own options (for blade_finish the paths CLI's)
    # depth = 0.2  vc = 60  fz = 0.05  spindle = 8000  feed = 900   # cutting data overrides

Every table's keys are checked (an unknown key is refused with the nearest known one); tool
numbers are unique; every operation names a tool of the table and a kind of this build. Errors
name the file, the operation (number and name) and the key.

The run (:func:`iter_run_job`): the part and the stock are built, every operation is prepared
once to check the whole job before long work, then each operation in order is planned
(:func:`.operation.iter_run_operation`), run on the stock (:func:`..stock.simulation.
iter_simulate`: the deviation map and the verdict after it; the stock, changed in place, is the
next operation's input), and given its cutting data at the effective diameter
(:mod:`.cutting_data`). Then the final verdict on the last stock (:mod:`.job_verdict`:
material left and gouges on blades, hub and fillets, the zones no finishing operation reaches
named with their area). At the end one program per post with a section per operation
(:func:`..post.job_program.job_program`), checked back through forward kinematics block by
block against every operation's poses.
"""

from __future__ import annotations

import hashlib
import math
import os
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from ..errors import BliskCamError, StockError, ToolError, check_known_keys
from ..geometry.mesh_io import MESH_SUFFIXES, read_mesh
from ..machine.description import Machine, forward, load_machine
from ..part.blisk import make_demo_blisk
from ..part.blisk_params import DemoParams
from ..part.model import BliskPart, part_from_blade, part_from_demo, read_rz_csv, split_blisk_mesh
from ..post.blocks import NcOptions
from ..post.export import get_post
from ..post.gate import CollisionGateError
from ..post.job_program import JobSection, check_job_post, job_program
from ..presets import preset_names
from ..runtime import Progress, scaled_progress
from ..stock.blank import is_part_based, stock_from_spec
from ..stock.dexels import MIN_RESOLUTION, RadialDexels
from ..stock.fine_check import FineCheck, RunProgram
from ..stock.rapid_clearance import clear_rapids
from ..stock.simulation import cut_into, iter_simulate, part_on_grid
from ..tool.assembly import AssemblyError, holder_profile
from ..tool.cutter import Cutter
from ..toolpath.types import MOVE_CUT
from .cutting_data import CuttingData, cutting_data, material_key
from .fillet_finish import part_fillet
from .job_verdict import FINISHING_KINDS, OperationContacts, job_verdict
from .operation import iter_run_operation
from .operation_kinds import (
    OperationContext,
    OperationKind,
    ToolEntry,
    operation_kind,
    tool_assembly,
)

__all__ = ["Job", "JobError", "JobOperation", "JobRun", "OperationRun", "build_part",
           "build_stock", "final_verdict", "iter_run_job", "job_from_data", "job_template",
           "load_job", "stock_digest", "TEMPLATES_DIR"]


class JobError(BliskCamError):
    """The job file is unusable: names the file, the operation and the key."""


TOP_KEYS = ("part", "stock", "machine", "tool", "operation")
PART_KEYS = ("source", "hub_profile", "blade_count", "material", "demo")
STOCK_KEYS = ("blank", "resolution", "gouge_tolerance")
MACHINE_KEYS = ("name", "posts", "max_spindle")
TOOL_KEYS = ("number", "type", "diameter", "corner_radius", "taper_angle", "flutes",
             "stick_out", "flute_length", "holder", "holder_diameter", "coolant",
             "max_spindle", "name")
#: keys every operation takes besides its kind's own
OPERATION_KEYS = ("name", "kind", "tool", "enabled", "depth", "vc", "fz", "spindle", "feed",
                  "allow_collisions")
TOOL_TYPES = ("ball", "bull", "flat", "taper")


@dataclass
class JobOperation:
    """One operation of the job: ``index`` (1-based), ``name``, ``kind``, ``tool``, the kind's
    ``options`` (as typed), the cutting-data overrides (None: from the material table) and
    ``where`` (how messages name it)."""

    index: int
    name: str
    kind: OperationKind
    tool: ToolEntry
    options: dict
    depth: float | None = None
    vc: float | None = None
    fz: float | None = None
    spindle: float | None = None
    feed: float | None = None
    allow_collisions: bool = False
    where: str = ""


@dataclass
class Job:
    """A loaded, checked job file (module docstring)."""

    file: Path
    part: dict
    material: str | None
    blank: str
    resolution: float
    gouge_tolerance: float | None
    machine: Machine
    machine_name: str
    posts: tuple[str, ...]
    max_spindle: float | None
    tools: dict
    operations: list


# ------------------------------------------------------------------------------ loading
def _number(table, key, where, *, lo=None, lo_open=False, integer=False, default=None,
            required=False):
    if key not in table:
        if required:
            raise JobError(f"{where}: missing key {key!r}")
        return default
    v = table[key]
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
    if ok and integer:
        ok = float(v) == int(v)
    if ok and lo is not None:
        ok = v > lo if lo_open else v >= lo
    if not ok:
        what = "a whole number" if integer else "a number"
        bound = "" if lo is None else f" {'>' if lo_open else '≥'} {lo:g}"
        raise JobError(f"{where} key {key!r}: expected {what}{bound}, got {v!r}")
    return int(v) if integer else float(v)


def _string(table, key, where, *, default=None, required=False, choices=None):
    if key not in table:
        if required:
            raise JobError(f"{where}: missing key {key!r}")
        return default
    v = table[key]
    if not isinstance(v, str):
        raise JobError(f"{where} key {key!r}: expected text, got {v!r}")
    if choices is not None and v not in choices:
        raise JobError(f"{where} key {key!r}: unknown value {v!r}; use one of "
                       f"{', '.join(choices)}")
    return v


def _table(data, key, where, *, required=True) -> dict:
    if key not in data:
        if required:
            raise JobError(f"{where}: missing table [{key}]")
        return {}
    v = data[key]
    if not isinstance(v, dict):
        raise JobError(f"{where}: [{key}] must be a table")
    return v


def _path(base: Path, text: str) -> str:
    p = Path(os.path.expanduser(text))
    return os.fspath(p if p.is_absolute() else base / p)


def _tool(t: dict, k: int, where0: str) -> ToolEntry:
    where = f"{where0} tool {k + 1}"
    if not isinstance(t, dict):
        raise JobError(f"{where}: each [[tool]] must be a table")
    number = _number(t, "number", where, lo=0, integer=True, required=True)
    where = f"{where0} tool {k + 1} (T{number})"
    check_known_keys(t, TOOL_KEYS, where, JobError)
    kind = _string(t, "type", where, required=True, choices=TOOL_TYPES)
    d = _number(t, "diameter", where, lo=0.0, lo_open=True, required=True)
    cr = _number(t, "corner_radius", where, lo=0.0, default=0.0)
    if kind == "bull" and not 0.0 < cr < d / 2:
        raise JobError(f"{where} key 'corner_radius': a bull nose needs 0 < corner radius < "
                       f"half the diameter ({d / 2:g} mm), got {cr:g}")
    if kind != "bull" and "corner_radius" in t:
        raise JobError(f"{where} key 'corner_radius': only a bull nose has one (type = "
                       f"{kind!r})")
    taper = _number(t, "taper_angle", where, lo=0.0, lo_open=True)
    if taper is not None and kind != "taper":
        raise JobError(f"{where} key 'taper_angle': only a taper cutter has one")
    flutes = _number(t, "flutes", where, lo=1, integer=True, default=2)
    stick = _number(t, "stick_out", where, lo=0.0, lo_open=True)
    flute = _number(t, "flute_length", where, lo=0.0, lo_open=True)
    holder = None
    if "holder" in t:
        text = t["holder"]
        if isinstance(text, list):
            text = " ".join(str(x) for x in text)
        try:
            holder = holder_profile(str(text), "holder")
        except AssemblyError as exc:
            raise JobError(f"{where} key 'holder': {exc}") from None
    elif stick is not None:
        # a plain shank of the tool's diameter out to the stick-out, then the holder's nose
        fl = flute if flute is not None else min(3.0 * d, 0.8 * stick)
        if fl >= stick:
            raise JobError(f"{where} key 'stick_out': {stick:g} mm is not longer than the "
                           f"flute length {fl:g} mm")
        hd = _number(t, "holder_diameter", where, lo=0.0, lo_open=True,
                     default=max(2.5 * d, 20.0))
        holder = ((fl, d / 2), (stick, d / 2), (stick, hd / 2), (stick + 60.0, hd / 2))
        flute = fl
    coolant = _string(t, "coolant", where, default="flood", choices=("flood", "off"))
    try:
        Cutter.from_spec(kind, d / 2, cr if kind == "bull" else 0.0,
                         **({"taper_angle": math.radians(taper)} if taper else {}))
    except BliskCamError as exc:
        raise JobError(f"{where}: {exc}") from None
    return ToolEntry(number=number, type=kind, diameter=d, corner_radius=cr,
                     taper_angle=math.radians(taper) if taper else None, flutes=flutes,
                     stick_out=stick, flute_length=flute, holder=holder,
                     coolant=coolant == "flood",
                     max_spindle=_number(t, "max_spindle", where, lo=0.0, lo_open=True),
                     name=_string(t, "name", where, default=""))


def make_cutter(tool: ToolEntry) -> Cutter:
    """The :class:`..tool.cutter.Cutter` of a tool entry."""
    kw = {"taper_angle": tool.taper_angle} if tool.taper_angle else {}
    return Cutter.from_spec(tool.type, tool.diameter / 2,
                            tool.corner_radius if tool.type == "bull" else 0.0, **kw)


#: the job templates shipped with the package (``process --template NAME``)
TEMPLATES_DIR = Path(__file__).resolve().parents[2] / "jobs"


def job_template(name: str) -> Path:
    """The file of the shipped job template ``name``; JobError listing the known ones."""
    names = preset_names(TEMPLATES_DIR)
    if name not in names:
        raise JobError(f"unknown job template {name!r}; known: {', '.join(names)}")
    return TEMPLATES_DIR / f"{name}.toml"


def load_job(filename) -> Job:
    """Read and check a job file (module docstring); JobError naming the file, the operation
    and the key. The machine is loaded and the posts checked; the part is not built yet
    (:func:`build_part`)."""
    path = Path(os.fspath(filename)).expanduser()
    if not path.is_file():
        raise JobError(f"job file {filename} not found")
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise JobError(f"job {path.name} is not valid TOML: {exc}") from None
    return job_from_data(data, path)


def job_from_data(data: dict, path) -> Job:
    """Check a job given as the tables of a job file (``data``: what ``tomllib`` reads from
    one, module docstring) as if read from ``path`` (relative file names are taken from its
    folder; messages name it; the file need not exist): the job of :func:`load_job` without a
    file, e.g. from the Blender Operations panel. JobError naming the operation and the
    key."""
    path = Path(os.fspath(path)).expanduser()
    name = path.name
    if not isinstance(data, dict):
        raise JobError(f"job {name}: expected the tables of a job file")
    base = path.parent
    where = f"job {name}"
    check_known_keys(data, TOP_KEYS, where, JobError)
    part = dict(_table(data, "part", where))
    check_known_keys(part, PART_KEYS, f"{where} [part]", JobError)
    src = _string(part, "source", f"{where} [part]", required=True)
    if src != "demo":
        part["source"] = _path(base, src)
    elif "hub_profile" in part:
        raise JobError(f"{where} [part] key 'hub_profile': the demo has its own hub")
    if "hub_profile" in part:
        part["hub_profile"] = _path(base, _string(part, "hub_profile", f"{where} [part]"))
    _number(part, "blade_count", f"{where} [part]", lo=1, integer=True,
            required=src != "demo")
    demo = part.get("demo", {})
    if not isinstance(demo, dict):
        raise JobError(f"{where} [part] key 'demo': expected a table of demo parameters")
    if demo and src != "demo":
        raise JobError(f"{where} [part.demo]: demo parameters need source = \"demo\"")
    check_known_keys(demo, [f.name for f in fields(DemoParams)], f"{where} [part.demo]",
                     JobError)
    material = _string(part, "material", f"{where} [part]")
    if material is not None:
        try:
            material = material_key(material)
        except BliskCamError as exc:
            raise JobError(f"{where} [part] key 'material': {exc}") from None
    stock = _table(data, "stock", where)
    check_known_keys(stock, STOCK_KEYS, f"{where} [stock]", JobError)
    blank = _string(stock, "blank", f"{where} [stock]", required=True)
    kind, _, value = blank.partition(":")
    if not (kind in ("allowance", "envelope") and value):
        blank = _path(base, blank)
        if not os.path.isfile(blank):
            raise JobError(f"{where} [stock] key 'blank': file {blank} not found (or give "
                           "allowance:MM / envelope:MM)")
    else:
        try:
            float(value)
        except ValueError:
            raise JobError(f"{where} [stock] key 'blank': expected a number of mm after "
                           f"'{kind}:', got {value!r}") from None
    resolution = _number(stock, "resolution", f"{where} [stock]", lo=0.005, default=0.5)
    gouge = _number(stock, "gouge_tolerance", f"{where} [stock]", lo=0.0)
    mach = _table(data, "machine", where)
    check_known_keys(mach, MACHINE_KEYS, f"{where} [machine]", JobError)
    mname = _string(mach, "name", f"{where} [machine]", required=True)
    mfile = _path(base, mname) if mname.endswith(".toml") else mname
    try:
        machine = load_machine(mfile)
    except BliskCamError as exc:
        raise JobError(f"{where} [machine] key 'name': {exc}") from None
    posts = mach.get("posts", ["linuxcnc"])
    if isinstance(posts, str):
        posts = [posts]
    if not isinstance(posts, list) or not posts or not all(isinstance(p, str) for p in posts):
        raise JobError(f"{where} [machine] key 'posts': expected a list of post names")
    for p in posts:
        try:
            check_job_post(p)
            get_post(p).check(machine)  # a post the machine cannot run: before any work
        except BliskCamError as exc:
            raise JobError(f"{where} [machine] key 'posts': {exc}") from None
    max_spindle = _number(mach, "max_spindle", f"{where} [machine]", lo=0.0, lo_open=True)
    raw_tools = data.get("tool", [])
    if not isinstance(raw_tools, list) or not raw_tools:
        raise JobError(f"{where}: no [[tool]] table; give at least one tool")
    tools: dict[int, ToolEntry] = {}
    for k, t in enumerate(raw_tools):
        tool = _tool(t, k, where)
        if tool.number in tools:
            raise JobError(f"{where} tool {k + 1} key 'number': tool number T{tool.number} is "
                           "used twice; give every tool its own number")
        tools[tool.number] = tool
    raw_ops = data.get("operation", [])
    if not isinstance(raw_ops, list) or not raw_ops:
        raise JobError(f"{where}: no [[operation]] table; give at least one operation")
    ops = []
    for k, o in enumerate(raw_ops):
        w = f"{where} operation {k + 1}"
        if not isinstance(o, dict):
            raise JobError(f"{w}: each [[operation]] must be a table")
        oname = o.get("name", f"operation {k + 1}")
        if not isinstance(oname, str):
            raise JobError(f"{w} key 'name': expected text, got {oname!r}")
        w = f"{where} operation {k + 1} ({oname!r})"
        kname = _string(o, "kind", w, required=True)
        try:
            kind = operation_kind(kname, w)
        except BliskCamError as exc:
            raise JobError(str(exc)) from None
        check_known_keys(o, (*OPERATION_KEYS, *kind.options), w, JobError)
        tnum = _number(o, "tool", w, lo=0, integer=True, required=True)
        if tnum not in tools:
            raise JobError(f"{w} key 'tool': tool T{tnum} is not in the tool table (tools: "
                           f"{', '.join(f'T{n}' for n in tools)})")
        enabled = o.get("enabled", True)
        if not isinstance(enabled, bool):
            raise JobError(f"{w} key 'enabled': expected true or false, got {enabled!r}")
        allow = o.get("allow_collisions", False)
        if not isinstance(allow, bool):
            raise JobError(f"{w} key 'allow_collisions': expected true or false, got {allow!r}")
        if not enabled:
            continue
        op = JobOperation(
            index=k + 1, name=oname, kind=kind, tool=tools[tnum],
            options={key: v for key, v in o.items() if key in kind.options},
            depth=_number(o, "depth", w, lo=0.0, lo_open=True),
            vc=_number(o, "vc", w, lo=0.0, lo_open=True),
            fz=_number(o, "fz", w, lo=0.0, lo_open=True),
            spindle=_number(o, "spindle", w, lo=0.0, lo_open=True),
            feed=_number(o, "feed", w, lo=0.0, lo_open=True),
            allow_collisions=allow, where=w)
        if material is None and not ((op.vc and op.fz) or (op.spindle and op.feed)):
            raise JobError(f"{w}: no cutting data: give [part] material, or vc and fz (or "
                           "spindle and feed) in the operation")
        ops.append(op)
    if not ops:
        raise JobError(f"{where}: every operation is disabled; nothing to run")
    return Job(file=path, part=part, material=material, blank=blank, resolution=resolution,
               gouge_tolerance=gouge, machine=machine, machine_name=mname, posts=tuple(posts),
               max_spindle=max_spindle, tools=tools, operations=ops)


# ------------------------------------------------------------------------------ part, stock
def build_part(job: Job) -> BliskPart:
    """The job's part (demo, blade + hub profile, or whole-blisk mesh); the blade count
    checked. JobError naming the [part] key."""
    p = job.part
    where = f"job {job.file.name} [part]"
    count = p.get("blade_count")
    try:
        if p["source"] == "demo":
            d = make_demo_blisk(**p.get("demo", {}))
            if count is not None and count != d.blade_count:
                raise JobError(f"{where} key 'blade_count': the demo has {d.blade_count} blades "
                               f"(its parameter blade_count), the job says {count}")
            return part_from_demo(d)
        src = p["source"]
        if Path(src).suffix.lower() not in MESH_SUFFIXES or not os.path.isfile(src):
            raise JobError(f"{where} key 'source': {src} is not a mesh file "
                           f"({', '.join(MESH_SUFFIXES)}) or \"demo\"")
        V, F = read_mesh(src)
        if "hub_profile" in p:
            return part_from_blade(V, F, read_rz_csv(p["hub_profile"]), count)
        return split_blisk_mesh(V, F, count).part
    except JobError:
        raise
    except BliskCamError as exc:
        raise JobError(f"{where}: {exc}") from None


def build_stock(job: Job, part: BliskPart) -> RadialDexels:
    """The blank (``[stock] blank``, as ``simulate --stock``) at the job's resolution;
    StockError naming the job when it does not hold the part."""
    where = f"job {job.file.name} [stock] key 'blank'"
    try:
        dex = stock_from_spec(job.blank, part, job.resolution)
    except BliskCamError as exc:
        raise StockError(f"{where}: {exc}") from None
    if is_part_based(job.blank):
        return dex
    V, F, _ = part.part_mesh()
    N = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-300)
    inner = V[F].mean(axis=1) - 0.5 * dex.resolution * N  # just inside the metal
    held = dex.occupied(inner)
    share = 1.0 - float(held.mean()) if len(held) else 0.0
    if share > 0.02:
        raise StockError(f"{where}: the stock does not hold the part: {100 * share:.0f} % of the "
                         "part's surface lies outside it; give a larger blank")
    return dex


def stock_digest(dex: RadialDexels) -> str:
    """SHA-256 of a stock's state (grid and intervals): equal digests, equal stocks."""
    h = hashlib.sha256()
    h.update(np.array([dex.blade_count, dex.n_theta, dex.n_z], np.int64).tobytes())
    h.update(np.array([dex.theta0, dex.z0, dex.resolution, dex.r_max], np.float64).tobytes())
    h.update(np.ascontiguousarray(dex.lo).tobytes())
    h.update(np.ascontiguousarray(dex.hi).tobytes())
    return h.hexdigest()


# ------------------------------------------------------------------------------ the run
@dataclass
class OperationRun:
    """One operation's outcome: its ``path``, ``cutting`` data, the ``simulation`` (deviation
    map, summary, verdict) after it, the stock before and after (``stock_in`` / ``stock_out``:
    volume mm³ and digest), stage ``seconds``; ``stock``: the stock after it, valid only inside
    the ``on_operation`` callback (the next operation changes it)."""

    op: JobOperation
    path: object
    cutting: CuttingData
    simulation: object
    stock_in: dict
    stock_out: dict
    seconds: dict
    stock: object = None


@dataclass
class JobRun:
    """The job's outcome: the part, the initial stock figures, every operation's run and one
    program per post: ``programs[post] = (text, [SolvedSection], fk)`` with ``fk`` the
    forward-kinematics check ({operation index: {"max_tip_error_mm", "max_axis_error_deg",
    "poses", "rows_per_blade_ok"}})."""

    job: Job
    part: BliskPart
    stock_initial: dict
    operations: list = field(default_factory=list)
    programs: dict = field(default_factory=dict)
    #: the final verdict on the stock after the last operation (:mod:`.job_verdict`)
    verdict: object = None
    #: post → why its program was not written (the collision gate refused it); the rest of
    #: the job's outputs stand, so the user sees the poses to correct
    refused: dict = field(default_factory=dict)


def _measured_tilt(path) -> float:
    """Median angle (rad) between the tool axis and the surface normal over the cut poses."""
    angles = []
    for c in path.curves:
        cut = np.asarray(c.move) == MOVE_CUT if len(c.move) else np.ones(len(c.cc), bool)
        cosang = np.clip(np.einsum("ij,ij->i", c.axis[cut], c.normal[cut]), -1.0, 1.0)
        angles.append(np.arccos(cosang))
    allang = np.concatenate(angles) if angles else np.zeros(1)
    return float(np.median(allang)) if len(allang) else 0.0


def _prefixed(exc: BliskCamError, where: str) -> BliskCamError:
    """The same error class with ``where`` in front of the message (a BliskCamError when the
    class takes more than a message)."""
    msg = f"{where}: {exc}"
    try:
        return type(exc)(msg)
    except TypeError:
        return BliskCamError(msg)


def fk_check(machine: Machine, solved) -> dict:
    """Forward kinematics of every pose block of every solved section against its planned
    tip and axis, and whether every program row of the operation is there once per blade:
    {section number: figures} (module docstring of :class:`JobRun`)."""
    out = {}
    for k, s in enumerate(solved):
        full = s.blocks.expanded()
        pose = full.poses
        tip, ax = forward(machine, full.xyz[pose], full.angles[pose])
        err = float(np.linalg.norm(tip - full.tip[pose], axis=1).max())
        cosang = np.clip(np.einsum("ij,ij->i", ax, full.axis[pose]), -1.0, 1.0)
        n_rows = len(s.path.program)
        ok = all(np.array_equal(full.source[pose & (full.blade == b) & (full.source >= 0)],
                                np.arange(n_rows)) for b in range(full.blades))
        out[k + 1] = {"max_tip_error_mm": err,
                      "max_axis_error_deg": float(np.degrees(np.arccos(cosang)).max()),
                      "poses": int(pose.sum()), "rows_per_blade_ok": bool(ok)}
    return out


def final_verdict(job: Job, part: BliskPart, stock, runs, *, solid=None):
    """The job's final verdict (:func:`.job_verdict.job_verdict`) on ``stock`` (after the
    last operation) from the finishing operations among ``runs`` (a hub finishing that
    leaves a ``hub_allowance`` semi-finishes: its contacts finish nothing); the fillet named on the
    part up to its measured radius (else a fillet operation's ``fillet_radius``). ``solid``:
    the part cast on the stock's grid when the caller has it."""
    contacts = [OperationContacts.from_path(r.op.index, r.op.name, r.path, r.op.kind.name)
                for r in runs
                if r.op.kind.name in FINISHING_KINDS
                and not float(r.op.options.get("hub_allowance") or 0.0) > 0.0]
    measured = part_fillet(part)
    fr = measured.radius if measured is not None else next(
        (float(r.op.options["fillet_radius"]) for r in runs
         if "fillet_radius" in r.op.options), None)
    into = cut_into([r.path for r in runs])
    cut = max([c.chord for c in contacts] + ([] if into is None else [into]) + [0.0])
    return job_verdict(part, stock, contacts, resolution=job.resolution,
                       gouge_tolerance=job.gouge_tolerance, fillet_radius=fr, cut_depth=cut,
                       solid=solid)


#: the fine re-check of the rows near the stock (:mod:`..stock.fine_check`) runs at the
#: job's resolution divided by this
FINE_CHECK_FACTOR = 5.0
#: a finishing operation's retract and approach points are moved out along the tool axis
#: until the rapids beyond them clear the stock it starts on by this many of its cells
#: (:mod:`..stock.rapid_clearance`)
RAPID_STOCK_MARGIN = 2.0


def _fine_blank(job: Job, part: BliskPart) -> RadialDexels | None:
    """The blank at the fine re-check's resolution; None when it cannot be finer (a stock
    state .npz keeps its own grid)."""
    res = max(MIN_RESOLUTION, job.resolution / FINE_CHECK_FACTOR)
    if res >= job.resolution:
        return None
    dex = stock_from_spec(job.blank, part, res)
    return dex if dex.resolution < job.resolution else None


def _add_fine_crashes(sim, found) -> None:
    """Add the crashes the fine re-check ``found`` to the simulation ``sim`` (its removal,
    summary and verdict: a crash fails the operation)."""
    known = {(c.row, c.kind) for c in sim.removal.crashes}
    new = [c for c in found if (c.row, c.kind) not in known]
    if not new:
        return
    sim.removal.crashes = sorted(sim.removal.crashes + new, key=lambda c: (c.row, c.kind))
    sim.summary["crashes"] = [c.as_dict() for c in sim.removal.crashes]
    sim.summary["passed"] = False


def iter_run_job(job: Job, *, on_operation: Callable[[OperationRun], None] | None = None):
    """Generator: the job's run (module docstring); yields Progress, returns a
    :class:`JobRun`. ``on_operation(run)`` is called after each operation while its stock is
    current (to save it). Raises a BliskCamError naming the operation before long work where
    the job is bad."""
    yield Progress(0.0, "building the part")
    part = build_part(job)
    prepared = []
    for op in job.operations:  # every operation checked before the first one runs
        cutter = make_cutter(op.tool)
        ctx = OperationContext(part, cutter, op.tool, dict(op.options), None, op.where)
        prepared.append(op.kind.prepare(ctx))
        try:  # the body the stock simulation sweeps, checked before anything runs
            tool_assembly(op.tool, cutter)
        except BliskCamError as exc:
            raise JobError(f"{op.where} (tool T{op.tool.number}): {exc}") from None
    yield Progress(0.01, "building the stock")
    stock = build_stock(job, part)
    for op, prep in zip(job.operations, prepared, strict=True):
        if prep.precheck is None:
            continue
        yield Progress(0.015, f"checking operation {op.index} ({op.name})")
        try:  # does the tool fit the gap? (the part's geometry, the blank)
            prep.precheck(stock)
        except ToolError as exc:
            raise JobError(f"{op.where} key 'tool': tool T{op.tool.number}: {exc}") from None
        except BliskCamError as exc:
            raise _prefixed(exc, op.where) from None
    run = JobRun(job, part, {"volume_mm3": stock.volume(), "digest": stock_digest(stock)})
    n = len(job.operations)
    frame = part_on_grid(part, stock)  # what every operation's verdict judges against
    fine_blank = _fine_blank(job, part)
    fine = None if fine_blank is None else FineCheck(fine_blank, [])
    for k, op in enumerate(job.operations):
        lo, hi = 0.02 + 0.9 * k / n, 0.02 + 0.9 * (k + 1) / n
        label = f"operation {op.index} ({op.name})"
        cutter = make_cutter(op.tool)
        ctx = OperationContext(part, cutter, op.tool, dict(op.options), stock, op.where, fine)
        prep = op.kind.prepare(ctx)
        stock_in = {"volume_mm3": stock.volume(), "digest": stock_digest(stock)}
        try:
            result = yield from scaled_progress(
                iter_run_operation(prep.operation, prep.part_input, prep.request,
                                   stock if prep.reads_stock else None, extra=prep.extra),
                lo, lo + 0.5 * (hi - lo), label)
            path = result.path
            if path.program is None or len(path.program) == 0:
                raise BliskCamError("the operation planned no moves")
            t_clear = time.perf_counter()
            if op.kind.name != "rough":  # finishing: the rapids clear of the stock before it
                path.program, moved = clear_rapids(path.program, stock, cutter,
                                                   margin=RAPID_STOCK_MARGIN * job.resolution)
                path.stats.update({"rapids_lifted_clear_of_stock": moved["moved"],
                                   "rapids_lift_max_mm": moved["longest_lift_mm"],
                                   "rapids_still_meeting_stock": moved["still_meeting"]})
            clear_seconds = time.perf_counter() - t_clear
            near: list = []
            body = tool_assembly(op.tool, cutter)
            sim = yield from scaled_progress(
                iter_simulate(part, stock, [path], gouge_tolerance=job.gouge_tolerance,
                              assembly=body,
                              cut_into_part=cut_into([r.path for r in run.operations]),
                              near=near, frame=frame),
                lo + 0.5 * (hi - lo), hi, f"{label} on the stock")
            # the rapids and body rows that met material the stock's crash test let pass
            # (thinner than half a cell) judged again on a fine stock round them
            t_fine = time.perf_counter()
            if near and fine is not None:
                yield Progress(hi, f"{label}: re-checking {len(near)} rows near the stock at "
                               f"{fine.blank.resolution:g} mm")
                _add_fine_crashes(sim, fine.crashes(stock, path.program, cutter, body, near))
            if fine is not None:
                fine.history.append(RunProgram(path.program, cutter, body))
            near = []
            fine_seconds = time.perf_counter() - t_fine
            tilt = prep.tilt if prep.tilt is not None else _measured_tilt(path)
            depth = op.depth if op.depth is not None else op.kind.default_depth
            limits = [x for x in (op.tool.max_spindle, job.max_spindle) if x]
            cut = cutting_data(cutter, op.tool.flutes, job.material, depth, tilt, vc=op.vc,
                               fz=op.fz, spindle=op.spindle, feed=op.feed,
                               max_spindle=min(limits) if limits else None)
        except BliskCamError as exc:
            raise _prefixed(exc, op.where) from None
        orun = OperationRun(op, path, cut, sim, stock_in,
                            {"volume_mm3": stock.volume(), "digest": stock_digest(stock)},
                            {**result.seconds, "rapid_clearance": clear_seconds,
                             "fine_check": fine_seconds}, stock)
        if on_operation is not None:
            on_operation(orun)
        orun.stock = None
        run.operations.append(orun)
    yield Progress(0.92, "the final verdict on the stock")
    try:
        run.verdict = final_verdict(job, part, stock, run.operations, solid=frame.solid)
    except BliskCamError as exc:
        raise _prefixed(exc, f"job {job.file.name} final verdict") from None
    yield Progress(0.93, "writing the programs")
    sections = [JobSection(f"{r.op.name} [{r.op.kind.name}] T{r.op.tool.number}", r.path,
                           NcOptions(feed=r.cutting.feed, spindle=r.cutting.spindle,
                                     tool_number=r.op.tool.number, coolant=r.op.tool.coolant,
                                     blades=part.blade_count, blade_name=r.op.name,
                                     allow_collisions=r.op.allow_collisions))
                for r in run.operations]
    header = [f"job: {job.file.name}  material: {job.material or 'not given'}  blades: "
              f"{part.blade_count}"]
    for post in job.posts:
        try:
            text, solved = job_program(sections, job.machine, post, header=header)
        except CollisionGateError as exc:
            run.refused[post] = str(_prefixed(exc, f"job {job.file.name} post {post}"))
            continue
        except BliskCamError as exc:
            raise _prefixed(exc, f"job {job.file.name} post {post}") from None
        run.programs[post] = (text, solved, fk_check(job.machine, solved))
    yield Progress(1.0, "done")
    return run
