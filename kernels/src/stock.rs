//! Material removal on the radial dexels of one sector (see `blisk_cam/core/stock/removal.py`,
//! the numpy reference): posed convex solids of revolution (meridional half-planes
//! nρ ρ + nz z ≤ c) met by the candidate rays of their (θ, z) boxes, each ray's intervals
//! merged and subtracted from its material, in parallel over the grid's z rows (a row's rays
//! are one block of the interval arrays, so every thread writes its own rays).
//!
//! The arithmetic of one ray–solid pair is the reference's (`ray_solid_intervals`), operation
//! for operation; the merge quantum and rule are `merge_intervals`'; the subtraction keeps
//! what `subtract_intervals` keeps. Pairs whose bounding interval (the ray inside the solid's
//! bounding cylinder, between its end planes) meets no material are skipped: subtracting
//! an interval from air changes nothing.

use crate::numpy_ops::sub;
use numpy::{
    PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyReadwriteArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

const EPS: f64 = 1e-12;
/// r quantum of the interval merge, mm (`dexels._R_QUANTUM`)
const R_QUANTUM: f64 = 1e-7;
/// widening of the bounding interval before the material test, mm
const CULL_MARGIN: f64 = 1e-6;

/// The grid of the stock (`RadialDexels`).
pub struct Grid {
    pub theta0: f64,
    pub d_theta: f64,
    pub z0: f64,
    pub dz: f64,
    pub n_theta: usize,
    pub n_z: usize,
    pub k: usize,
    /// origin, e1, e2, d of the axis' angular frame
    pub frame: [[f64; 3]; 4],
}

/// The group (the batch row) and the (θ, z) box of each solid or move: the grid's columns
/// c0..=c1 (unwrapped) and rows w0..=w1 its sweep can meet.
#[derive(Clone, Copy)]
pub struct ItemBoxes<'a> {
    pub group: &'a [i64],
    pub c0: &'a [i64],
    pub c1: &'a [i64],
    pub w0: &'a [i64],
    pub w1: &'a [i64],
}

impl<'a> ItemBoxes<'a> {
    /// The items' `group` ids and box columns (c0, c1, w0, w1) ([`box_columns`]).
    pub fn new(group: &'a [i64], [c0, c1, w0, w1]: &'a [Vec<i64>; 4]) -> Self {
        ItemBoxes {
            group,
            c0,
            c1,
            w0,
            w1,
        }
    }
}

/// Posed solids of one kind: tip, unit axis, group and box of each.
pub struct Solids<'a> {
    pub tips: &'a [[f64; 3]],
    pub axes: &'a [[f64; 3]],
    pub boxes: ItemBoxes<'a>,
    pub planes: &'a [[f64; 3]],
    pub z_lo: f64,
    pub z_hi: f64,
    pub radius: f64,
    /// per plane the ρ range of its edge (see `Profile`), or None
    pub rho: Option<&'a [[f64; 2]]>,
    /// the solid shrunk by the crash tolerance (measured with `measure`), or None
    pub planes_in: Option<&'a [[f64; 3]]>,
}

/// Where a solid can meet the rays of the grid row at height `zr` (mm, from the axis'
/// origin): the columns (unwrapped, within the solid's box) and the radii. The solid lies
/// within `r_b` of its axis segment, so its points in the row's plane lie within `r_b` of
/// the plane projection of the part of the segment within `r_b` in height. None: no ray.
#[inline]
fn row_reach(
    g: &Grid,
    tip: &[f64; 3],
    ax: &[f64; 3],
    s: &Solids,
    si: usize,
    zr: f64,
    r_b: f64,
) -> Option<(i64, i64, f64, f64)> {
    let b = &s.boxes;
    reach_in_row(g, tip, ax, s.z_lo, s.z_hi, b.c0[si], b.c1[si], zr, r_b)
}

