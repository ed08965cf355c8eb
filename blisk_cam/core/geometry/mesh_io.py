"""Mesh files → arrays, without Blender: binary and ASCII STL, Wavefront OBJ, PLY (ASCII and
binary). The batch command line reads the blade with these so that a path needs no bpy; the
sidebar reads the evaluated Blender mesh instead (``blender.objects.object_to_arrays``).

Units: the file's numbers are taken as millimetres. Polygons of OBJ and PLY are fanned into
triangles. Returns V (n, 3) float64 and F (m, 3) int64, unwelded where the format repeats
vertices (STL); :meth:`.mesh.TriMesh.from_arrays` welds.
"""

from __future__ import annotations

import mmap
import os
from pathlib import Path

import numpy as np

from ..errors import MeshError
from ..kernels import weld as compiled_weld
from .axis import meridional
from .mesh import TriMesh

__all__ = ["BLADE_RADIUS_MM", "MESH_SUFFIXES", "UNITS", "check_blade_size", "read_mesh",
           "read_mesh_for_weld", "read_stl_welded", "read_trimesh", "to_mm"]

#: mm per unit of a mesh file (``--units``)
UNITS = {"mm": 1.0, "m": 1000.0, "in": 25.4}
#: the outer radius a blisk blade has about its axis, mm (smallest fan/compressor blisks to
#: the largest): a mesh outside is in other units
BLADE_RADIUS_MM = (20.0, 3000.0)

MESH_SUFFIXES = (".stl", ".obj", ".ply")

#: vertices per block of :func:`check_blade_size`
_SIZE_CHECK_BLOCK = 1 << 15


def read_mesh(path) -> tuple[np.ndarray, np.ndarray]:
    """(V (n, 3) float64 mm, F (m, 3) int64) of a mesh file.

    Raises MeshError naming the file and the problem: missing, unreadable, an unknown
    suffix, no triangles, indices out of range, non-finite coordinates.
    """
    path = Path(os.fspath(path)).expanduser()
    suffix = path.suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise MeshError(f"{path}: unsupported mesh format '{suffix or '(none)'}'; use one of "
                        f"{', '.join(MESH_SUFFIXES)} (in mm)")
    if not path.is_file():
        raise MeshError(f"mesh file {path} not found")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise MeshError(f"cannot read mesh file {path}: {exc.strerror or exc}") from None
    try:
        reader = {".stl": _read_stl, ".obj": _read_obj, ".ply": _read_ply}[suffix]
        V, F = reader(raw)
    except MeshError as exc:
        raise MeshError(f"cannot read mesh file {path}: {exc}") from None
    except (ValueError, IndexError, KeyError, UnicodeDecodeError) as exc:
        raise MeshError(f"cannot read mesh file {path}: not a valid {suffix[1:].upper()} file "
                        f"({type(exc).__name__}: {exc})") from None
    V = np.ascontiguousarray(V, dtype=np.float64).reshape(-1, 3)
    F = np.ascontiguousarray(F, dtype=np.int64).reshape(-1, 3)
    if len(F) == 0:
        raise MeshError(f"mesh file {path} has no faces (no triangles): the blade must be a "
                        "surface mesh")
    if F.min() < 0 or F.max() >= len(V):
        raise MeshError(f"mesh file {path}: a face refers to a vertex that does not exist")
    if not np.isfinite(V).all() and not np.isfinite(V[np.unique(F)]).all():
        raise MeshError(f"mesh file {path} has NaN or infinite coordinates: repair the mesh")
    return V, F


def read_stl_welded(path):
    """A binary STL read and welded exactly in one compiled pass, straight from the file's
    bytes (mapped, not copied): (V (k, 3) float64 mm, F (m, 3) int64, the soup's corner count
    3m), where V holds the distinct corners in the order of their first appearance. This is
    what :func:`read_mesh` followed by the weld's exact pass makes of the file — V is the
    welded soup's vertices, F the soup's faces mapped onto them — without the float64 soup
    (3m, 3) and its maps: give the three to ``TriMesh.from_arrays(V, F,
    soup_corners=...)``, which then builds the mesh ``from_arrays(*read_mesh(path))`` builds.

    None when it does not apply: not a binary STL, the numpy kernels running, a NaN or
    infinite coordinate, a file that cannot be read; :func:`read_mesh` then reads the file
    (and names any problem).
    """
    path = Path(os.fspath(path)).expanduser()
    if path.suffix.lower() != ".stl":
        return None
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            head = fh.read(84)
            n = int.from_bytes(head[80:84], "little") if len(head) == 84 else 0
            if n == 0 or 84 + 50 * n != size:  # ASCII, empty or truncated: read_mesh's case
                return None
            with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mapped:
                records = np.frombuffer(mapped, dtype=np.uint8, offset=84)
                try:
                    got = compiled_weld.stl_corners_welded(records, n)
                finally:
                    del records  # the map closes only without views of it
    except (OSError, ValueError):
        return None
    if got is None:
        return None
    V, F = got
    return V, F, 3 * n


