"""One entry point from user settings to a finished tool path: the request the panel, the
operators and the CLI all fill in, and the run that turns it into a :class:`ToolPath`.

Stages (each its own module, one concept of the papers each):
cone fitting (:mod:`.fitting`, when a cone is not given) → LMC passes of CC points
(:mod:`.pathgen`, paper 001) → tool axes from lead/tilt (:mod:`.orientation`, paper 003) →
cutter location per cutter type (:mod:`.cutter`, paper 003 Table I) → linking
(:mod:`.linking`, paper 002 for the spiral).

Angles are radians, lengths mm, as everywhere in core. ``iter_plan_paths`` yields
:class:`~.pathgen.Progress` and returns a :class:`PlanResult` (``StopIteration.value``) so a
modal operator can drive it and cancel between yields; ``plan_paths`` exhausts it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .cones import Axis, Cone
from .errors import BliskCamError
from .fitting import ConeFit, fit_cones_to_mesh
from .mesh import TriMesh
from .pathgen import iter_generate_paths
from .toolpath import ToolPath

__all__ = ["PathRequest", "PlanResult", "NotSupportedError", "iter_plan_paths", "plan_paths"]

TOOL_TYPES = ("ball", "bull", "flat", "taper")
LINK_MODES = ("oneway", "zigzag", "spiral")


class NotSupportedError(BliskCamError):
    """The request asks for something this version cannot do yet (names what, and the way out)."""


@dataclass(frozen=True)
class PathRequest:
    """Everything that decides a finishing path, in core units.

    Attributes
    ----------
    axis : Axis — the blisk axis
    cone1, cone2 : Cone or None — hub (s = 0) and tip (s = 1) cones; None = fit from the mesh
    tool_type : one of ``TOOL_TYPES``
    tool_radius : float, mm — cutter radius d/2
    corner_radius : float, mm — torus corner radius of a bull-nose cutter (0 otherwise)
    cusp, chord : float, mm — scallop height and chord error tolerances
    lead, tilt : float, radians — tool axis angles in the local (feed, normal, side) frame
    link : one of ``LINK_MODES``
    extra : dict — options of later stages (kept so the request stays one object)
    """

    axis: Axis
    cone1: Cone | None = None
    cone2: Cone | None = None
    tool_type: str = "ball"
    tool_radius: float = 6.0
    corner_radius: float = 0.0
    cusp: float = 0.05
    chord: float = 0.05
    lead: float = 0.0
    tilt: float = 0.0
    link: str = "oneway"
    extra: dict = field(default_factory=dict)


@dataclass
class PlanResult:
    """The path and, when a cone was fitted, the fit (for the residual report)."""

    path: ToolPath
    fit: ConeFit | None = None


def _check_supported(req: PathRequest) -> None:
    if req.tool_type not in TOOL_TYPES:
        raise BliskCamError(f"unknown tool type {req.tool_type!r}; use one of {', '.join(TOOL_TYPES)}")
    if req.link not in LINK_MODES:
        raise BliskCamError(f"unknown link mode {req.link!r}; use one of {', '.join(LINK_MODES)}")
    if req.tool_type != "ball":
        raise NotSupportedError(
            f"tool type {req.tool_type!r}: only the ball cutter is implemented so far; use ball"
        )
    if req.lead or req.tilt:
        raise NotSupportedError(
            "lead/tilt: the tool axis is the surface normal until orientation lands; use 0"
        )
    if req.link != "oneway":
        raise NotSupportedError(f"link mode {req.link!r}: only one-way is implemented so far")


def iter_plan_paths(mesh: TriMesh, req: PathRequest):
    """Generator: yields Progress, returns a :class:`PlanResult`."""
    _check_supported(req)
    fit = None
    c1, c2 = req.cone1, req.cone2
    if c1 is None or c2 is None:
        fit = fit_cones_to_mesh(mesh, req.axis)
        c1 = c1 or fit.cone1
        c2 = c2 or fit.cone2
    path = yield from iter_generate_paths(
        mesh, req.axis, c1, c2, tool_radius=req.tool_radius, cusp=req.cusp, chord=req.chord
    )
    return PlanResult(path=path, fit=fit)


def plan_paths(mesh: TriMesh, req: PathRequest) -> PlanResult:
    """Run :func:`iter_plan_paths` to the end."""
    it = iter_plan_paths(mesh, req)
    while True:
        try:
            next(it)
        except StopIteration as stop:
            return stop.value
