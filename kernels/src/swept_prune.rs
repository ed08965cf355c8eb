//! Steps 1–4 of the swept cutter's "fast" method for one point (`verify/sweep.py`,
//! `_fast_search`), with the cutter's distance at a pose evaluated only where it can matter.
//!
//! A child module of `swept_cutter` (it reads the profile's constants and the search state).
//! The figures are those of the plain steps bit for bit: the values, brackets and golden-
//! section searches of the moves that reach step 4 are the same floats in the same order;
//! what is skipped could not change them. The argument, per point:
//!
//! * the cutter lies in the slab 0 ≤ z ≤ h of its frame and within `Rm` (the profile's
//!   largest radius) of its axis, so at a pose its signed distance is at least
//!   `L = max(−z, z − h, ρ − Rm)` (inside the cutter too: straight down, straight up or
//!   radially out reaches its boundary within those lengths); `L` is lowered by a rounding
//!   allowance far above the evaluation's own rounding (1e-9 of the lengths);
//! * step 2's best `u2 = min(u0, values at the candidate moves' poses)`: a pose with
//!   `L > u0` has a value above `u0 ≥ u2`, so it neither lowers `u2` nor ties it (the
//!   segment named by the best is the last one reaching it): only poses with `L ≤ u0` are
//!   evaluated for it;
//! * step 2's motion bound `max(lb, (v0 + v1 − D)/2) < u2` decides which moves go on; with
//!   `L` in place of a value not evaluated the bound is lower (rounding is monotone), so a
//!   move it drops the exact bound drops too; a move it keeps is decided on the exact values,
//!   evaluated then;
//! * step 1's chord bound `max(−max(z0, z1), min(z0, z1) − h) − eps < u0` needs eps's square
//!   root only when the height part is below `u0` plus an upper bound of every move's eps in
//!   the leaf (see [`LeafReach`]): above it, the plain step drops the move too.
//!
//! Leaves are the caller's (sorted), moves in leaf order, as in the plain steps.

use super::{sd_in_frame, search_point, Pair, Profile, State, Tables};
use crate::numpy_ops::{nanmax, nanmin};

/// The largest radius of the cutter's profile (mm): every boundary point of the meridional
/// profile — the bottom line to B, the corner arc about (e, f) of radius r, the side S–T and
/// the top from T to the axis — lies within it.
fn max_radius(prof: &Profile) -> f64 {
    let m = prof.b[0].max(prof.s[0]).max(prof.t[0]).max(prof.e + prof.r);
    m * (1.0 + 1e-12) + 1e-12
}

/// A pose of a candidate leaf: the point relative to the tip, its height and squared
/// distance, the lower bound of the value, and the value once evaluated.
#[derive(Clone, Copy)]
struct Pose {
    x: [f64; 3],
    z: f64,
    n: f64,
    lb: f64,
    v: f64,
    have: bool,
}

/// A move that passed step 1: its poses (indices into the point's poses), leaf table row.
#[derive(Clone, Copy)]
struct Cand {
    sg: usize,
    p0: usize,
    a0: [f64; 3],
    phi: f64,
    reach: f64,
    eps: f64,
    lb: f64,
    dtip: f64,
}

/// `L` of the module docstring at a pose where the point is at height `z` above the tip and
/// `n` = |point − tip|² from it, lowered by the rounding allowance; −∞ for a NaN.
#[inline(always)]
fn lower_bound(z: f64, n: f64, h: f64, rm: f64) -> f64 {
    let rr = n - z * z;
    let rho = (if rr > 0.0 { rr } else { 0.0 }).sqrt();
    let lb = (-z).max(z - h).max(rho - rm) - 1e-9 * (1.0 + rho + z.abs());
    if lb.is_nan() {
        f64::NEG_INFINITY
    } else {
        lb
    }
}

#[inline(always)]
fn value(prof: &Profile, p: &mut Pose) -> f64 {
    if !p.have {
        let rr = p.n - p.z * p.z;
        p.v = prof.sd_rz((if rr > 0.0 || rr.is_nan() { rr } else { 0.0 }).sqrt(), p.z);
        p.have = true;
    }
    p.v
}

/// The buffers of [`fast_point`], kept by a worker from one point to the next (their
/// contents are each point's own: every one is cleared before use).
#[derive(Default)]
pub(super) struct Scratch {
    poses: Vec<Pose>,
    cands: Vec<Cand>,
    pairs: Vec<Pair>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    segs: Vec<usize>,
    live: Vec<State>,
}