def read_mesh_for_weld(path, units: str = "mm"):
    """A mesh file's arrays ready for the weld: (V (n, 3) float64 mm, F (m, 3) int64,
    soup_corners int or None), to give to ``TriMesh.from_arrays(V, F,
    soup_corners=soup_corners)``. A binary STL is read and welded exactly as it is read
    (:func:`read_stl_welded`: the float64 soup, 3 corners a face, is never built) and
    ``soup_corners`` is its corner count 3m; any other file (or where that does not apply, or
    where ``units`` overflow a coordinate) is :func:`read_mesh`'s arrays with None. Either
    way ``from_arrays`` builds the same mesh. ``units``: the file's ("mm", "m", "in",
    :func:`to_mm`). Raises MeshError as :func:`read_mesh` and :func:`to_mm` do."""
    to_mm(np.zeros((0, 3)), units)  # unknown units: refused before the file is read
    welded = read_stl_welded(path)
    if welded is not None:
        V, F, corners = welded
        del welded  # (the tuple would hold the file's arrays)
        V = to_mm(V, units)
        if np.isfinite(V).all():  # else overflowed by the units: read_mesh's way names it
            return V, F, corners
    V, F = read_mesh(path)
    return to_mm(V, units), F, None


def read_trimesh(path, units: str = "mm"):
    """The :class:`.mesh.TriMesh` of a mesh file in ``units`` (welded and oriented, as
    ``TriMesh.from_arrays(to_mm(*read_mesh(path)))`` makes it), read by
    :func:`read_mesh_for_weld`: for a binary STL its ``vertex_map`` is None (there is no
    soup to map from). Raises MeshError naming the file and the problem."""
    V, F, corners = read_mesh_for_weld(path, units)
    return TriMesh.from_arrays(V, F, soup_corners=corners)


# ------------------------------------------------------------------------------- STL
def _read_stl(raw: bytes):
    if len(raw) >= 84:
        n = int(np.frombuffer(raw, dtype="<u4", count=1, offset=80)[0])
        if 84 + 50 * n == len(raw):
            rec = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
            data = np.frombuffer(raw, dtype=rec, count=n, offset=84)
            # widened straight from the records into the result (reshaping the strided
            # field first would copy it as float32 on the way)
            V = np.empty((3 * n, 3), dtype=np.float64)
            V.reshape(n, 3, 3)[...] = data["v"]
            return V, np.arange(len(V)).reshape(-1, 3)
    text = raw.decode("ascii", errors="strict")
    if not text.lstrip().lower().startswith("solid"):
        raise MeshError("neither a binary STL (size does not match its triangle count) nor an "
                        "ASCII STL (no 'solid' header)")
    words = text.split()
    vals = [words[i + 1: i + 4] for i, w in enumerate(words) if w.lower() == "vertex"]
    V = np.asarray(vals, dtype=np.float64).reshape(-1, 3)
    if len(V) % 3:
        raise MeshError(f"{len(V)} vertices is not a whole number of triangles")
    return V, np.arange(len(V)).reshape(-1, 3)


# ------------------------------------------------------------------------------- OBJ
def _fan(polys):
    """Triangles of polygons given as lists of vertex indices (fan from the first)."""
    tris = [(p[0], p[i], p[i + 1]) for p in polys for i in range(1, len(p) - 1)]
    return np.asarray(tris, dtype=np.int64).reshape(-1, 3)


def _read_obj(raw: bytes):
    verts, polys = [], []
    for line in raw.decode("utf-8", errors="replace").splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            verts.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            idx = []
            for token in parts[1:]:
                i = int(token.split("/")[0])
                idx.append(i - 1 if i > 0 else len(verts) + i)  # negative: relative
            if len(idx) >= 3:
                polys.append(idx)
    return np.asarray(verts, dtype=np.float64).reshape(-1, 3), _fan(polys)


# ------------------------------------------------------------------------------- PLY
_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def _read_ply(raw: bytes):
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise MeshError("no PLY header ('ply' … 'end_header')")
    header = raw[:end].decode("ascii").splitlines()
    body = raw[raw.index(b"\n", end) + 1:]
    fmt = next((h.split()[1] for h in header if h.startswith("format")), "ascii")
    elements = []  # [name, count, [(prop, type, list count type or None)]]
    for h in header:
        p = h.split()
        if not p:
            continue
        if p[0] == "element":
            elements.append([p[1], int(p[2]), []])
        elif p[0] == "property" and elements:
            if p[1] == "list":
                elements[-1][2].append((p[4], _PLY_TYPES[p[3]], _PLY_TYPES[p[2]]))
            else:
                elements[-1][2].append((p[2], _PLY_TYPES[p[1]], None))
    if fmt == "ascii":
        return _ply_ascii(body, elements)
    order = "<" if fmt == "binary_little_endian" else ">"
    return _ply_binary(body, elements, order)


