"""The collision check as an extra stage of blade finishing (:mod:`.blade_finish`; the check
itself is :mod:`..collision.avoid`, paper 004): ``iter_plan_paths(mesh, req,
extra=(collision_stage(options, obstacles),))``.

A module of its own so that a plan without the check (the ``paths`` command's default, the
panel's Generate) does not import the collision package: ~0.05 s of every command-line run.
"""

from __future__ import annotations

from ..collision.avoid import iter_run_collisions
from ..runtime import Progress
from .blade_finish import PlanState
from .operation import Stage

__all__ = ["collision_stage"]


def collision_stage(options, obstacles=()) -> Stage:
    """The "collision" stage for ``iter_plan_paths(..., extra=(collision_stage(options,
    obstacles),))``: the planned passes and program are checked against the blade, its
    rotated neighbours and the ``obstacles`` ((name, V, F)), and corrected in mode "avoid".
    The report is ``PlanResult.collision``."""
    def run(st: PlanState):
        planned = st.result().path
        it = iter_run_collisions(st.mesh, planned, obstacles, options)
        while True:
            try:
                fraction = next(it)
            except StopIteration as stop:
                path, report = stop.value
                break
            yield Progress(float(fraction), "checking collisions")
        st.curves, st.program, st.collision = path.curves, path.program, report

    return Stage("collision", run)