/// `row_reach` of a cylinder about the axis segment tip + [z_lo, z_hi] · ax of radius `r_b`
/// whose box has the columns c0..c1.
#[allow(clippy::too_many_arguments)]
#[inline]
fn reach_in_row(
    g: &Grid,
    tip: &[f64; 3],
    ax: &[f64; 3],
    z_lo: f64,
    z_hi: f64,
    c0: i64,
    c1: i64,
    zr: f64,
    r_b: f64,
) -> Option<(i64, i64, f64, f64)> {
    let [o, e1, e2, d] = g.frame;
    let p0 = [
        tip[0] + z_lo * ax[0] - o[0],
        tip[1] + z_lo * ax[1] - o[1],
        tip[2] + z_lo * ax[2] - o[2],
    ];
    let p1 = [
        tip[0] + z_hi * ax[0] - o[0],
        tip[1] + z_hi * ax[1] - o[1],
        tip[2] + z_hi * ax[2] - o[2],
    ];
    let (h0, h1) = (dot(&p0, &d), dot(&p1, &d));
    let dh = h1 - h0;
    let pad = 1e-6 * (1.0 + h0.abs().max(h1.abs()));
    let (mut ta, mut tb) = if dh.abs() > 1e-12 {
        let a = (zr - r_b - pad - h0) / dh;
        let b = (zr + r_b + pad - h0) / dh;
        (a.min(b), a.max(b))
    } else if (zr - h0).abs() <= r_b + pad {
        (0.0, 1.0)
    } else {
        return None;
    };
    ta = ta.max(0.0);
    tb = tb.min(1.0);
    if ta > tb {
        return None;
    }
    let (x0, y0, x1, y1) = (dot(&p0, &e1), dot(&p0, &e2), dot(&p1, &e1), dot(&p1, &e2));
    let a = [x0 + ta * (x1 - x0), y0 + ta * (y1 - y0)];
    let b = [x0 + tb * (x1 - x0), y0 + tb * (y1 - y0)];
    let ab = [b[0] - a[0], b[1] - a[1]];
    let l2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = if l2 > 0.0 {
        (-(a[0] * ab[0] + a[1] * ab[1]) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let dmin = (a[0] + t * ab[0]).hypot(a[1] + t * ab[1]);
    let dmax = a[0].hypot(a[1]).max(b[0].hypot(b[1]));
    let scale = 1.0 + dmax;
    let rlo = dmin - r_b - 1e-6 * scale;
    let rhi = dmax + r_b + 1e-6 * scale;
    if dmin <= r_b + 1e-6 * scale {
        return Some((c0, c1, rlo, rhi));
    }
    let tha = a[1].atan2(a[0]);
    let mut thb = b[1].atan2(b[0]);
    let two_pi = 2.0 * std::f64::consts::PI;
    thb = tha + (thb - tha + std::f64::consts::PI).rem_euclid(two_pi) - std::f64::consts::PI;
    let w = (r_b / dmin).min(1.0).asin() + 1e-9;
    let (mut lo_t, mut hi_t) = (tha.min(thb) - w, tha.max(thb) + w);
    if (c1 - c0 + 3) as f64 * g.d_theta + (hi_t - lo_t) >= two_pi {
        return Some((c0, c1, rlo, rhi)); // the box could meet the range twice a turn apart
    }
    // to the 2π turn of the box's columns (a turn is N · n_theta columns: whole columns)
    let mid_box = g.theta0 + (0.5 * (c0 + c1) as f64 + 0.5) * g.d_theta;
    let turns = ((mid_box - 0.5 * (lo_t + hi_t)) / two_pi).round();
    lo_t += turns * two_pi;
    hi_t += turns * two_pi;
    let ca = ((lo_t - g.theta0) / g.d_theta - 0.5).ceil() as i64 - 1;
    let cb = ((hi_t - g.theta0) / g.d_theta - 0.5).floor() as i64 + 1;
    let (ca, cb) = (ca.max(c0), cb.min(c1));
    if ca > cb {
        return None;
    }
    Some((ca, cb, rlo, rhi))
}

/// What a call did: Σ (hi² − lo²)/2 removed (mm²), per group the material its own union
/// met before the removal (mm², Σ (hi² − lo²)/2) and the longest stretch (mm), and the rays
/// that needed more than K intervals with their new intervals (the caller grows K).
pub struct Outcome {
    pub removed: f64,
    pub group_vol: Vec<f64>,
    /// per group the material the union of the inner solid's intervals met (mm²)
    pub group_vol_in: Vec<f64>,
    pub group_depth: Vec<f64>,
    pub overflow_rays: Vec<i64>,
    pub overflow: Vec<Vec<(f64, f64)>>,
}

impl Outcome {
    fn new(n_groups: usize) -> Self {
        Outcome {
            removed: 0.0,
            group_vol: vec![0.0; n_groups],
            group_vol_in: vec![0.0; n_groups],
            group_depth: vec![0.0; n_groups],
            overflow_rays: Vec::new(),
            overflow: Vec::new(),
        }
    }

    /// Add the grid rows' outcomes (in row order).
    fn absorb(&mut self, rows: Vec<RowOut>) {
        for r in rows {
            self.removed += r.removed;
            for (g, v, dm, vi) in r.groups {
                self.group_vol[g] += v;
                self.group_vol_in[g] += vi;
                self.group_depth[g] = self.group_depth[g].max(dm);
            }
            for (ray, pc) in r.overflow {
                self.overflow_rays.push(ray);
                self.overflow.push(pc);
            }
        }
    }
}

#[inline]
fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The reference's per-pair quantities of a ray (origin o, direction u) against a pose.
struct RayFrame {
    z0: f64,
    zu: f64,
    a: f64,
    b: f64,
    c: f64,
    sa: f64,
}

#[inline]
fn ray_frame(o: &[f64; 3], u: &[f64; 3], tip: &[f64; 3], ax: &[f64; 3]) -> RayFrame {
    let dv = [o[0] - tip[0], o[1] - tip[1], o[2] - tip[2]];
    let z0 = dot(&dv, ax);
    let zu = dot(u, ax);
    let a = (1.0 - zu * zu).max(0.0);
    let b = 2.0 * (dot(&dv, u) - z0 * zu);
    let c = (dot(&dv, &dv) - z0 * z0).max(0.0);
    RayFrame {
        z0,
        zu,
        a,
        b,
        c,
        sa: a.sqrt(),
    }
}

/// The ray's interval inside the bounding cylinder ρ ≤ radius, z_lo ≤ z ≤ z_hi (a superset
/// of the solid's), or None.
#[inline]
fn bounding_interval(f: &RayFrame, z_lo: f64, z_hi: f64, radius: f64) -> Option<(f64, f64)> {
    let mut lo = 0.0f64;
    let mut hi = f64::INFINITY;
    // z_lo ≤ z0 + zu r ≤ z_hi
    if f.zu.abs() > EPS {
        let r1 = (z_lo - f.z0) / f.zu;
        let r2 = (z_hi - f.z0) / f.zu;
        lo = lo.max(r1.min(r2));
        hi = hi.min(r1.max(r2));
    } else if f.z0 < z_lo - CULL_MARGIN || f.z0 > z_hi + CULL_MARGIN {
        return None;
    }
    // A r² + B r + C ≤ R² (the roots in the stable form)
    let cc = f.c - radius * radius;
    if f.a > 0.0 {
        let disc = f.b * f.b - 4.0 * f.a * cc;
        if disc < 0.0 {
            return None;
        }
        let qq = -0.5
            * (f.b
                + if f.b >= 0.0 {
                    disc.sqrt()
                } else {
                    -disc.sqrt()
                });
        let r1 = qq / f.a;
        let r2 = if qq != 0.0 { cc / qq } else { r1 };
        lo = lo.max(r1.min(r2));
        hi = hi.min(r1.max(r2));
    } else if f.b.abs() > EPS {
        let r = -cc / f.b;
        if f.b > 0.0 {
            hi = hi.min(r);
        } else {
            lo = lo.max(r);
        }
    } else if cc > 0.0 {
        return None;
    }
    let scale = 1.0 + hi.abs().min(1e6);
    let m = CULL_MARGIN * scale;
    if hi + m < lo - m {
        return None;
    }
    Some((lo - m, hi + m))
}

/// One half-plane's interval along the ray (the reference's arithmetic), applied to (lo, hi).
#[inline]
fn apply_plane(f: &RayFrame, plane: &[f64; 3], lo: &mut f64, hi: &mut f64) {
    let [nr, nz, c] = *plane;
    if nr.abs() < EPS {
        let s = nz * f.zu;
        let rhs = c - nz * f.z0;
        let root = rhs / s;
        if s > EPS {
            *hi = hi.min(root);
        } else if s < -EPS {
            *lo = lo.max(root);
        } else if rhs < 0.0 {
            *hi = f64::NEG_INFINITY;
        }
        return;
    }
    let m0 = c - nz * f.z0;
    let m1 = -nz * f.zu;
    let a2 = nr * nr * f.a - m1 * m1;
    let a1 = nr * nr * f.b - 2.0 * m0 * m1;
    let a0 = nr * nr * f.c - m0 * m0;
    let disc = a1 * a1 - 4.0 * a2 * a0;
    let sq = disc.max(0.0).sqrt();
    let lin = a2.abs() < 1e-12;
    let qq = -0.5 * (a1 + if a1 >= 0.0 { sq } else { -sq });
    let (r1, r2) = if lin {
        (-a0 / a1, f64::NAN)
    } else {
        (qq / a2, a0 / qq)
    };
    let real = disc >= 0.0 || lin;
    let tol = 1e-9 * (1.0 + m0.abs());
    let v1 = real && r1.is_finite() && m0 + m1 * r1 >= -tol;
    let v2 = real && r2.is_finite() && m0 + m1 * r2 >= -tol;
    let (rlo, rhi) = if v1 && v2 {
        (r1.min(r2), r1.max(r2))
    } else if v1 || v2 {
        let v = if v1 { r1 } else { r2 };
        if nr * f.sa - m1 < 0.0 {
            (v, f64::INFINITY)
        } else {
            (f64::NEG_INFINITY, v)
        }
    } else if nr * f.c.sqrt() - m0 <= 0.0 {
        (f64::NEG_INFINITY, f64::INFINITY)
    } else {
        (f64::INFINITY, f64::NEG_INFINITY)
    };
    *lo = lo.max(rlo);
    *hi = hi.min(rhi);
}

/// The solid's half-planes and how to pick the ones that can bind on a ray.
pub struct Profile<'a> {
    pub planes: &'a [[f64; 3]],
    /// the reference's order (top, side, then the rest)
    pub order: Vec<usize>,
    /// per plane: evaluated on every ray (the top and the first two of `order`)
    pub always: Vec<bool>,
    /// per plane: the ρ range (mm) of its edge of the meridional polygon; None: no selection
    /// (every plane on every ray)
    pub rho: Option<&'a [[f64; 2]]>,
}

/// `ray_solid_intervals` for one pair (lo < hi: contact). With `rho` ranges (a profile whose
/// boundary below the top rises with ρ: z ≥ Z(ρ), Z increasing), a point of the ray outside
/// the solid but inside the top and side planes lies below the edge whose ρ range holds its
/// ρ, so only the edges whose ρ range meets the ray's ρ range inside (top ∩ side) can bind:
/// the others are skipped (the same values decide, the others hold the interval with room).
#[inline]
fn solid_interval(f: &RayFrame, p: &Profile) -> (f64, f64) {
    let mut lo = 0.0f64;
    let mut hi = f64::INFINITY;
    let Some(rho) = p.rho else {
        for &i in &p.order {
            apply_plane(f, &p.planes[i], &mut lo, &mut hi);
            if !(hi > lo) {
                return (lo, hi);
            }
        }
        return (lo, hi);
    };
    for &i in &p.order {
        if p.always[i] {
            apply_plane(f, &p.planes[i], &mut lo, &mut hi);
            if !(hi > lo) {
                return (lo, hi);
            }
        }
    }
    // ρ² = A r² + B r + C over [lo, hi]
    let (rmin, rmax) = if hi.is_finite() {
        let q = |r: f64| f.a * r * r + f.b * r + f.c;
        let (ql, qh) = (q(lo), q(hi));
        let mut qmin = ql.min(qh);
        let qmax = ql.max(qh);
        if f.a > 0.0 {
            let rs = -f.b / (2.0 * f.a);
            if rs > lo && rs < hi {
                qmin = qmin.min(q(rs));
            }
        }
        let pad = 1e-9 * (1.0 + f.c + f.b.abs() * hi.abs() + f.a * hi * hi);
        (
            (qmin - pad).max(0.0).sqrt(),
            (qmax + pad).max(0.0).sqrt() * (1.0 + 1e-9) + 1e-9,
        )
    } else if f.a == 0.0 {
        let r = f.c.sqrt();
        (r * (1.0 - 1e-9) - 1e-9, r * (1.0 + 1e-9) + 1e-9)
    } else {
        (0.0, f64::INFINITY)
    };
    for &i in &p.order {
        if p.always[i] || rho[i][1] < rmin || rho[i][0] > rmax {
            continue;
        }
        apply_plane(f, &p.planes[i], &mut lo, &mut hi);
        if !(hi > lo) {
            return (lo, hi);
        }
    }
    (lo, hi)
}

#[inline]
fn quantum(x: f64) -> i64 {
    (x / R_QUANTUM).round_ties_even() as i64
}

/// `merge_intervals` of one ray's (a, b) sorted by a: the union, merged as the reference does
/// (a run goes on while the next a, quantised, is not above the run's largest b, quantised).
fn merge_sorted(iv: &[(f64, f64)], out: &mut Vec<(f64, f64)>) {
    out.clear();
    let mut run_q = i64::MIN;
    for &(a, b) in iv {
        if !(b > a) {
            continue;
        }
        let aq = quantum(a);
        if out.is_empty() || aq > run_q {
            out.push((a, b));
        } else {
            let last = out.last_mut().unwrap();
            last.1 = last.1.max(b);
        }
        run_q = run_q.max(quantum(b));
    }
}

/// Σ (min(H, b)² − max(L, a)²)/2 and the overlap length of [a, b) with the material.
#[inline]
fn overlap(mat: &[(f64, f64)], a: f64, b: f64) -> (f64, f64) {
    let (mut v, mut l) = (0.0, 0.0);
    for &(lo, hi) in mat {
        let x0 = lo.max(a);
        let x1 = hi.min(b);
        if x1 > x0 {
            v += x1 * x1 - x0 * x0;
            l += x1 - x0;
        }
    }
    (0.5 * v, l)
}

struct RowOut {
    removed: f64,
    groups: Vec<(usize, f64, f64, f64)>,
    overflow: Vec<(i64, Vec<(f64, f64)>)>,
}

/// A hit of a grid row: (column, a, b, group, inner a, inner b).
type Hit = (usize, f64, f64, usize, f64, f64);

/// Subtract the union of a grid row's hits from its rays' material (and, with `measure`,
/// measure per group the material its union and its inner union met first).
#[allow(clippy::too_many_arguments)]
fn apply_hits(
    lrow: &mut [f64],
    hrow: &mut [f64],
    hits: &mut [Hit],
    k: usize,
    measure: bool,
    w: usize,
    nt: usize,
) -> RowOut {
    let mut ro = RowOut {
        removed: 0.0,
        groups: Vec::new(),
        overflow: Vec::new(),
    };
    if hits.is_empty() {
        return ro;
    }
    hits.sort_unstable_by(|x, y| (x.0, x.3).cmp(&(y.0, y.3)).then(x.1.total_cmp(&y.1)));
    let mut mat: Vec<(f64, f64)> = Vec::with_capacity(k);
    let mut iv: Vec<(f64, f64)> = Vec::new();
    let mut merged: Vec<(f64, f64)> = Vec::new();
    let mut pieces: Vec<(f64, f64)> = Vec::new();
    let mut p = 0;
    while p < hits.len() {
        let i = hits[p].0;
        let mut e = p;
        while e < hits.len() && hits[e].0 == i {
            e += 1;
        }
        let (lr, hr) = (&mut lrow[i * k..(i + 1) * k], &mut hrow[i * k..(i + 1) * k]);
        mat.clear();
        mat.extend(
            lr.iter()
                .zip(hr.iter())
                .filter(|(l, h)| h > l)
                .map(|(&l, &h)| (l, h)),
        );
        if measure {
            let mut g0 = p;
            while g0 < e {
                let g = hits[g0].3;
                let mut g1 = g0;
                while g1 < e && hits[g1].3 == g {
                    g1 += 1;
                }
                iv.clear();
                iv.extend(hits[g0..g1].iter().map(|h| (h.1, h.2)));
                merge_sorted(&iv, &mut merged);
                let (mut v, mut dmax) = (0.0, 0.0f64);
                for &(a, b) in &merged {
                    let (vv, ll) = overlap(&mat, a, b);
                    v += vv;
                    dmax = dmax.max(ll);
                }
                iv.clear();
                iv.extend(
                    hits[g0..g1]
                        .iter()
                        .filter(|h| h.5 > h.4)
                        .map(|h| (h.4, h.5)),
                );
                iv.sort_by(|x, y| x.0.total_cmp(&y.0));
                merge_sorted(&iv, &mut merged);
                let v_in: f64 = merged.iter().map(|&(a, b)| overlap(&mat, a, b).0).sum();
                if v != 0.0 || dmax > 0.0 {
                    ro.groups.push((g, v, dmax, v_in));
                }
                g0 = g1;
            }
        }
        iv.clear();
        iv.extend(hits[p..e].iter().map(|h| (h.1, h.2)));
        iv.sort_by(|x, y| x.0.total_cmp(&y.0));
        merge_sorted(&iv, &mut merged);
        // material minus the union, piece by piece (each material interval keeps its
        // parts outside every merged interval)
        pieces.clear();
        let mut before = 0.0;
        for &(l, h) in &mat {
            before += h * h - l * l;
            let mut cur = l;
            for &(a, b) in &merged {
                if b <= cur {
                    continue;
                }
                if a >= h {
                    break;
                }
                let end = h.min(a);
                if end > cur {
                    pieces.push((cur, end));
                }
                cur = cur.max(b);
                if cur >= h {
                    break;
                }
            }
            if h > cur {
                pieces.push((cur, h));
            }
        }
        let after: f64 = pieces.iter().map(|&(l, h)| h * h - l * l).sum();
        ro.removed += 0.5 * (before - after);
        pieces.sort_by(|x, y| x.0.total_cmp(&y.0));
        if pieces.len() > k {
            ro.overflow.push(((w * nt + i) as i64, pieces.clone()));
        } else {
            for t in 0..k {
                let (l, h) = pieces.get(t).copied().unwrap_or((0.0, 0.0));
                lr[t] = l;
                hr[t] = h;
            }
        }
        p = e;
    }
    ro
}

/// The items (solids or moves) whose column range `c0..=c1` and row range `w0..=w1` meet the
/// grid, bucketed by grid row (CSR: `by_row[start[j]..start[j + 1]]` for row `wmin + j`), and
/// the unit ray directions `dirs` of the unwrapped columns from `cmin` on that they span; None when
/// no item meets the grid.
struct RowBuckets {
    wmin: usize,
    nrow: usize,
    start: Vec<usize>,
    by_row: Vec<usize>,
    cmin: i64,
    dirs: Vec<[f64; 3]>,
    /// candidate ray–item pairs (each live item's rows × columns in the grid)
    pairs: u64,
}

fn row_buckets(grid: &Grid, boxes: &ItemBoxes) -> Option<RowBuckets> {
    let ItemBoxes { c0, c1, w0, w1, .. } = *boxes;
    let nz = grid.n_z as i64;
    let live: Vec<usize> = (0..c0.len())
        .filter(|&i| c1[i] >= c0[i] && w1[i] >= w0[i] && w0[i] < nz && w1[i] >= 0)
        .collect();
    if live.is_empty() {
        return None;
    }
    let wmin = live.iter().map(|&i| w0[i].max(0)).min().unwrap() as usize;
    let wmax = live.iter().map(|&i| w1[i].min(nz - 1)).max().unwrap() as usize;
    let nrow = wmax - wmin + 1;
    let mut start = vec![0usize; nrow + 1];
    for &i in &live {
        for w in w0[i].max(wmin as i64)..=w1[i].min(wmax as i64) {
            start[w as usize - wmin + 1] += 1;
        }
    }
    for j in 0..nrow {
        start[j + 1] += start[j];
    }
    let mut fill = start.clone();
    let mut by_row = vec![0usize; start[nrow]];
    for &i in &live {
        for w in w0[i].max(wmin as i64)..=w1[i].min(wmax as i64) {
            let j = w as usize - wmin;
            by_row[fill[j]] = i;
            fill[j] += 1;
        }
    }
    let cmin = live.iter().map(|&i| c0[i]).min().unwrap();
    let cmax = live.iter().map(|&i| c1[i]).max().unwrap();
    let [_, e1, e2, _] = grid.frame;
    let dirs: Vec<[f64; 3]> = (cmin..=cmax)
        .map(|c| {
            let ang = grid.theta0 + (c as f64 + 0.5) * grid.d_theta;
            let (sn, cs) = (ang.sin(), ang.cos());
            [
                cs * e1[0] + sn * e2[0],
                cs * e1[1] + sn * e2[1],
                cs * e1[2] + sn * e2[2],
            ]
        })
        .collect();
    let pairs: u64 = live
        .iter()
        .map(|&i| {
            let nw = (w1[i].min(nz - 1) - w0[i].max(0) + 1).max(0) as u64;
            nw * (c1[i] - c0[i] + 1) as u64
        })
        .sum();
    Some(RowBuckets {
        wmin,
        nrow,
        start,
        by_row,
        cmin,
        dirs,
        pairs,
    })
}

/// Remove the solids from the stock `lo`, `hi` ((n_rays, K) row-major, changed in place);
/// `measure`: also the material each group's union met (crash checks).
pub fn remove(
    grid: &Grid,
    s: &Solids,
    n_groups: usize,
    measure: bool,
    lo: &mut [f64],
    hi: &mut [f64],
) -> (Outcome, u64) {
    // the reference's plane order: the widest first (top, side), then the rest
    let profile = polygon_profile(s.planes, s.rho);
    let inner = s.planes_in.map(|pl| polygon_profile(pl, None));
    let r_b = s.radius;
    by_rows(grid, &s.boxes, n_groups, measure, lo, hi, |row, hits| {
        for &si in row.bucket {
            let (tip, ax) = (&s.tips[si], &s.axes[si]);
            let Some((ca, cb, rlo_w, rhi_w)) = row_reach(grid, tip, ax, s, si, row.zr, r_b) else {
                continue;
            };
            row.each_live_column((ca, cb), (rlo_w, rhi_w), |c, i, lr, hr| {
                let f = ray_frame(&row.origin, row.dir(c), tip, ax);
                let Some((ba, bb)) = bounding_interval(&f, s.z_lo, s.z_hi, s.radius) else {
                    return;
                };
                if !lr
                    .iter()
                    .zip(hr)
                    .any(|(&l, &h)| h > l && l.max(ba) < h.min(bb))
                {
                    return;
                }
                let (a, b) = solid_interval(&f, &profile);
                if b > a {
                    let (ai, bi) = match (&inner, measure) {
                        (Some(pin), true) => solid_interval(&f, pin),
                        _ => (0.0, f64::NEG_INFINITY),
                    };
                    hits.push((i, a, b, s.boxes.group[si] as usize, ai, bi));
                }
            });
        }
    })
}

/// A row of the grid's rays (n_theta columns × K intervals at height index w) as the work of
/// [`remove`] and [`sweep`] on it sees it: the rays' origin (mm), the items whose box meets
/// the row, its material (read only) and envelope, the columns' ray directions.
struct Row<'a> {
    /// the row's height (mm along the frame's axis) and the rays' origin there
    zr: f64,
    origin: [f64; 3],
    /// the items (solids or moves) whose box meets the row
    bucket: &'a [usize],
    env: RowEnvelope,
    lrow: &'a [f64],
    hrow: &'a [f64],
    k: usize,
    /// the unit ray directions of the columns `cmin..` (unwrapped)
    dirs: &'a [[f64; 3]],
    cmin: i64,
}