def _ply_ascii(body: bytes, elements):
    tokens = body.decode("ascii").split()
    pos, V, polys = 0, None, []
    for name, count, props in elements:
        if name == "face":
            for _ in range(count):
                for prop, _t, list_t in props:
                    if list_t is None:
                        pos += 1
                        continue
                    k = int(tokens[pos])
                    values = [int(x) for x in tokens[pos + 1: pos + 1 + k]]
                    pos += 1 + k
                    if prop in ("vertex_indices", "vertex_index"):
                        polys.append(values)
        else:
            width = len(props)  # vertex and other scalar elements
            block = np.asarray(tokens[pos: pos + width * count], dtype=np.float64)
            pos += width * count
            if name == "vertex":
                names = [p[0] for p in props]
                block = block.reshape(count, width)
                V = block[:, [names.index(c) for c in ("x", "y", "z")]]
    if V is None:
        raise MeshError("no vertex element")
    return V, _fan(polys)


def _ply_binary(body: bytes, elements, order: str):
    pos, V, F = 0, None, None
    for name, count, props in elements:
        if all(list_t is None for _, _, list_t in props):
            dt = np.dtype([(p, order + t) for p, t, _ in props])
            block = np.frombuffer(body, dtype=dt, count=count, offset=pos)
            pos += dt.itemsize * count
            if name == "vertex":
                V = np.column_stack([block[c].astype(np.float64) for c in ("x", "y", "z")])
            continue
        # a face element: the common case of one list of equal-length polygons (triangles)
        if len(props) != 1:
            raise MeshError("face elements with more than one property are not supported; "
                            "export the mesh as STL or OBJ")
        _, t, list_t = props[0]
        k = int(np.frombuffer(body, dtype=order + list_t, count=1, offset=pos)[0])
        dt = np.dtype([("k", order + list_t), ("i", order + t, (k,))])
        block = np.frombuffer(body, dtype=dt, count=count, offset=pos)
        if np.any(block["k"] != k):
            raise MeshError("mixed polygon sizes in a binary PLY are not supported; "
                            "triangulate it or export as STL or OBJ")
        pos += dt.itemsize * count
        F = _fan(block["i"].astype(np.int64).tolist())
    if V is None or F is None:
        raise MeshError("no vertex or face element")
    return V, F


def to_mm(V, units: str = "mm") -> np.ndarray:
    """Vertices ``V`` (n, 3) given in ``units`` ("mm", "m", "in") scaled to mm."""
    key = str(units).strip().lower()
    if key not in UNITS:
        raise MeshError(f"unknown mesh units {units!r}; use one of {', '.join(UNITS)}")
    V = np.asarray(V, dtype=np.float64)
    return V if UNITS[key] == 1.0 else V * UNITS[key]


def check_blade_size(V, axis) -> None:
    """MeshError, with the size and the fix, when the mesh's outer radius about ``axis`` (a
    :class:`.axis.Axis`) is not that of a blisk blade in mm (:data:`BLADE_RADIUS_MM`): a file
    in metres or inches names ``--units m`` / ``--units in`` and what the radius would be."""
    V = np.asarray(V, dtype=np.float64)
    # in blocks that stay in the cache: the temporaries of 3M corners at once cost more in
    # fresh pages than the arithmetic (a block's NaN propagates as np.max's does)
    step = _SIZE_CHECK_BLOCK
    rmax = (float(np.max([np.max(meridional(V[s:s + step], axis)[0])
                          for s in range(0, len(V), step)])) if len(V) else 0.0)
    lo, hi = BLADE_RADIUS_MM
    if lo <= rmax <= hi:
        return
    fits = [(u, rmax * f) for u, f in UNITS.items() if u != "mm" and lo <= rmax * f <= hi]
    if fits:
        fix = " or ".join(f"--units {u} (outer radius {x:.4g} mm)" for u, x in fits)
        hint = f"is the file in other units? give {fix}"
    elif rmax > hi:
        hint = "is the file in µm, or is the axis wrong (--axis)?"
    else:
        hint = "is the axis right (--axis)?"
    raise MeshError(f"the mesh reaches {rmax:.3g} (file units) from the blisk axis, but a blisk "
                    f"blade lies {lo:g}-{hi:g} mm from it; {hint}")
