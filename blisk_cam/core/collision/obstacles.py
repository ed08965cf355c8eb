"""What the tool may hit: the blade, its neighbours and the hub as triangle
meshes (:class:`Obstacles`), copies about the blisk axis, closed or open. mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..errors import CollisionError
from ..geometry.axis import Axis
from ..geometry.vectors import rotate_about

__all__ = ["Obstacle", "Obstacles", "split_faces"]


# ====================================================================== obstacles
def split_faces(V, F, mask):
    """Split a triangle mesh by a per-triangle mask: ((V, F) of the masked triangles,
    (V, F) of the others), each with only the vertices it uses (renumbered); the second is
    None when every triangle is masked."""
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F, dtype=np.int64)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != (len(F),):
        raise CollisionError(f"face mask has {mask.shape} entries for {len(F)} triangles")

    def part(sel):
        used, inv = np.unique(F[sel].ravel(), return_inverse=True)
        return V[used], inv.reshape(-1, 3).astype(np.int64)

    return part(mask), (part(~mask) if np.any(~mask) else None)


def _mesh_arrays(name, V, F):
    try:
        V = np.asarray(V, dtype=np.float64)
        F = np.asarray(F, dtype=np.int64)
    except (TypeError, ValueError):
        raise CollisionError(f"obstacle {name!r}: vertices and faces must be numeric arrays") \
            from None
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3:
        raise CollisionError(f"obstacle {name!r}: need vertices (n, 3) and triangles (m, 3), got "
                             f"{V.shape} and {F.shape}")
    if len(F) == 0:
        raise CollisionError(f"obstacle {name!r} has no triangles; leave it out")
    if not np.all(np.isfinite(V)):
        raise CollisionError(f"obstacle {name!r} has NaN or infinite coordinates")
    if F.min() < 0 or F.max() >= len(V):
        raise CollisionError(f"obstacle {name!r}: face indices out of range 0..{len(V) - 1}")
    return V, F


@dataclass(frozen=True)
class Obstacle:
    """A named triangle mesh: V (n, 3) float64 mm, F (m, 3) int64. ``turned_from``: set by
    :meth:`Obstacles.build` on a neighbour it made — (the blade's V, sign, k, blade count):
    V is that array turned by sign·k·360°/N about the axis, F the blade's (the collision
    scene then need not compare the vertices to know it is a copy)."""

    name: str
    V: np.ndarray = field(repr=False)
    F: np.ndarray = field(repr=False)
    turned_from: tuple | None = field(default=None, repr=False, compare=False)

    @property
    def n_triangles(self) -> int:
        return int(len(self.F))


@dataclass(frozen=True)
class Obstacles:
    """The target blade (index 0), its neighbours, then the extra meshes.

    Attributes
    ----------
    meshes : tuple of Obstacle — ``meshes[0]`` is the target blade
    axis : Axis — the blisk axis the neighbours are turned about
    blade_count : int — N ≥ 2
    neighbours : int — copies per side
    """

    meshes: tuple
    axis: Axis
    blade_count: int
    neighbours: int

    @classmethod
    def build(cls, blade_V, blade_F, axis: Axis, blade_count: int, neighbours: int = 2,
              extra=(), *, check_extra: bool = True) -> Obstacles:
        """The target blade, its ±k·360°/N copies (k = 1..neighbours) and ``extra``
        obstacles: an iterable of ``(name, V, F)`` or :class:`Obstacle`.

        Raises
        ------
        CollisionError — blade count < 2, neighbours < 0 or so many that the copies wrap
        around onto each other (2 · neighbours + 1 > blade count), bad arrays, an extra
        obstacle that contains or coincides with the blade (:meth:`check_extras`)."""
        try:
            n = int(blade_count)
        except (TypeError, ValueError):
            raise CollisionError(f"blade count must be an integer ≥ 2, got {blade_count!r}") \
                from None
        if n != blade_count or n < 2:
            raise CollisionError(f"blade count must be an integer ≥ 2 (the blades on the blisk), "
                                 f"got {blade_count!r}")
        try:
            k = int(neighbours)
        except (TypeError, ValueError):
            raise CollisionError(f"neighbours must be an integer ≥ 0, got {neighbours!r}") \
                from None
        if k != neighbours or k < 0:
            raise CollisionError(f"neighbours (blades checked on each side) must be an integer "
                                 f"≥ 0, got {neighbours!r}")
        if 2 * k + 1 > n:
            raise CollisionError(
                f"{k} neighbours per side need {2 * k + 1} blades but the blisk has {n}: the "
                f"copies would wrap around onto each other; use at most {(n - 1) // 2} "
                "neighbours per side")
        V, F = _mesh_arrays("blade", blade_V, blade_F)
        meshes = [Obstacle("blade", V, F)]
        pitch = 2.0 * math.pi / n
        for j in range(1, k + 1):
            for sign, tag in ((1, "+"), (-1, "-")):
                turned = rotate_about(V, axis.d, sign * j * pitch, axis.o, form="outer")
                meshes.append(Obstacle(f"blade {tag}{j}", turned, F, (V, sign, j, n)))
        names = {m.name for m in meshes}
        for e in extra:
            if isinstance(e, Obstacle):
                ob = e
            else:
                try:
                    name, EV, EF = e
                except (TypeError, ValueError):
                    raise CollisionError("extra obstacles must be (name, vertices, faces) "
                                         "triples") from None
                ob = Obstacle(str(name), *_mesh_arrays(str(name), EV, EF))
            if ob.name in names:
                raise CollisionError(f"two obstacles are named {ob.name!r}; give each a name")
            names.add(ob.name)
            meshes.append(ob)
        out = cls(tuple(meshes), axis, n, k)
        if check_extra:
            out.check_extras()
        return out

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.meshes]

    @property
    def n_triangles(self) -> int:
        return int(sum(m.n_triangles for m in self.meshes))

    @property
    def extra_start(self) -> int:
        """Index of the first extra obstacle."""
        return 1 + 2 * self.neighbours

    def summary(self) -> dict:
        return {"names": self.names, "triangles": [m.n_triangles for m in self.meshes],
                "blade_count": self.blade_count, "neighbours": self.neighbours}

    def check_extras(self, samples: int = 24) -> None:
        """Refuse an extra obstacle that coincides with the blade's faces (shares its surface:
        the blade would collide with itself) or, closed, contains the blade's vertices.

        Raises CollisionError naming the obstacle and the way out."""
        blade = self.meshes[0]
        Vb = blade.V
        scale = float(np.linalg.norm(Vb.max(0) - Vb.min(0)))
        rng = np.random.default_rng(0)
        pick = Vb[rng.choice(len(Vb), size=min(samples, len(Vb)), replace=False)]
        for ob in self.meshes[self.extra_start:]:
            pts = np.vstack([ob.V, ob.V[ob.F].mean(axis=1)])
            d, _ = cKDTree(pts).query(Vb)
            same = np.mean(d <= 1e-6 * max(scale, 1.0))
            if same > 0.1:
                raise CollisionError(
                    f"obstacle {ob.name!r} contains the blade's own faces ({100 * same:.0f} % of "
                    "the blade's vertices lie on it), so every pose would collide: remove the "
                    "blade's faces from it (or select only the blade faces as the blade)")
            if _closed(ob.F):
                w = _winding_numbers(ob.V, ob.F, pick)
                inside = np.mean(np.abs(w) > 0.5)
                if inside > 0.5:
                    raise CollisionError(
                        f"obstacle {ob.name!r} is a closed mesh that contains the blade "
                        f"({100 * inside:.0f} % of the sampled blade vertices lie inside it), so "
                        "every pose would collide: remove the blade's faces and volume from it, "
                        "or give the hub/fixture without the blade")


def _closed(F) -> bool:
    e = np.sort(np.vstack([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    _, cnt = np.unique(e, axis=0, return_counts=True)
    return bool(np.all(cnt == 2))


def _winding_numbers(V, F, P, chunk: int = 200_000) -> np.ndarray:
    """(k,) generalised winding numbers of points P (k, 3) w.r.t. the triangle mesh
    (solid angles, Van Oosterom & Strackee); ≈ ±1 inside a closed mesh, 0 outside."""
    out = np.zeros(len(P))
    for s in range(0, len(F), chunk):
        A, B, C = (V[F[s:s + chunk, i]] for i in range(3))
        for j, p in enumerate(P):
            a, b, c = A - p, B - p, C - p
            la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
            num = np.einsum("ij,ij->i", a, np.cross(b, c))
            den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc
                   + np.einsum("ij,ij->i", b, c) * la + np.einsum("ij,ij->i", c, a) * lb)
            out[j] += 2.0 * np.arctan2(num, den).sum()
    return out / (4.0 * math.pi)