impl Row<'_> {
    /// The ray direction of the (unwrapped) column c.
    #[inline(always)]
    fn dir(&self, c: i64) -> &[f64; 3] {
        &self.dirs[(c - self.cmin) as usize]
    }

    /// [`each_live_column`] of this row.
    #[inline(always)]
    fn each_live_column<F: FnMut(i64, usize, &[f64], &[f64])>(
        &self,
        cols: (i64, i64),
        radii: (f64, f64),
        visit: F,
    ) {
        each_live_column(&self.env, self.lrow, self.hrow, self.k, cols, radii, visit)
    }
}

/// The skeleton of [`remove`] and [`sweep`]: the items' `boxes` bucketed by
/// grid row, the rows in parallel; per row that some item meets, `hits_of(row, hits)` lists
/// its hits, then they are subtracted from the row's stock `lo`, `hi` ((n_rays, K), changed
/// in place; with `measure` also measured per group). Returns the outcome and the
/// candidate ray–item pairs.
fn by_rows<F>(
    grid: &Grid,
    boxes: &ItemBoxes,
    n_groups: usize,
    measure: bool,
    lo: &mut [f64],
    hi: &mut [f64],
    hits_of: F,
) -> (Outcome, u64)
where
    F: Fn(&Row, &mut Vec<Hit>) + Sync,
{
    let (nt, k) = (grid.n_theta, grid.k);
    let mut out = Outcome::new(n_groups);
    let Some(RowBuckets {
        wmin,
        nrow,
        start,
        by_row,
        cmin,
        dirs,
        pairs,
    }) = row_buckets(grid, boxes)
    else {
        return (out, 0);
    };
    let wmax = wmin + nrow - 1;
    let [o, _, _, d] = grid.frame;
    let block = nt * k;
    let lo_rows = &mut lo[wmin * block..(wmax + 1) * block];
    let hi_rows = &mut hi[wmin * block..(wmax + 1) * block];
    let rows: Vec<RowOut> = lo_rows
        .par_chunks_mut(block)
        .zip(hi_rows.par_chunks_mut(block))
        .enumerate()
        .map(|(jr, (lrow, hrow))| {
            let w = wmin + jr;
            let zr = grid.z0 + (w as f64 + 0.5) * grid.dz;
            let mut hits: Vec<Hit> = Vec::new();
            let bucket = &by_row[start[jr]..start[jr + 1]];
            if bucket.is_empty() {
                return RowOut {
                    removed: 0.0,
                    groups: Vec::new(),
                    overflow: Vec::new(),
                };
            }
            let row = Row {
                zr,
                origin: [o[0] + zr * d[0], o[1] + zr * d[1], o[2] + zr * d[2]],
                bucket,
                env: RowEnvelope::new(lrow, hrow, nt, k),
                lrow,
                hrow,
                k,
                dirs: &dirs,
                cmin,
            };
            hits_of(&row, &mut hits);
            apply_hits(lrow, hrow, &mut hits, k, measure, w, nt)
        })
        .collect();
    out.absorb(rows);
    (out, pairs)
}

