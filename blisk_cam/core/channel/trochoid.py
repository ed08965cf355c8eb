"""Trochoidal slotting on a level: loops across the channel stepped along it, then one pass
along each wall.

On a level the tip may take any θ between the two bounds lo(z) and hi(z) of :mod:`.region`
(flute, shank and holder keeping the allowance from both blades at every height). A
trochoidal pass moves the tip on loops: at the phase φ of a loop the fraction across the
channel is w = ½ (1 + cos φ) (φ = 0 on blade 1's side, π on blade 0's) and the station is
z = z_c + A sin φ, the loop's centre z_c advancing by ``advance`` mm per turn (φ over 2π) and
its axial half-width A the tool radius. Every point lies between the bounds of its station
(w ∈ [0, 1], z clipped to the run of reachable stations), so the whole tool keeps the
allowance wherever the zig-zag's would; the tool cuts on short arcs with a small engagement —
the advance bounds the chip — instead of a full-width slot (the trochoidal milling of narrow
slots in hard alloys: low radial force, the tool's full flute length in the cut).

Between the walls the loops leave nothing the tool's width does not cover: the two crossing
strokes of a loop lie 2A = D apart (D the diameter) and consecutive loops ``advance`` ≤ D
apart. At the walls a loop touches once per turn, which would leave cusps of
R − √(R² − (advance/2)²); one pass along each wall (the bounds themselves, as the zig-zag's
first and last) finishes them. The bounds are linear between stations; the region's margin
covers the envelope's sag there (:mod:`.region`). Units mm, radians.
"""

from __future__ import annotations

import math

import numpy as np

from .patterns import Piece, pass_pieces, runs_of

__all__ = ["trochoid_passes"]


def _loop_path(z0: float, z1: float, advance: float, half: float, forward: bool,
               width_mm: float, chord: float):
    """(z (k,), w (k,)) of the loops from ``z0`` to ``z1`` (the run's ends, mm) for
    ``forward`` toward +z: centres advancing ``advance`` mm per turn, the axial half-width
    ``half`` mm, every ≤ ``chord`` mm along a loop as wide as ``width_mm``."""
    span = z1 - z0
    turns = max(1.0, math.ceil(span / advance - 1e-9))
    # points per turn: the tip's speed along φ is at most √((a/2π + A)² + (width/2)²) (the
    # centre's advance a per turn, the loop's half-axes A and width / 2), so equal steps of
    # φ keep every move within the chord
    speed = math.hypot(span / (2 * math.pi * turns) + half, 0.5 * width_mm)
    n = max(12, int(math.ceil(2 * math.pi * speed / chord)))
    phi = np.linspace(0.0, 2 * math.pi * turns, int(n * turns) + 1)
    zc = z0 + (span / (2 * math.pi * turns)) * phi
    z = np.clip(zc + half * np.sin(phi), z0, z1)
    w = 0.5 * (1.0 + np.cos(phi))
    if not forward:
        z = z0 + z1 - z
    return z, w


def trochoid_passes(level: int, z, r, lo, hi, reach, outside, advance: float, frame,
                    forward: bool, half: float, chord: float = 0.5):
    """[Piece] of one level: per run of reachable stations the loops (module docstring) and
    then a pass along each wall (blade 0's bound, then blade 1's); ``z`` (n,) the stations
    (mm), ``r`` (n,) the tip radii, ``lo``, ``hi`` (n,) the bounds (rad), ``reach`` (n,) the
    reachable stations, ``outside`` (n,) those beyond the blank, ``advance`` the step of the
    loops along the channel (mm, the stepover), ``half`` the loops' axial half-width (mm, the
    tool radius), ``frame(theta, z, r)`` → (tips, axes). Returns (pieces, forward) for the
    next level to continue from."""
    z = np.asarray(z, float)
    pieces = []
    fwd = forward
    for a, b in runs_of(reach):
        if b - a < 2:
            continue
        seg = slice(a, b)
        width = float(np.max((hi[seg] - lo[seg]) * r[seg]))
        zz, w = _loop_path(float(z[a]), float(z[b - 1]), advance, half, fwd, width, chord)
        l_, h_ = np.interp(zz, z[seg], lo[seg]), np.interp(zz, z[seg], hi[seg])
        rr = np.interp(zz, z[seg], r[seg])
        tips, axes = frame(l_ + w * (h_ - l_), zz, rr)
        ends = (bool(outside[a if fwd else b - 1]), bool(outside[b - 1 if fwd else a]))
        pieces.append(Piece(tips, axes, level, ends))
        fwd = not fwd
    for bound in (lo, hi):  # along each wall, against the direction the loops ended
        tips, axes = frame(bound, z, r)
        pieces.extend(pass_pieces(level, tips, axes, reach, outside, fwd))
        fwd = not fwd
    return pieces, fwd
