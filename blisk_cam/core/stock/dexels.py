"""Radial dexels of one pitch sector: the stock as material intervals along rays from the axis.

The sector [θ0, θ0 + 2π/N) about the blisk axis is gridded over (θ, z): cell (i, j) has its
ray at θ_i = θ0 + (i + ½) Δθ, height z_j = z0 + (j + ½) Δz, running from the axis outward
(r ≥ 0). A ray holds up to K sorted disjoint intervals [lo, hi) of r (mm) that are material;
an unused slot has lo = hi = 0. A ray stands for its cell: the volume of an interval is
Δθ Δz (hi² − lo²)/2, exact in r. Δθ is chosen so that the arc at the stock's largest radius
is at most the resolution (finer inside), Δz is the resolution.

The blisk is periodic: one sector holds everything (memory and time fall by N); a point at
any angle is wrapped into the sector (θ − θ0 mod 2π/N).

The one kernel that changes intervals is :func:`subtract_intervals` (vectorised over rays;
the compiled kernel can replace it one for one).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..errors import StockError
from ..files import atomic_output
from ..geometry.axis import Axis

__all__ = ["RadialDexels", "merge_intervals", "subtract_intervals"]

TWO_PI = 2.0 * math.pi
#: resolution bounds, mm
MIN_RESOLUTION, MAX_RESOLUTION = 0.005, 10.0
#: r quantum of the interval merge, mm
_R_QUANTUM = 1e-7


def subtract_intervals(lo, hi, rays, a, b):
    """Remove [a_k, b_k) from ray ``rays[k]``'s material, in place.

    Parameters
    ----------
    lo, hi : (n_rays, K) float, mm — the material intervals (modified; may be returned grown)
    rays : (k,) int — distinct ray indices
    a, b : (k,) float, mm — the removed interval of each

    Returns
    -------
    lo, hi : the arrays (new ones when a ray needed more than K intervals)
    removed : (k,) float, mm² — Σ (hi² − lo²)/2 removed from each ray (× Δθ Δz = volume)
    """
    L, H = lo[rays], hi[rays]
    a = a[:, None]
    b = b[:, None]
    full = H > L
    lh = np.minimum(H, a)
    rl = np.maximum(L, b)
    keep_l = full & (lh > L)
    keep_r = full & (H > rl)
    before = np.where(full, H * H - L * L, 0.0).sum(axis=1)
    after = (np.where(keep_l, lh * lh - L * L, 0.0) + np.where(keep_r, H * H - rl * rl, 0.0)
             ).sum(axis=1)
    removed = 0.5 * (before - after)
    cand_lo = np.concatenate([np.where(keep_l, L, np.inf), np.where(keep_r, rl, np.inf)], 1)
    cand_hi = np.concatenate([np.where(keep_l, lh, np.inf), np.where(keep_r, H, np.inf)], 1)
    order = np.argsort(cand_lo, axis=1, kind="stable")
    cand_lo = np.take_along_axis(cand_lo, order, 1)
    cand_hi = np.take_along_axis(cand_hi, order, 1)
    count = np.isfinite(cand_lo).sum(axis=1)
    need = int(count.max()) if len(count) else 0
    K = lo.shape[1]
    if need > K:
        grow = need - K
        lo = np.hstack([lo, np.zeros((len(lo), grow))])
        hi = np.hstack([hi, np.zeros((len(hi), grow))])
        K = need
    width = min(K, cand_lo.shape[1])
    new_lo = np.zeros((len(rays), K))
    new_hi = np.zeros((len(rays), K))
    cl, ch = cand_lo[:, :width], cand_hi[:, :width]
    ok = np.isfinite(cl)
    new_lo[:, :width] = np.where(ok, cl, 0.0)
    new_hi[:, :width] = np.where(ok, ch, 0.0)
    lo[rays] = new_lo
    hi[rays] = new_hi
    return lo, hi, removed


def merge_intervals(rays, a, b):
    """Union of intervals per ray: (rays, a, b, rank) of disjoint intervals sorted by ray and
    a; ``rank`` is the interval's number within its ray (0, 1, ...). Empty input → empty."""
    keep = b > a
    rays, a, b = rays[keep], a[keep], b[keep]
    if len(rays) == 0:
        z = np.zeros(0)
        return rays, z, z, np.zeros(0, np.int64)
    order = np.lexsort((a, rays))
    rays, a, b = rays[order], a[order], b[order]
    # segmented running max of b: the ray index dominates the integer key
    bq = np.round(b / _R_QUANTUM).astype(np.int64)
    aq = np.round(a / _R_QUANTUM).astype(np.int64)
    base = rays.astype(np.int64) << 34
    run = np.maximum.accumulate(base + bq)
    prev = np.concatenate([[-1], run[:-1]])
    start = np.ones(len(a), bool)
    start[1:] = (rays[1:] != rays[:-1]) | (base[1:] + aq[1:] > prev[1:])
    idx = np.nonzero(start)[0]
    m_rays, m_a = rays[idx], a[idx]
    m_b = np.maximum.reduceat(b, idx)
    first = np.ones(len(idx), bool)
    first[1:] = m_rays[1:] != m_rays[:-1]
    grp = np.cumsum(first) - 1
    rank = np.arange(len(idx)) - np.nonzero(first)[0][grp]
    return m_rays, m_a, m_b, rank


