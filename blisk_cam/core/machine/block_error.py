"""Theoretical machining error of a 5-axis block: joint deviation → tool pose deviation →
over/undercut at the contact (paper 002, Wang et al., *Machines* 2025, 13, 768, §2.2–3.1).

Chain of the model, for a dense pose j of a planned pass (joint vector
``q_j = (X, Y, Z, θ1, θ2)``) and the joint-linear motion of one NC block passing near it:

1. **Trajectory deviation** (Eqs. 1–3). The machine moves every joint linearly between two
   blocks, so it leaves the planned joint curve C(v). At the chord point M_j that corresponds to
   C(v_j), the deviation is ``Δq_j = M_j − C(v_j)`` (linear part ΔQ_MT mm, rotary part ΔQ_MR rad).
   Eq. (1) picks M_j in the normal plane of the curve; joint space mixes mm and radians, so
   here the normal plane is taken in the tool's space (the chord parameter minimising
   ``|J_c Δq|``, J_c the corner-centre Jacobian below). To first order the error of step 3 does
   not depend on this choice (a shift along the curve moves the tool along the surface).
2. **Pose deviation** (Eqs. 4–7). ``ΔP_W = J_TT ΔQ_MT + J_TR ΔQ_MR`` and
   ``ΔO_W = J_RR ΔQ_MR`` (J_RT = 0) with the Jacobian of the forward model
   :func:`.machine.forward`. Eq. (6) is the closed form for the A/C trunnion; here J is taken by
   central differences of ``forward`` so it holds for every machine kind (exact in X, Y, Z,
   O(h²) ≈ 1e-10 relative in the rotaries).
3. **Over/undercut at the contact** (Eqs. 8–14). With the unit surface normal n_M at the CC
   point: the tip part ``l_P = ΔP_W · n_M`` (Eq. 8); the axis part: the axis turns by θ about
   ``t_ω = O_W × O_W'`` (Eq. 10) through the tip, which moves the centre C of the cutter's
   corner circle at the contact by ``n_ω = (R(t_ω, θ) − I)(C − P)`` (Eqs. 11–12) and the
   cutting edge (an arc about C) by the same, so ``l_θ = n_ω · n_M`` (Eq. 13);
   ``d_M = l_P + l_θ`` (Eq. 14), > 0 undercut (the tool stays off the surface), < 0 overcut.
   For a ball of radius ρ, ``C − P = ρ O_W`` and ``d_M = (ΔP_W + ρ ΔO_W) · n_M``.
   Linearised (θ small): ``l_P = g_P · Δq`` and ``l_θ = g_θ · Δq`` with the per-pose gradients
   of :func:`error_gradients`.

Lengths mm, angles radians; joint vectors are (X, Y, Z, θ1, θ2).
"""

from __future__ import annotations

import numpy as np

from .description import Machine, forward

__all__ = [
    "contact_lever",
    "error_gradients",
    "machine_jacobian",
    "pose_error",
]

_H_LIN = 1.0  # mm: forward is affine in X, Y, Z (any step is exact)
_H_ROT = 1e-5  # rad: central difference, O(h²) ≈ 1e-10 relative


def machine_jacobian(machine: Machine, q) -> tuple[np.ndarray, np.ndarray]:
    """Jacobian of the forward model at joints q (n, 5) = (X, Y, Z mm, θ1, θ2 rad).

    Returns ``JP`` (n, 3, 5): d tip / d q (columns 0–2 = J_TT, 3–4 = J_TR of paper 002 Eq. 6,
    mm/mm and mm/rad) and ``JO`` (n, 3, 5): d axis / d q (columns 0–2 = J_RT = 0, 3–4 = J_RR,
    1/rad), both in the paths' frame."""
    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    n = len(q)
    steps = np.array([_H_LIN, _H_LIN, _H_LIN, _H_ROT, _H_ROT])
    Q = np.repeat(q[None], 10, axis=0)  # (10, n, 5): +h, −h per joint
    for k in range(5):
        Q[2 * k, :, k] += steps[k]
        Q[2 * k + 1, :, k] -= steps[k]
    Qf = Q.reshape(-1, 5)
    tip, ax = forward(machine, Qf[:, :3], Qf[:, 3:])
    tip = tip.reshape(5, 2, n, 3)
    ax = ax.reshape(5, 2, n, 3)
    JP = ((tip[:, 0] - tip[:, 1]) / (2 * steps)[:, None, None]).transpose(1, 2, 0)
    JO = ((ax[:, 0] - ax[:, 1]) / (2 * steps)[:, None, None]).transpose(1, 2, 0)
    return JP, JO


