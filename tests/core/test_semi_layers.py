"""Semi-finishing in offset layers (#23: "Semi-finishing: … and a layer count", as the lead's
brief reads it — paper 003 §5's "25 layers" are its cutting layers, the passes): K
(``offset_layers``) whole pass sets offset from the stock before (``offset_from``) down to the
allowance.

Measured truths, each by a means the planner does not use:

* each layer's ball centres lie R + a_i from the blade mesh (exact point-to-triangle
  distances), a_i = a + (a_0 − a)(K − i)/K the layers asked (0.3, 0.2, 0.1 from 0.4);
* the stock simulation: the part plus 0.5 mm, a patch of each layer (4 passes × 20 poses
  round the middle of the region) run in order; after layer i the material left on the blade
  there lies between a_i − chord and a_i + cusp + chord (± the stock's resolution; the
  median inside without it) — after the last one the acceptance line, 0.1 − chord …
  0.1 + cusp + chord;
* between two layers the tool goes round the blade outside it: only rapids, and every
  straight rapid segment keeps its nearest point to the axis (closed form) outside every
  cutting pose of the program;
* bad input (offset from not above the allowance, a fractional count) is refused by name.

Cheap: the demo blade at mesh resolution 0.5 between the morphs at 0.4 and 0.6, stock 0.15 mm.
"""

from __future__ import annotations

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError, ToleranceError
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import part_from_demo, theta_about
from blisk_cam.core.part.profiles import morph_between
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.process.job import iter_run_job, load_job
from blisk_cam.core.stock.blank import stock_from_allowance
from blisk_cam.core.stock.removal import remove_program
from blisk_cam.core.stock.simulation import part_surface
from blisk_cam.core.toolpath.types import MOVE_CUT, MOVE_RAPID, Program
from tests.support.patch import deviation_under_passes, short_flute

A, A0, K = 0.1, 0.4, 3
CUSP = CHORD = 0.05
RES = 0.15
LAYERS = [0.3, 0.2, 0.1]  # a + (a0 − a)(K − i)/K, i = 1 … K


@pytest.fixture(scope="module")
def demo():
    d = make_demo_blisk(resolution=0.5)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    band = morph_between(d.hub_cone, d.tip_cone)
    return d, mesh, band.cone_at(0.4), band.cone_at(0.6)


@pytest.fixture(scope="module")
def layered(demo):
    d, mesh, c1, c2 = demo
    req = PathRequest(axis=d.axis, cone1=c1, cone2=c2, cusp=CUSP, chord=CHORD, allowance=A,
                      offset_layers=K, offset_from=A0)
    return plan_paths(mesh, req).path


def _layers(path):
    """[(a_i, curves of layer i)] from the path's per-layer pass counts."""
    counts = path.stats["layer_curves"]
    stops = np.cumsum(counts)
    return [(a, path.curves[s - n:s]) for a, n, s in zip(path.stats["layer_allowances"],
                                                         counts, stops, strict=True)]


def test_each_layer_lies_its_allowance_from_the_blade(demo, layered):
    _, mesh, _, _ = demo
    md = MeshDistance(mesh)
    R = layered.tool.radius
    assert layered.tool.type == "ball" and R == 6.0 and layered.allowance == A
    assert layered.stats["offset_layers"] == K
    assert layered.stats["layer_allowances"] == pytest.approx(LAYERS)
    assert sum(layered.stats["layer_curves"]) == len(layered.curves)
    for a, curves in _layers(layered):
        tip = np.vstack([c.tip for c in curves])
        axis = np.vstack([c.axis for c in curves])
        dist = md.query(tip + R * axis).distance
        assert np.abs(dist - (R + a)).max() < 1e-3, (a, dist.min() - R, dist.max() - R)
        # each layer is a whole pass set: from cone 1 to cone 2
        assert curves[0].s == 0.0 and curves[-1].s == 1.0


