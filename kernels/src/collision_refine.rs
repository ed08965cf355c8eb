//! The refine step of collision detection (`blisk_cam/core/collision/tri_tree.py::_refine`):
//! the exact minimum of a posed tool part's signed distance over candidate triangles —
//! vertices, the feet of the part's support points on the triangle's plane, the cut
//! candidates, then golden-section searches along the edges pruned by the pose's upper bound.
//! Each pose's pairs run together (first every pair's vertices and interior, then the edges,
//! as numpy orders them), the poses in parallel; a pair skipped by the bound returns a value
//! above its pose's minimum, as in numpy. The part's distance is `_Flute.sd_rz`
//! (`Cutter.signed_distance_rz`) or `_Frustum.sd_rz`, operation for operation.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::arrays::{points_n, values_n};
use crate::numpy_ops::einsum_dot as dot;
use crate::numpy_ops::{cross, sub};
use crate::numpy_ops::{nanmax, nanmin};
use crate::swept_cutter::{seg2, Profile};

type P3 = [f64; 3];

#[inline(always)]
fn axpy(a: &P3, t: f64, d: &P3) -> P3 {
    [a[0] + t * d[0], a[1] + t * d[1], a[2] + t * d[2]]
}
/// `np.linalg.norm(a, axis=1)` of one row: the squares summed left to right.
#[inline(always)]
pub(crate) fn norm(a: &P3) -> f64 {
    ((a[0] * a[0] + a[1] * a[1]) + a[2] * a[2]).sqrt()
}

/// `x.hypot(y)` (libm's, as numpy's np.hypot), without the call where one side is zero
/// (then it is the other's magnitude exactly): the cylinder's distance beside or above it.
#[inline(always)]
pub fn hypot_exact(x: f64, y: f64) -> f64 {
    if y == 0.0 {
        x.abs()
    } else if x == 0.0 {
        y.abs()
    } else {
        crate::hypot::hypot(x, y)
    }
}

const GOLDEN_STEPS: usize = 40;
const EDGE_TOL: f64 = 1e-9;

/// A tool part about its axis (meridional ρ, z), z0 ≤ z ≤ z1.
pub enum Part {
    Flute {
        p: Profile,
        e: f64,
        r: f64,
        f: f64,
        th_lo: f64,
        th_hi: f64,
        top: [f64; 2],
        z1: f64,
    },
    Frustum {
        z0: f64,
        r0: f64,
        z1: f64,
        r1: f64,
    },
}

impl Part {
    /// From `tri_tree._part_spec`: [0, 17 profile floats, e, r, f, θ_lo, θ_hi, T, h] or
    /// [1, z0, r0, z1, r1].
    pub fn from_slice(s: &[f64]) -> Option<Part> {
        match (s.first().copied(), s.len()) {
            (Some(k), 26) if k == 0.0 => Some(Part::Flute {
                p: Profile::from_slice(&s[1..18]),
                e: s[18],
                r: s[19],
                f: s[20],
                th_lo: s[21],
                th_hi: s[22],
                top: [s[23], s[24]],
                z1: s[25],
            }),
            (Some(k), 5) if k == 1.0 => Some(Part::Frustum {
                z0: s[1],
                r0: s[2],
                z1: s[3],
                r1: s[4],
            }),
            _ => None,
        }
    }

    pub fn z0(&self) -> f64 {
        match self {
            Part::Flute { .. } => 0.0,
            Part::Frustum { z0, .. } => *z0,
        }
    }

    pub fn z1(&self) -> f64 {
        match self {
            Part::Flute { z1, .. } => *z1,
            Part::Frustum { z1, .. } => *z1,
        }
    }

    fn sd_rz(&self, rho: f64, z: f64) -> f64 {
        match self {
            Part::Flute { p, .. } => p.sd_rz(rho, z),
            &Part::Frustum { z0, r0, z1, r1 } => {
                if r0 == r1 {
                    let dr = rho - r0;
                    let dz = nanmax(z0 - z, z - z1);
                    let out = hypot_exact(nanmax(dr, 0.0), nanmax(dz, 0.0));
                    if dr > 0.0 || dz > 0.0 {
                        out
                    } else {
                        nanmax(dr, dz)
                    }
                } else {
                    let mut d2 = seg2(rho, z, 0.0, z0, r0, z0);
                    d2 = nanmin(d2, seg2(rho, z, r0, z0, r1, z1));
                    d2 = nanmin(d2, seg2(rho, z, r1, z1, 0.0, z1));
                    let t = (z - z0) / (z1 - z0);
                    let t = if t < 0.0 {
                        0.0
                    } else if t > 1.0 {
                        1.0
                    } else {
                        t
                    };
                    let inside = z >= z0 && z <= z1 && rho <= r0 + t * (r1 - r0);
                    let d = d2.sqrt();
                    if inside {
                        -d
                    } else {
                        d
                    }
                }
            }
        }
    }