// ------------------------------------------------------------------------------------------
// Swept volumes per move (`removal.simulate_moves` with the compiled kernel)

/// A primitive of a tool solid in the tool frame (z up the axis from the tip, ρ from it): a
/// ball (centre height `zc`, radius) or a frustum ρ ≤ r1 + (r2 − r1)(z − z1)/(z2 − z1),
/// z1 ≤ z ≤ z2 (a cylinder, a cone, a disc-ended slab).
#[derive(Clone, Copy, Debug)]
pub enum Prim {
    Ball { zc: f64, rad: f64 },
    Frustum { z1: f64, r1: f64, z2: f64, r2: f64 },
}

/// The moves of one batch: per move its start and end pose, group (row of the batch), the
/// (θ, z) box of the rays its whole sweep can meet, the knots of its balls' centre paths,
/// the knots of its frustums' translational sweeps (0: by the samples) and the samples.
pub struct Moves<'a> {
    pub t0: &'a [[f64; 3]],
    pub a0: &'a [[f64; 3]],
    pub t1: &'a [[f64; 3]],
    pub a1: &'a [[f64; 3]],
    pub boxes: ItemBoxes<'a>,
    pub knots: &'a [i64],
    pub fknots: &'a [i64],
    pub samples: &'a [i64],
}

/// The solid swept: the union of `prims` (exact sweeps) and, when given, the polygon
/// `poly` (sampled poses); the inner versions for the crash measure; the bounding cylinder
/// (z_lo..z_hi, radius) of the whole solid about the tool axis.
pub struct Tool<'a> {
    pub prims: Vec<Prim>,
    pub prims_in: Vec<Prim>,
    pub poly: Option<Profile<'a>>,
    pub poly_in: Option<Profile<'a>>,
    pub z_lo: f64,
    pub z_hi: f64,
    pub radius: f64,
    /// the samples start after the start pose (t ∈ (0, 1], the reference's sub-poses: the
    /// start pose is the previous move's end, measured with it)
    pub open_start: bool,
}

#[inline]
fn axpy(p: &[f64; 3], s: f64, v: &[f64; 3]) -> [f64; 3] {
    [p[0] + s * v[0], p[1] + s * v[1], p[2] + s * v[2]]
}