/// `swept_cutter::fast_point` (steps 1–4 for one point and its candidate leaves) with the
/// pose values evaluated only where they can matter (module docstring): (u, arg).
#[allow(clippy::too_many_arguments)]
pub(super) fn fast_point(
    sc: &mut Scratch,
    prof: &Profile,
    tab: &Tables,
    reach: &[LeafReach],
    p: &[f64; 3],
    leaves: &[i64],
    u0: f64,
    arg0: i64,
    slack: f64,
    xtol: f64,
    delta: f64,
) -> (f64, i64) {
    let nb = tab.nb;
    let h = prof.h;
    let rm = max_radius(prof);
    let Scratch {
        poses,
        cands,
        pairs,
        lo,
        hi,
        segs,
        live,
    } = sc;
    poses.clear();
    cands.clear();
    pairs.clear();
    lo.clear();
    hi.clear();
    segs.clear();
    // 1. heights above the tips, the chord bound (the plain step's floats); a move whose
    // height bound alone is above u0 by more than the leaf's largest allowance is dropped
    // without its allowance's square root (the plain step drops it too)
    for &leaf in leaves {
        let l = leaf as usize;
        let base = poses.len();
        let skip_above = u0 + eps_bound(&reach[l], p, slack);
        for j in 0..=nb {
            let t = &tab.lt[l * (nb + 1) + j];
            let x = [p[0] - t[0], p[1] - t[1], p[2] - t[2]];
            let a = &tab.la[l * (nb + 1) + j];
            let z = super::dot3(&x, a);
            let n = super::dot3(&x, &x);
            poses.push(Pose {
                x,
                z,
                n,
                lb: f64::NAN,
                v: f64::INFINITY,
                have: false,
            });
        }
        for j in 0..nb {
            let sg = tab.ls[l * nb + j];
            if sg < 0 {
                continue;
            }
            let (q0, q1) = (&poses[base + j], &poses[base + j + 1]);
            let (z0, z1, n0, n1) = (q0.z, q1.z, q0.n, q1.n);
            if nanmax(-nanmax(z0, z1), nanmin(z0, z1) - h) >= skip_above {
                continue;
            }
            let phi = tab.lphi[l * nb + j];
            let dtip = tab.ldt[l * nb + j];
            let reach = nanmax(n0, n1).sqrt();
            let eps = (phi * phi * reach + 2.0 * phi * dtip) * (0.125 * (1.0 + 1e-9)) + slack;
            let lb = nanmax(-nanmax(z0, z1), nanmin(z0, z1) - h) - eps;
            if !(lb < u0) {
                continue;
            }
            cands.push(Cand {
                sg: sg as usize,
                p0: base + j,
                a0: tab.la[l * (nb + 1) + j],
                phi,
                reach,
                eps,
                lb,
                dtip,
            });
        }
    }
    // 2. the point's best so far: only poses that may reach u0 are evaluated
    for c in cands.iter() {
        for k in [c.p0, c.p0 + 1] {
            let q = &mut poses[k];
            if q.lb.is_nan() {
                q.lb = lower_bound(q.z, q.n, h, rm);
            }
            if !(q.lb > u0) {
                value(prof, &mut poses[k]);
            }
        }
    }
    let mut u = u0;
    for c in cands.iter() {
        u = nanmin(u, nanmin(poses[c.p0].v, poses[c.p0 + 1].v));
    }
    let mut arg = if u0 <= u { arg0 } else { -1 };
    for c in cands.iter() {
        if nanmin(poses[c.p0].v, poses[c.p0 + 1].v) <= u {
            arg = c.sg as i64;
        }
    }
    // the motion bound, then 3. convexity along the chord and 4. the golden-section search
    for c in cands.iter() {
        let dd = (c.dtip + c.phi * c.reach) * (1.0 + 1e-9) + slack;
        let (q0, q1) = (&poses[c.p0], &poses[c.p0 + 1]);
        let w0 = if q0.have { q0.v } else { q0.lb };
        let w1 = if q1.have { q1.v } else { q1.lb };
        if !(nanmax(c.lb, 0.5 * (w0 + w1 - dd)) < u) {
            continue;
        }
        let v0 = value(prof, &mut poses[c.p0]);
        let v1 = value(prof, &mut poses[c.p0 + 1]);
        let lb = nanmax(c.lb, 0.5 * (v0 + v1 - dd));
        if !(lb < u) {
            continue;
        }
        let (d0, d1) = (poses[c.p0].x, poses[c.p0 + 1].x);
        let (z0, n0) = (poses[c.p0].z, poses[c.p0].n);
        let k = &tab.kk[c.sg];
        let v = &d1;
        let (co, si) = ((-c.phi).cos(), (-c.phi).sin());
        let kv = super::dot3(k, v);
        let kx = [
            k[1] * v[2] - k[2] * v[1],
            k[2] * v[0] - k[0] * v[2],
            k[0] * v[1] - k[1] * v[0],
        ];
        let w = kv * (1.0 - co);
        let p1 = [
            v[0] * co + kx[0] * si + k[0] * w,
            v[1] * co + kx[1] * si + k[1] * w,
            v[2] * co + kx[2] * si + k[2] * w,
        ];
        let ch = [p1[0] - d0[0], p1[1] - d0[1], p1[2] - d0[2]];
        let g0 = sd_in_frame(
            prof,
            &[
                d0[0] + delta * ch[0],
                d0[1] + delta * ch[1],
                d0[2] + delta * ch[2],
            ],
            &c.a0,
        );
        let g1 = sd_in_frame(
            prof,
            &[
                p1[0] - delta * ch[0],
                p1[1] - delta * ch[1],
                p1[2] - delta * ch[2],
            ],
            &c.a0,
        );
        let s0 = (g0 - v0) / delta;
        let s1 = (g1 - v1) / delta;
        let uu = u + c.eps + 2.0 * delta * super::dot3(&ch, &ch).sqrt() + slack;
        // _bracket_below
        let (mut tlo, mut thi) = (0.0f64, 1.0f64);
        let ra = (uu - v0) / s0;
        let rb = 1.0 - (uu - v1) / s1;
        if s0 > 0.0 {
            thi = nanmin(thi, ra);
        }
        if s0 < 0.0 {
            tlo = nanmax(tlo, ra);
        }
        if s1 > 0.0 {
            tlo = nanmax(tlo, rb);
        }
        if s1 < 0.0 {
            thi = nanmin(thi, rb);
        }
        let dead = (s0 == 0.0 && v0 > uu)
            || (s1 == 0.0 && v1 > uu)
            || !uu.is_finite()
            || tlo.is_nan()
            || thi.is_nan();
        if dead {
            tlo = 1.0;
            thi = 0.0;
        }
        if !tab.chord_ok[c.sg] {
            tlo = 0.0;
            thi = 1.0;
        }
        if !(tlo <= thi) {
            continue;
        }
        let (ta, tb, b) = (&tab.ta[c.sg], &tab.tb[c.sg], &tab.bb[c.sg]);
        let dl = [tb[0] - ta[0], tb[1] - ta[1], tb[2] - ta[2]];
        pairs.push(Pair {
            za: z0,
            zb: super::dot3(&d0, b),
            ta: super::dot3(&dl, &c.a0),
            tb: super::dot3(&dl, b),
            n0,
            m2: 2.0 * super::dot3(&d0, &dl),
            l2: super::dot3(&dl, &dl),
            phi: c.phi,
            d: dd,
        });
        lo.push(tlo);
        hi.push(thi);
        segs.push(c.sg);
    }
    if pairs.is_empty() {
        return (u, arg);
    }
    let (best, i) = search_point(prof, pairs, lo, hi, 0, pairs.len(), u, xtol, live);
    if best < u {
        (best, segs[i.max(0) as usize] as i64)
    } else {
        (u, arg)
    }
}

