"""The small vector kernels, one of each: row-wise dot products, unit vectors,
angles, slerp, rotations about an axis, the 2-D cross product. Arrays of
shape (..., 3) (or (..., 2) for :func:`cross2`), lengths in mm, angles in
radians.

Some kernels have a keyword that selects between arithmetic forms of the same
value (``slerp(..., weights_first=)``, ``rotation_matrix(..., form=)``,
``rotate_about(..., form=)``, ``rotate(..., scale_last=)``). The forms agree up
to rounding; each caller keeps the form it had, so the paths, verify reports and
NC programs stay bit for bit what they were.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["angle_between", "cross2", "dot", "perpendicular", "rotate", "rotate_about",
           "rotation_matrix", "slerp", "unit"]


# ================================================================== exact kernels
def dot(a, b):
    """Row-wise dot products.

    Parameters
    ----------
    a, b : (k, n) float

    Returns
    -------
    (k,) float — ``a[i] · b[i]`` (einsum; its bits differ from BLAS ``a @ b``)
    """
    return np.einsum("ij,ij->i", a, b)


def cross2(a, b):
    """2-D cross product (the z of the 3-D one).

    Parameters
    ----------
    a, b : (..., 2) float, broadcast — e.g. (r, z) points or directions in mm

    Returns
    -------
    (...,) float — ``a[0] b[1] − a[1] b[0]`` (mm² for two mm vectors); > 0 when b is
    counter-clockwise of a
    """
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def angle_between(a, b):
    """Angles between unit rows, accurate near 0 and π.

    Parameters
    ----------
    a, b : (k, 3) float, unit

    Returns
    -------
    (k,) float, radians in [0, π] — ``atan2(|a × b|, a · b)``
    """
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def unit(v, *, keep_zero=True):
    """Unit vectors along ``v`` (the direction kept, the length made 1).

    Parameters
    ----------
    v : (..., n) float (array or nested list), any length unit
    keep_zero : bool
        True (default): zero rows stay zero (``v / |v|`` with |v| = 0 replaced by 1), for
        callers that treat a zero vector as "no direction" (averaged normals, slerp rows).
        False: plain ``v / |v|``, zero rows become NaN (with numpy's invalid-value warning).
        The machine kinematics use it on the path's axes: a zero axis must fail there
        (``solve_poses`` turns the NaN axis into a ``ReachError`` naming the pose), where a
        zero vector would solve to some joint angles without a word. Collision avoidance and
        the block search keep the plain form they had (their rows are never zero).

    Returns
    -------
    (..., n) float — the same bits as ``v / np.linalg.norm(v, axis=-1, keepdims=True)``
    wherever |v| > 0
    """
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / (np.where(n > 0, n, 1.0) if keep_zero else n)


# ============================================================================ slerp
def perpendicular(a):
    """A unit vector perpendicular to each unit vector: ``a × X`` normalised, or ``a × Y``
    where ``a`` is within about 26° of X (|a_x| ≥ 0.9).

    Parameters
    ----------
    a : (3,) or (k, 3) float, unit

    Returns
    -------
    (3,) or (k, 3) float, unit, perpendicular to ``a`` row by row
    """
    a = np.asarray(a, dtype=np.float64)
    ref = np.where(np.abs(a[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    p = np.cross(a, ref)
    return p / np.linalg.norm(p, axis=-1, keepdims=True)


def slerp(a0, a1, t, *, weights_first=False):
    """Unit vectors on the great arcs from ``a0`` to ``a1`` at fractions ``t`` (uniform angle).

    ``v(t) = (sin((1 − t) Ω) a0 + sin(t Ω) a1) / sin Ω``, Ω the angle between a0 and a1,
    renormalised. Where sin Ω < 1e-9 the arc is degenerate: nearly equal vectors are
    interpolated linearly (then renormalised); nearly opposite ones turn through π in the
    plane of a0 and a fixed perpendicular (``cos(tπ) a0 + sin(tπ) p``, the same p for every
    row with the same a0).

    Parameters
    ----------
    a0, a1 : (k, 3) float, unit — one arc per row; or (3,) each — one arc for every t
        (the inputs are not renormalised: pass :func:`unit` rows)
    t : (k,) float — fractions, 0 → a0, 1 → a1
    weights_first : bool
        False (default): the sum of the weighted vectors is divided by sin Ω (the machine's
        interpolation and linking). True: each weight is divided by sin Ω first (the verify
        sweep). The same value up to rounding; each caller keeps its bits.

    Returns
    -------
    (k, 3) float, unit
    """
    a0 = np.asarray(a0, dtype=np.float64)
    a1 = np.asarray(a1, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)[:, None]
    pair = a0.ndim == 1
    # one pair: BLAS's dot (a @ b), as the pair form always had; rows: einsum
    c = np.clip(a0 @ a1 if pair else dot(a0, a1), -1.0, 1.0)
    om = np.arccos(c)
    so = np.sin(om)
    small = so < 1e-9
    om, sd = om[..., None], np.where(small, 1.0, so)[..., None]
    if weights_first:
        w0 = np.where(small[..., None], 1.0 - t, np.sin((1.0 - t) * om) / sd)
        w1 = np.where(small[..., None], t, np.sin(t * om) / sd)
        v = w0 * a0 + w1 * a1
    else:
        v = (np.sin((1 - t) * om) * a0 + np.sin(t * om) * a1) / sd
        if np.any(small):
            lin = (1 - t) * a0 + t * a1
            v = lin if pair else np.where(small[:, None], lin, v)
    anti = np.flatnonzero(small & (c < 0))
    if pair and len(anti):
        v = np.cos(t * math.pi) * a0 + np.sin(t * math.pi) * perpendicular(a0)
    elif len(anti):
        p = np.array([perpendicular(a0[i]) for i in anti]).reshape(-1, 3)
        ta = t[anti]
        v[anti] = np.cos(ta * math.pi) * a0[anti] + np.sin(ta * math.pi) * p
    return unit(v, keep_zero=False)


# ====================================================================== rotations
def rotation_matrix(axis, angle, *, form="square"):
    """Right-handed rotation matrices about a unit axis (Rodrigues).

    Parameters
    ----------
    axis : (3,) float, unit — the direction turned about (through the origin)
    angle : float or (n,) float, radians — right-handed about ``axis``
    form : {"square", "outer"}
        "square" (default): ``I + sin θ K + (1 − cos θ) K²`` (K the cross-product matrix of
        the axis; the NC blocks). "outer": ``cos θ I + sin θ K + (1 − cos θ) a aᵀ`` (the
        collision obstacles, the demo scene's neighbour blades). Equal up to rounding; each
        caller keeps its bits.

    Returns
    -------
    (3, 3) float for a scalar angle, (n, 3, 3) for (n,) angles — ``R @ v`` turns ``v``
    """
    k = np.asarray(axis, dtype=np.float64)
    t = np.asarray(angle, dtype=np.float64)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    s, c = np.sin(t)[..., None, None], np.cos(t)[..., None, None]
    if form == "outer":
        return c * np.eye(3) + s * K + (1.0 - c) * np.outer(k, k)
    if form != "square":
        raise ValueError(f"rotation_matrix: unknown form {form!r}")
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def rotate_about(points, direction, angle, origin=None, *, form="square"):
    """Points (or vectors) turned by one angle about a line.

    Parameters
    ----------
    points : (n, 3) float, mm (or vectors when ``origin`` is None)
    direction : (3,) float, unit — the line's direction
    angle : float, radians — right-handed about ``direction``
    origin : (3,) float, mm, or None — a point of the line; None turns about the origin
        without the shift (vectors: no ``+ 0`` to flip the sign of a zero)
    form : {"square", "outer", "coordinate"}
        "square", "outer": ``(points − origin) Rᵀ + origin`` with R of
        :func:`rotation_matrix` in that form. "coordinate": ``direction`` must be a
        coordinate axis e_i (the demo blisk's z); the two other coordinates are turned in
        their plane (``x' = c x − s y, y' = s x + c y`` for z) and the i-th is copied, exact
        on the axis (the demo blisk's blade copies keep those bits).

    Returns
    -------
    (n, 3) float
    """
    if form == "coordinate":
        d = np.asarray(direction, dtype=np.float64)
        nz = np.flatnonzero(d)
        if len(nz) != 1 or d[nz[0]] != 1.0:
            raise ValueError(f"rotate_about: {direction!r} is not a coordinate axis")
        a = int(nz[0])
        i, j = (a + 1) % 3, (a + 2) % 3
        V = np.asarray(points, dtype=np.float64)
        o = None if origin is None else np.asarray(origin, dtype=np.float64)
        if o is not None:
            V = V - o
        c, s = math.cos(angle), math.sin(angle)
        out = np.empty_like(V)
        out[:, i] = c * V[:, i] - s * V[:, j]
        out[:, j] = s * V[:, i] + c * V[:, j]
        out[:, a] = V[:, a]
        return out if o is None else out + o
    R = rotation_matrix(direction, angle, form=form)
    if origin is None:
        return np.asarray(points) @ R.T
    o = np.asarray(origin, dtype=np.float64)
    return (np.asarray(points, dtype=np.float64) - o) @ R.T + o


def rotate(v, axis, angle, *, scale_last=False):
    """Vectors turned about unit axes, one angle per row (Rodrigues).

    ``v cos θ + (k × v) sin θ + k (k · v)(1 − cos θ)``

    Parameters
    ----------
    v : (m, 3) float, or (3,) turned by every angle — the vectors (turned about the origin)
    axis : (3,) float, unit — one axis for every row; or (m, 3) unit rows (a zero row scales
        v by cos θ, harmless with θ = 0)
    angle : (m,) float, radians — right-handed about the axis
    scale_last : bool
        False (default): ``k ((k · v)(1 − cos θ))`` (the verify sweep). True:
        ``(k (k · v))(1 − cos θ)`` (the machine's rotaries). The same value up to rounding;
        each caller keeps its bits. k · v is BLAS's ``v @ k`` for one axis, einsum for rows.

    Returns
    -------
    (m, 3) float
    """
    k = np.asarray(axis, dtype=np.float64)
    t = np.asarray(angle, dtype=np.float64).reshape(-1)[:, None]
    c, s = np.cos(t), np.sin(t)
    if k.ndim == 1:
        v = np.broadcast_to(np.asarray(v, dtype=np.float64), (len(t), 3))
        kv = v @ k
    else:
        kv = dot(k, v)
    if scale_last:
        return v * c + np.cross(k, v) * s + k * kv[:, None] * (1 - c)
    return v * c + np.cross(k, v) * s + k * (kv[:, None] * (1.0 - c))