    /// Meridional (ρ, z) of the support point in the direction with radial part s ≥ 0 and
    /// axial part c.
    fn support_rz(&self, s: f64, c: f64) -> (f64, f64) {
        match self {
            &Part::Flute {
                e,
                r,
                f,
                th_lo,
                th_hi,
                top,
                ..
            } => {
                let th = s.atan2(-c);
                let th_c = if th < th_lo {
                    th_lo
                } else if th > th_hi {
                    th_hi
                } else {
                    th
                };
                if th > th_hi {
                    (top[0], top[1])
                } else if th < th_lo {
                    (0.0, 0.0)
                } else {
                    (e + r * th_c.sin(), f - r * th_c.cos())
                }
            }
            &Part::Frustum { z0, r0, z1, r1 } => {
                if r0 * s + z0 * c >= r1 * s + z1 * c {
                    (r0, z0)
                } else {
                    (r1, z1)
                }
            }
        }
    }

    /// `_posed_sd` of one point.
    #[inline]
    pub fn posed_sd(&self, x: &P3, tip: &P3, axis: &P3) -> f64 {
        let dv = sub(x, tip);
        let z = dot(&dv, axis);
        let rr = dot(&dv, &dv) - z * z;
        self.sd_rz((if rr > 0.0 || rr.is_nan() { rr } else { 0.0 }).sqrt(), z)
    }

    /// `_posed_support` of one direction.
    fn posed_support(&self, v: &P3, tip: &P3, axis: &P3) -> P3 {
        let c = dot(v, axis);
        let perp = [v[0] - c * axis[0], v[1] - c * axis[1], v[2] - c * axis[2]];
        let s = norm(&perp);
        let u = if s > 1e-12 {
            let m = s.max(1e-300);
            [perp[0] / m, perp[1] / m, perp[2] / m]
        } else {
            let rf = if axis[0].abs() < 0.9 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 1.0, 0.0]
            };
            let ap = cross(axis, &rf);
            let l = norm(&ap);
            [ap[0] / l, ap[1] / l, ap[2] / l]
        };
        let (rho, z) = self.support_rz(s, c);
        [
            tip[0] + z * axis[0] + rho * u[0],
            tip[1] + z * axis[1] + rho * u[1],
            tip[2] + z * axis[2] + rho * u[2],
        ]
    }
}

fn inside_tri(q: &P3, a: &P3, b: &P3, c: &P3, n: &P3) -> bool {
    let side = |p0: &P3, p1: &P3| dot(&cross(&sub(p1, p0), &sub(q, p0)), n);
    side(a, b) >= 0.0 && side(b, c) >= 0.0 && side(c, a) >= 0.0
}

/// One candidate pair's triangle and pose.
pub struct Pair<'a> {
    pub a: &'a P3,
    pub b: &'a P3,
    pub c: &'a P3,
    pub n: &'a P3,
    pub ok: bool,
    pub tip: &'a P3,
    pub axis: &'a P3,
}