/// Unit axis between a0 and a1 at fraction t (spherical linear interpolation, as the
/// reference's `_slerp_rows`).
fn slerp(a0: &[f64; 3], a1: &[f64; 3], t: f64) -> [f64; 3] {
    let c = dot(a0, a1).clamp(-1.0, 1.0);
    let om = c.acos();
    let so = om.sin();
    let (w0, w1) = if so < 1e-9 {
        (1.0 - t, t)
    } else {
        (((1.0 - t) * om).sin() / so, (t * om).sin() / so)
    };
    let v = [
        w0 * a0[0] + w1 * a1[0],
        w0 * a0[1] + w1 * a1[1],
        w0 * a0[2] + w1 * a1[2],
    ];
    let n = dot(&v, &v).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// Real roots of α s² + β s + γ (stable form), or None; (s1 ≤ s2).
#[inline]
fn roots(al: f64, be: f64, ga: f64) -> Option<(f64, f64)> {
    let disc = be * be - 4.0 * al * ga;
    if disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    let q = -0.5 * (be + if be >= 0.0 { sq } else { -sq });
    if q == 0.0 {
        return Some((0.0, 0.0));
    }
    let (r1, r2) = (q / al, ga / q);
    Some((r1.min(r2), r1.max(r2)))
}

/// The ray o + r u within the ball of radius `rad` about `c`: (lo, hi), lo > hi when missed.
#[inline]
fn sphere_interval(o: &[f64; 3], u: &[f64; 3], c: &[f64; 3], rad: f64) -> (f64, f64) {
    let w = sub(o, c);
    let b = dot(&w, u);
    let disc = b * b - (dot(&w, &w) - rad * rad);
    if disc < 0.0 {
        return (f64::INFINITY, f64::NEG_INFINITY);
    }
    let s = disc.sqrt();
    (-b - s, -b + s)
}

/// The ray o + r u within the ball of radius `rad` swept by its centre from c0 to c1 (a
/// capsule): (lo, hi), lo > hi when missed.
#[inline]
fn capsule_interval(
    o: &[f64; 3],
    u: &[f64; 3],
    c0: &[f64; 3],
    c1: &[f64; 3],
    rad: f64,
) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let r2 = rad * rad;
    for c in [c0, c1] {
        // a miss is (+inf, -inf) and a NaN discriminant (NaN, NaN): min/max keep lo, hi
        let (a, b) = sphere_interval(o, u, c, rad);
        lo = lo.min(a);
        hi = hi.max(b);
    }
    let dv = sub(c1, c0);
    let l2 = dot(&dv, &dv);
    if l2 > 1e-24 {
        let l = l2.sqrt();
        let dh = [dv[0] / l, dv[1] / l, dv[2] / l];
        let w = sub(o, c0);
        let wd = dot(&w, &dh);
        let ud = dot(u, &dh);
        let a = 1.0 - ud * ud;
        if a > 1e-14 {
            let b = 2.0 * (dot(&w, u) - wd * ud);
            let c = dot(&w, &w) - wd * wd - r2;
            if let Some((r1, r2)) = roots(a, b, c) {
                let (mut x, mut y) = (r1, r2);
                if ud.abs() > 1e-14 {
                    let (s1, s2) = (-wd / ud, (l - wd) / ud);
                    x = x.max(s1.min(s2));
                    y = y.min(s1.max(s2));
                } else if wd < 0.0 || wd > l {
                    x = f64::INFINITY;
                }
                if y >= x {
                    lo = lo.min(x);
                    hi = hi.max(y);
                }
            }
        }
    }
    (lo, hi)
}

/// The ray o + r u within the frustum (tool frame: tip `tip`, unit axis `ax`) swept by the
/// translation `dl` of its tip (t ∈ [0, 1]): the extremes of r over the convex set F of
/// (r, t) with ρ(r, t) ≤ m(r, t), z1 ≤ z(r, t) ≤ z2, 0 ≤ t ≤ 1 — ρ the norm of an affine
/// map, z and m affine — found among F's points on its four edge lines and on the line where
/// the cone's boundary is tangent to r = const (every extreme of a linear function over F
/// lies on one of them). (lo, hi), lo > hi when missed.
#[allow(clippy::too_many_arguments)]
fn frustum_sweep_interval(
    o: &[f64; 3],
    u: &[f64; 3],
    tip: &[f64; 3],
    ax: &[f64; 3],
    dl: &[f64; 3],
    z1: f64,
    r1: f64,
    z2: f64,
    r2: f64,
) -> (f64, f64) {
    let k = if z2 > z1 { (r2 - r1) / (z2 - z1) } else { 0.0 };
    let w0 = sub(o, tip);
    let z0 = dot(&w0, ax);
    let zu = dot(u, ax);
    let zd = dot(dl, ax);
    let p0 = axpy(&w0, -z0, ax);
    let pu = axpy(u, -zu, ax);
    let pd = axpy(dl, -zd, ax);
    // m = r1 + k (z − z1) = m0 + mr r + mt t
    let m0 = r1 + k * (z0 - z1);
    let (mr, mt) = (k * zu, -k * zd);
    // g = ρ² − m² = grr r² + 2 grt r t + gtt t² + 2 gr r + 2 gt t + g0
    let grr = dot(&pu, &pu) - mr * mr;
    let grt = -dot(&pu, &pd) - mr * mt;
    let gtt = dot(&pd, &pd) - mt * mt;
    let gr = dot(&p0, &pu) - m0 * mr;
    let gt = -dot(&p0, &pd) - m0 * mt;
    let g0 = dot(&p0, &p0) - m0 * m0;
    // linear constraints cr r + ct t + c0 ≥ 0
    let lin = [
        (0.0, 1.0, 0.0),
        (0.0, -1.0, 1.0),
        (zu, -zd, z0 - z1),
        (-zu, zd, z2 - z0),
    ];
    let scale = 1.0 + w0[0].abs() + w0[1].abs() + w0[2].abs() + r2.abs().max(r1.abs()) + z2.abs();
    let ltol = 1e-12 * scale;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut on_line = |pr: f64, pt: f64, vr: f64, vt: f64| {
        // s range within the linear constraints
        let (mut sa, mut sb) = (f64::NEG_INFINITY, f64::INFINITY);
        for &(cr, ct, c0) in &lin {
            let c = cr * pr + ct * pt + c0;
            let v = cr * vr + ct * vt;
            if v.abs() <= 1e-14 {
                if c < -ltol {
                    return;
                }
            } else if v > 0.0 {
                sa = sa.max((-c - ltol) / v);
            } else {
                sb = sb.min((-c - ltol) / v);
            }
        }
        if !(sb >= sa) {
            return;
        }
        // g along the line: al s² + be s + ga ≤ 0
        let al = grr * vr * vr + 2.0 * grt * vr * vt + gtt * vt * vt;
        let be =
            2.0 * (grr * pr * vr + grt * (pr * vt + pt * vr) + gtt * pt * vt + gr * vr + gt * vt);
        let ga = grr * pr * pr
            + 2.0 * grt * pr * pt
            + gtt * pt * pt
            + 2.0 * gr * pr
            + 2.0 * gt * pt
            + g0;
        let gs = 1e-12 * (1.0 + ga.abs() + be.abs() + al.abs());
        let (x, y) = if al.abs() <= 1e-13 * (1.0 + grr.abs() + gtt.abs()) {
            if be.abs() <= gs {
                if ga > gs {
                    return;
                }
                (sa, sb)
            } else if be > 0.0 {
                (sa, sb.min(-ga / be))
            } else {
                (sa.max(-ga / be), sb)
            }
        } else if al > 0.0 {
            match roots(al, be, ga) {
                Some((s1, s2)) => (sa.max(s1), sb.min(s2)),
                None => return,
            }
        } else {
            match roots(al, be, ga) {
                None => (sa, sb),
                Some((s1, s2)) => {
                    let left = (sa, sb.min(s1));
                    let right = (sa.max(s2), sb);
                    match (left.1 >= left.0, right.1 >= right.0) {
                        (true, true) => (left.0, right.1),
                        (true, false) => left,
                        (false, true) => right,
                        _ => return,
                    }
                }
            }
        };
        if !(y >= x) || !x.is_finite() || !y.is_finite() {
            return;
        }
        for s in [x, y] {
            let r = pr + s * vr;
            lo = lo.min(r);
            hi = hi.max(r);
        }
    };
    // the edges t = 0, t = 1
    on_line(0.0, 0.0, 1.0, 0.0);
    on_line(0.0, 1.0, 1.0, 0.0);
    // the edges z = z1, z = z2
    for zc in [z1, z2] {
        if zu.abs() > 1e-12 {
            on_line((zc - z0) / zu, 0.0, zd / zu, 1.0);
        } else if zd.abs() > 1e-12 {
            on_line(0.0, (z0 - zc) / zd, 1.0, 0.0);
        }
    }
    // ∂g/∂t = 0: grt r + gtt t + gt = 0
    if gtt.abs() > 1e-13 * (1.0 + grr.abs()) {
        on_line(0.0, -gt / gtt, 1.0, -grt / gtt);
    }
    (lo, hi)
}

