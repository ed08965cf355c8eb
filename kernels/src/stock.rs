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
}

/// What a call did: Σ (hi² − lo²)/2 removed (mm²), per group the material its own union
/// met before the removal (mm², Σ (hi² − lo²)/2) and the longest stretch (mm), and the rays
/// that needed more than K intervals with their new intervals (the caller grows K).
pub struct Outcome {
    pub removed: f64,
    pub group_vol: Vec<f64>,
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

/// `ray_solid_intervals` for one pair (lo < hi: contact).
#[inline]
fn solid_interval(f: &RayFrame, planes: &[[f64; 3]], order: &[usize]) -> (f64, f64) {
    let mut lo = 0.0f64;
    let mut hi = f64::INFINITY;
    for &p in order {
        let [nr, nz, c] = planes[p];
        if nr.abs() < EPS {
            let s = nz * f.zu;
            let rhs = c - nz * f.z0;
            let root = rhs / s;
            if s > EPS {
                hi = hi.min(root);
            } else if s < -EPS {
                lo = lo.max(root);
            } else if rhs < 0.0 {
                hi = f64::NEG_INFINITY;
            }
        } else {
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
            lo = lo.max(rlo);
            hi = hi.min(rhi);
        }
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
    groups: Vec<(usize, f64, f64)>,
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
            let mut hits: Vec<(usize, f64, f64, usize)> = Vec::new();
            for &si in &by_row[start[jr]..start[jr + 1]] {
                let (tip, ax) = (&s.tips[si], &s.axes[si]);
                for c in s.c0[si]..=s.c1[si] {
                    let i = c.rem_euclid(nt as i64) as usize;
                    let (lr, hr) = (&lrow[i * k..(i + 1) * k], &hrow[i * k..(i + 1) * k]);
                    if !lr.iter().zip(hr).any(|(l, h)| h > l) {
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
                    let (a, b) = solid_interval(&f, s.planes, &order);
                    if b > a {
                        hits.push((i, a, b, s.group[si] as usize));
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
                        if v != 0.0 || dmax > 0.0 {
                            ro.groups.push((g, v, dmax));
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
        for (g, v, dm) in r.groups {
            out.group_vol[g] += v;
            out.group_depth[g] = out.group_depth[g].max(dm);
        }
        for (ray, pc) in r.overflow {
            out.overflow_rays.push(ray);
            out.overflow.push(pc);
        }
    }
    (out, pairs)
}
