//! Step 4 of the swept cutter's "fast" method (`blisk_cam/core/verify/sweep.py`,
//! `_golden_pairs`): the golden-section search of the cutter's signed distance along each
//! (point, move) pair's bracket, each point's pairs stepped together as numpy steps them (the
//! same pruning by the point's best after every step, the same pairs dropped), the points
//! in parallel. The cutter's distance is `Cutter.signed_distance_rz` operation for operation.

use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

/// A cutter's meridional profile (`Cutter.signed_distance_rz`'s constants).
#[derive(Clone, Copy)]
pub struct Profile {
    e: f64,
    f: f64,
    r: f64,
    h: f64,
    b: [f64; 2],
    s: [f64; 2],
    t: [f64; 2],
    sa: f64,
    ca: f64,
    sb: f64,
    cb: f64,
    tan_a: f64,
    cos_b: f64,
    sin_b: f64,
}

/// `closest.segment_distance2_2d` for one point.
#[inline(always)]
pub fn seg2(px: f64, py: f64, ax: f64, ay: f64, bx: f64, by: f64) -> f64 {
    let (dx, dy) = (bx - ax, by - ay);
    let dd = dx * dx + dy * dy;
    let (qx, qy) = (px - ax, py - ay);
    let t = (qx * dx + qy * dy) / (if dd > 0.0 { dd } else { 1.0 });
    let t = if t < 0.0 { 0.0 } else { t };
    let t = if t > 1.0 { 1.0 } else { t };
    let (ex, ey) = (qx - t * dx, qy - t * dy);
    ex * ex + ey * ey
}

/// np.minimum: NaN if either is NaN.
#[inline(always)]
pub fn nanmin(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if a <= b {
        a
    } else {
        b
    }
}

impl Profile {
    /// From the 17 floats of `sweep._profile` (e, f, r, h, B, S, T, sin/cos of the arc's
    /// sector bounds, tan α, cos β, sin β).
    pub fn from_slice(p: &[f64]) -> Profile {
        Profile {
            e: p[0], f: p[1], r: p[2], h: p[3], b: [p[4], p[5]], s: [p[6], p[7]], t: [p[8], p[9]],
            sa: p[10], ca: p[11], sb: p[12], cb: p[13], tan_a: p[14], cos_b: p[15], sin_b: p[16],
        }
    }

    /// `Cutter.signed_distance_rz` of one meridional point.
    #[inline]
    pub fn sd_rz(&self, rho: f64, z: f64) -> f64 {
        let rho = rho.abs();
        let mut d2 = seg2(rho, z, 0.0, 0.0, self.b[0], self.b[1]);
        d2 = nanmin(d2, seg2(rho, z, self.s[0], self.s[1], self.t[0], self.t[1]));
        d2 = nanmin(d2, seg2(rho, z, self.t[0], self.t[1], 0.0, self.h));
        let (vr, vz) = (rho - self.e, z - self.f);
        let vl = vr.hypot(vz);
        let in_sector = (vr * self.ca - vz * self.sa >= 0.0) && (vr * self.cb + vz * self.sb <= 0.0);
        let arc_d = (vl - self.r).abs();
        let mut dist = d2.sqrt();
        if in_sector {
            dist = nanmin(dist, arc_d);
        }
        let inside = (z >= rho * self.tan_a)
            && (z <= self.h)
            && ((rho - self.s[0]) * self.cos_b - (z - self.s[1]) * self.sin_b <= 0.0)
            && !(in_sector && vl > self.r);
        if inside { -dist } else { dist }
    }
}

/// The constants of one pair: z(t) = cos tφ (za − t Ta) + sin tφ (zb − t Tb),
/// |d(t)|² = n0 − t m2 + t² L2.
#[derive(Clone, Copy)]
struct Pair {
    za: f64,
    zb: f64,
    ta: f64,
    tb: f64,
    n0: f64,
    m2: f64,
    l2: f64,
    phi: f64,
    d: f64,
}

impl Pair {
    #[inline(always)]
    fn f(&self, prof: &Profile, t: f64) -> f64 {
        let tp = t * self.phi;
        let (c, s) = (tp.cos(), tp.sin());
        let z = c * (self.za - t * self.ta) + s * (self.zb - t * self.tb);
        let n = self.n0 - t * self.m2 + t * t * self.l2;
        let rr = n - z * z;
        prof.sd_rz((if rr > 0.0 || rr.is_nan() { rr } else { 0.0 }).sqrt(), z)
    }
}

#[derive(Clone, Copy)]
struct State {
    i: usize, // the pair's index in the caller's arrays
    lo: f64,
    hi: f64,
    x1: f64,
    x2: f64,
    f1: f64,
    f2: f64,
}

