//! The fixed-point lift of `passes._fixed_point_lift` (paper 001 §3: the ball kept clear of
//! the mesh around its contact): per point, while the exact distance from the ball centre
//! `p + (ρ + λ) n` to its nearest candidate triangle is below `ρ − tol`, λ grows by
//! `gain (ρ − d)`. The distances are `passes._point_triangle_distance` operation for
//! operation (three-term dot products summed as numpy's einsum, `(x0 y0 + x2 y2) + x1 y1`;
//! np.clip and np.minimum with numpy's NaN), so λ is the numpy reference's to the last bit.
//! A triangle whose plane is farther than `ρ − tol + slack` is skipped (its distance cannot
//! decide a step; the numpy code skips it too, with the same slack far above rounding).

use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::numpy_ops::einsum_dot as dot;
use crate::numpy_ops::nanmin;
use crate::numpy_ops::{cross, sub};

pub(crate) type P3 = [f64; 3];

/// np.clip(x, 0, 1) as numpy computes it (NaN passes through).
#[inline(always)]
fn clip01(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    let y = if x > 0.0 { x } else { 0.0 };
    if y < 1.0 {
        y
    } else {
        1.0
    }
}

/// `passes._point_triangle_distance` for one point and one triangle, given its normal
/// `n` = (b − a) × (c − a) and `n2` = n · n (the caller's table holds them per face).
pub(crate) fn point_triangle_distance(p: &P3, a: &P3, b: &P3, c: &P3, n: &P3, n2: f64) -> f64 {
    let h = dot(&sub(p, a), n) / if n2 > 0.0 { n2 } else { 1.0 };
    let foot = [p[0] - h * n[0], p[1] - h * n[1], p[2] - h * n[2]];
    let mut inside = n2 > 0.0;
    for (u, v) in [(a, b), (b, c), (c, a)] {
        inside &= dot(&cross(&sub(v, u), &sub(&foot, u)), n) >= 0.0;
    }
    let mut best = if inside {
        h.abs() * n2.sqrt()
    } else {
        f64::INFINITY
    };
    for (u, v) in [(a, b), (b, c), (c, a)] {
        let uv = sub(v, u);
        let l2 = dot(&uv, &uv);
        let t = clip01(dot(&sub(p, u), &uv) / if l2 > 0.0 { l2 } else { 1.0 });
        let q = [u[0] + t * uv[0], u[1] + t * uv[1], u[2] + t * uv[2]];
        let d = sub(p, &q);
        best = nanmin(best, dot(&d, &d).sqrt());
    }
    best
}

/// A candidate triangle of [`lift_one`]: its corners a, b, c, normal n = (b − a) × (c − a),
/// n · n, 1 / |n| (0 for a degenerate one: never pruned) and a · n (pruning only).
pub(crate) type Tri = (P3, P3, P3, P3, f64, f64, f64);

/// The [`Tri`] of face `fi` (an id into F, in range: the caller checked) of V, F.
#[inline]
pub(crate) fn face_tri(vv: &[P3], ff: &[i64], fi: i64) -> Tri {
    let t = &ff[3 * fi as usize..3 * fi as usize + 3];
    let (a, b, c) = (vv[t[0] as usize], vv[t[1] as usize], vv[t[2] as usize]);
    let nrm = cross(&sub(&b, &a), &sub(&c, &a));
    let n2 = dot(&nrm, &nrm);
    let inv = if n2 > 0.0 { 1.0 / n2.sqrt() } else { 0.0 };
    (a, b, c, nrm, n2, inv, dot(&a, &nrm))
}

/// The [`Tri`]s of the faces `faces` (ids into F, in range: the caller checked) of V, F.
pub(crate) fn candidate_tris(vv: &[P3], ff: &[i64], faces: impl Iterator<Item = i64>) -> Vec<Tri> {
    faces.map(|fi| face_tri(vv, ff, fi)).collect()
}

/// λ of one point `p`, unit normal `n`, from `lam` after up to `steps` fixed-point steps on
/// its candidate triangles `tris`; `consts` = (ρ, tol, gain, plane limit ρ − tol + slack).
pub(crate) fn lift_one(
    tris: &[Tri],
    p: &P3,
    n: &P3,
    lam: f64,
    consts: (f64, f64, f64, f64),
    steps: usize,
) -> f64 {
    let (rho, tol, gain, limit) = consts;
    let mut lam = lam;
    for _ in 0..steps {
        let s = rho + lam;
        let c = [p[0] + s * n[0], p[1] + s * n[1], p[2] + s * n[2]];
        let mut dmin = f64::INFINITY;
        for (a, b, cc_, nrm, n2, inv, an) in tris {
            let plane = (dot(&c, nrm) - an).abs() * inv;
            if plane < limit {
                dmin = nanmin(dmin, point_triangle_distance(&c, a, b, cc_, nrm, *n2));
            }
        }
        let short = rho - dmin;
        if short > tol {
            lam += short * gain;
        } else {
            break;
        }
    }
    lam
}

/// (q,) λ after up to `steps` fixed-point steps, from `lam` (q,), for points `p` and unit
/// normals `n` (q, 3), candidate faces `cand` (q, c) of the mesh V (nv, 3), F (m, 3)
/// (−1: padding); `consts` = (ρ, tol, gain, slack). On `threads` threads, GIL released.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn fixed_point_lift<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
    cand: PyReadonlyArray2<'py, i64>,
    p: PyReadonlyArray2<'py, f64>,
    n: PyReadonlyArray2<'py, f64>,
    lam: PyReadonlyArray1<'py, f64>,
    consts: (f64, f64, f64, f64),
    steps: usize,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let vv = crate::points(&v, "V")?;
    let ff = crate::arrays::flat(&f, "F")?;
    let pp = crate::points(&p, "p")?;
    let q = pp.len();
    let nn = crate::arrays::points_n(&n, "n", q)?;
    let l0 = crate::arrays::values_n(&lam, "lam", q)?;
    let cc = crate::arrays::flat(&cand, "cand")?;
    let width = if q == 0 { 0 } else { cc.len() / q };
    if cc.len() != q * width {
        return Err(PyValueError::new_err("cand must have one row per point"));
    }
    let (nv, m) = (vv.len() as i64, (ff.len() / 3) as i64);
    if cc.iter().any(|&i| i >= m) {
        return Err(PyValueError::new_err("cand holds face ids out of range"));
    }
    if cc.iter().filter(|&&i| i >= 0).any(|&i| {
        let t = &ff[3 * i as usize..3 * i as usize + 3];
        t.iter().any(|&x| x < 0 || x >= nv)
    }) {
        return Err(PyValueError::new_err("F holds vertex ids out of range"));
    }
    let (rho, tol, gain, slack) = consts;
    let limit = rho - tol + slack;
    let pl = crate::pool_for(threads, q)?;
    let mut out = l0.to_vec();
    let one = |(i, lam): (usize, &mut f64)| {
        let row = &cc[i * width..(i + 1) * width];
        let tris = candidate_tris(vv, ff, row.iter().copied().filter(|&fi| fi >= 0));
        *lam = lift_one(&tris, &pp[i], &nn[i], *lam, (rho, tol, gain, limit), steps);
    };
    py.detach(|| {
        if threads <= 1 || q < 256 {
            out.iter_mut().enumerate().for_each(one);
        } else {
            pl.install(|| {
                out.par_iter_mut()
                    .enumerate()
                    .with_min_len(32)
                    .for_each(one)
            });
        }
    });
    Ok(PyArray1::from_vec(py, out))
}