/// What a leaf's moves can reach, from its first pose: every pose of the leaf has its tip
/// within `tt` of the first tip; `phi_max`, `dt_max` the largest turn and tip move of one
/// move.
pub(super) struct LeafReach {
    t0: [f64; 3],
    tt: f64,
    phi_max: f64,
    dt_max: f64,
}

/// [`LeafReach`] of every leaf of the tables.
pub(super) fn leaf_reach(tab: &Tables, nc: usize) -> Vec<LeafReach> {
    let nb = tab.nb;
    (0..nc)
        .map(|l| {
            let t0 = tab.lt[l * (nb + 1)];
            let mut tt = 0.0f64;
            for j in 1..=nb {
                let t = &tab.lt[l * (nb + 1) + j];
                let d = [t[0] - t0[0], t[1] - t0[1], t[2] - t0[2]];
                tt = tt.max(super::dot3(&d, &d).sqrt());
            }
            let (mut phi_max, mut dt_max) = (0.0f64, 0.0f64);
            for j in 0..nb {
                phi_max = phi_max.max(tab.lphi[l * nb + j]);
                dt_max = dt_max.max(tab.ldt[l * nb + j]);
            }
            // a rounding allowance: the norms are far more accurate than 1e-9
            LeafReach {
                t0,
                tt: tt * (1.0 + 1e-9) + 1e-12,
                phi_max,
                dt_max,
            }
        })
        .collect()
}

/// An upper bound of the allowance `eps` of step 1 of every move of the leaf for the point
/// (the reach from a pose's tip is at most |x0| + tt), with a rounding allowance: a move
/// whose height bound is at least `u0` plus it has `lb ≥ u0` in the plain step's floats.
#[inline]
fn eps_bound(lr: &LeafReach, p: &[f64; 3], slack: f64) -> f64 {
    let x = [p[0] - lr.t0[0], p[1] - lr.t0[1], p[2] - lr.t0[2]];
    let xl = super::dot3(&x, &x).sqrt() + lr.tt;
    let e = (lr.phi_max * lr.phi_max * xl + 2.0 * lr.phi_max * lr.dt_max) * (0.125 * (1.0 + 1e-6))
        + slack;
    e * (1.0 + 1e-9) + 1e-9 * (1.0 + xl)
}