/// One move's poses: the knots (tip, axis) of its balls' centre paths, the knots (tip, mid
/// axis, translation) of its frustums' translational sweeps (empty: the frustums are swept by
/// the samples), the samples (tip, axis) and the mid pose.
struct MovePoses {
    knots: Vec<([f64; 3], [f64; 3])>,
    fknots: Vec<([f64; 3], [f64; 3], [f64; 3])>,
    samples: Vec<([f64; 3], [f64; 3])>,
    /// the pose halfway (tip, axis): every pose of the move is the mid pose turned by at most
    /// half the axis turn about the tip and moved by at most half the tip's travel
    mid: ([f64; 3], [f64; 3]),
    /// the tip's travel (mm) and the axis turn (rad)
    dist: f64,
    ang: f64,
}

fn move_poses(mv: &Moves, i: usize, tool: &Tool) -> MovePoses {
    let (t0, a0, t1, a1) = (&mv.t0[i], &mv.a0[i], &mv.t1[i], &mv.a1[i]);
    let dl = sub(t1, t0);
    let pose = |t: f64| (axpy(t0, t, &dl), slerp(a0, a1, t));
    let nk = mv.knots[i].max(1) as usize;
    let knots = (0..=nk).map(|j| pose(j as f64 / nk as f64)).collect();
    let nf = mv.fknots[i].max(0) as usize;
    let fknots = (0..nf)
        .map(|j| {
            let (ta, tb) = (j as f64 / nf as f64, (j + 1) as f64 / nf as f64);
            let p = axpy(t0, ta, &dl);
            let q = axpy(t0, tb, &dl);
            (p, slerp(a0, a1, 0.5 * (ta + tb)), sub(&q, &p))
        })
        .collect();
    let need = tool.poly.is_some()
        || (nf == 0 && tool.prims.iter().any(|p| matches!(p, Prim::Frustum { .. })));
    let ns = mv.samples[i].max(1) as usize;
    let first = usize::from(tool.open_start);
    let samples = if need {
        (first..=ns).map(|j| pose(j as f64 / ns as f64)).collect()
    } else {
        Vec::new()
    };
    let ang = dot(a0, a1).clamp(-1.0, 1.0).acos();
    let dist = dot(&dl, &dl).sqrt();
    MovePoses {
        knots,
        fknots,
        samples,
        mid: pose(0.5),
        dist,
        ang,
    }
}

/// A part of the swept solid culled on its own: a primitive (swept exactly) or the polygon
/// (`poly`, by the samples), of the solid or of its inner solid (`inner`: the crash
/// measure's), with a cylinder about the tool axis that holds it (z_lo..z_hi, radius) and
/// that cylinder's farthest point from the tip (`reach`, mm).
struct Part<'a> {
    prim: Option<Prim>,
    poly: Option<&'a Profile<'a>>,
    inner: bool,
    z_lo: f64,
    z_hi: f64,
    radius: f64,
    reach: f64,
}

/// The tool's parts (the inner solid's too when `measure`): each primitive with its own
/// bounding cylinder, the polygon with the tool's.
fn tool_parts<'a>(tool: &'a Tool, measure: bool) -> Vec<Part<'a>> {
    let mut out = Vec::new();
    let mut add = |prims: &[Prim], poly: Option<&'a Profile<'a>>, inner: bool| {
        for p in prims {
            // a ball's points move with its centre (it turns about it): its reach is zc
            let (z_lo, z_hi, radius, reach) = match *p {
                Prim::Ball { zc, rad } => (zc - rad, zc + rad, rad, zc.abs()),
                Prim::Frustum { z1, r1, z2, r2 } => {
                    (z1, z2, r1.max(r2), z1.abs().max(z2.abs()).hypot(r1.max(r2)))
                }
            };
            out.push(Part {
                prim: Some(*p),
                poly: None,
                inner,
                z_lo,
                z_hi,
                radius,
                reach,
            });
        }
        if let Some(pf) = poly {
            // up to its top plane (a bull nose's corner ends at the side's tangent height)
            let top = pf
                .planes
                .iter()
                .filter(|p| p[0].abs() < EPS && p[1] > 0.0)
                .map(|p| p[2] / p[1])
                .fold(f64::INFINITY, f64::min);
            let z_hi = tool.z_hi.min(top + 1e-3);
            let reach = tool.z_lo.abs().max(z_hi.abs()).hypot(tool.radius);
            out.push(Part {
                prim: None,
                poly: Some(pf),
                inner,
                z_lo: tool.z_lo,
                z_hi,
                radius: tool.radius,
                reach,
            });
        }
    };
    add(&tool.prims, tool.poly.as_ref(), false);
    if measure {
        add(&tool.prims_in, tool.poly_in.as_ref(), true);
    }
    out
}

/// The pieces (a, b) of the ray o + r u inside the part's sweep over the move, appended to
/// `out` (unclipped at r = 0): a ball by the capsules between its centres at the knots (its
/// centre path's chords), a frustum by its translational sweeps between knots (the mid axis)
/// or by the samples, the polygon by the samples.
fn part_pieces(o: &[f64; 3], u: &[f64; 3], mp: &MovePoses, part: &Part, out: &mut Vec<(f64, f64)>) {
    let mut push = |(a, b): (f64, f64)| {
        if b > a {
            out.push((a, b));
        }
    };
    match part.prim {
        Some(Prim::Ball { zc, rad }) => {
            for j in 0..mp.knots.len() - 1 {
                let ((ta, aa), (tb, ab)) = (&mp.knots[j], &mp.knots[j + 1]);
                push(capsule_interval(
                    o,
                    u,
                    &axpy(ta, zc, aa),
                    &axpy(tb, zc, ab),
                    rad,
                ));
            }
        }
        Some(Prim::Frustum { z1, r1, z2, r2 }) => {
            if mp.fknots.is_empty() {
                let planes = frustum_planes(z1, r1, z2, r2);
                for (tp, ax) in &mp.samples {
                    let f = ray_frame(o, u, tp, ax);
                    let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
                    for pl in &planes {
                        apply_plane(&f, pl, &mut lo, &mut hi);
                        if !(hi > lo) {
                            break;
                        }
                    }
                    push((lo, hi));
                }
            } else {
                for (tp, ax, dl) in &mp.fknots {
                    push(frustum_sweep_interval(o, u, tp, ax, dl, z1, r1, z2, r2));
                }
            }
        }
        None => {
            if let Some(pf) = part.poly {
                for (tp, ax) in &mp.samples {
                    let f = ray_frame(o, u, tp, ax);
                    push(solid_interval(&f, pf));
                }
            }
        }
    }
}

/// The frustum's half-planes (nρ, nz, c): the top, the side, the bottom (the reference's
/// `frustum_halfplanes` order: widest first).
fn frustum_planes(z1: f64, r1: f64, z2: f64, r2: f64) -> [[f64; 3]; 3] {
    let (dr, dz) = (r2 - r1, z2 - z1);
    let l = dr.hypot(dz);
    let (nr, nz) = if l > 0.0 {
        (dz / l, -dr / l)
    } else {
        (1.0, 0.0)
    };
    [
        [0.0, 1.0, z2],
        [nr, nz, nr * r1 + nz * z1],
        [0.0, -1.0, -z1],
    ]
}

/// Merge the (unsorted) pieces in place into disjoint sorted intervals clipped at r ≥ 0.
fn merge_pieces(v: &mut Vec<(f64, f64)>) {
    for p in v.iter_mut() {
        p.0 = p.0.max(0.0);
    }
    v.retain(|p| p.1 > p.0);
    v.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut n = 0;
    for i in 0..v.len() {
        if n > 0 && v[i].0 <= v[n - 1].1 {
            v[n - 1].1 = v[n - 1].1.max(v[i].1);
        } else {
            v[n] = v[i];
            n += 1;
        }
    }
    v.truncate(n);
}

/// What `stock_sweep` can do: 2 — every part culled on its own, and `open_start` (the body
/// swept by the reference's sub-poses).
pub const SWEEP_REVISION: i64 = 2;

/// Columns per block of a grid row's material envelope.
const ENV_BLOCK: usize = 16;

