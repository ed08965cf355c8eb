"""Fillet finishing (paper 003 §5; issue 24 item 2): closed passes around the blade root
with a ball smaller than the fillet radius — the pass along the lower fillet edge, where the
fillet meets the hub, and optionally layers across the fillet up to the wall
(:mod:`..hub.fillet`), so that no ridge is left between blade finishing and hub finishing.

Stages over one :class:`~.hub_finish.HubState` (operation ``"fillet-finish"``): loops (the
layers' ball centres at their heights above the hub, ρ + allowance from the blade, the
contact points) → orient (``axis_mode`` "channel", the default: aimed through the blade tips'
gap on the loop's own side of the blade — to blade +1 or −1, blended around the edges — then
leaned by the lead along the feed, at least the lead off the hub normal; "normal": the hub
normal leaned by the lead and tilted away from the blade by the tilt; either way the ball never
cuts at its tip and the shank leans off the wall) → link → collision (as hub finishing:
holder and shank against blade 0 and its neighbours, the flute's clearance) → pattern (every
blade, on request) → checks.

The request is a :class:`~.hub_finish.HubRequest` with ``fillet_radius`` (required: the
ball must be smaller than it and than the fillet measured on the part, :func:`part_fillet`; a
ToolError names both radii) and ``layers``, or ``scallop`` (the layers spaced for that scallop
height between neighbours by the exact two-ball formula,
:func:`..hub.fillet.layer_heights_for_scallop`) up to ``layers_top`` mm above the hub (up the
wall to where blade finishing starts, so no band is left between them); its other spacing
fields are not used. On the demo blisk with a Ø6 ball and a Ø5 shank to 100 mm, the hub
normal tilted 20° off the wall left 6 poses with the shank in the leaning wall (tilt 5°–35°:
16–36); aimed through the channel, with 0° or 10° of tilt, none. Lengths mm, angles radians.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import BliskCamError, ToolError
from ..geometry.distance import MeshDistance
from ..geometry.mesh import TriMesh
from ..geometry.vectors import rotate_about, unit
from ..hub.channel import TipChannel
from ..hub.fillet import (
    check_fillet_ball,
    fillet_layers,
    layer_heights_for_scallop,
    measure_fillet,
)
from ..hub.surface import HubSurface, stepover_for_scallop
from ..part.model import BliskPart
from ..paths.orientation import feed_directions, lead_tilt_axes
from ..runtime import Progress
from ..toolpath.types import FLAG_ZERO_SPEED, PassCurve
from .hub_finish import (
    HubRequest,
    HubState,
    _at_least_lead,
    _body_radius,
    _stage_collision,
    _stage_link,
    _stage_pattern,
    start_state,
)
from .operation import Operation, OperationResult, Stage

__all__ = ["FILLET_FINISH", "FilletFinish", "part_fillet"]


def _stage_loops(st: HubState):
    req = st.req
    yield Progress(0.0, "fillet: tracing the fillet loops")
    heights, ring_step = None, 1.0
    if req.scallop is not None:
        heights, scallops = layer_heights_for_scallop(req.radius, float(req.fillet_radius),
                                                      req.scallop, req.layers_top)
        st.stats["scallop_estimate_mm"] = float(scallops.max()) if len(scallops) else 0.0
        # the rings on the hub: the flat two-ball stepover for the scallop
        ring_step = float(stepover_for_scallop(req.radius, req.scallop, np.zeros(1))[0])
    layers = fillet_layers(st.blade, st.hub, req.radius, float(req.fillet_radius),
                           layers=req.layers, allowance=req.allowance, chord=req.chord,
                           max_step=req.max_step, tool_name=req.tool_name, heights=heights,
                           hub_rings=req.hub_rings, ring_step=ring_step)
    st.curves = []
    for k, lay in enumerate(layers):
        c = PassCurve(s=float(lay.angle / (0.5 * math.pi)), closed=True, cc=lay.cc,
                      normal=lay.normal, tip=lay.cc.copy(), axis=lay.normal.copy())
        # for orient (not written)
        c.hub_normal, c.outward, c.centre = lay.hub_normal, lay.outward, lay.centre
        st.curves.append(c)
        yield Progress((k + 1) / len(layers), "fillet: loops")
    st.stats["layer_heights_mm"] = [float(lay.height) for lay in layers]
    st.stats["layer_angles_deg"] = [math.degrees(lay.angle) for lay in layers]


#: channel axis mode: the fillet's axis aims at this ratio across the tips' gap on its own
#: side of the blade (0: beside blade 0's tip, 0.5: the gap's middle)
FILLET_AIM = 0.35


def _channel_aims(st: HubState, c) -> np.ndarray:
    """(k, 3) unit directions from the ball centres of loop ``c`` through the blade tips' gap
    on each pose's own side of the blade (:class:`..hub.channel.TipChannel`: the gap to blade
    +1 where the loop faces +θ, the gap to blade −1 where it faces −θ, blended by the side's
    share around the leading and trailing edges), the shank radius + safety inside the tips."""
    req, part = st.req, st.part
    tips = TipChannel(st.blade, st.hub, part.pitch)
    margin = _body_radius(st) + req.safety
    z = (c.centre - part.axis.o) @ part.axis.d
    plus = tips.point(z, np.full(len(z), FILLET_AIM), margin)
    minus = rotate_about(tips.point(z, np.full(len(z), 1.0 - FILLET_AIM), margin),
                         part.axis.d, -part.pitch, part.axis.o)
    _, th, _ = st.hub.coordinates(c.centre)
    side = np.einsum("ij,ij->i", c.outward, st.hub.tangential(th))
    w = 0.5 + 0.5 * np.clip(side / 0.5, -1.0, 1.0)
    a_plus = unit(plus - c.centre)
    a_minus = unit(minus - c.centre)
    return unit(w[:, None] * a_plus + (1.0 - w)[:, None] * a_minus)


def _stage_orient(st: HubState):
    req = st.req
    for c in st.curves:
        n = c.hub_normal
        f = feed_directions(c.cc, n, True)
        k = np.cross(f, n)
        side = np.sign(np.einsum("ij,ij->i", k, c.outward))  # tilt away from the blade
        if req.axis_mode == "channel":  # aimed through the tips' gap, then lead and tilt
            a0 = _channel_aims(st, c)
            f0 = unit(f - np.einsum("ij,ij->i", f, a0)[:, None] * a0)
            k0 = np.cross(f0, a0)
            side0 = np.sign(np.einsum("ij,ij->i", k0, c.outward))
            c.axis = _at_least_lead(lead_tilt_axes(f0, a0, k0, req.lead, req.tilt * side0), n,
                                    f, abs(req.lead))
        else:
            c.axis = lead_tilt_axes(f, n, k, req.lead, req.tilt * side)
        c.tip = c.centre - req.radius * c.axis  # the ball: tip below the centre
        # the contact's distance from the axis, ρ sin∠(n, a): zero speed when ≈ 0
        cos = np.clip(np.einsum("ij,ij->i", c.normal, c.axis), -1.0, 1.0)
        c.flags = np.where((cos > 0) & (req.radius * np.sqrt(1.0 - cos * cos) <= 1e-3),
                           FLAG_ZERO_SPEED, 0).astype(np.uint8)
        del c.hub_normal, c.outward, c.centre
    return
    yield


def _stage_checks(st: HubState):
    req = st.req
    dist = MeshDistance(st.blade)
    n_layers = len(st.stats["layer_heights_mm"])
    first = st.curves[:n_layers]
    C = np.vstack([c.tip + req.radius * c.axis for c in first])
    d = dist.query(C).distance
    over = sum(int(np.count_nonzero(np.einsum("ij,ij->i", c.normal, c.axis) < 0.0))
               for c in first)
    _, _, h = st.hub.coordinates(C)
    zero = int(sum(int(np.count_nonzero(c.flags & FLAG_ZERO_SPEED)) for c in st.curves))
    st.stats.update({
        "operation": st.operation,
        "tool": req.tool_name,
        "fillet_radius_mm": float(req.fillet_radius),
        "layers": n_layers,
        "gaps": st.part.blade_count if req.gaps == "all" else 1,
        "curves": len(st.curves),
        "poses": int(sum(len(c.cc) for c in st.curves)),
        "clearance_blade0_min_mm": float(d.min() - req.radius),
        "centre_above_hub_min_mm": float(h.min()),
        "lead_deg": math.degrees(req.lead),
        "tilt_deg": math.degrees(req.tilt),
        "zero_speed_poses": zero,
        "contacts_above_equator": over,
    })
    if over:
        st.warnings.append(f"{over} poses touch the fillet above the ball's equator (the "
                           "contact normal more than 90° from the tool axis): the flute's "
                           "side would cut there; use fewer layers or more tilt")
    return
    yield


_FILLET_MEASURED: dict = {}


def part_fillet(part: BliskPart):
    """The hub fillet measured on ``part``'s blade mesh (:func:`..hub.fillet.measure_fillet`;
    None: no fillet), kept for the last part asked (a job prepares and runs each operation)."""
    key = id(part)
    if key not in _FILLET_MEASURED or _FILLET_MEASURED[key][0] is not part:
        _FILLET_MEASURED.clear()
        mesh = TriMesh.from_arrays(part.blade_vertices, part.blade_faces)
        _FILLET_MEASURED[key] = (part, measure_fillet(mesh, HubSurface(part.hub_profile,
                                                                       part.axis)))
    return _FILLET_MEASURED[key][1]


class FilletFinish(Operation):
    """Fillet finishing as an operation (see the module docstring)."""

    name = "fillet_finish"

    def start(self, part: BliskPart, request: HubRequest, stock=None) -> HubState:
        if request.fillet_radius is None:
            raise BliskCamError("fillet finishing needs the fillet radius (mm): the ball must "
                                "be smaller than it")
        if request.hub_allowance:
            raise BliskCamError(f"fillet finishing leaves no stock on the hub (hub allowance "
                                f"{request.hub_allowance:g} mm): semi-finish the hub with hub "
                                f"finishing, or set the hub allowance to 0")
        if not (isinstance(request.layers, int) and 1 <= request.layers <= 50):
            raise BliskCamError(f"fillet layers must be a whole number in 1 … 50, got "
                                f"{request.layers!r}")
        if request.scallop is not None and request.layers != 1:
            raise BliskCamError("fillet layers: give 'layers' or 'scallop' (the layers spaced "
                                "for it), not both")
        if not (isinstance(request.hub_rings, int) and 0 <= request.hub_rings <= 20):
            raise BliskCamError(f"fillet hub rings must be a whole number in 0 … 20, got "
                                f"{request.hub_rings!r}")
        if request.hub_rings and request.scallop is None:
            raise BliskCamError("fillet layers: 'hub_rings' needs 'scallop' (the rings spaced "
                                "for it)")
        if request.layers_top is not None and request.scallop is None:
            raise BliskCamError("fillet layers: 'layers_top' needs 'scallop' (the layers "
                                "spaced for it up to that height)")
        check_fillet_ball(request.radius, float(request.fillet_radius), request.tool_name)
        measured = part_fillet(part) if isinstance(part, BliskPart) else None
        if measured is not None and not request.radius < measured.radius:
            raise ToolError(f"fillet finishing needs a ball smaller than the fillet: the "
                            f"{request.tool_name} has radius {request.radius:g} mm, the fillet "
                            f"measured on the part {measured.radius:.2f} mm (tightest "
                            f"{measured.tightest:.2f} mm); use a ball of radius < "
                            f"{measured.radius:.2f} mm")
        st = start_state(part, request, spacing=False)
        st.operation = "fillet-finish"
        return st

    def stages(self, state: HubState) -> tuple[Stage, ...]:
        return (Stage("loops", _stage_loops), Stage("orient", _stage_orient),
                Stage("link", _stage_link), Stage("collision", _stage_collision),
                Stage("pattern", _stage_pattern), Stage("checks", _stage_checks))

    def finish(self, state: HubState, seconds: dict) -> OperationResult:
        return OperationResult(path=state.path())


#: the fillet finishing operation
FILLET_FINISH = FilletFinish()
