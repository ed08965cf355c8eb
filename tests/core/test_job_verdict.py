"""The job's final verdict (issue 24, acceptance 1): the stock after the last operation judged on
the part's faces — material left ≤ cusp + chord (+ the stock's resolution) and no gouge beyond
the tolerance, except the zones named unreachable with their areas.

A cheap equivalent of the template's end state: the demo blisk (coarse mesh) from a blank of the
part + 2 mm at a 1 mm stock, one hub finishing operation (Ø6 ball, coarse stepover) simulated on
it. The blade, its fillet and the hub outside the channel keep their 2 mm and no finishing
operation plans contacts there: named "not machined" (the verdict incomplete), each with the
operation that would cover it; where contacts are planned but all collide: unreachable. Checked
against independent measurements: each zone's area is the sum of its triangles' areas from the
mesh; the stock holds material beyond the bound above the zones' faces (read straight from the
dexels) and the faces with material beyond the bound outside every contact region add up to the
zones' area; every face of an unreachable zone lies farther from every contact polyline (exact
point-to-segment distance) than the contact region's width. The same contacts on the untouched
blank: the hub they cover keeps 2 mm, and those zones fail. Blade finishing contacts from some
height up: the blade sides below them are not machined, to be covered by its hub cone lowered."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from blisk_cam.core.geometry.vectors import rotate_about
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import part_from_demo
from blisk_cam.core.process.hub_finish import HUB_FINISH, HubRequest
from blisk_cam.core.process.job_verdict import (
    OperationContacts,
    face_frame,
    job_verdict,
    job_verdict_dict,
)
from blisk_cam.core.process.operation import run_operation
from blisk_cam.core.runtime import run_to_end
from blisk_cam.core.stock.blank import stock_from_allowance
from blisk_cam.core.stock.simulation import iter_simulate

RES = 1.0
BLANK = 2.0



@pytest.fixture(scope="module")
def finished():
    part = part_from_demo(make_demo_blisk(resolution=0.3))
    req = HubRequest(tool_diameter=6.0, stepover=2.0, allowance=0.3, extend=3.0,
                     collisions="off")
    path = run_operation(HUB_FINISH, part, req).path
    stock = stock_from_allowance(part, BLANK, RES)
    run_to_end(iter_simulate(part, stock, [path]))
    contacts = OperationContacts.from_path(1, "hub", path)
    return part, path, stock, contacts, job_verdict(part, stock, [contacts], fillet_radius=8.0)


def _segments_distance(P, path, part, near: float = 4.0):
    """Distance from points P to the contact polylines of ``path`` (each pass, turned to
    blades −1, 0, +1): exact (point to segment) where a contact point lies within ``near`` mm,
    else a lower bound (the distance to the nearest contact point less half the longest
    segment)."""
    A, B = [], []
    for c in path.curves:
        cc = np.vstack([c.cc, c.cc[:1]]) if c.closed else c.cc
        A.append(cc[:-1])
        B.append(cc[1:])
    A, B = np.vstack(A), np.vstack(B)
    A = np.vstack([rotate_about(A, part.axis.d, k * part.pitch, part.axis.o) for k in (-1, 0, 1)])
    B = np.vstack([rotate_about(B, part.axis.d, k * part.pitch, part.axis.o) for k in (-1, 0, 1)])
    D = B - A
    half = 0.5 * float(np.linalg.norm(D, axis=1).max())
    d_pts, _ = cKDTree(np.vstack([A, B])).query(P)
    out = np.maximum(d_pts - half, 0.0)
    idx = np.flatnonzero(d_pts < near + half)
    seg_tree = cKDTree(0.5 * (A + B))
    for a in range(0, len(idx), 256):
        k = idx[a:a + 256]
        cand = seg_tree.query_ball_point(P[k], near + 2 * half)
        for j, c in zip(k, cand, strict=True):
            c = np.asarray(c, int)
            if len(c) == 0:
                continue
            t = np.clip(np.einsum("ij,ij->i", P[j] - A[c], D[c])
                        / np.maximum(np.einsum("ij,ij->i", D[c], D[c]), 1e-300), 0.0, 1.0)
            out[j] = np.linalg.norm(P[j] - (A[c] + t[:, None] * D[c]), axis=1).min()
    return out


def test_unreached_zones_are_named_with_their_measured_areas(finished):
    part, path, stock, contacts, v = finished
    V, F, hub, C, N, _ = face_frame(part)
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]),
                                axis=1)
    assert v.status == "incomplete" and not v.passed, [
        z.reason for z in v.zones if z.status == "failed"][:3]
    assert not [z for z in v.zones if z.status == "unreachable"]  # no contact collides
    unr = [z for z in v.zones if z.status == "not machined"]
    surfaces = {z.surface.split(" (")[0] for z in unr}
    # the blade's sides and fillet keep the blank's 2 mm: no finishing contact there
    assert {"blade 0 fillet", "blade 0 +θ side", "blade 0 −θ side"} <= surfaces
    cover = {"hub": "hub finishing", "blade 0 fillet": "fillet finishing's layers"}
    for z in unr:
        assert z.area_mm2 == pytest.approx(area[z.faces].sum(), rel=1e-9)
        assert z.area_mm2 > 0
        assert "no finishing operation plans contacts here" in z.reason
        assert z.cover.startswith(cover.get(z.surface.split(" (")[0], "blade finishing"))
        assert z.cover in z.reason
        r = np.hypot(*(C[z.faces] - part.axis.o)[:, :2].T)
        assert z.r_mm[0] - 0.01 <= r.min() and r.max() <= z.r_mm[1] + 0.01
        assert (hub[z.faces] if z.surface == "hub" else ~hub[z.faces]).all()
    # the stock holds material beyond the bound above the zones' faces (read from the dexels)
    faces = np.concatenate([z.faces for z in unr])
    b = v.bound[faces]
    beyond = stock.occupied(C[faces] + (b + 0.05)[:, None] * N[faces])
    assert area[faces][beyond].sum() >= 0.97 * area[faces].sum()
    # every face of an unreachable zone lies outside the hub operation's contact region
    w = math.sqrt(2 * contacts.radius * (contacts.cusp + contacts.chord))
    assert _segments_distance(C[faces], path, part).min() > w - 1e-9
    # and the faces with material beyond the bound outside every contact region make the zones
    judged = np.isfinite(v.left)
    out = judged & (_segments_distance(C, path, part) > w + 0.5)
    held = out & stock.occupied(C + (v.bound + 0.25 * RES)[:, None] * N)
    in_zones = np.zeros(len(F), bool)
    in_zones[faces] = True
    assert area[held & in_zones].sum() >= 0.95 * area[held].sum()
    d = job_verdict_dict(v)
    assert d["area_not_machined_mm2"] == pytest.approx(sum(z.area_mm2 for z in unr), abs=1e-2)
    assert d["status"] == "incomplete" and d["area_unreachable_mm2"] == 0
    # the hub the passes finish is within the bound: no zone covers the channel's middle
    mid = judged & hub & (_segments_distance(C, path, part) < 0.5)
    assert mid.sum() > 50
    assert not in_zones[mid].any()


def test_contacts_on_a_stock_they_never_cut_fail_the_verdict(finished):
    part, path, _, contacts, _ = finished
    blank = stock_from_allowance(part, BLANK, RES)
    v = job_verdict(part, blank, [contacts], fillet_radius=8.0)
    assert not v.passed
    failed = [z for z in v.zones if z.status == "failed"]
    assert failed and all(z.what == "left" for z in failed)
    assert {z.surface for z in failed} >= {"hub"}
    assert all("operation 1 (hub) plans contacts" in z.reason for z in failed)
    assert max(z.worst_mm for z in failed) == pytest.approx(BLANK, abs=0.5 * RES)


def test_contacts_that_collide_name_their_zone_unreachable(finished):
    """Where every contact planned collides (the tool body within the safety: those poses are
    the tool's unreachable ones), the material they would have cut is named unreachable for
    that reason, not failed."""
    from dataclasses import replace

    part, _, _, contacts, _ = finished
    blank = stock_from_allowance(part, BLANK, RES)
    hit = replace(contacts, colliding=np.ones(len(contacts.cc), bool))
    v = job_verdict(part, blank, [hit], fillet_radius=8.0)
    assert v.status == "incomplete"  # nothing failed; the blades are not machined
    hub_zones = [z for z in v.zones if z.surface == "hub" and "collides" in z.reason]
    assert hub_zones and all(z.status == "unreachable" for z in hub_zones)
    # the same faces that failed under clear contacts
    failed = np.concatenate([z.faces for z in job_verdict(part, blank, [contacts],
                                                          fillet_radius=8.0).zones
                             if z.status == "failed"])
    assert set(failed) <= set(np.concatenate([z.faces for z in hub_zones]))


def test_the_suction_side_follows_the_camber():
    """The demo's camber turns its sections one way or the other: the side named suction (the
    convex one) changes with the camber's sign."""
    from blisk_cam.core.process.job_verdict import _classes

    named = []
    for camber in ({}, {"camber_hub": -0.6, "camber_tip": -0.4}):
        part = part_from_demo(make_demo_blisk(resolution=0.3, **camber))
        _, _, hub, C, N, _ = face_frame(part)
        _, _, names = _classes(part, C, N, hub, 8.0)
        named.append(names[2])  # the +θ side
    assert {n.split("(")[1] for n in named} == {"suction)", "pressure)"}


