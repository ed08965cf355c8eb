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

/// Posed solids of one kind: tip, unit axis, group (the batch row) and (θ, z) box of each.
pub struct Solids<'a> {
    pub tips: &'a [[f64; 3]],
    pub axes: &'a [[f64; 3]],
    pub group: &'a [i64],
    pub c0: &'a [i64],
    pub c1: &'a [i64],
    pub w0: &'a [i64],
    pub w1: &'a [i64],
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
fn row_reach(g: &Grid, tip: &[f64; 3], ax: &[f64; 3], s: &Solids, si: usize, zr: f64, r_b: f64)
             -> Option<(i64, i64, f64, f64)> {
    let [o, e1, e2, d] = g.frame;
    let p0 = [tip[0] + s.z_lo * ax[0] - o[0], tip[1] + s.z_lo * ax[1] - o[1],
              tip[2] + s.z_lo * ax[2] - o[2]];
    let p1 = [tip[0] + s.z_hi * ax[0] - o[0], tip[1] + s.z_hi * ax[1] - o[1],
              tip[2] + s.z_hi * ax[2] - o[2]];
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
    let t = if l2 > 0.0 { (-(a[0] * ab[0] + a[1] * ab[1]) / l2).clamp(0.0, 1.0) } else { 0.0 };
    let dmin = (a[0] + t * ab[0]).hypot(a[1] + t * ab[1]);
    let dmax = a[0].hypot(a[1]).max(b[0].hypot(b[1]));
    let scale = 1.0 + dmax;
    let rlo = dmin - r_b - 1e-6 * scale;
    let rhi = dmax + r_b + 1e-6 * scale;
    let (c0, c1) = (s.c0[si], s.c1[si]);
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
    RayFrame { z0, zu, a, b, c, sa: a.sqrt() }
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
        let qq = -0.5 * (f.b + if f.b >= 0.0 { disc.sqrt() } else { -disc.sqrt() });
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
    let (r1, r2) = if lin { (-a0 / a1, f64::NAN) } else { (qq / a2, a0 / qq) };
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
        ((qmin - pad).max(0.0).sqrt(), (qmax + pad).max(0.0).sqrt() * (1.0 + 1e-9) + 1e-9)
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

/// Remove the solids from the stock `lo`, `hi` ((n_rays, K) row-major, changed in place);
/// `measure`: also the material each group's union met (crash checks).
pub fn remove(grid: &Grid, s: &Solids, n_groups: usize, measure: bool, lo: &mut [f64],
              hi: &mut [f64]) -> (Outcome, u64) {
    let m = s.tips.len();
    let (nt, k) = (grid.n_theta, grid.k);
    let mut out = Outcome {
        removed: 0.0,
        group_vol: vec![0.0; n_groups],
        group_vol_in: vec![0.0; n_groups],
        group_depth: vec![0.0; n_groups],
        overflow_rays: Vec::new(),
        overflow: Vec::new(),
    };
    // solids per grid row (CSR)
    let live: Vec<usize> = (0..m)
        .filter(|&i| s.c1[i] >= s.c0[i] && s.w1[i] >= s.w0[i] && s.w0[i] < grid.n_z as i64 && s.w1[i] >= 0)
        .collect();
    if live.is_empty() {
        return (out, 0);
    }
    let wmin = live.iter().map(|&i| s.w0[i].max(0)).min().unwrap() as usize;
    let wmax = live.iter().map(|&i| s.w1[i].min(grid.n_z as i64 - 1)).max().unwrap() as usize;
    let nrow = wmax - wmin + 1;
    let mut start = vec![0usize; nrow + 1];
    for &i in &live {
        for w in s.w0[i].max(wmin as i64)..=s.w1[i].min(wmax as i64) {
            start[w as usize - wmin + 1] += 1;
        }
    }
    for j in 0..nrow {
        start[j + 1] += start[j];
    }
    let mut fill = start.clone();
    let mut by_row = vec![0usize; start[nrow]];
    for &i in &live {
        for w in s.w0[i].max(wmin as i64)..=s.w1[i].min(wmax as i64) {
            let j = w as usize - wmin;
            by_row[fill[j]] = i;
            fill[j] += 1;
        }
    }
    // unit ray directions of the unwrapped columns
    let cmin = live.iter().map(|&i| s.c0[i]).min().unwrap();
    let cmax = live.iter().map(|&i| s.c1[i]).max().unwrap();
    let [o, e1, e2, d] = grid.frame;
    let dirs: Vec<[f64; 3]> = (cmin..=cmax)
        .map(|c| {
            let ang = grid.theta0 + (c as f64 + 0.5) * grid.d_theta;
            let (sn, cs) = (ang.sin(), ang.cos());
            [cs * e1[0] + sn * e2[0], cs * e1[1] + sn * e2[1], cs * e1[2] + sn * e2[2]]
        })
        .collect();
    // the reference's plane order: the widest first (top, side), then the rest
    let q = s.planes.len();
    let order: Vec<usize> = if q > 2 {
        [q - 1, q - 2].into_iter().chain(0..q - 2).collect()
    } else {
        (0..q).collect()
    };
    let mut always: Vec<bool> =
        s.planes.iter().map(|p| p[0].abs() < EPS && p[1] > 0.0).collect();
    for &i in order.iter().take(2) {
        always[i] = true;
    }
    let profile = Profile { planes: s.planes, order, always, rho: s.rho };
    let inner = s.planes_in.map(|pl| {
        let q = pl.len();
        let order: Vec<usize> =
            if q > 2 { [q - 1, q - 2].into_iter().chain(0..q - 2).collect() } else { (0..q).collect() };
        Profile { planes: pl, always: vec![true; q], order, rho: None }
    });
    let r_b = s.radius;
    let pairs: u64 = live
        .iter()
        .map(|&i| {
            let nw = (s.w1[i].min(grid.n_z as i64 - 1) - s.w0[i].max(0) + 1).max(0) as u64;
            nw * (s.c1[i] - s.c0[i] + 1) as u64
        })
        .sum();
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
            let origin = [o[0] + zr * d[0], o[1] + zr * d[1], o[2] + zr * d[2]];
            let mut hits: Vec<(usize, f64, f64, usize, f64, f64)> = Vec::new();
            for &si in &by_row[start[jr]..start[jr + 1]] {
                let (tip, ax) = (&s.tips[si], &s.axes[si]);
                let Some((ca, cb, rlo_w, rhi_w)) = row_reach(grid, tip, ax, s, si, zr, r_b) else {
                    continue;
                };
                for c in ca..=cb {
                    let i = c.rem_euclid(nt as i64) as usize;
                    let (lr, hr) = (&lrow[i * k..(i + 1) * k], &hrow[i * k..(i + 1) * k]);
                    if !lr.iter().zip(hr).any(|(&l, &h)| h > l && l < rhi_w && h > rlo_w) {
                        continue;
                    }
                    let u = &dirs[(c - cmin) as usize];
                    let f = ray_frame(&origin, u, tip, ax);
                    let Some((ba, bb)) = bounding_interval(&f, s.z_lo, s.z_hi, s.radius) else {
                        continue;
                    };
                    if !lr.iter().zip(hr).any(|(&l, &h)| h > l && l.max(ba) < h.min(bb)) {
                        continue;
                    }
                    let (a, b) = solid_interval(&f, &profile);
                    if b > a {
                        let (ai, bi) = match (&inner, measure) {
                            (Some(pin), true) => solid_interval(&f, pin),
                            _ => (0.0, f64::NEG_INFINITY),
                        };
                        hits.push((i, a, b, s.group[si] as usize, ai, bi));
                    }
                }
            }
            let mut ro = RowOut { removed: 0.0, groups: Vec::new(), overflow: Vec::new() };
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
                mat.extend(lr.iter().zip(hr.iter()).filter(|(l, h)| h > l).map(|(&l, &h)| (l, h)));
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
                        iv.extend(hits[g0..g1].iter().filter(|h| h.5 > h.4).map(|h| (h.4, h.5)));
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
        })
        .collect();
    for r in rows {
        out.removed += r.removed;
        for (g, v, dm, vi) in r.groups {
            out.group_vol[g] += v;
            out.group_vol_in[g] += vi;
            out.group_depth[g] = out.group_depth[g].max(dm);
        }
        for (ray, pc) in r.overflow {
            out.overflow_rays.push(ray);
            out.overflow.push(pc);
        }
    }
    (out, pairs)
}
