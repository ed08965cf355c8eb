"""A semi-finishing path (stock left, ``ToolPath.allowance`` a > 0) as the checker measures it.

The path's cutter touches the blade offset outward by a; the checker has the blade only. It
does not build an offset mesh (an offset of a triangle mesh self-intersects at concave
places): it uses the identity of Minkowski sums instead. A point p lies at signed distance
δ from the volume swept by the cutter C exactly when it lies at δ − a from the volume swept
by C ⊕ B(a), the cutter grown by a (:meth:`..tool.cutter.Cutter.grown`), placed a lower on
the same axes (its corner circles are C's): the offset of a union is the union of the
offsets. So the path of the grown cutter, tips moved down their axes by a and CC points in
along their normals by a (onto the blade), measured on the blade by
:func:`.measure.verify_path`, gives every figure of the real path against the offset blade:

* material left on the blade = a + the measured material left;
* the depth of a cut below the offset blade (into the allowance) = the measured gouge;
* the links' depth into the allowance = the measured link gouge.

This is geometry, not the generator's code: a tip placed wrong by the generator is placed
wrong here too, and measured so. The verdict (:mod:`.verdict`) states the bounds with a:
material left ≤ a + cusp + chord, cut into the allowance ≤ chord (material left ≥ a − chord).
mm.
"""

from __future__ import annotations

import dataclasses

from ..tool.cutter import as_cutter
from ..toolpath.types import ToolPath

__all__ = ["as_measured_on_blade"]


def as_measured_on_blade(path: ToolPath) -> ToolPath:
    """The path of the cutter grown by ``path.allowance`` that sweeps the real path's volume
    grown by the allowance (see the module docstring); ``path`` itself when it leaves no
    stock. The input is not changed."""
    a = float(path.allowance or 0.0)
    if a <= 0.0:
        return path
    curves = [dataclasses.replace(c, cc=c.cc - a * c.normal, tip=c.tip - a * c.axis)
              for c in path.curves]
    program = path.program
    if program is not None:
        program = dataclasses.replace(program, tip=program.tip - a * program.axis)
    return dataclasses.replace(path, tool=as_cutter(path.tool).grown(a), curves=curves,
                               program=program, allowance=0.0)
