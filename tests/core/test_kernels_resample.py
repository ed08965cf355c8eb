"""The level samples of the scallop measurement resampled in one compiled call
(``kernels.polyline.resample_offset``, issue 21) against the numpy reference
(``paths.trial_levels._resample``) on the same inputs: the same points and normals bit for bit, open
and closed polylines, with and without an offset, repeated points, zero-length and very long
segments; and every level's samples of a generator.

Tests comparing the two backends skip (saying why) when the extension is not built."""

from __future__ import annotations

import numpy as np

from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import polyline as compiled_polyline
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.paths.passes import _Generator
from blisk_cam.core.paths.trial_levels import _resample
from tests.support.kernels import needs_compiled

compiled = needs_compiled("resample_offset")


def _polylines(rng):
    t = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    loop = np.stack([40 * np.cos(t), 8 * np.sin(t) ** 3, 5 + 0.1 * t], 1)
    n = rng.normal(size=loop.shape)
    yield loop, n / np.linalg.norm(n, axis=1)[:, None]
    wavy = np.cumsum(rng.uniform(-0.3, 0.3, (300, 3)), axis=0) + 150.0
    wavy[40:43] = wavy[40]  # repeated points: zero-length segments
    n = rng.normal(size=wavy.shape)
    yield wavy, n / np.linalg.norm(n, axis=1)[:, None]
    yield np.array([[0.0, 0, 0], [1e3, 0, 0], [1e3, 1e-9, 0]]), np.eye(3)
    yield np.array([[1.0, 2, 3], [1.0, 2, 3]]), np.array([[0.0, 0, 1], [0.0, 0, 1]])
    yield np.array([[1.0, 2, 3]]), np.array([[0.0, 0, 1]])


@compiled
def test_resample_offset_is_numpys_bit_for_bit():
    rng = np.random.default_rng(11)
    checked = 0
    for P, N in _polylines(rng):
        for closed in (False, True):
            for spacing, offset in ((0.25, 6.0), (0.05, 0.0), (3.0, 2.5), (0.25, -1.0)):
                got = compiled_polyline.resample_offset(P, N, closed, spacing, offset)
                ref = _resample(P, closed, spacing, N, offset)
                if got is None:  # only where the reference's own special case answers
                    assert len(P) + closed < 2
                    continue
                for g, r in zip(got, ref, strict=True):
                    assert g.shape == r.shape and np.array_equal(g, r), (len(P), closed)
                checked += 1
                # independent: without an offset, consecutive samples are no farther apart
                # than the spacing (a chord is no longer than its arc)
                if offset == 0:
                    gaps = np.linalg.norm(np.diff(got[0], axis=0), axis=1)
                    assert np.all(gaps <= spacing * (1 + 1e-9))
                assert np.allclose(np.linalg.norm(got[1], axis=1), 1.0)
    assert checked > 20


@compiled
def test_level_samples_are_numpys():
    d = make_demo_blisk(resolution=0.3, fillet=True)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    gen = _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)
    for s in (0.0, 0.21, 0.5, 0.77, 1.0):
        got = gen.level_samples(s)
        ref = [_resample(c.points, c.closed, gen.sample_spacing, c.normals, gen.radius)
               for c in gen.level(s)]
        assert len(gen.level(s)) > 0
        assert np.array_equal(got[0], np.concatenate([x[0] for x in ref]))
        assert np.array_equal(got[1], np.concatenate([x[1] for x in ref]))
