"""User options, declared once.

Every option a user can set — in the sidebar, on the command line or from Python — is one
field of a frozen *option group* dataclass (the cutter, the tolerances, the tool axis, the local
gouge limits, the linking; collision and NC add theirs). The field's metadata
(:class:`Spec`: label, help, unit, bounds, choices, command-line flag) is the only place where
the option is described. From it:

* :func:`check_group` validates the values with the same bounds for every front end (called
  by each group's ``__post_init__``);
* ``blisk_cam.properties`` generates the Blender properties (name = field name, in core units:
  an angle is a radian ``FloatProperty`` with subtype ANGLE, shown in degrees);
* ``blisk_cam.panels`` draws the rows (:func:`fields`, :attr:`Spec.show_if`);
* ``blisk_cam.cli`` generates the flags (angles in degrees there, converted here).

Adding an option is one edit (a field with its :func:`option`) plus its use.

Units: mm and radians in core; ``Spec.unit`` says what the user sees ("mm", "deg", "mm/min",
"rpm", "" for counts and words).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from .errors import LinkError, OptionError, OrientationError, ToleranceError, ToolError

__all__ = [
    "AXIS_MODE_CHOICES",
    "AxisOptions",
    "Choice",
    "CutterOptions",
    "GougeOptions",
    "LINK_CHOICES",
    "LinkingOptions",
    "OptionError",
    "PATH_OPTION_GROUPS",
    "Spec",
    "TOOL_CHOICES",
    "ToleranceOptions",
    "check_group",
    "describe_tool",
    "fields",
    "from_user",
    "option",
    "to_user",
]


@dataclass(frozen=True)
class Choice:
    """One value of a choice option: ``value`` in core, ``ident`` the Blender enum item
    (default ``value`` upper-cased), ``cli`` the command-line word (default ``value`` with
    '-' for '_')."""

    value: Any
    label: str
    help: str = ""
    ident: str | None = None
    cli: str | None = None

    @property
    def blender_id(self) -> str:
        return self.ident or str(self.value).upper()

    @property
    def cli_word(self) -> str:
        return self.cli or str(self.value).replace("_", "-")


@dataclass(frozen=True)
class Spec:
    """How an option is shown and checked (see the module docstring).

    label : str — panel label (Title Case)
    help : str — one sentence: the tooltip and the ``--help`` text
    unit : "mm" | "deg" | "mm/min" | "rpm" | "" — what the user types; "deg" options are
        radians in core and in the Blender property (subtype ANGLE), degrees on the CLI
    lo, hi : float or None — inclusive bounds in core units (radians for angles)
    lo_open, hi_open : bool — ``lo`` / ``hi`` itself is not allowed (> lo, < hi)
    soft_max : float or None — slider end in the panel (core units)
    choices : tuple of Choice or None — the allowed values
    flag : str or None — command-line flag ("" : derived from the name, None: no flag)
    none_as : value — an optional option (default None) is stored as this in Blender, where a
        property cannot be empty (e.g. 0.0 = automatic)
    show_if : (field, values) or None — the panel shows the row only when that other option
        of the group has one of these values
    precision : int — decimals shown in the panel
    size : int — numbers per value (3 for a point)
    prop : str or None — name of the Blender property when it differs from the field's
    blender : bool — False: the Blender side declares and draws it by hand (it needs more
        than one property, e.g. an optional hub → tip variation behind a toggle)
    """

    label: str
    help: str
    unit: str = ""
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    soft_max: float | None = None
    choices: tuple | None = None
    flag: str | None = ""
    none_as: Any = None
    show_if: tuple | None = None
    precision: int = 3
    size: int = 1
    blender: bool = True
    prop: str | None = None

    def prop_name(self, name: str) -> str:
        return self.prop or name

    def choice(self, value) -> Choice:
        """The :class:`Choice` of a core value (KeyError when it is none of them)."""
        for c in self.choices or ():
            if c.value == value:
                return c
        raise KeyError(value)

    def cli_flag(self, name: str) -> str | None:
        if self.flag is None:
            return None
        return self.flag or "--" + name.replace("_", "-")

    def bounds_text(self) -> str:
        """The bounds in user units, e.g. '> 0 mm', '0–89°'."""
        u = "°" if self.unit == "deg" else (f" {self.unit}" if self.unit else "")
        lo = None if self.lo is None else to_user(self, self.lo)
        hi = None if self.hi is None else to_user(self, self.hi)
        if lo is not None and hi is not None:
            return (f"{'>' if self.lo_open else '≥'} {lo:g}{u} and "
                    f"{'<' if self.hi_open else '≤'} {hi:g}{u}")
        if lo is not None:
            return f"{'>' if self.lo_open else '≥'} {lo:g}{u}"
        if hi is not None:
            return f"{'<' if self.hi_open else '≤'} {hi:g}{u}"
        return "any finite number"


def option(default, label: str, help: str, **spec) -> Any:
    """A dataclass field carrying its :class:`Spec` (``default`` in core units)."""
    return field(default=default, metadata={"spec": Spec(label=label, help=help, **spec)})


def fields(group) -> list[tuple[str, Spec, Any]]:
    """[(name, spec, default)] of the options of an option group class (or instance), in order."""
    out = []
    for f in dataclasses.fields(group):
        spec = f.metadata.get("spec")
        if spec is not None:
            out.append((f.name, spec, f.default))
    return out


def to_user(spec: Spec, value):
    """A core value in the unit the user types (degrees for angles)."""
    if value is None or spec.unit != "deg":
        return value
    return math.degrees(value)


def from_user(spec: Spec, value):
    """A value typed by the user in core units (radians for angles)."""
    if value is None or spec.unit != "deg":
        return value
    return math.radians(value)


def _who(name: str, spec: Spec) -> str:
    flag = spec.cli_flag(name)
    return f"{spec.label} ({flag})" if flag else spec.label


def check_value(name: str, spec: Spec, value, error=OptionError):
    """``value`` checked against ``spec``: OptionError naming the option, the value (in user
    units) and what is allowed. Returns the value (a bool/str/float as declared)."""
    if value is None:
        return None
    if spec.choices is not None:
        allowed = [c.value for c in spec.choices]
        if value not in allowed:
            words = ", ".join(c.cli_word for c in spec.choices)
            raise error(f"{_who(name, spec)}: unknown {spec.label.lower()} {value!r}; use one of "
                        f"{words}")
        return value
    if isinstance(value, bool) or isinstance(value, str):
        return value
    if isinstance(value, (tuple, list)):
        return tuple(check_value(name, spec, v, error) for v in value)
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise error(f"{_who(name, spec)}: expected a number, got {value!r}") from None
    shown = to_user(spec, x)
    unit = "°" if spec.unit == "deg" else (f" {spec.unit}" if spec.unit else "")
    if math.isnan(x):
        raise error(f"{_who(name, spec)}: the value is not a number (NaN)")
    if not math.isfinite(x):
        raise error(f"{_who(name, spec)}: expected a finite number, got {shown}")
    low_bad = spec.lo is not None and (x <= spec.lo if spec.lo_open else x < spec.lo - 1e-12)
    high_bad = spec.hi is not None and (x >= spec.hi if spec.hi_open else x > spec.hi + 1e-12)
    if low_bad or high_bad:
        raise error(
            f"{_who(name, spec)}: {shown:g}{unit} is out of range; the {spec.label.lower()} "
            f"must be {spec.bounds_text()}"
        )
    return value


def check_group(group) -> None:
    """Check every option of an option group against its spec (the group's ``error`` class,
    an :class:`OptionError` by default)."""
    error = getattr(group, "error", OptionError)
    for name, spec, _ in fields(group):
        check_value(name, spec, getattr(group, name), error)


class OptionGroup:
    """Mixin: options checked on construction; ``error`` is the exception class a bad value
    raises (the one the group's own module raises); ``title`` heads its group of flags and
    panel rows."""

    error = OptionError
    title = ""

    def __post_init__(self):
        check_group(self)


def _deg(x: float) -> float:
    return math.radians(x)


# ----------------------------------------------------------------------------- choices
TOOL_CHOICES = (
    Choice("ball", "Ball", "Ball-end mill: corner radius equals the tool radius"),
    Choice("bull", "Bull Nose", "Torus mill: flat bottom with a corner radius"),
    Choice("flat", "Flat", "Flat-end mill: corner radius 0"),
    Choice("taper", "Taper", "Tapered ball-end mill"),
)
LINK_CHOICES = (
    Choice("oneway", "One Way", "Every pass in the same direction, retract between passes",
           ident="ONE_WAY"),
    Choice("zigzag", "Zig-Zag", "Alternate the direction of successive passes"),
    Choice("spiral", "Spiral", "Blend successive passes into one continuous spiral"),
)
AXIS_MODE_CHOICES = (
    Choice("local", "Lead/Tilt",
           "Lead and tilt in the local frame (feed, normal, side) of each pose"),
    Choice("radial", "Radial", "Lead in the feed direction, then lean away from (> 0) or "
           "toward (< 0) the blisk axis by the radial tilt"),
    Choice("toward_line", "Toward Axis", "Tool axis through the blisk axis (toward it)",
           ident="TOWARD_AXIS", cli="toward-axis"),
    Choice("from_line", "Away from Axis", "Tool axis away from the blisk axis",
           ident="FROM_AXIS", cli="from-axis"),
    Choice("toward_point", "Toward Point", "Tool axis toward the fixed point"),
    Choice("from_point", "Away from Point", "Tool axis away from the fixed point"),
)


# ----------------------------------------------------------------------- option groups
@dataclass(frozen=True)
class CutterOptions(OptionGroup):
    """The cutter (DIN 66215 shapes, :mod:`.tool.cutter`). Sizes by diameter, as tools are named."""

    title = "Cutter (sized by diameter)"
    error = ToolError

    tool_type: str = option(
        "ball", "Tool", "Cutter shape: ball, bull (bull nose), flat or taper (tapered ball)",
        choices=TOOL_CHOICES, flag="--tool")
    tool_diameter: float = option(
        12.0, "Diameter", "Cutter diameter in mm (a 'Ø12 ball' is 12; the radius is half)",
        unit="mm", lo=0.0, lo_open=True, soft_max=100.0)
    corner_radius: float = option(
        2.0, "Corner Radius", "Corner radius of a bull-nose cutter in mm ('Ø12 R2' is 2)",
        unit="mm", lo=0.0, soft_max=50.0, show_if=("tool_type", ("bull",)))
    taper_angle: float = option(
        _deg(3.0), "Taper Angle", "Side angle of a tapered ball-end mill (half the cone "
        "angle), degrees", unit="deg", lo=0.0, lo_open=True, hi=_deg(60.0), hi_open=True,
        show_if=("tool_type", ("taper",)))

    def __post_init__(self):
        check_group(self)
        # a corner radius or taper angle means something for its own cutter only
        if self.tool_type != "bull":
            object.__setattr__(self, "corner_radius", 0.0)
        if self.tool_type != "taper":
            object.__setattr__(self, "taper_angle", None)

    @property
    def tool_radius(self) -> float:
        """Cutter radius d/2, mm."""
        return 0.5 * float(self.tool_diameter)

    def describe(self) -> str:
        """The tool as a machinist names it: 'Ø12 ball', 'Ø12 R2 bull nose', 'Ø10 flat',
        'Ø6 taper 3°'."""
        return describe_tool(self.tool_type, self.tool_diameter, self.corner_radius,
                             self.taper_angle)


def describe_tool(tool_type: str, diameter: float, corner_radius: float = 0.0,
                  taper_angle: float | None = None) -> str:
    """'Ø12 ball', 'Ø12 R2 bull nose', 'Ø10 flat', 'Ø6 taper 3°' (mm, radians in)."""
    d = f"Ø{float(diameter):g}"
    if tool_type == "bull":
        return f"{d} R{float(corner_radius):g} bull nose"
    if tool_type == "taper":
        angle = math.degrees(taper_angle) if taper_angle is not None else 3.0
        return f"{d} taper {angle:g}°"
    return f"{d} {tool_type}"


@dataclass(frozen=True)
class ToleranceOptions(OptionGroup):
    """Scallop (cusp) and chord tolerances and the stock to leave (allowance), mm."""

    title = "Tolerances (mm)"
    error = ToleranceError

    cusp: float = option(
        0.05, "Cusp", "Largest scallop height left between passes, mm",
        unit="mm", lo=1e-4, soft_max=1.0, precision=4)
    chord: float = option(
        0.05, "Chord", "Largest chord error along a pass (surface and tool path), mm",
        unit="mm", lo=1e-4, soft_max=1.0, precision=4)
    allowance: float = option(
        0.0, "Allowance", "Stock to leave on the blade, mm (semi-finishing: the passes "
        "machine the blade offset outward by this much; 0: finish to size)",
        unit="mm", lo=0.0, soft_max=2.0, precision=3)
    offset_layers: int = option(
        1, "Offset Layers", "Semi-finishing in depth: the blade offset from 'offset from' down "
        "to the allowance in this many equal steps, each a whole pass set (1: one layer at "
        "the allowance)", lo=1, soft_max=50)
    offset_from: float = option(
        0.5, "Offset From", "Stock on the blade before the offset layers (the roughing's "
        "allowance), mm; read with more than one layer", unit="mm", lo=0.0, soft_max=2.0,
        precision=3)


@dataclass(frozen=True)
class AxisOptions(OptionGroup):
    """How the tool axis is chosen (:mod:`.paths.orientation`): a = normalize(n + tan(lead) f +
    tan(tilt) k) with f the feed direction, n the surface normal and k = f × n; lead > 0
    leans the spindle forward toward the feed, tilt > 0 to the right of the feed."""

    title = ("Tool axis (angles in degrees; lead > 0 leans the spindle forward toward the "
             "feed, tilt > 0 to the right of the feed, seen with the normal up)")
    error = OrientationError

    axis_mode: str = option(
        "local", "Tool Axis", "How the tool axis is chosen: local lead/tilt, radial lean, "
        "or through the blisk axis or a point", choices=AXIS_MODE_CHOICES)
    lead: float = option(
        0.0, "Lead", "Lead angle: the axis tipped in the feed direction from the surface "
        "normal, degrees (a few degrees keep a ball off its zero-speed centre)", unit="deg",
        show_if=("axis_mode", ("local", "radial")))
    tilt: float = option(
        0.0, "Tilt", "Tilt angle: the axis leaned across the feed from the surface normal, "
        "degrees", unit="deg", show_if=("axis_mode", ("local",)))
    radial_tilt: float = option(
        0.0, "Radial Tilt", "Mode radial: lean of the tool axis away from (> 0) or toward "
        "(< 0) the blisk axis, degrees", unit="deg", show_if=("axis_mode", ("radial",)))
    lead_tip: float | None = option(
        None, "Lead at Tip", "Lead at the tip (cone 2): the lead varies linearly from the hub "
        "value to this, degrees", unit="deg", blender=False)
    tilt_tip: float | None = option(
        None, "Tilt at Tip", "Tilt at the tip (cone 2): the tilt varies linearly from the hub "
        "value to this, degrees", unit="deg", blender=False)
    axis_point: tuple | None = option(
        None, "Axis Point", "Modes toward/from point: the fixed point, mm", unit="mm", size=3,
        blender=False)
    axis_direction: tuple | None = None  # the fixed line's direction (modes *_line)
    max_axis_turn: float | None = option(
        None, "Max Axis Turn", "Smooth the tool axes so that consecutive poses turn by at most "
        "this angle, degrees (0: no smoothing)", unit="deg", lo=0.0, hi=_deg(89.0),
        none_as=0.0)


@dataclass(frozen=True)
class GougeOptions(OptionGroup):
    """Local gouge check and fix (:mod:`.paths.gouge`)."""

    title = "Local gouge fix"
    error = OrientationError

    fix_local_gouge: bool = option(
        True, "Fix Local Gouges", "Raise lead/tilt (up to the limits) where the cutter would "
        "gouge the surface next to the contact point (off: only flag those poses)",
        flag="--fix-gouge")
    gouge_max_lead: float = _deg(30.0)  # the fix raises |lead| at most to this, radians
    gouge_max_tilt: float = _deg(20.0)
    zero_speed_tol: float = 1e-3  # mm: contact this close to the axis is zero speed


@dataclass(frozen=True)
class LinkingOptions(OptionGroup):
    """Order of the passes and the moves between them (:mod:`.paths.linking`)."""

    title = "Linking"
    error = LinkError

    link: str = option(
        "oneway", "Link Mode", "Order of the passes: oneway, zigzag or spiral",
        choices=LINK_CHOICES, prop="link_mode")
    climb: bool = option(
        True, "Climb Milling", "Climb milling for a clockwise (M03) spindle (off: "
        "conventional milling)", flag="--milling",
        choices=(Choice(True, "Climb", cli="climb"),
                 Choice(False, "Conventional", cli="conventional")))
    approach: float = option(
        2.0, "Approach", "Approach and retract distance along the tool axis, mm",
        unit="mm", lo=0.0, lo_open=True, soft_max=50.0)
    clearance_radius: float | None = option(
        None, "Clearance Radius", "Radius of the clearance cylinder for rapid moves, mm "
        "(0 or not given: the passes' largest radius plus the clearance margin)",
        unit="mm", lo=0.0, soft_max=2000.0, none_as=0.0)
    clearance_margin: float = option(
        5.0, "Clearance Margin", "Margin of the automatic clearance radius above the "
        "passes, mm", unit="mm", lo=0.0, lo_open=True, soft_max=100.0)
    order: str = "hub_to_tip"  # or "tip_to_hub"
    clearance_z0: float = 0.0  # clearance cone: r(z) = radius + slope (z − z0), mm
    clearance_slope: float = 0.0
    direct_link: float | None = None  # mm; None: 2 × the tool radius


#: the option groups of a path request, in the order the panels and ``--help`` show them
PATH_OPTION_GROUPS = (CutterOptions, ToleranceOptions, AxisOptions, GougeOptions, LinkingOptions)