def contact_lever(cutter, normal, axis) -> np.ndarray:
    """(n, 3) mm: ``C − P``, from the tool tip P to the centre C of the cutter's corner circle
    at the contact (paper 002 Fig. 8: the cutting edge is an arc about C). Ball: ``ρ O_W``;
    bull nose: ``e u + f O_W``; flat end (r = 0): the edge point. ``normal``, ``axis`` (n, 3)
    unit."""
    n = np.atleast_2d(np.asarray(normal, dtype=np.float64))
    _, info = cutter.contact(n, axis)
    return info.point + float(cutter.r) * n


def error_gradients(JP, JO, normal, axis, lever):
    """Linearised paper 002 Eqs. (8)–(14) per pose.

    Parameters: JP, JO (n, 3, 5) from :func:`machine_jacobian`; normal, axis (n, 3) unit;
    lever (n, 3) mm from :func:`contact_lever`.

    Returns ``gP`` (n, 5): ``l_P = gP · Δq`` (Eq. 8, tip part); ``gT`` (n, 5):
    ``l_θ = gT · Δq`` (Eqs. 10–13, axis part: the axis change ΔO = JO Δq is the rotation
    ω = O_W × ΔO, which moves C by ω × (C − P)); ``Jc`` (n, 3, 5): the Jacobian of C itself
    (``ΔC = Jc Δq``), so ``d_M = n · Jc Δq = (gP + gT) · Δq`` (Eq. 14)."""
    n = np.asarray(normal, dtype=np.float64)
    a = np.asarray(axis, dtype=np.float64)
    r = np.asarray(lever, dtype=np.float64)
    gP = np.einsum("ni,nik->nk", n, JP)
    # n · (ω × r) = ω · (r × n), ω = a × ΔO  ⇒  = ΔO · ((r × n) × a)
    w = np.cross(np.cross(r, n), a)
    gT = np.einsum("ni,nik->nk", w, JO)
    # ΔC = JP Δq + (a × JO Δq) × r = JP Δq − r × (a × JO Δq)
    # r × (a × v) = a (r·v) − v (r·a)
    ra = np.einsum("ni,ni->n", r, a)
    rJO = np.einsum("ni,nik->nk", r, JO)
    Jc = JP - (a[:, :, None] * rJO[:, None, :] - ra[:, None, None] * JO)
    return gP, gT, Jc


def pose_error(tip, axis, tip_dev, axis_dev, normal, lever, *, centre: bool = False):
    """Exact paper 002 Eqs. (8)–(14) for finite pose deviations (no linearisation).

    tip, axis (n, 3): the theoretical pose; tip_dev, axis_dev (n, 3): the deviated pose (tip mm,
    unit axis); normal (n, 3) unit surface normals n_M at the contacts; lever (n, 3) mm ``C − P``
    (:func:`contact_lever`). Returns ``(lP, lθ, dM)`` each (n,) mm: Eq. (8) ``lP = ΔP·n_M``;
    Eqs. (10)–(13) ``n_ω = M_C R(θ) M_C⁻¹ (C − P) − (C − P)`` with ``M_C = [O_W, t_ω,
    O_W × t_ω]``, ``lθ = n_ω · n_M``; Eq. (14) ``dM = lP + lθ``. With ``centre`` also the
    (n, 3) displacement of the corner centre C, ``ΔP + n_ω``."""
    a = np.atleast_2d(np.asarray(axis, dtype=np.float64))
    b = np.atleast_2d(np.asarray(axis_dev, dtype=np.float64))
    n = np.atleast_2d(np.asarray(normal, dtype=np.float64))
    r = np.atleast_2d(np.asarray(lever, dtype=np.float64))
    lP = np.einsum("ni,ni->n", np.asarray(tip_dev) - np.asarray(tip), n)
    t = np.cross(a, b)
    s = np.linalg.norm(t, axis=1)
    c = np.clip(np.einsum("ni,ni->n", a, b), -1.0, 1.0)
    theta = np.arctan2(s, c)
    safe = s > 1e-300
    t = np.where(safe[:, None], t / np.where(safe, s, 1.0)[:, None], 0.0)
    # Rodrigues about t_ω (the frame M_C of Eq. 12 rotates by θ about its second column)
    rr = (r * np.cos(theta)[:, None] + np.cross(t, r) * np.sin(theta)[:, None]
          + t * np.einsum("ni,ni->n", t, r)[:, None] * (1 - np.cos(theta))[:, None])
    n_w = rr - r
    lT = np.einsum("ni,ni->n", n_w, n)
    if centre:
        return lP, lT, lP + lT, np.asarray(tip_dev) - np.asarray(tip) + n_w
    return lP, lT, lP + lT