/// The columns `ca..=cb` (unwrapped; the index mod `nt`) of one grid row whose material can
/// lie within the radii (`rlo`, `rhi`): whole blocks are skipped by the row's envelope, then
/// single columns by their own intervals; `visit(c, i, lo, hi)` for each one left, with the
/// column's K intervals.
#[inline(always)]
fn each_live_column<F: FnMut(i64, usize, &[f64], &[f64])>(
    env: &RowEnvelope,
    lrow: &[f64],
    hrow: &[f64],
    k: usize,
    (ca, cb): (i64, i64),
    (rlo, rhi): (f64, f64),
    mut visit: F,
) {
    let nt = env.nt as i64;
    let mut c = ca - 1;
    while c < cb {
        c += 1;
        let i = c.rem_euclid(nt) as usize;
        if let Some(skip) = env.skip(i, rlo, rhi) {
            c += skip as i64 - 1;
            continue;
        }
        let (lr, hr) = (&lrow[i * k..(i + 1) * k], &hrow[i * k..(i + 1) * k]);
        if lr
            .iter()
            .zip(hr)
            .any(|(&l, &h)| h > l && l < rhi && h > rlo)
        {
            visit(c, i, lr, hr);
        }
    }
}

/// The material of a grid row in blocks of `ENV_BLOCK` columns: per block the smallest lo and
/// the largest hi of its rays' material (a block without material: +∞, −∞), so that a run of
/// columns none of whose material can meet a radius range is skipped at once.
struct RowEnvelope {
    lo: Vec<f64>,
    hi: Vec<f64>,
    nt: usize,
}

impl RowEnvelope {
    fn new(lrow: &[f64], hrow: &[f64], nt: usize, k: usize) -> Self {
        let nb = nt.div_ceil(ENV_BLOCK);
        let (mut lo, mut hi) = (vec![f64::INFINITY; nb], vec![f64::NEG_INFINITY; nb]);
        for i in 0..nt {
            let b = i / ENV_BLOCK;
            for t in i * k..(i + 1) * k {
                let (l, h) = (lrow[t], hrow[t]);
                if h > l {
                    lo[b] = lo[b].min(l);
                    hi[b] = hi[b].max(h);
                }
            }
        }
        RowEnvelope { lo, hi, nt }
    }

    /// None when column `i`'s block may hold material within (rlo, rhi); otherwise the number
    /// of columns from `i` to the block's end (all of them skipped).
    #[inline]
    fn skip(&self, i: usize, rlo: f64, rhi: f64) -> Option<usize> {
        let b = i / ENV_BLOCK;
        if self.lo[b] < rhi && self.hi[b] > rlo {
            return None;
        }
        Some(((b + 1) * ENV_BLOCK).min(self.nt) - i)
    }
}

/// Remove the moves' swept solids from the stock `lo`, `hi` ((n_rays, K) row-major, changed
/// in place); `measure`: per group the material its own sweep met (and its inner sweep's).
/// Returns what `remove` returns; the count is the candidate ray–move pairs.
///
/// Every part of the solid (`tool_parts`) is culled on its own, in each grid row, by its
/// bounding cylinder about the move's mid pose grown by what the move can move it (half the
/// tip's travel + the part's reach × half the axis turn): the columns of the row it can meet,
/// then per ray the material within the row's radii, then within the cylinder. A piece that
/// lies wholly outside the ray's material hull (beyond its outermost or before its innermost
/// material, by more than the merge quantum) is dropped: it can neither remove material nor
/// join two stretches of it, so what is removed and measured is the same without it.
pub fn sweep(
    grid: &Grid,
    mv: &Moves,
    tool: &Tool,
    n_groups: usize,
    measure: bool,
    lo: &mut [f64],
    hi: &mut [f64],
) -> (Outcome, u64) {
    let m = mv.t0.len();
    let poses: Vec<MovePoses> = (0..m).map(|i| move_poses(mv, i, tool)).collect();
    let parts = tool_parts(tool, measure);
    let bx = &mv.boxes;
    by_rows(grid, bx, n_groups, measure, lo, hi, |row, hits| {
        let mut pcs: Vec<(f64, f64)> = Vec::new();
        for &mi in row.bucket {
            let mp = &poses[mi];
            let (tip, ax) = (&mp.mid.0, &mp.mid.1);
            let g = bx.group[mi] as usize;
            for part in &parts {
                let gr = 0.5 * (mp.dist + part.reach * mp.ang) + 1e-6;
                let (zl, zh, rb) = (part.z_lo - gr, part.z_hi + gr, part.radius + gr);
                let Some((ca, cb, rlo_w, rhi_w)) =
                    reach_in_row(grid, tip, ax, zl, zh, bx.c0[mi], bx.c1[mi], row.zr, rb)
                else {
                    continue;
                };
                row.each_live_column((ca, cb), (rlo_w, rhi_w), |c, i, lr, hr| {
                    let (origin, u) = (&row.origin, row.dir(c));
                    let bound = match part.prim {
                        // a ball's sweep lies in the ball about its mid centre grown by gr
                        Some(Prim::Ball { zc, rad }) => {
                            let (a, b) = sphere_interval(origin, u, &axpy(tip, zc, ax), rad + gr);
                            if b >= a {
                                Some((a - CULL_MARGIN, b + CULL_MARGIN))
                            } else {
                                None
                            }
                        }
                        _ => bounding_interval(&ray_frame(origin, u, tip, ax), zl, zh, rb),
                    };
                    let Some((ba, bb)) = bound else {
                        return;
                    };
                    let (mut ml, mut mh) = (f64::INFINITY, f64::NEG_INFINITY);
                    let mut meets = false;
                    for (&l, &h) in lr.iter().zip(hr) {
                        if h > l {
                            ml = ml.min(l);
                            mh = mh.max(h);
                            meets |= l.max(ba) < h.min(bb);
                        }
                    }
                    if !meets {
                        return;
                    }
                    pcs.clear();
                    part_pieces(origin, u, mp, part, &mut pcs);
                    merge_pieces(&mut pcs);
                    for &(a, b) in &pcs {
                        if a < mh + CULL_MARGIN && b > ml - CULL_MARGIN {
                            hits.push(if part.inner {
                                (i, 0.0, f64::NEG_INFINITY, g, a, b)
                            } else {
                                (i, a, b, g, 0.0, f64::NEG_INFINITY)
                            });
                        }
                    }
                });
            }
        }
    })
}

/// A polygon solid's profile as `remove` orders it (top, side, then the rest; `rho`: the ρ
/// range of each edge, or None).
pub fn polygon_profile<'a>(planes: &'a [[f64; 3]], rho: Option<&'a [[f64; 2]]>) -> Profile<'a> {
    let q = planes.len();
    let order: Vec<usize> = if q > 2 {
        [q - 1, q - 2].into_iter().chain(0..q - 2).collect()
    } else {
        (0..q).collect()
    };
    let mut always: Vec<bool> = planes
        .iter()
        .map(|p| p[0].abs() < EPS && p[1] > 0.0)
        .collect();
    for &i in order.iter().take(2) {
        always[i] = true;
    }
    if rho.is_none() {
        always = vec![true; q];
    }
    Profile {
        planes,
        order,
        always,
        rho,
    }
}

fn prims_of(a: &[[f64; 5]]) -> PyResult<Vec<Prim>> {
    a.iter()
        .map(|p| match p[0] as i64 {
            0 => Ok(Prim::Ball {
                zc: p[1],
                rad: p[2],
            }),
            1 => Ok(Prim::Frustum {
                z1: p[1],
                r1: p[2],
                z2: p[3],
                r2: p[4],
            }),
            _ => Err(PyValueError::new_err(
                "a primitive's kind must be 0 (ball) or 1 (frustum)",
            )),
        })
        .collect()
}

/// The stock's grid from `stock_remove`'s and `stock_sweep`'s arguments: `lo`, `hi`
/// (n_z · n_theta, K) alike, `grid` (θ0, dθ, z0, dz), `frame` (4, 3).
pub fn grid_of(
    lo: &PyReadwriteArray2<'_, f64>,
    hi: &PyReadwriteArray2<'_, f64>,
    n_theta: usize,
    grid: (f64, f64, f64, f64),
    frame: &PyReadonlyArray2<'_, f64>,
) -> PyResult<Grid> {
    let shape = lo.shape();
    if hi.shape() != shape || n_theta == 0 || shape[0] % n_theta != 0 || shape[1] == 0 {
        return Err(PyValueError::new_err(
            "lo and hi must be (n_z · n_theta, K) alike",
        ));
    }
    let fr = crate::points(frame, "frame")?;
    if fr.len() != 4 {
        return Err(PyValueError::new_err("frame must be (4, 3)"));
    }
    Ok(Grid {
        theta0: grid.0,
        d_theta: grid.1,
        z0: grid.2,
        dz: grid.3,
        n_theta,
        n_z: shape[0] / n_theta,
        k: shape[1],
        frame: [fr[0], fr[1], fr[2], fr[3]],
    })
}

