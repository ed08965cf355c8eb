"""Blisk CAM core: pure numpy/scipy geometry (no bpy, bmesh or mathutils).

Modules, one per concept of the papers (see ``shared/docs/ARCHITECTURE.md``):
``mesh`` (TriMesh arrays), ``cones`` (cones, linear morphing cones, morph field),
``slicing`` (mesh ∩ LMC), ``sampling`` (forward step), ``expansion`` (cusp height),
``verify`` (independent measurement), ``demo`` (parametric blisk), ``paths_io`` (JSON).
Import the submodules you need; this package imports nothing heavy on its own.
"""

from .errors import BliskCamError, ConeError, MeshError, ToleranceError

__all__ = ["BliskCamError", "ConeError", "MeshError", "ToleranceError"]