def test_blade_sides_below_blade_finishing_are_not_machined(finished):
    """Blade finishing contacts only from 12 mm above the hub up (on blade 0's mesh vertices):
    the side faces below them (left at the blank's 2 mm) are "not machined", to be covered by
    blade finishing's hub cone lowered (the lowest contact's height named), never unreachable;
    the faces among its contacts, on the uncut blank, fail."""
    from blisk_cam.core.hub.surface import HubSurface

    part, _, stock, contacts, _ = finished
    hs = HubSurface(part.hub_profile, part.axis)
    Vb = np.asarray(part.blade_vertices, float)
    _, _, hv = hs.coordinates(Vb)
    cc = Vb[hv > 12.0]
    blade = OperationContacts(2, "blade", cc, np.zeros(len(cc), bool), 5.0, 0.05, 0.02,
                              "blade_finish")
    v = job_verdict(part, stock, [contacts, blade], fillet_radius=8.0)
    assert v.status == "failed"
    sides = [z for z in v.zones if z.status == "not machined" and "side" in z.surface]
    low = float(hv[hv > 12.0].min())
    below = [z for z in sides if z.height_mm[0] < low]
    assert below and sum(z.area_mm2 for z in below) > 100.0
    for z in sides:  # (between sparse contacts higher up: blade finishing's own)
        if z.height_mm[0] < low:
            assert "hub cone lower" in z.cover and f"{low:.1f} mm" in z.cover
        else:
            assert z.cover == "blade finishing"
    assert not [z for z in v.zones if z.status == "unreachable"]
    failed = [z for z in v.zones if z.status == "failed"]
    assert failed and all("operation 2 (blade) plans contacts" in z.reason for z in failed
                          if "side" in z.surface)
