"""The orient stage orients every pass at once (``orient_passes.orient_all_local``): the
same axes, tips, flags, gouge report and program as pass by pass, bit for bit; and the link
check's answers do not depend on which points it measured before."""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.paths.link_check import SweptLinkCheck
from blisk_cam.core.process import blade_finish, orient_passes
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.toolpath.types import FLAG_AXIS_SMOOTHED, FLAG_GOUGE_FIXED, FLAG_LOCAL_GOUGE

D = math.radians


@pytest.fixture(scope="module")
def demos():
    """{fillet: (mesh, demo blisk)}: with the hub fillet (a ball larger than it is flagged
    there) and without (a bull nose plans)."""
    out = {}
    for fillet in (True, False):
        d = make_demo_blisk(resolution=0.8, fillet=fillet)
        out[fillet] = TriMesh.from_arrays(d.blade_vertices, d.blade_faces), d
    return out


def _plan(mesh, d, **kw):
    req = PathRequest(axis=d.axis, cone1=d.hub_cone, cone2=d.tip_cone, cusp=0.05, chord=0.05,
                      **kw)
    return plan_paths(mesh, req)


def _refuse(*args, **kwargs):
    raise BliskCamError("pass by pass")  # the stage then orients pass by pass, as before


@pytest.mark.parametrize("fillet, kw", [
    # a ball larger than the hub fillet: poses flagged there, the search per pass
    (True, dict(tool_type="ball", tool_radius=6.0, lead=D(3), tilt=D(2))),
    (True, dict(tool_type="ball", tool_radius=5.0, lead=D(8), tilt=D(0),
                fix_local_gouge=False, max_axis_turn=D(6))),
    # smoothing per pass; a bull nose (its effective radius depends on the axis)
    (False, dict(tool_type="bull", tool_radius=6.0, corner_radius=2.0, lead=D(10),
                 tilt=D(-5), max_axis_turn=D(4))),
])
def test_all_passes_at_once_as_pass_by_pass(demos, monkeypatch, fillet, kw):
    mesh, d = demos[fillet]
    batched = _plan(mesh, d, **kw)

    monkeypatch.setattr(orient_passes, "orient_all_local", _refuse)
    single = _plan(mesh, d, **kw)
    a, b = batched.path, single.path
    assert len(a.curves) == len(b.curves) > 3
    for ca, cb in zip(a.curves, b.curves, strict=True):
        for name in ("axis", "tip", "flags"):
            np.testing.assert_array_equal(getattr(ca, name), getattr(cb, name))
    for name in ("tip", "axis", "move", "curve", "index", "flags"):
        np.testing.assert_array_equal(getattr(a.program, name), getattr(b.program, name))
    assert batched.gouge.summary() == single.gouge.summary()
    np.testing.assert_array_equal(batched.gouge.left_at, single.gouge.left_at)
    flags = np.concatenate([c.flags for c in a.curves])
    if "max_axis_turn" in kw:
        assert np.any(flags & FLAG_AXIS_SMOOTHED)
    if fillet and kw["tool_radius"] == 6.0:
        assert np.any(flags & (FLAG_GOUGE_FIXED | FLAG_LOCAL_GOUGE))
        assert batched.gouge.summary()["flagged"] > 0


def test_an_error_is_raised_as_pass_by_pass(demos, monkeypatch):
    """A pass that cannot be oriented (smoothing too tight for a thin edge) raises what the
    pass-by-pass loop raises, message and all."""
    mesh, d = demos[True]
    kw = dict(tool_type="ball", tool_radius=5.0, lead=D(8), max_axis_turn=D(3))
    with pytest.raises(BliskCamError) as batched:
        _plan(mesh, d, **kw)
    monkeypatch.setattr(orient_passes, "orient_all_local", _refuse)
    with pytest.raises(BliskCamError) as single:
        _plan(mesh, d, **kw)
    assert type(batched.value) is type(single.value)
    assert str(batched.value) == str(single.value)
    assert "smoothing" in str(single.value)


def test_link_check_memo_answers_as_a_fresh_check(demos):
    """Points measured before (the routes' shared ends) give the figures a fresh check
    gives, for a ball and a bull nose."""
    mesh, d = demos[True]
    res = _plan(mesh, d, tool_type="ball", tool_radius=6.0)
    p = res.path.program
    rng = np.random.default_rng(3)
    for cutter in (res.path.tool,
                   blade_finish.make_cutter(PathRequest(d.axis, tool_type="bull",
                                                        tool_radius=6.0, corner_radius=2.0))):
        kept = SweptLinkCheck(mesh, cutter, 0.05)
        for _ in range(12):
            j = int(rng.integers(0, len(p.tip) - 8))
            sl = slice(j, j + int(rng.integers(1, 8)))
            fresh = SweptLinkCheck(mesh, cutter, 0.05).depth(p.tip[sl], p.axis[sl])
            assert kept.depth(p.tip[sl], p.axis[sl]) == fresh
            assert kept.depth(p.tip[sl], p.axis[sl]) == fresh  # all from the memo now
        assert len(kept._memo) > 0


@pytest.mark.parametrize("link, order", [("oneway", "hub_to_tip"), ("zigzag", "tip_to_hub"),
                                         ("spiral", "hub_to_tip")])
def test_climb_senses_at_once_as_pass_by_pass(demos, monkeypatch, link, order):
    """The order stage's climb senses of all passes at once (``linking._climb_senses``) are
    each pass's own ``_climb_sense``, float for float, and order the passes as before."""
    from blisk_cam.core.paths import linking

    mesh, d = demos[False]
    kw = dict(tool_type="ball", tool_radius=5.0, lead=D(5), link=link, order=order)
    res = _plan(mesh, d, **kw)
    monkeypatch.setattr(linking, "_climb_senses", lambda *a, **k: {})
    single = _plan(mesh, d, **kw).path
    for name in ("tip", "axis", "move", "curve", "index", "flags"):
        np.testing.assert_array_equal(getattr(res.path.program, name),
                                      getattr(single.program, name))
    monkeypatch.undo()
    if link == "spiral":
        return  # one joined pass: its program compared above
    from blisk_cam.core.part.profiles import morph_between

    curves = [c for c in res.path.curves if len(c.cc) >= 2]
    morph = morph_between(res.path.cone1, res.path.cone2)
    senses = linking._climb_senses(curves, morph, d.axis, order == "hub_to_tip")
    assert len(senses) == len(curves) > 3
    for c in curves:
        assert senses[id(c)] == linking._climb_sense(c, morph, d.axis, order == "hub_to_tip")
