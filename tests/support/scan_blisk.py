"""A scan-like whole blisk where every blade differs (a repaired blisk): the demo blisk with
blade k offset along its own normals by δ_k (mm, thicker or thinner, as after tip rebuilding
and blending) (optionally turned about the axis); hub ring and blades in one mesh, as a scan
arrives. Small and coarse so the per-blade tests stay cheap."""

from __future__ import annotations

import math

import numpy as np

from blisk_cam.core.geometry.vectors import rotate_about
from blisk_cam.core.part.blisk import make_demo_blisk

Z = np.array([0.0, 0.0, 1.0])


def vertex_normals(V, F):
    """(n, 3) area-weighted unit vertex normals (the blade's normals point out of the metal)."""
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    n = np.zeros_like(V)
    for j in range(3):
        np.add.at(n, F[:, j], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]


def worn_blisk(blade_count=4, resolution=0.12, offsets=None, turns_deg=None, broken=None):
    """(V, F, demo, blades): the whole scan (hub ring first, then blade 0..N−1 in order) and
    per blade k its own mesh ``blades[k] = (Vk, F)`` as built.

    offsets : (N,) mm along the blade's normals (default 0.04 + 0.04·k);
    turns_deg : (N,) extra turn about the axis, degrees (default none);
    broken : int or None — this blade gets a 1.5 mm deep, 2 mm wide notch across its
        mid-span (a scan fault tighter than the ball: the plan refuses it)."""
    d = make_demo_blisk(blade_count=blade_count, hub_pitches=blade_count, resolution=resolution)
    N = blade_count
    offsets = np.asarray(offsets if offsets is not None else 0.04 + 0.04 * np.arange(N), float)
    turns = np.asarray(turns_deg if turns_deg is not None else np.zeros(N), float)
    n0 = vertex_normals(d.blade_vertices, d.blade_faces)
    parts = [(d.hub_vertices, np.asarray(d.hub_faces, np.int64))]
    blades = []
    for k in range(N):
        V0 = d.blade_vertices + offsets[k] * n0
        if broken is not None and k == broken:
            r = np.hypot(V0[:, 0], V0[:, 1])
            mid = 0.5 * (r.min() + r.max())
            band = np.abs(r - mid) < 1.0
            V0 = V0.copy()
            V0[band] -= 1.5 * n0[band]
        Vk = rotate_about(V0, Z, k * d.pitch + math.radians(turns[k]), form="coordinate")
        blades.append((Vk, np.asarray(d.blade_faces, np.int64)))
        parts.append(blades[-1])
    offs = np.cumsum([0] + [len(V) for V, _ in parts[:-1]])
    V = np.concatenate([V for V, _ in parts])
    F = np.concatenate([F + o for (_, F), o in zip(parts, offs, strict=True)])
    return V, F, d, blades