/// The columns (c0, c1, w0, w1) of the solids' or moves' boxes (m, 4) int64 (their shape
/// checked by the caller), after checking their `group` ids lie in 0..n_groups (see
/// [`ItemBoxes::new`]).
pub fn box_columns(
    boxes: &PyReadonlyArray2<'_, i64>,
    group: &[i64],
    n_groups: usize,
) -> PyResult<[Vec<i64>; 4]> {
    if group.iter().any(|&g| g < 0 || g as usize >= n_groups) {
        return Err(PyValueError::new_err("group ids must lie in 0..n_groups"));
    }
    let bx = boxes
        .as_slice()
        .map_err(|_| PyValueError::new_err("boxes must be C-contiguous"))?;
    Ok([0, 1, 2, 3].map(|j| bx.iter().skip(j).step_by(4).copied().collect()))
}

/// `rho` (q, 2): the ρ range of each of the polygon's q planes.
pub fn plane_ranges<'a>(
    rho: &'a PyReadonlyArray2<'_, f64>,
    planes: &[[f64; 3]],
) -> PyResult<&'a [[f64; 2]]> {
    if rho.shape() != [planes.len(), 2] {
        return Err(PyValueError::new_err(
            "rho must be (q, 2), one range per plane",
        ));
    }
    crate::arrays::rows::<2>(rho, "rho")
}

type Overflow<'py> = (
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
);

/// What `stock_remove` and `stock_sweep` return (see `stock_remove`).
pub type Removed<'py> = (
    f64,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    u64,
    Overflow<'py>,
);

/// Run `kernel` on the stock `lo`, `hi` (C-contiguous, changed in place) on `threads` workers
/// with the GIL released, and hand its outcome to Python as `stock_remove` returns it.
pub fn run_on_stock<'py, K>(
    py: Python<'py>,
    lo: &mut PyReadwriteArray2<'py, f64>,
    hi: &mut PyReadwriteArray2<'py, f64>,
    threads: usize,
    kernel: K,
) -> PyResult<Removed<'py>>
where
    K: FnOnce(&mut [f64], &mut [f64]) -> (Outcome, u64) + Send,
{
    let ls = lo
        .as_slice_mut()
        .map_err(|_| PyValueError::new_err("lo must be C-contiguous"))?;
    let hs = hi
        .as_slice_mut()
        .map_err(|_| PyValueError::new_err("hi must be C-contiguous"))?;
    let pool_ = crate::pool(threads)?;
    let (out, pairs) = py.detach(|| pool_.install(|| kernel(ls, hs)));
    let counts: Vec<i64> = out.overflow.iter().map(|p| p.len() as i64).collect();
    let olo: Vec<f64> = out.overflow.iter().flatten().map(|p| p.0).collect();
    let ohi: Vec<f64> = out.overflow.iter().flatten().map(|p| p.1).collect();
    Ok((
        out.removed,
        PyArray1::from_vec(py, out.group_vol),
        PyArray1::from_vec(py, out.group_vol_in),
        PyArray1::from_vec(py, out.group_depth),
        pairs,
        (
            PyArray1::from_vec(py, out.overflow_rays),
            PyArray1::from_vec(py, counts),
            PyArray1::from_vec(py, olo),
            PyArray1::from_vec(py, ohi),
        ),
    ))
}

/// Remove the swept solids of moves from the stock (see `stock::sweep` and
/// `removal.simulate_moves`): `lo`, `hi` (n_rays, K) float64 changed in place; `grid`,
/// `frame` as `stock_remove`; per move its start and end tips and unit axes (m, 3), group
/// (m,), box (m, 4) = (c0, c1, w0, w1) of its whole sweep, axis knots (m,) and polygon samples
/// (m,) (the balls' centre chords), frustum knots (m,) (translational sweeps between them
/// with the mid axis; 0: the frustums by the samples) and samples; the solid's primitives `prims` (p, 5) rows (kind, …): (0, zc, radius, 0, 0) a ball,
/// (1, z1, r1, z2, r2) a frustum, and `prims_in` the inner solid's (crash measure); `bounds`
/// (z_lo, z_hi, radius) a cylinder about the tool axis holding the solid; `planes` (q, 3) and
/// `rho` a polygon part swept by its samples (None: none), `planes_in` its inner polygon.
/// Returns what `stock_remove` returns (the count: candidate ray–move pairs).
#[pyfunction]
#[pyo3(signature = (lo, hi, n_theta, grid, frame, t0, a0, t1, a1, group, n_groups, boxes, knots,
                    fknots, samples, prims, prims_in, bounds, measure, threads, planes=None, rho=None,
                    planes_in=None, open_start=false))]
#[allow(clippy::too_many_arguments)]
pub fn stock_sweep<'py>(
    py: Python<'py>,
    mut lo: PyReadwriteArray2<'py, f64>,
    mut hi: PyReadwriteArray2<'py, f64>,
    n_theta: usize,
    grid: (f64, f64, f64, f64),
    frame: PyReadonlyArray2<'py, f64>,
    t0: PyReadonlyArray2<'py, f64>,
    a0: PyReadonlyArray2<'py, f64>,
    t1: PyReadonlyArray2<'py, f64>,
    a1: PyReadonlyArray2<'py, f64>,
    group: PyReadonlyArray1<'py, i64>,
    n_groups: usize,
    boxes: PyReadonlyArray2<'py, i64>,
    knots: PyReadonlyArray1<'py, i64>,
    fknots: PyReadonlyArray1<'py, i64>,
    samples: PyReadonlyArray1<'py, i64>,
    prims: PyReadonlyArray2<'py, f64>,
    prims_in: PyReadonlyArray2<'py, f64>,
    bounds: (f64, f64, f64),
    measure: bool,
    threads: usize,
    planes: Option<PyReadonlyArray2<'py, f64>>,
    rho: Option<PyReadonlyArray2<'py, f64>>,
    planes_in: Option<PyReadonlyArray2<'py, f64>>,
    open_start: bool,
) -> PyResult<Removed<'py>> {
    let g = grid_of(&lo, &hi, n_theta, grid, &frame)?;
    let (pt0, pa0, pt1, pa1) = (
        crate::points(&t0, "t0")?,
        crate::points(&a0, "a0")?,
        crate::points(&t1, "t1")?,
        crate::points(&a1, "a1")?,
    );
    let gg = crate::slice1(&group, "group")?;
    let (kn, sm) = (
        crate::slice1(&knots, "knots")?,
        crate::slice1(&samples, "samples")?,
    );
    let fk = crate::slice1(&fknots, "fknots")?;
    let m = pt0.len();
    if pa0.len() != m
        || pt1.len() != m
        || pa1.len() != m
        || gg.len() != m
        || kn.len() != m
        || sm.len() != m
        || fk.len() != m
        || boxes.shape() != [m, 4]
    {
        return Err(PyValueError::new_err(
            "t0, a0, t1, a1, group, boxes, knots and samples must describe the same moves",
        ));
    }
    let cols = box_columns(&boxes, gg, n_groups)?;
    let pl = match &planes {
        Some(p) => Some(crate::points(p, "planes")?),
        None => None,
    };
    let rr = match (&rho, pl) {
        (Some(r), Some(pl)) => Some(plane_ranges(r, pl)?),
        _ => None,
    };
    let pin = match &planes_in {
        Some(p) => Some(crate::points(p, "planes_in")?),
        None => None,
    };
    let tool = Tool {
        prims: prims_of(crate::arrays::rows::<5>(&prims, "prims")?)?,
        prims_in: prims_of(crate::arrays::rows::<5>(&prims_in, "prims_in")?)?,
        poly: pl.map(|p| polygon_profile(p, rr)),
        poly_in: pin.map(|p| polygon_profile(p, None)),
        z_lo: bounds.0,
        z_hi: bounds.1,
        radius: bounds.2,
        open_start,
    };
    let mv = Moves {
        t0: pt0,
        a0: pa0,
        t1: pt1,
        a1: pa1,
        boxes: ItemBoxes::new(gg, &cols),
        knots: kn,
        fknots: fk,
        samples: sm,
    };
    run_on_stock(py, &mut lo, &mut hi, threads, |ls, hs| {
        sweep(&g, &mv, &tool, n_groups, measure, ls, hs)
    })
}
