"""Orientation conventions of the robot controllers, both ways, vectorised.

* KUKA ``A B C`` and Fanuc ``W P R``: ``R = Rz(A) Ry(B) Rx(C)`` (Fanuc: ``R = Rz(R) Ry(P)
  Rx(W)``, so KUKA A30 B20 C10 is Fanuc W10 P20 R30);
* ABB quaternion ``[q1, q2, q3, q4]`` scalar first, normalised, q1 ≥ 0;
* Comau PDL2 Euler ``Z-Y-Z``: ``R = Rz(E1) Ry(E2) Rz(E3)``; at E2 = 0 or 180° (tool straight
  down or up: the representation singularity) only E1 ∓ E3 is defined, and E3 = 0 is written.

Angles radians (the posts print degrees); R (..., 3, 3).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "abc_from_matrix",
    "matrix_from_abc",
    "matrix_from_quaternion",
    "matrix_from_zyz",
    "quaternion_from_matrix",
    "zyz_from_matrix",
]

_SINGULAR = 1e-9  # |sin E2| or cos B below which the Euler angles are degenerate


def _rz(t):
    c, s = np.cos(t), np.sin(t)
    z, o = np.zeros_like(t), np.ones_like(t)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1),
                     np.stack([z, z, o], -1)], -2)


def _ry(t):
    c, s = np.cos(t), np.sin(t)
    z, o = np.zeros_like(t), np.ones_like(t)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1),
                     np.stack([-s, z, c], -1)], -2)


def _rx(t):
    c, s = np.cos(t), np.sin(t)
    z, o = np.zeros_like(t), np.ones_like(t)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1),
                     np.stack([z, s, c], -1)], -2)


def matrix_from_abc(a, b, c) -> np.ndarray:
    """(..., 3, 3) ``Rz(a) Ry(b) Rx(c)`` (KUKA A B C; Fanuc R P W)."""
    a, b, c = (np.asarray(x, dtype=np.float64) for x in (a, b, c))
    return _rz(a) @ _ry(b) @ _rx(c)


def abc_from_matrix(R) -> np.ndarray:
    """(..., 3) angles (A, B, C) with ``R = Rz(A) Ry(B) Rx(C)``, B in [−π/2, π/2]; at B = ±π/2
    (gimbal lock) C = 0."""
    R = np.asarray(R, dtype=np.float64)
    b = np.arcsin(np.clip(-R[..., 2, 0], -1.0, 1.0))
    cb = np.hypot(R[..., 0, 0], R[..., 1, 0])
    lock = cb < _SINGULAR
    a = np.where(lock, np.arctan2(-R[..., 0, 1], R[..., 1, 1]),
                 np.arctan2(R[..., 1, 0], R[..., 0, 0]))
    c = np.where(lock, 0.0, np.arctan2(R[..., 2, 1], R[..., 2, 2]))
    return np.stack([a, b, c], -1)


def matrix_from_zyz(e1, e2, e3) -> np.ndarray:
    """(..., 3, 3) ``Rz(e1) Ry(e2) Rz(e3)`` (Comau PDL2)."""
    e1, e2, e3 = (np.asarray(x, dtype=np.float64) for x in (e1, e2, e3))
    return _rz(e1) @ _ry(e2) @ _rz(e3)


def zyz_from_matrix(R) -> np.ndarray:
    """(..., 3) (E1, E2, E3) with ``R = Rz(E1) Ry(E2) Rz(E3)``, E2 in [0, π]. At the
    representation singularity (E2 = 0: tool up; E2 = π: tool straight down) E3 = 0 and E1
    carries the whole turn about z."""
    R = np.asarray(R, dtype=np.float64)
    s2 = np.hypot(R[..., 0, 2], R[..., 1, 2])
    e2 = np.arctan2(s2, R[..., 2, 2])
    lock = s2 < _SINGULAR
    # E2 = 0: R = Rz(E1 + E3); E2 = π: R = Rz(E1 − E3) Ry(π) → with E3 = 0, E1 from column x
    e1_lock = np.where(R[..., 2, 2] > 0, np.arctan2(R[..., 1, 0], R[..., 0, 0]),
                       np.arctan2(-R[..., 1, 0], -R[..., 0, 0]))
    e1 = np.where(lock, e1_lock, np.arctan2(R[..., 1, 2], R[..., 0, 2]))
    e3 = np.where(lock, 0.0, np.arctan2(R[..., 2, 1], -R[..., 2, 0]))
    return np.stack([e1, e2, e3], -1)


def quaternion_from_matrix(R) -> np.ndarray:
    """(..., 4) unit quaternion [w, x, y, z] (scalar first, w ≥ 0) of rotation matrices."""
    R = np.asarray(R, dtype=np.float64)
    m = R.reshape(-1, 3, 3)
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    # Shepperd: the largest of 4w², 4x², 4y², 4z² as the pivot
    d = np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], -1)
    k = np.argmax(d, axis=1)
    q = np.empty((len(m), 4))
    for i in range(4):
        s = k == i
        if not s.any():
            continue
        a = m[s]
        if i == 0:
            r = np.sqrt(1.0 + tr[s]) * 2.0
            q[s] = np.stack([0.25 * r, (a[:, 2, 1] - a[:, 1, 2]) / r,
                             (a[:, 0, 2] - a[:, 2, 0]) / r, (a[:, 1, 0] - a[:, 0, 1]) / r], -1)
        elif i == 1:
            r = np.sqrt(1.0 + a[:, 0, 0] - a[:, 1, 1] - a[:, 2, 2]) * 2.0
            q[s] = np.stack([(a[:, 2, 1] - a[:, 1, 2]) / r, 0.25 * r,
                             (a[:, 0, 1] + a[:, 1, 0]) / r, (a[:, 0, 2] + a[:, 2, 0]) / r], -1)
        elif i == 2:
            r = np.sqrt(1.0 + a[:, 1, 1] - a[:, 0, 0] - a[:, 2, 2]) * 2.0
            q[s] = np.stack([(a[:, 0, 2] - a[:, 2, 0]) / r, (a[:, 0, 1] + a[:, 1, 0]) / r,
                             0.25 * r, (a[:, 1, 2] + a[:, 2, 1]) / r], -1)
        else:
            r = np.sqrt(1.0 + a[:, 2, 2] - a[:, 0, 0] - a[:, 1, 1]) * 2.0
            q[s] = np.stack([(a[:, 1, 0] - a[:, 0, 1]) / r, (a[:, 0, 2] + a[:, 2, 0]) / r,
                             (a[:, 1, 2] + a[:, 2, 1]) / r, 0.25 * r], -1)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q = np.where(q[:, :1] < 0, -q, q)
    return q.reshape(R.shape[:-2] + (4,))


def matrix_from_quaternion(q) -> np.ndarray:
    """(..., 3, 3) rotation of quaternions [w, x, y, z] (normalised here)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)
