"""The operation kinds a job may name, and how each turns a job's operation into an
:class:`~.operation.Operation` run (paper 003 §5: roughing, semi-finishing, blade finishing,
hub and fillet finishing, each with its tool and options).

An operation kind is an :class:`OperationKind`: its ``name`` (the job file's ``kind``), the
``options`` it accepts (key → (default in the user's units, help); angles in degrees) and
``prepare(ctx) -> PreparedOperation``. ``prepare`` gets an :class:`OperationContext` (the part,
the cutter and tool entry, the operation's options as typed, the stock before it) and returns
the :class:`~.operation.Operation`, its part input and request, extra stages (a collision
check) and the tool's angle from the surface normal for the cutting data. It must do no long
work: the job calls it for every operation before the first one runs, with ``ctx.stock`` None,
to check the whole job before any path is planned, and again at run time with the stock.
Errors: a :class:`~..errors.BliskCamError`; the job prefixes the file, the operation and the
key.

A kind is made available by :func:`register_operation_kind` (this module registers blade
finishing, semi-finishing — blade finishing leaving an allowance — channel roughing, and hub
and fillet finishing). The kinds of the whole process that this build does not have
(:data:`PLANNED`) are refused with "operation kind '…' is not available in this build", never
skipped.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from ..channel.gaps import GAP_ORDERS
from ..channel.level_scallop import check_depth_options
from ..collision.options import CollisionOptions
from ..errors import BliskCamError, OptionError
from ..geometry.mesh import TriMesh
from ..geometry.vectors import rotate_about
from ..options import AxisOptions, GougeOptions, LinkingOptions, ToleranceOptions, check_value
from ..options import fields as option_fields
from ..part.cones import Cone
from .blade_finish import BLADE_FINISH, PathRequest
from .collision_stage import collision_stage
from .fillet_finish import FILLET_FINISH, part_fillet
from .hub_finish import HUB_FINISH, HubRequest, _stage_channel, start_state
from .operation import Operation, Stage
from .roughing import BODY_MEETS_STOCK, RoughingOperation, RoughRequest
from .semi_layers import layer_allowances

__all__ = ["OPERATION_KINDS", "PLANNED", "OperationContext", "OperationKind",
           "PreparedOperation", "ToolEntry", "narrowest_gap", "operation_kind",
           "register_operation_kind", "typed_options"]


@dataclass(frozen=True)
class ToolEntry:
    """One tool of the job's tool table (DIN 66215 shapes as the CLI's tool flags).

    number : int — T; type : "ball" | "bull" | "flat" | "taper"; diameter, corner_radius :
    mm; taper_angle : rad or None; flutes : int (z); stick_out : mm or None (length out of
    the holder); flute_length : mm or None; holder : ((z, r), ...) mm from the tip or None
    (the cutter's own shank and holder); coolant : bool; max_spindle : rpm or None; name :
    str (free text)."""

    number: int
    type: str
    diameter: float
    corner_radius: float = 0.0
    taper_angle: float | None = None
    flutes: int = 2
    stick_out: float | None = None
    flute_length: float | None = None
    holder: tuple | None = None
    coolant: bool = True
    max_spindle: float | None = None
    name: str = ""

    def cutter_options(self) -> dict:
        """PathRequest keywords of the cutter."""
        kw = {"tool_type": self.type, "tool_diameter": self.diameter}
        if self.type == "bull":
            kw["corner_radius"] = self.corner_radius
        if self.type == "taper" and self.taper_angle is not None:
            kw["taper_angle"] = self.taper_angle
        return kw


@dataclass
class OperationContext:
    """What ``prepare`` gets: ``part`` (:class:`..part.model.BliskPart`), ``cutter``
    (:class:`..tool.cutter.Cutter`), ``tool`` (:class:`ToolEntry`), ``options`` (the
    operation's own keys as typed in the job file, user units), ``stock`` (the
    :class:`..stock.dexels.RadialDexels` before the operation; None while the job is checked),
    ``where`` (e.g. "job blisk.toml operation 2 ('finish')"), ``fine_check`` (the job's
    :class:`..stock.fine_check.FineCheck`, for an operation that checks its program against
    the stock itself: roughing; None: none)."""

    part: object
    cutter: object
    tool: ToolEntry
    options: dict
    stock: object = None
    where: str = ""
    fine_check: object = None


@dataclass
class PreparedOperation:
    """``operation`` run as ``iter_run_operation(operation, part_input, request, stock,
    extra=extra)``; ``tilt`` (rad): the tool axis' angle from the surface normal for the
    effective cutting diameter, None: measured on the planned path (median over the cut
    poses); ``reads_stock``: the stock is passed to the operation; ``precheck(stock)``: see
    the field."""

    operation: Operation
    part_input: object
    request: object
    extra: tuple[Stage, ...] = ()
    tilt: float | None = None
    reads_stock: bool = False
    #: called once by the job with the initial stock, after every operation was prepared and
    #: before the first one runs: the checks that need the part's geometry or the stock (does
    #: the tool fit the gap?); raises a BliskCamError (a ToolError when the tool does not fit)
    precheck: Callable | None = None


@dataclass(frozen=True)
class OperationKind:
    """An operation kind of the job file (module docstring). ``options``: key → (default in
    user units or None, help); ``default_depth``: mm, the depth of cut ap the cutting data
    assume unless the operation gives ``depth``."""

    name: str
    title: str
    prepare: Callable[[OperationContext], PreparedOperation]
    options: dict = field(default_factory=dict)
    default_depth: float = 0.2


#: name → OperationKind, the kinds this build runs
OPERATION_KINDS: dict[str, OperationKind] = {}

#: kinds of the process (paper 003 §5) a job may name that this build may not have
PLANNED = ("rough", "semi_finish", "blade_finish", "hub_finish", "fillet_finish")


def register_operation_kind(kind: OperationKind) -> OperationKind:
    """Make ``kind`` available to jobs (a second kind of one name replaces the first)."""
    OPERATION_KINDS[kind.name] = kind
    return kind


def operation_kind(name, where: str = "job") -> OperationKind:
    """The registered kind ``name``; BliskCamError: a planned kind not in this build, or an
    unknown kind (with the nearest known name)."""
    if name in OPERATION_KINDS:
        return OPERATION_KINDS[name]
    if name in PLANNED:
        raise BliskCamError(f"{where}: operation kind {name!r} is not available in this build "
                            f"(available: {', '.join(OPERATION_KINDS)})")
    known = sorted(set(OPERATION_KINDS) | set(PLANNED))
    close = difflib.get_close_matches(str(name), known, n=1, cutoff=0.5)
    hint = f"did you mean {close[0]!r}? " if close else ""
    raise BliskCamError(f"{where}: unknown operation kind {name!r}; {hint}(kinds: "
                        f"{', '.join(known)})")


def typed_options(values: dict, groups, where: str) -> dict:
    """Values typed by a user for options of the option ``groups`` (user units: degrees,
    choices by their command-line word) → {name: core value}, each checked against its spec.
    BliskCamError naming ``where`` and the key."""
    specs = {name: spec for g in groups for name, spec, _ in option_fields(g)}
    out = {}
    for key, value in values.items():
        spec = specs[key]
        try:
            if spec.choices is not None:
                words = {c.cli_word: c.value for c in spec.choices}
                words.update({str(c.value): c.value for c in spec.choices})
                if isinstance(value, str) and value in words:
                    value = words[value]
                elif not any(value == c.value and type(value) is type(c.value)
                             for c in spec.choices):
                    raise OptionError(f"unknown value {value!r}; use one of "
                                      f"{', '.join(c.cli_word for c in spec.choices)}")
            elif isinstance(value, bool) or isinstance(value, str):
                raise OptionError(f"expected a number{' (' + spec.unit + ')' if spec.unit else ''}"
                                  f", got {value!r}")
            elif isinstance(value, list):
                value = tuple(float(v) for v in value)
                if spec.unit == "deg":
                    value = tuple(math.radians(v) for v in value)
            elif spec.unit == "deg":
                value = math.radians(float(value))
            out[key] = check_value(key, spec, value)
        except (OptionError, TypeError, ValueError) as exc:
            raise BliskCamError(f"{where} key {key!r}: {exc}") from None
    return out


# --------------------------------------------------------------------- blade finishing
_PATH_GROUPS = (ToleranceOptions, AxisOptions, GougeOptions, LinkingOptions)
_COLLISION_KEYS = {name for name, _, _ in option_fields(CollisionOptions)} - {
    "mode", "blade_count", "flute_length"}


def _blade_finish_options() -> dict:
    out = {"cone1": (None, "hub cone r1 z1 r2 z2 (mm); not given: fitted to the blade"),
           "cone2": (None, "tip cone r1 z1 r2 z2 (mm); not given: fitted to the blade"),
           "collisions": ("check", "off, check or avoid (holder and shank against the blade "
                                   "and its neighbours)")}
    for g in _PATH_GROUPS:
        for name, spec, default in option_fields(g):
            out[name] = (default, spec.help)
    for name, spec, default in option_fields(CollisionOptions):
        if name in _COLLISION_KEYS:
            out[name] = (default, spec.help)
    return out


def _cone(value, key: str, where: str):
    if value is None:
        return None
    try:
        return Cone.from_list([float(v) for v in value])
    except (BliskCamError, TypeError, ValueError) as exc:
        raise BliskCamError(f"{where} key {key!r}: expected [r1, z1, r2, z2] in mm ({exc})") \
            from None


def prepare_blade_finish(ctx: OperationContext) -> PreparedOperation:
    """Blade finishing (paper 001, :mod:`.blade_finish`) of blade 0 of the part with the
    operation's tolerances, tool axis, gouge fix and linking options; the collision check of
    the tool's holder against the blade and its neighbours (``collisions``, default check)."""
    opts = dict(ctx.options)
    where = ctx.where
    cone1 = _cone(opts.pop("cone1", None), "cone1", where)
    cone2 = _cone(opts.pop("cone2", None), "cone2", where)
    mode = opts.pop("collisions", "check")
    coll = {k: opts.pop(k) for k in list(opts) if k in _COLLISION_KEYS}
    path_kw = typed_options(opts, _PATH_GROUPS, where)
    coll_kw = typed_options(coll, (CollisionOptions,), where)
    try:
        req = PathRequest(ctx.part.axis, cone1, cone2, **ctx.tool.cutter_options(), **path_kw)
        layer_allowances(req.allowance, req.offset_from, req.offset_layers)  # up front
    except BliskCamError as exc:
        raise BliskCamError(f"{where}: {exc}") from None
    extra = ()
    if mode not in ("off", "check", "avoid"):
        raise BliskCamError(f"{where} key 'collisions': unknown value {mode!r}; use off, check "
                            "or avoid")
    if mode != "off":
        if ctx.part.blade_count < 2:
            raise BliskCamError(f"{where} key 'collisions': the part has one blade, there are no "
                                "neighbours to check against; set collisions = \"off\"")
        try:
            co = CollisionOptions(mode=mode, blade_count=ctx.part.blade_count,
                                  flute_length=ctx.tool.flute_length,
                                  **({"holder": ctx.tool.holder} if ctx.tool.holder else {}),
                                  **coll_kw)
            co.assembly(ctx.cutter)
        except BliskCamError as exc:
            raise BliskCamError(f"{where} (tool T{ctx.tool.number}): {exc}") from None
        extra = (collision_stage(co),)
    tilt = None
    if req.axis_mode == "local" and req.lead_tip is None and req.tilt_tip is None:
        tilt = math.acos(max(-1.0, min(1.0, math.cos(req.lead) * math.cos(req.tilt))))
    gap = narrowest_gap(ctx.part, cone1)
    if ctx.cutter.d >= gap:
        raise BliskCamError(
            f"{where} key 'tool': tool T{ctx.tool.number} (Ø{ctx.cutter.d:g}) does not fit the "
            f"gap between the blades: the narrowest gap above the hub cone is {gap:.1f} mm; "
            "choose a smaller tool")
    mesh = TriMesh.from_arrays(ctx.part.blade_vertices, ctx.part.blade_faces)
    return PreparedOperation(BLADE_FINISH, mesh, req, extra, tilt)


def narrowest_gap(part, cone1=None) -> float:
    """The narrowest gap (mm) between blade 0 and its neighbour (blade 0 turned by the pitch):
    the smallest distance from a vertex of one to a vertex of the other, over the vertices on
    or above the hub cone ``cone1`` (all vertices when None); inf for one blade. Vertex to
    vertex: at most the mesh's edge length above the surfaces' distance."""
    if part.blade_count < 2:
        return math.inf
    V = np.asarray(part.blade_vertices, float)
    if cone1 is not None and hasattr(cone1, "r1"):
        o, d = np.asarray(part.axis.o, float), np.asarray(part.axis.d, float)
        rel = V - o
        z = rel @ d
        r = np.linalg.norm(rel - z[:, None] * d, axis=1)
        t = (z - cone1.z1) / (cone1.z2 - cone1.z1) if cone1.z2 != cone1.z1 else 0.0
        keep = r >= cone1.r1 + t * (cone1.r2 - cone1.r1) - 1e-6
        V = V[keep] if keep.any() else V
    other = rotate_about(V, part.axis.d, part.pitch, part.axis.o)
    dist, _ = cKDTree(other).query(V)
    return float(dist.min())


register_operation_kind(OperationKind(
    "blade_finish", "blade finishing (LMC, paper 001)", prepare_blade_finish,
    _blade_finish_options(), default_depth=0.2))

__all__ += ["prepare_blade_finish"]


def tool_assembly(tool: ToolEntry, cutter):
    """The tool as the job's collision check and stock simulation see it: ``cutter``, the
    tool's flute length and holder profile (the cutter's own shank and holder when the tool
    table gives none)."""
    co = CollisionOptions(mode="check", blade_count=2, flute_length=tool.flute_length,
                          **({"holder": tool.holder} if tool.holder else {}))
    return co.assembly(cutter)


__all__ += ["tool_assembly"]


# ------------------------------------------------------------------------ semi-finishing
def prepare_semi_finish(ctx: OperationContext) -> PreparedOperation:
    """Semi-finishing (paper 003 §5: leaving 0.1 mm): blade finishing with a stock-to-leave
    ``allowance`` (default 0.1 mm, :mod:`.blade_finish`)."""
    opts = dict(ctx.options)
    opts.setdefault("allowance", 0.1)
    return prepare_blade_finish(OperationContext(ctx.part, ctx.cutter, ctx.tool, opts, ctx.stock,
                                                 ctx.where))


def _semi_finish_options() -> dict:
    out = _blade_finish_options()
    out["allowance"] = (0.1, "stock left on the blade, mm (paper 003: 0.1)")
    return out


register_operation_kind(OperationKind(
    "semi_finish", "semi-finishing (blade finishing leaving an allowance)", prepare_semi_finish,
    _semi_finish_options(), default_depth=0.4))
__all__ += ["prepare_semi_finish"]


# ------------------------------------------------------------------- hub and fillet finishing
#: job key → (default in user units, help, kind of value); lead and tilt in degrees
_HUB_KEYS = {
    "stepover": (None, "stepover between hub passes, mm (or scallop)", "mm"),
    "scallop": (None, "scallop height between hub passes, mm (or stepover)", "mm"),
    "ring_width": (0.0, "width of the ring beside each blade root with its own spacing, mm",
                   "mm"),
    "ring_stepover": (None, "the ring's stepover, mm (default: the main one)", "mm"),
    "ring_scallop": (None, "the ring's scallop height, mm", "mm"),
    "extend": (5.0, "passes extended past the leading and trailing edges, mm", "mm"),
    "lead": (10.0, "tool axis leaned from the hub normal along the feed, degrees", "deg"),
    "tilt": (0.0, "tool axis tilted across the feed, degrees", "deg"),
    "axis_mode": ("channel", "channel (aimed through the gap at the tips) or normal", "word"),
    "aim_spread": (0.3, "channel mode: spread of the aim across the tips' gap, 0 … 1", "num"),
    "allowance": (0.0, "distance kept from the blades (and stock left), mm", "mm"),
    "hub_allowance": (0.0, "stock left on the hub, mm (> 0: hub semi-finishing, its contacts "
                      "then finish nothing in the final verdict)", "mm"),
    "chord": (0.05, "chord tolerance, mm", "mm"),
    "approach": (2.0, "approach/retract along the tool axis, mm", "mm"),
    "clearance_margin": (10.0, "clearance cylinder outside the blade tips, mm", "mm"),
    "collisions": ("check", "check or off (shank and holder against both blades)", "word"),
    "safety": (1.0, "least clearance of shank and holder, mm", "mm"),
}
_FILLET_KEYS = {
    "fillet_radius": (None, "the fillet's radius, mm (default: measured on the part; the ball "
                            "must be smaller than the measured one)", "mm"),
    "layers": (1, "loops across the fillet (1: the lower edge only)", "int"),
    "scallop": (None, "layers across the fillet spaced for this scallop height between "
                      "neighbours, mm (instead of 'layers')", "mm"),
    "layers_top": (None, "with 'scallop': the highest layer's contact, mm above the hub "
                         "(default: the fillet's top; up the wall to where blade finishing "
                         "starts)", "mm"),
    "hub_rings": (0, "with 'scallop': loops of the ball on the hub round the blade root, "
                     "outward of the lower edge (behind the edges, where the hub passes end)",
                  "int"),
}


def _hub_request(ctx: OperationContext, keys: dict, **fixed):
    """The :class:`.hub_finish.HubRequest` of the job's operation (ball tools only)."""
    where = ctx.where
    if ctx.tool.type != "ball":
        raise BliskCamError(f"{where} key 'tool': hub and fillet finishing need a ball; tool "
                            f"T{ctx.tool.number} is a {ctx.tool.type}")
    kw = {}
    for key, value in ctx.options.items():
        _, _, kind = keys[key]
        try:
            if kind == "word":
                if not isinstance(value, str):
                    raise ValueError(f"expected a word, got {value!r}")
                kw[key] = value
            elif kind == "int":
                if isinstance(value, bool) or not isinstance(value, int):
                    raise ValueError(f"expected a whole number, got {value!r}")
                kw[key] = value
            else:
                if isinstance(value, (bool, str)):
                    raise ValueError(f"expected a number, got {value!r}")
                v = float(value)
                kw[key] = math.radians(v) if kind == "deg" else v
        except (TypeError, ValueError) as exc:
            raise BliskCamError(f"{where} key {key!r}: {exc}") from None
    try:
        req = HubRequest(tool_diameter=ctx.tool.diameter, flute_length=ctx.tool.flute_length,
                         holder=ctx.tool.holder, gaps="one", **kw, **fixed)
        req.check(spacing="fillet_radius" not in keys)
    except BliskCamError as exc:
        raise BliskCamError(f"{where}: {exc}") from None
    return req


def prepare_hub_finish(ctx: OperationContext) -> PreparedOperation:
    """Hub finishing (paper 003 §5, Fig. 10, :mod:`.hub_finish`) of the gap between blade 0
    and blade 1; the job's post repeats it for every gap."""
    req = _hub_request(ctx, _HUB_KEYS)
    return PreparedOperation(HUB_FINISH, ctx.part, req, (), None,
                             precheck=lambda stock: ball_fits_channel(ctx.part, req))


def ball_fits_channel(part, req: HubRequest) -> None:
    """ToolError unless the ball of ``req`` touching the hub keeps its allowance from both
    blades of the gap all along it (the hub channel's boundaries,
    :func:`..hub.channel.channel_boundaries`, traced alone)."""
    st = start_state(part, req, spacing=False)
    for _ in _stage_channel(st):
        pass


def prepare_fillet_finish(ctx: OperationContext) -> PreparedOperation:
    """Fillet finishing (paper 003 §5, :mod:`.fillet_finish`): the pass along the lower fillet
    edge (and layers across it) with a ball smaller than the fillet."""
    req = _hub_request(ctx, {**_HUB_KEYS, **_FILLET_KEYS})
    measured = part_fillet(ctx.part)
    tool = f"tool T{ctx.tool.number} (Ø{ctx.tool.diameter:g} ball, radius {req.radius:g} mm)"
    if measured is not None and not req.radius < measured.radius:
        raise BliskCamError(
            f"{ctx.where} key 'tool': {tool} is not smaller than the fillet measured on the "
            f"part: radius {measured.radius:.2f} mm (tightest {measured.tightest:.2f} mm, "
            f"{measured.height:g} mm high); use a ball of radius < {measured.radius:.2f} mm")
    if req.fillet_radius is None:
        if measured is None:
            raise BliskCamError(f"{ctx.where}: key 'fillet_radius' is missing and the part shows "
                                "no fillet at the blade root to measure: give the fillet's "
                                "radius (mm); the ball must be smaller")
        req = replace(req, fillet_radius=measured.radius)
    return PreparedOperation(FILLET_FINISH, ctx.part, req, (), None,
                             precheck=lambda stock: ball_fits_channel(ctx.part, req))



def _options_of(keys: dict, drop=()) -> dict:
    return {k: (d, h) for k, (d, h, _) in keys.items() if k not in drop}


register_operation_kind(OperationKind(
    "hub_finish", "hub finishing (paper 003, two regions)", prepare_hub_finish,
    _options_of(_HUB_KEYS), default_depth=0.2))
register_operation_kind(OperationKind(
    "fillet_finish", "fillet finishing (the lower fillet edge; layers across it by a scallop)",
    prepare_fillet_finish,
    _options_of({**_HUB_KEYS, **_FILLET_KEYS}, drop=("stepover", "ring_width",
                                                     "ring_stepover", "ring_scallop",
                                                     "hub_allowance")),
    default_depth=0.2))
__all__ += ["ball_fits_channel", "prepare_fillet_finish", "prepare_hub_finish"]


# ------------------------------------------------------------------------ channel roughing
#: job key → (default in user units, help, kind of value); lead and side tilt in degrees
_ROUGH_KEYS = {
    "stepover": (None, "largest step across the channel, mm (≤ the tool diameter)", "mm"),
    "depth_per_cut": (None, "largest step between levels, mm (or level_scallop)", "mm"),
    "level_scallop": (None, "instead of depth_per_cut: levels spaced so that the step cusp on "
                      "the blade walls is at most MM (from the walls' slope)", "mm"),
    "max_depth_per_cut": (None, "with level_scallop: the largest step between levels, mm "
                          "(default: the flute length)", "mm"),
    "levels": ("from-hub", "from-hub, from-shroud or morph", "word"),
    "pattern": ("zigzag", "zigzag, plunge or trochoid", "word"),
    "allowance": (0.5, "material left on the blades, mm (paper 003: 0.5)", "mm"),
    "hub_allowance": (None, "material left on the hub, mm (default: allowance)", "mm"),
    "lead": (0.0, "tool axis tilted from radial toward +z, degrees", "deg"),
    "side_tilt": (0.0, "tool axis tilted from radial toward +θ, degrees", "deg"),
    "axis": ("blades", "blades (leaning with the blades' mean camber surface) or radial",
             "word"),
    "max_turn": (2.0, "largest turn of the tool axis between consecutive cutting poses, "
                 "degrees", "deg"),
    "safety": (0.5, "the body's distance from the allowance shell, mm", "mm"),
    "station_step": (0.5, "pose spacing along the channel, mm", "mm"),
    "clearance": (5.0, "safe radius above the blank's top for rapids, mm", "mm"),
    "order": ("gap", "gap (every level of a gap, then the next gap) or level (a level in every "
              "gap, then the next level: the post interleaves the gaps)", "word"),
    "body_meets_stock": ("leave-out", "where the tool body would meet the stock the levels "
                         "above left: leave-out that stretch (named) or flag it as unresolved "
                         "collisions (the post refuses them unless allowed)", "word"),
    "floor_band_step": (0.5, "with axis = blades, rows of surface-driven passes on the blades' "
                        "allowance offset every MM from the hub to the level above (0: none)",
                        "mm"),
}


def prepare_rough(ctx: OperationContext) -> PreparedOperation:
    """Channel roughing (paper 003 §5, stage 1: slotting leaving 0.5 mm, :mod:`.roughing`)
    of the gap between blade 0 and blade 1 from the stock before it; the job's post repeats it
    for every gap. The tool's own body (tool table) is kept clear of the allowance."""
    where = ctx.where
    kw = {}
    for key, value in ctx.options.items():
        _, _, kind = _ROUGH_KEYS[key]
        if kind == "word":
            if not isinstance(value, str):
                raise BliskCamError(f"{where} key {key!r}: expected a word, got {value!r}")
            kw[key] = value
            continue
        if isinstance(value, (bool, str)) or not isinstance(value, (int, float)):
            raise BliskCamError(f"{where} key {key!r}: expected a number, got {value!r}")
        if kind == "mm" and not (math.isfinite(value) and value >= 0):
            raise BliskCamError(f"{where} key {key!r}: a length must be ≥ 0 mm, got {value!r}")
        kw[key] = math.radians(float(value)) if kind == "deg" else float(value)
    if "stepover" not in kw:
        raise BliskCamError(f"{where}: key 'stepover' is missing (mm)")
    if ("depth_per_cut" in kw) == ("level_scallop" in kw):
        raise BliskCamError(f"{where}: give one of the keys 'depth_per_cut' (constant steps, "
                            "mm) and 'level_scallop' (steps from the walls' slope, mm)")
    if kw.get("body_meets_stock", "leave-out") not in BODY_MEETS_STOCK:
        raise BliskCamError(f"{where} key 'body_meets_stock': one of "
                            f"{', '.join(BODY_MEETS_STOCK)}, got {kw['body_meets_stock']!r}")
    if kw.get("order", "gap") not in GAP_ORDERS:
        raise BliskCamError(f"{where} key 'order': order must be one of {', '.join(GAP_ORDERS)}"
                            f", got {kw['order']!r}")
    if "axis" in kw:
        axis = kw.pop("axis")
        if axis not in ("blades", "radial"):
            raise BliskCamError(f"{where} key 'axis': blades or radial, got {axis!r}")
        kw["follow_blades"] = axis == "blades"
    try:
        req = RoughRequest(tool=ctx.cutter, assembly=tool_assembly(ctx.tool, ctx.cutter),
                           fine_check=ctx.fine_check, **kw)
        check_depth_options(req, ctx.cutter)
    except (BliskCamError, TypeError, ValueError) as exc:
        raise BliskCamError(f"{where}: {exc}") from None
    return PreparedOperation(RoughingOperation(), ctx.part, req, (), 0.0, reads_stock=True,
                             precheck=lambda stock: RoughingOperation().start(ctx.part, req,
                                                                              stock))


register_operation_kind(OperationKind(
    "rough", "channel roughing (paper 003, stage 1)", prepare_rough,
    _options_of(_ROUGH_KEYS), default_depth=1.0))
__all__ += ["prepare_rough"]