@dataclass
class RadialDexels:
    """The stock of one pitch sector (module docstring).

    Attributes
    ----------
    axis : Axis
    blade_count : int — N; the sector spans 2π/N
    theta0 : float, rad — start of the sector (θ of :meth:`Axis.angular_frame`)
    z0 : float, mm — bottom of the grid
    n_theta, n_z : int — cells
    resolution : float, mm — Δz, and the arc Δθ · r_max
    r_max : float, mm — the largest radius the grid was sized for
    lo, hi : (n_z · n_theta, K) float, mm — material intervals of each ray (row j · n_theta + i)
    """

    axis: Axis
    blade_count: int
    theta0: float
    z0: float
    n_theta: int
    n_z: int
    resolution: float
    r_max: float
    lo: np.ndarray
    hi: np.ndarray

    # ------------------------------------------------------------------ construction
    @classmethod
    def empty(cls, axis: Axis, blade_count: int, theta0: float, z_range, r_max: float,
              resolution: float, K: int = 2) -> RadialDexels:
        """An empty grid over the sector, ``z_range`` (mm) and radii up to ``r_max``."""
        res = float(resolution)
        if not (MIN_RESOLUTION <= res <= MAX_RESOLUTION):
            raise StockError(f"stock resolution must be in [{MIN_RESOLUTION:g}, "
                             f"{MAX_RESOLUTION:g}] mm, got {resolution!r}")
        if int(blade_count) < 1:
            raise StockError(f"blade count must be at least 1, got {blade_count}")
        z_lo, z_hi = float(z_range[0]), float(z_range[1])
        if not (z_hi > z_lo and r_max > 0):
            raise StockError(f"the stock has no extent: z {z_lo:g}..{z_hi:g} mm, largest "
                             f"radius {r_max:g} mm")
        phi = TWO_PI / int(blade_count)
        n_theta = max(1, int(math.ceil(phi * r_max / res)))
        n_z = max(1, int(math.ceil((z_hi - z_lo) / res)))
        n = n_theta * n_z
        if n * K * 16 > 8e9:
            raise StockError(f"the stock grid would need {n * K * 16 / 1e9:.1f} GB at "
                             f"{res:g} mm ({n_theta} × {n_z} rays); coarsen the resolution")
        return cls(axis, int(blade_count), float(theta0), z_lo, n_theta, n_z, res,
                   float(r_max), np.zeros((n, K)), np.zeros((n, K)))

    @property
    def pitch(self) -> float:
        return TWO_PI / self.blade_count

    @property
    def d_theta(self) -> float:
        return self.pitch / self.n_theta

    @property
    def dz(self) -> float:
        return self.resolution

    @property
    def n_rays(self) -> int:
        return self.n_theta * self.n_z

    def ray_theta(self, i) -> np.ndarray:
        """θ (rad) of ray column(s) ``i`` (any integer: columns outside 0..n_theta−1 are the
        neighbouring sectors' rays, the same by periodicity)."""
        return self.theta0 + (np.asarray(i) + 0.5) * self.d_theta

    def ray_z(self, j) -> np.ndarray:
        return self.z0 + (np.asarray(j) + 0.5) * self.dz

    def copy(self) -> RadialDexels:
        return RadialDexels(self.axis, self.blade_count, self.theta0, self.z0, self.n_theta,
                            self.n_z, self.resolution, self.r_max, self.lo.copy(),
                            self.hi.copy())

    # ------------------------------------------------------------------ measures
    def ray_volume(self) -> np.ndarray:
        """(n_rays,) material volume of each ray's cell, mm³."""
        w = np.where(self.hi > self.lo, self.hi ** 2 - self.lo ** 2, 0.0).sum(axis=1)
        return 0.5 * self.d_theta * self.dz * w

    def volume(self) -> float:
        """Material volume of the sector, mm³ (× N for the whole blisk)."""
        return float(self.ray_volume().sum())

    def locate(self, points):
        """Cell (i, j), r and in-grid mask of (n, 3) points, the angle wrapped into the
        sector."""
        e1, e2, d = self.axis.angular_frame()
        p = np.asarray(points, float).reshape(-1, 3) - self.axis.o
        x, y, z = p @ e1, p @ e2, p @ d
        th = np.mod(np.arctan2(y, x) - self.theta0, self.pitch)
        i = np.minimum((th / self.d_theta).astype(np.int64), self.n_theta - 1)
        jf = np.floor((z - self.z0) / self.dz)
        inside = (jf >= 0) & (jf < self.n_z)
        j = np.clip(jf, 0, self.n_z - 1).astype(np.int64)
        return i, j, np.hypot(x, y), inside

    def ray_points(self, points) -> np.ndarray:
        """(n, 3): each point moved onto the ray that stands for it — its cell's ray (θ and z
        of the cell's centre, in the point's own pitch sector) at the point's radius: the
        point of the stock :meth:`occupied` reads for it (exactly, in r)."""
        P = np.asarray(points, float).reshape(-1, 3)
        e1, e2, d = self.axis.angular_frame()
        rel = P - self.axis.o
        x, y = rel @ e1, rel @ e2
        th = np.arctan2(y, x)
        k = np.floor((th - self.theta0) / self.pitch)  # the sector the point lies in
        i, j, r, _ = self.locate(P)
        t = self.ray_theta(i) + k * self.pitch
        z = self.ray_z(j)
        return (self.axis.o + z[:, None] * d
                + r[:, None] * (np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2))

    def occupied(self, points) -> np.ndarray:
        """(n,) bool — the points lie in material (the nearest ray's interval holds their r)."""
        i, j, r, inside = self.locate(points)
        ray = j * self.n_theta + i
        L, H = self.lo[ray], self.hi[ray]
        return inside & ((L <= r[:, None]) & (r[:, None] < H)).any(axis=1)

    # ------------------------------------------------------------------ state files
    def save(self, path) -> str:
        """Write the stock state to ``path`` (.npz) atomically; returns the path."""
        path = os.fspath(path)
        with atomic_output(path, suffix=".npz", error=StockError) as tmp:
            np.savez_compressed(
                tmp, format=np.array("blisk_cam.radial_dexels.1"),
                axis=np.array(self.axis.as_list()), blade_count=self.blade_count,
                theta0=self.theta0, z0=self.z0, n_theta=self.n_theta, n_z=self.n_z,
                resolution=self.resolution, r_max=self.r_max, lo=self.lo, hi=self.hi)
        return path

    @classmethod
    def load(cls, path) -> RadialDexels:
        """A stock state written by :meth:`save` (StockError when it is not one)."""
        try:
            with np.load(os.fspath(path), allow_pickle=False) as z:
                if str(z["format"]) != "blisk_cam.radial_dexels.1":
                    raise KeyError("format")
                ax = z["axis"]
                return cls(Axis(tuple(ax[:3]), tuple(ax[3:])), int(z["blade_count"]),
                           float(z["theta0"]), float(z["z0"]), int(z["n_theta"]),
                           int(z["n_z"]), float(z["resolution"]), float(z["r_max"]),
                           np.array(z["lo"]), np.array(z["hi"]))
        except FileNotFoundError:
            raise StockError(f"stock state {path} not found") from None
        except (KeyError, ValueError, OSError) as exc:
            raise StockError(f"{path} is not a stock state written by blisk_cam ({exc}); give "
                             "a .npz saved by a simulation") from None