/// One point's pairs `i0..i1`, stepped together: (best, pair achieving it or −1).
fn search_point(prof: &Profile, pairs: &[Pair], lo0: &[f64], hi0: &[f64], i0: usize, i1: usize,
                u0: f64, xtol: f64) -> (f64, i64) {
    let gold = 0.5 * (5.0f64.sqrt() - 1.0);
    let mut live: Vec<State> = (i0..i1)
        .map(|i| {
            let (lo, hi) = (lo0[i], hi0[i]);
            let x1 = hi - gold * (hi - lo);
            let x2 = lo + gold * (hi - lo);
            State { i, lo, hi, x1, x2, f1: pairs[i].f(prof, x1), f2: pairs[i].f(prof, x2) }
        })
        .collect();
    let (mut u, mut arg) = (u0, -1i64);
    for _ in 0..200 {
        // the best among the pairs that may beat the point's best (NaN: no update, as
        // numpy's minimum over the group is then NaN)
        let (mut gmin, mut gi, mut any, mut nan) = (f64::INFINITY, -1i64, false, false);
        for st in &live {
            let fb = nanmin(st.f1, st.f2);
            if !(fb >= u) {
                any = true;
                if fb.is_nan() {
                    nan = true;
                } else if fb <= gmin {
                    gmin = fb;
                    gi = st.i as i64;
                }
            }
        }
        if any && !nan && gmin < u {
            u = gmin;
            arg = gi;
        }
        live.retain(|st| {
            let wd = (st.hi - st.lo) * pairs[st.i].d;
            (wd > xtol) && (nanmin(st.f1, st.f2) - wd <= u)
        });
        if live.is_empty() {
            break;
        }
        for st in live.iter_mut() {
            let left = st.f1 < st.f2;
            if left {
                st.hi = st.x2;
            } else {
                st.lo = st.x1;
            }
            let nx = if left { st.hi - gold * (st.hi - st.lo) } else { st.lo + gold * (st.hi - st.lo) };
            let fnx = pairs[st.i].f(prof, nx);
            if left {
                st.x2 = st.x1;
                st.f2 = st.f1;
                st.x1 = nx;
                st.f1 = fnx;
            } else {
                st.x1 = st.x2;
                st.f1 = st.f2;
                st.x2 = nx;
                st.f2 = fnx;
            }
        }
    }
    (u, arg)
}

/// `_golden_pairs` on pairs sorted by point `q`; (best per point (kc,), pair index or −1).
#[pyfunction]
#[pyo3(signature = (profile, q, u, scal, lo, hi, xtol, threads))]
#[allow(clippy::too_many_arguments)]
pub fn golden_pairs<'py>(
    py: Python<'py>,
    profile: Vec<f64>,
    q: PyReadonlyArray1<'py, i64>,
    u: PyReadonlyArray1<'py, f64>,
    scal: Vec<PyReadonlyArray1<'py, f64>>,
    lo: PyReadonlyArray1<'py, f64>,
    hi: PyReadonlyArray1<'py, f64>,
    xtol: f64,
    threads: usize,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>)> {
    if profile.len() != 17 {
        return Err(PyValueError::new_err("profile must hold 17 numbers"));
    }
    let prof = Profile::from_slice(&profile);
    let qq = crate::slice1(&q, "q")?;
    let uu = crate::slice1(&u, "u")?;
    let (ll, hh) = (crate::slice1(&lo, "lo")?, crate::slice1(&hi, "hi")?);
    if scal.len() != 9 {
        return Err(PyValueError::new_err("scal must be (za, zb, Ta, Tb, n0, m2, L2, phi, D)"));
    }
    let cols: Vec<&[f64]> = scal.iter().map(|c| crate::slice1(c, "scal")).collect::<PyResult<_>>()?;
    let m = qq.len();
    if cols.iter().any(|c| c.len() != m) || ll.len() != m || hh.len() != m {
        return Err(PyValueError::new_err("q, scal, lo and hi must describe the same pairs"));
    }
    let kc = uu.len();
    if qq.iter().any(|&x| x < 0 || x as usize >= kc) || qq.windows(2).any(|w| w[1] < w[0]) {
        return Err(PyValueError::new_err("q must be sorted point ids in 0..len(u)"));
    }
    let pairs: Vec<Pair> = (0..m)
        .map(|i| Pair {
            za: cols[0][i], zb: cols[1][i], ta: cols[2][i], tb: cols[3][i], n0: cols[4][i],
            m2: cols[5][i], l2: cols[6][i], phi: cols[7][i], d: cols[8][i],
        })
        .collect();
    // the runs of pairs of one point
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut s = 0;
    for i in 1..=m {
        if i == m || qq[i] != qq[s] {
            runs.push((s, i));
            s = i;
        }
    }
    let pl = crate::pool(threads)?;
    let res: Vec<(f64, i64)> = py.detach(|| {
        pl.install(|| {
            runs.par_iter()
                .with_min_len(8)
                .map(|&(a, b)| search_point(&prof, &pairs, ll, hh, a, b, uu[qq[a] as usize], xtol))
                .collect()
        })
    });
    let mut best = uu.to_vec();
    let mut arg = vec![-1i64; kc];
    for (&(a, _), &(v, i)) in runs.iter().zip(res.iter()) {
        let k = qq[a] as usize;
        best[k] = v;
        arg[k] = i;
    }
    Ok((PyArray1::from_vec(py, best), PyArray1::from_vec(py, arg)))
}