/// `_edge_minima` of one edge E0 + x D: (best value, x).
fn edge_min(
    part: &Part,
    e0: &P3,
    d: &P3,
    tip: &P3,
    axis: &P3,
    f0: f64,
    f1: f64,
    ub: &mut f64,
) -> (f64, f64) {
    let g = 0.5 * (5.0f64.sqrt() - 1.0);
    let sd = |x: f64| part.posed_sd(&axpy(e0, x, d), tip, axis);
    let mut val = nanmin(f0, f1);
    let mut xv = if f0 <= f1 { 0.0 } else { 1.0 };
    let (mut lo, mut hi, mut flo, mut fhi) = (0.0, 1.0, f0, f1);
    let (mut x1, mut x2) = (1.0 - g, g);
    let (mut v1, mut v2) = (sd(x1), sd(x2));
    for step in 0..=GOLDEN_STEPS {
        let left = v1 <= v2;
        let (up, xu) = if left { (v1, x1) } else { (v2, x2) };
        if up < val {
            val = up;
            xv = xu;
        }
        *ub = nanmin(*ub, up);
        let s12 = (v2 - v1) / (x2 - x1);
        let b_left = nanmin(v1, v1 - s12 * (x1 - lo));
        let b_right = nanmin(v2, v2 + s12 * (hi - x2));
        let sa = (v1 - flo) / (x1 - lo);
        let sb = (fhi - v2) / (hi - x2);
        let den = sa - sb;
        let xi = (v2 - sb * x2 - v1 + sa * x1) / (if den != 0.0 { den } else { 1.0 });
        let xi = if xi < x1 {
            x1
        } else if xi > x2 {
            x2
        } else {
            xi
        };
        let mid = nanmin(
            nanmin(
                nanmax(v1, v2 + sb * (x1 - x2)),
                nanmax(v1 + sa * (x2 - x1), v2),
            ),
            if den != 0.0 {
                nanmax(v1 + sa * (xi - x1), v2 + sb * (xi - x2))
            } else {
                f64::INFINITY
            },
        );
        let bound = nanmin(nanmin(b_left, b_right), mid);
        let go = bound <= *ub && val - bound > EDGE_TOL;
        if step == GOLDEN_STEPS || !go {
            break;
        }
        if left {
            hi = x2;
            fhi = v2;
        } else {
            lo = x1;
            flo = v1;
        }
        let nx1 = hi - g * (hi - lo);
        let nx2 = lo + g * (hi - lo);
        let fnx = sd(if left { nx1 } else { nx2 });
        if left {
            x2 = x1;
            v2 = v1;
            x1 = nx1;
            v1 = fnx;
        } else {
            x1 = x2;
            v1 = v2;
            x2 = nx2;
            v2 = fnx;
        }
    }
    (val, xv)
}

/// The pairs of one pose: (best (k,), where (k,)) and the pose's bound lowered in place.
pub fn refine_pose(part: &Part, pairs: &[Pair], ub: &mut f64) -> Vec<(f64, P3)> {
    struct St {
        best: f64,
        at: P3,
        fv: [f64; 3],
        plane_lb: f64,
        solved: bool,
    }
    let mut st: Vec<St> = Vec::with_capacity(pairs.len());
    for pr in pairs {
        let (a, b, c, n, tip, axis) = (pr.a, pr.b, pr.c, pr.n, pr.tip, pr.axis);
        let mut best = f64::INFINITY;
        let mut at = [0.0; 3];
        let mut offer = |v: f64, p: P3| {
            if v < best {
                best = v;
                at = p;
            }
        };
        let fv = [
            part.posed_sd(a, tip, axis),
            part.posed_sd(b, tip, axis),
            part.posed_sd(c, tip, axis),
        ];
        offer(fv[0], *a);
        offer(fv[1], *b);
        offer(fv[2], *c);
        let ym = part.posed_support(&[-n[0], -n[1], -n[2]], tip, axis);
        let yp = part.posed_support(n, tip, axis);
        let hm = dot(&sub(&ym, a), n);
        let hp = dot(&sub(&yp, a), n);
        let above = pr.ok && hm > 0.0;
        let q = axpy(&ym, -hm, n);
        let hit = above && inside_tri(&q, a, b, c, n);
        if hit {
            offer(hm, q);
        }
        let below = pr.ok && hp < 0.0;
        let q = axpy(&yp, -hp, n);
        let hit_b = below && inside_tri(&q, a, b, c, n);
        if hit_b {
            offer(-hp, q);
        }
        let plane_lb = if above {
            hm
        } else if below {
            -hp
        } else {
            f64::NEG_INFINITY
        };
        if pr.ok && !above && !below {
            let w = -hm / (if hp - hm > 0.0 { hp - hm } else { 1.0 });
            let q = axpy(&ym, w, &sub(&yp, &ym));
            if inside_tri(&q, a, b, c, n) {
                offer(part.posed_sd(&q, tip, axis), q);
            }
            let na = dot(n, axis);
            let good = na.abs() > 1e-9;
            let tl = dot(&sub(a, tip), n) / (if good { na } else { 1.0 });
            let q = axpy(tip, tl, axis);
            if good && inside_tri(&q, a, b, c, n) {
                offer(part.posed_sd(&q, tip, axis), q);
            }
            let (z0, z1) = (part.z0(), part.z1());
            for zz in [z0, 0.5 * (z0 + z1), z1] {
                let m = axpy(tip, zz, axis);
                let q = axpy(&m, -dot(&sub(&m, a), n), n);
                if inside_tri(&q, a, b, c, n) {
                    offer(part.posed_sd(&q, tip, axis), q);
                }
            }
        }
        *ub = nanmin(*ub, best);
        st.push(St {
            best,
            at,
            fv,
            plane_lb,
            solved: hit || hit_b,
        });
    }
    for (pr, s) in pairs.iter().zip(st.iter_mut()) {
        if s.solved {
            continue;
        }
        let ends = [
            (pr.a, pr.b, s.fv[0], s.fv[1]),
            (pr.b, pr.c, s.fv[1], s.fv[2]),
            (pr.c, pr.a, s.fv[2], s.fv[0]),
        ];
        for (e0, e1, f0, f1) in ends {
            let d = sub(e1, e0);
            let lb = nanmax(0.5 * (f0 + f1 - norm(&d)), s.plane_lb);
            if lb <= *ub {
                let (v, x) = edge_min(part, e0, &d, pr.tip, pr.axis, f0, f1, ub);
                if v < s.best {
                    s.best = v;
                    s.at = axpy(e0, x, &d);
                }
            }
        }
        *ub = nanmin(*ub, s.best);
    }
    st.into_iter().map(|s| (s.best, s.at)).collect()
}