def test_between_layers_the_tool_goes_round_outside_the_blade(demo, layered):
    P = layered.program
    cut = np.nonzero(P.move == MOVE_CUT)[0]
    layer_of_curve = np.repeat(np.arange(K), layered.stats["layer_curves"])
    lay = layer_of_curve[P.curve[cut]]
    assert (np.diff(lay) >= 0).all() and set(lay.tolist()) == set(range(K))
    r_cut, _, _ = theta_about(P.tip[cut], layered.axis)
    o, d = layered.axis.o, layered.axis.d
    for i in np.nonzero(np.diff(lay))[0]:
        a, b = cut[i], cut[i + 1]
        j = np.nonzero(P.move[a + 1:b] == MOVE_RAPID)[0] + a + 1
        assert len(j) >= 2
        seg = j[1:][np.diff(j) == 1]  # consecutive rapid rows: the route round the blade
        p0, p1 = P.tip[seg - 1] - o, P.tip[seg] - o
        p0 -= np.outer(p0 @ d, d)
        p1 -= np.outer(p1 @ d, d)
        e = p1 - p0
        t = np.clip(-np.einsum("ij,ij->i", p0, e) / np.maximum(
            np.einsum("ij,ij->i", e, e), 1e-12), 0.0, 1.0)
        near = np.linalg.norm(p0 + t[:, None] * e, axis=1)
        # the rapids that go round (not the ones down the tool axis to the approach)
        top = np.minimum(np.linalg.norm(p0, axis=1), np.linalg.norm(p1, axis=1))
        round_ = top > r_cut.max()
        assert round_.sum() >= 2
        assert near[round_].min() > r_cut.max(), (near[round_].min(), r_cut.max())


def test_the_stock_after_each_layer_is_that_layers_allowance(demo, layered):
    d = demo[0]
    part = part_from_demo(d)
    stock = stock_from_allowance(part, 0.5, RES)
    cutter = short_flute(layered.tool)
    V, F, N, outer = part_surface(part, RES)
    _, _, hub = part.part_mesh()
    on_blade = np.zeros(len(V), bool)
    on_blade[np.unique(F[~hub])] = True
    ratio = morph_between(layered.cone1, layered.cone2).ratio_of_points(V, layered.axis)
    mid = None
    for a, curves in _layers(layered):
        s = np.array([c.s for c in curves])
        chosen = np.sort(np.argsort(np.abs(s - 0.5))[:4])
        if mid is None:  # one patch of the blade for every layer
            c0 = curves[chosen[0]]
            mid = c0.cc[len(c0.cc) // 3] - a * c0.normal[len(c0.cc) // 3]
        core, core_n = [], []
        for i in chosen:
            c = curves[i]
            on = c.cc - a * c.normal  # the blade points under the contacts
            k = int(np.argmin(np.linalg.norm(on - mid, axis=1)))
            idx = np.arange(k - 10, k + 10) % len(c.cc)
            n = len(idx)
            remove_program(stock, Program(c.tip[idx], c.axis[idx],
                                          np.full(n, MOVE_CUT, np.int8), np.full(n, i), idx,
                                          np.zeros(n, np.uint8)),
                           cutter, check_body=False, sweep_tolerance=0.01)
            core.append(on[idx[5:-5]])
            core_n.append(c.normal[idx[5:-5]])
        dev, _ = deviation_under_passes(stock, (V, N, outer, on_blade), ratio, s[chosen[1]],
                                        s[chosen[-2]], core, core_n)
        lo, hi = a - CHORD, a + CUSP + CHORD
        assert dev.min() >= lo - RES, (a, dev.min())
        assert dev.max() <= hi + RES, (a, dev.max())
        assert lo <= np.median(dev) <= hi, (a, np.median(dev))


def test_bad_layers_are_refused(demo):
    d, mesh, c1, c2 = demo
    for kw, msg in (({"offset_layers": 3, "offset_from": 0.1}, "give an offset from more"),
                    ({"offset_layers": 2, "offset_from": 0.05}, "give an offset from more"),
                    ({"offset_layers": 0}, "[Oo]ffset [Ll]ayers"),
                    ({"offset_layers": 2.5}, "whole number")):
        with pytest.raises((ToleranceError,), match=msg):
            plan_paths(mesh, PathRequest(axis=d.axis, cone1=c1, cone2=c2, allowance=A, **kw))


def test_a_job_checks_the_layers_up_front(tmp_path):
    """The job's semi_finish operation takes 'offset_layers' and 'offset_from' (the same
    options);
    a bad pair is refused naming the operation before anything runs."""
    from tests.core.test_process_kinds import JOB

    job = tmp_path / "layers.toml"
    job.write_text(JOB.replace('radial_tilt = 75\n',
                               'radial_tilt = 75\nallowance = 0.1\noffset_layers = 3\n'
                               'offset_from = 0.05\n', 1))
    gen = iter_run_job(load_job(job))
    with pytest.raises(BliskCamError, match=r"operation 1 \('semi-finish'\).*give an offset from "
                                            r"more than the allowance"):
        for _ in range(3):
            next(gen)
