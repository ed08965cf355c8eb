"""A robot plan (``core.robot.free_angle.RobotPlan``) as Blender objects: the arm drawn from
simple link shapes and the planned tool poses coloured by their margin.

The world is the part frame (where the paths are drawn). Each link is a mesh object in its own
frame (``core.robot.kinematics.joint_frames``): a tube from its joint to the next joint, built
once from the first pose (the links are rigid), so that keyframing the link objects' matrices
per pose animates the arm; the polishing head is a tube from the flange to the tool point,
parented to the flange with the tool centre point (an Empty) at the tool frame. With the robot
holding the part the arm moves about the standing part (the world stays the part frame).

A link with a mesh in the robot's ``[meshes]`` is drawn from that mesh instead.

Pose colours: the margin of a pose is the smaller of its distance to the wrist singularity
(|A5|) and its nearest joint limit, degrees; :data:`MARGIN_BINS_DEG` splits it into the colours
of :data:`MARGIN_RGBA` (red: closest). Lengths mm in the arguments, Blender units in the scene.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from ..core.geometry.mesh_io import read_mesh
from ..core.robot import kinematics as K
from .objects import arrays_to_object, colored_material

__all__ = [
    "LINK_NAMES",
    "MARGIN_BINS_DEG",
    "MARGIN_RGBA",
    "link_frames_world",
    "link_shapes",
    "margin_bin",
    "margin_legend",
    "pose_margin_deg",
    "tube",
    "write_margin_points",
]

#: the drawn links, in the order of ``joint_frames``
LINK_NAMES = ("base", "carousel", "lower arm", "upper arm", "wrist 4", "wrist 5", "flange")
#: margin bin edges, degrees, and the colours of the bins (closest first)
MARGIN_BINS_DEG = (5.0, 15.0, 30.0)
MARGIN_RGBA = ((0.95, 0.05, 0.05, 1.0), (1.0, 0.5, 0.0, 1.0), (0.95, 0.85, 0.1, 1.0),
               (0.1, 0.8, 0.2, 1.0))
_COLOUR_NAMES = ("red", "orange", "yellow", "green")


def margin_legend() -> str:
    """The legend line of the pose colours (the Robot panel)."""
    e = MARGIN_BINS_DEG
    return (f"Pose margin (wrist / joint limit): {_COLOUR_NAMES[0]} < {e[0]:g}°, "
            f"{_COLOUR_NAMES[1]} < {e[1]:g}°, {_COLOUR_NAMES[2]} < {e[2]:g}°, "
            f"{_COLOUR_NAMES[3]} ≥ {e[2]:g}°")


def pose_margin_deg(robot, q) -> np.ndarray:
    """(n,) the margin of joints q (n, 6) radians, degrees: the smaller of the wrist
    singularity distance |A5| and the nearest joint limit."""
    wrist = K.singularity(robot, q)["wrist"]
    limit = K.limit_margin(robot, q).min(axis=-1)
    return np.degrees(np.minimum(wrist, limit))


def margin_bin(margin_deg) -> np.ndarray:
    """(n,) int colour index of margins (degrees) into :data:`MARGIN_RGBA`."""
    return np.searchsorted(np.asarray(MARGIN_BINS_DEG), np.asarray(margin_deg), side="right")


def tube(p0, p1, radius: float, segments: int = 12):
    """A closed tube (prism) from ``p0`` to ``p1`` (3,) mm of ``radius`` mm: V (2k+2, 3),
    F quads and triangles as (m, 4) with the caps fanned (a degenerate 4th index repeats)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    L = float(np.linalg.norm(d))
    z = d / L if L > 0 else np.array([0.0, 0.0, 1.0])
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    t = np.linspace(0.0, 2.0 * math.pi, segments, endpoint=False)
    ring = radius * (np.cos(t)[:, None] * x + np.sin(t)[:, None] * y)
    V = np.vstack([p0 + ring, p1 + ring, p0, p1])
    k = segments
    i = np.arange(k)
    j = (i + 1) % k
    sides = np.column_stack([i, j, k + j, k + i])
    c0, c1 = 2 * k, 2 * k + 1
    cap0 = np.column_stack([np.full(k, c0), j, i, i])
    cap1 = np.column_stack([np.full(k, c1), k + i, k + j, k + j])
    return V, np.vstack([sides, cap0, cap1])


def _tri(F):
    """(m, 4) faces with repeated last index → triangles (m', 3)."""
    quads = F[F[:, 2] != F[:, 3]]
    tris = F[F[:, 2] == F[:, 3]][:, :3]
    return np.vstack([tris, quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])