/// `_refine` with the pose `pose` (k,) of each pair and the poses' bounds `ub` (m,):
/// (best (k,), where (k, 3), ub lowered (m,)).
#[pyfunction]
#[pyo3(signature = (part, a, b, c, nrm, ok, tip, axis, pose, ub, threads))]
#[allow(clippy::too_many_arguments)]
pub fn refine_pairs<'py>(
    py: Python<'py>,
    part: Vec<f64>,
    a: PyReadonlyArray2<'py, f64>,
    b: PyReadonlyArray2<'py, f64>,
    c: PyReadonlyArray2<'py, f64>,
    nrm: PyReadonlyArray2<'py, f64>,
    ok: PyReadonlyArray1<'py, bool>,
    tip: PyReadonlyArray2<'py, f64>,
    axis: PyReadonlyArray2<'py, f64>,
    pose: PyReadonlyArray1<'py, i64>,
    ub: PyReadonlyArray1<'py, f64>,
    threads: usize,
) -> PyResult<(
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
)> {
    let part =
        Part::from_slice(&part).ok_or_else(|| PyValueError::new_err("unknown part description"))?;
    let pp = crate::slice1(&pose, "pose")?;
    let k = pp.len();
    let (aa, bb, cc, nn) = (
        points_n(&a, "a", k)?,
        points_n(&b, "b", k)?,
        points_n(&c, "c", k)?,
        points_n(&nrm, "nrm", k)?,
    );
    let (tt, xx) = (points_n(&tip, "tip", k)?, points_n(&axis, "axis", k)?);
    let okk = values_n(&ok, "ok", k)?;
    let ubb = crate::slice1(&ub, "ub")?;
    let m = ubb.len();
    if pp.iter().any(|&p| p < 0 || p as usize >= m) {
        return Err(PyValueError::new_err("pose ids must lie in 0..len(ub)"));
    }
    let mut order: Vec<usize> = (0..k).collect();
    order.sort_by_key(|&i| pp[i]);
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut s = 0;
    for i in 1..=k {
        if i == k || pp[order[i]] != pp[order[s]] {
            runs.push((s, i));
            s = i;
        }
    }
    let pl = crate::pool(threads)?;
    let res: Vec<(Vec<(f64, P3)>, f64)> = py.detach(|| {
        pl.install(|| {
            runs.par_iter()
                .map(|&(s, e)| {
                    let pairs: Vec<Pair> = order[s..e]
                        .iter()
                        .map(|&i| Pair {
                            a: &aa[i],
                            b: &bb[i],
                            c: &cc[i],
                            n: &nn[i],
                            ok: okk[i],
                            tip: &tt[i],
                            axis: &xx[i],
                        })
                        .collect();
                    let mut u = ubb[pp[order[s]] as usize];
                    let out = refine_pose(&part, &pairs, &mut u);
                    (out, u)
                })
                .collect()
        })
    });
    let mut best = vec![f64::INFINITY; k];
    let mut at = vec![0.0f64; 3 * k];
    let mut ub_out = ubb.to_vec();
    for (&(s, _), (out, u)) in runs.iter().zip(res.into_iter()) {
        ub_out[pp[order[s]] as usize] = u;
        for (j, (v, p)) in out.into_iter().enumerate() {
            let i = order[s + j];
            best[i] = v;
            at[3 * i..3 * i + 3].copy_from_slice(&p);
        }
    }
    let at = PyArray1::from_vec(py, at).reshape([k, 3])?;
    Ok((
        PyArray1::from_vec(py, best),
        at,
        PyArray1::from_vec(py, ub_out),
    ))
}
