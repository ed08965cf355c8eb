"""The small vector kernels, one of each: row-wise dot products, unit vectors,
angles, slerp, rotations about an axis, the 2-D cross product. Arrays of
shape (..., 3) (or (..., 2) for :func:`cross2`), lengths in mm, angles in
radians.
"""

from __future__ import annotations

import math

import numpy as np


# ================================================================== exact kernels
def dot(a, b):
    return np.einsum("ij,ij->i", a, b)


def cross2(a, b):
    """2-D cross product a × b of (..., 2) arrays."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def angle_between(a, b):
    """(k,) angles (rad) between unit rows, accurate near 0 (atan2 of |a × b| and a · b)."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


# ============================================================================ program
def slerp_pair(a, b, t):
    """Unit vectors between unit a (3,) and b (3,) at fractions t (k,)."""
    c = float(np.clip(a @ b, -1.0, 1.0))
    th = math.acos(c)
    t = np.asarray(t, dtype=np.float64)[:, None]
    if th < 1e-9:
        v = (1 - t) * a + t * b
    elif th > math.pi - 1e-9:
        p = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
        p /= np.linalg.norm(p)
        v = np.cos(t * math.pi) * a + np.sin(t * math.pi) * p
    else:
        v = (np.sin((1 - t) * th) * a + np.sin(t * th) * b) / math.sin(th)
    return v / np.linalg.norm(v, axis=1, keepdims=True)