def link_shapes(robot, q0) -> list:
    """[(V, F)] per link of :data:`LINK_NAMES`, in the link's own frame (mm): the robot's
    ``[meshes]`` where given (read here), else a tube between the link frames at joints ``q0``
    (6,) radians; the flange's shape includes the head's tube to the tool point (robot holds
    the tool)."""
    p = robot.opw
    F0 = K.joint_frames(robot, q0)
    size = max(p["c2"], p["c3"], 1.0)
    r_arm, r_wrist = 0.07 * size, 0.045 * size
    given = dict(robot.meshes)
    out = []
    for i in range(7):
        if i in given:  # the user's mesh, in the link's frame
            V, F = read_mesh(given[i])
            V = V * robot.mesh_scale
            if i == 6 and not robot.holds_part:  # the head's tube to the tool point
                V2, F2 = tube([0, 0, 0], robot.tool[:3, 3], 0.5 * r_wrist)
                V, F = np.vstack([V, V2]), np.vstack([F, _tri(F2) + len(V)])
            out.append((V, F))
            continue
        if i == 0:
            shape = tube([0, 0, 0], [0, 0, 0.45 * p["c1"]], 1.4 * r_arm)
        elif i == 6:
            V1, F1 = tube([0, 0, -0.08 * p["c4"]], [0, 0, 0], 1.2 * r_wrist)
            if robot.holds_part:
                shape = (V1, F1)
            else:
                V2, F2 = tube([0, 0, 0], robot.tool[:3, 3], 0.5 * r_wrist)
                shape = (np.vstack([V1, V2]), np.vstack([F1, F2 + len(V1)]))
        else:
            start = np.array([0.0, 0.0, 0.45 * p["c1"]]) if i == 1 else np.zeros(3)
            end = np.linalg.solve(F0[i], np.append(F0[i + 1][:3, 3], 1.0))[:3]
            if np.linalg.norm(end - start) < 1e-6:  # the wrist joint: a drum about its axis
                axis = np.array([0.0, 1.0, 0.0]) if i == 4 else np.array([0.0, 0.0, 1.0])
                start, end = -1.1 * r_wrist * axis, 1.1 * r_wrist * axis
            shape = tube(start, end, r_arm if i <= 3 else r_wrist)
        V, F = shape
        out.append((V, _tri(F)))
    return out


def link_frames_world(robot, q) -> np.ndarray:
    """(n, 7, 4, 4) the link frames of joints q (n, 6) radians in the part frame (mm): the
    world of the scene. Robot holds the tool: the base stands where the cell puts it; robot
    holds the part: the arm moves about the standing part."""
    F = K.joint_frames(robot, q)
    if robot.holds_part:  # the part is on the flange: base = part⁻¹ · flange⁻¹
        W = np.linalg.inv(robot.part) @ np.linalg.inv(F[:, 6])
        return W[:, None] @ F
    return np.linalg.inv(robot.part_in_base()) @ F


def write_margin_points(name, tips, margin_deg, collection, size_mm: float):
    """A mesh of small diamonds at ``tips`` (n, 3) mm coloured by margin (degrees, (n,)):
    one material per bin of :data:`MARGIN_BINS_DEG`; the margins kept as the face attribute
    ``margin_deg``. Returns the object."""
    tips = np.asarray(tips, float)
    n = len(tips)
    s = 0.5 * size_mm
    D = np.array([[s, 0, 0], [-s, 0, 0], [0, s, 0], [0, -s, 0], [0, 0, s], [0, 0, -s]])
    Fd = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4],
                   [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    V = (tips[:, None, :] + D[None]).reshape(-1, 3)
    F = (Fd[None] + 6 * np.arange(n)[:, None, None]).reshape(-1, 3)
    ob = arrays_to_object(name, V, F, collection)
    mesh = ob.data
    for k, rgba in enumerate(MARGIN_RGBA):
        mesh.materials.append(colored_material(f"Blisk CAM robot margin {_COLOUR_NAMES[k]}",
                                               rgba))
    bins = np.repeat(margin_bin(margin_deg), len(Fd)).astype(np.int32)
    mesh.polygons.foreach_set("material_index", bins)
    attr = mesh.attributes.new("margin_deg", "FLOAT", "FACE")
    attr.data.foreach_set("value", np.repeat(np.asarray(margin_deg, np.float32), len(Fd)))
    mesh.update()
    return ob


def remove_objects(collection) -> None:
    """Remove every object of ``collection`` (the previous robot display)."""
    for ob in list(collection.objects):
        data = ob.data
        bpy.data.objects.remove(ob, do_unlink=True)
        if isinstance(data, bpy.types.Mesh) and data.users == 0:
            bpy.data.meshes.remove(data)


__all__ += ["remove_objects"]
