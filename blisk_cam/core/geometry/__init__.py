"""Geometry kernels every other core package builds on (floor 2: imports only ``errors``,
``runtime`` and numpy/scipy).

``vectors`` (the one dot, unit, angle, slerp, rotation, 2-D cross), ``axis`` (the blisk axis,
meridional and cylindrical coordinates, surfaces of revolution), ``mesh`` (TriMesh arrays:
adjacency, orientation, normals, boundaries), ``weld`` (triangle soup → indexed mesh: input
checks, weld, dropped faces, the edge table), ``mesh_io`` (STL, OBJ, PLY files), ``closest``
(exact closest points on segments and triangles), ``bvh`` (the cluster tree and its chunked
queries), ``distance`` (point → mesh distances). Lengths in mm.
"""
