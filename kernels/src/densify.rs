//! `sampling.densify_by_normal_turn` (points inserted on a polyline where its normal turns by
//! more than `max_turn`), compiled in two halves around numpy's `np.arccos`:
//! [`densify_cosines`] makes the unit normals and the clipped cosines between neighbours, the
//! caller takes their `np.arccos`, and [`densify_by_turn`] splits the segments and slerps the
//! normals. Every other operation is numpy's, in numpy's order (module `vectors`: `unit`
//! divides by `np.linalg.norm`, summed `(s₀ + s₁) + s₂`; `dot` is an einsum, summed
//! `(x₀y₀ + x₂y₂) + x₁y₁`; `slerp(weights_first=True)` divides each weight by sin Ω), and
//! `sin` is libm's, which numpy's float64 `np.sin` calls on every host (its AVX-512 loops
//! included: the same bits on 2·10⁷ values, numpy 1.26 and 2.5). The arc cosine stays
//! numpy's: its AVX-512 loops differ from libm's `acos` by up to 2 ulp (numpy 1.26: 29 % of
//! values; 2.5: 5 %), so a compiled `acos` would give other bits than the numpy reference on
//! such a host. With numpy's arc cosines the result is the reference's to the last bit on any
//! loops.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::arrays::P3;
use crate::numpy_ops::{einsum_dot as dot, nanmax, nanmin};

/// Most pieces a segment is split into (the reference's cap).
const MAX_PIECES: i64 = 10_000;

/// `np.linalg.norm` of one row: `sqrt((x₀² + x₁²) + x₂²)` (numpy's reduction order).
#[inline(always)]
fn norm(v: &P3) -> f64 {
    ((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2]).sqrt()
}

/// numpy's float64 → int64 cast on x86: values outside the int64 range and NaN become
/// `i64::MIN` (the processor's "integer indefinite"; Rust's `as` would saturate).
#[inline(always)]
fn c_cast(x: f64) -> i64 {
    if (i64::MIN as f64..-(i64::MIN as f64)).contains(&x) {
        x as i64
    } else {
        i64::MIN
    }
}

/// The normals as `unit` makes them (zero rows stay zero), the first repeated at the end when
/// `closed`, and the cosines `clip(dot(nᵢ, nᵢ₊₁), −1, 1)` between neighbours.
pub fn unit_cosines(normals: &[P3], closed: bool) -> (Vec<P3>, Vec<f64>) {
    let mut n: Vec<P3> = normals
        .iter()
        .map(|v| {
            let l = norm(v);
            let d = if l > 0.0 { l } else { 1.0 };
            [v[0] / d, v[1] / d, v[2] / d]
        })
        .collect();
    if closed && !n.is_empty() {
        n.push(n[0]);
    }
    let c = n
        .windows(2)
        .map(|w| nanmin(nanmax(dot(&w[0], &w[1]), -1.0), 1.0))
        .collect();
    (n, c)
}

/// The densified polyline: (points, normals, segment of each point), or None where a
/// segment's normals are anti-parallel (sin Ω < 1e-9 and cos Ω < 0: `slerp` turns those
/// through a perpendicular, which only the numpy reference does). `points` (k, 3) as given,
/// `n` and `cos` from [`unit_cosines`], `ang` their arc cosines (k' − 1 each, k' = k + closed).
pub fn densify(
    points: &[P3],
    n: &[P3],
    cos: &[f64],
    ang: &[f64],
    closed: bool,
    max_turn: f64,
) -> Option<(Vec<P3>, Vec<P3>, Vec<i64>)> {
    let mut p: Vec<P3> = points.to_vec();
    if closed && !p.is_empty() {
        p.push(p[0]);
    }
    let segs = ang.len();
    let nsub: Vec<i64> = ang
        .iter()
        .map(|&a| c_cast((a / max_turn).ceil()).clamp(1, MAX_PIECES))
        .collect();
    if nsub.iter().all(|&s| s == 1) {
        let seg = (0..p.len() as i64)
            .map(|i| i.min(segs as i64 - 1))
            .collect();
        return Some((p, n.to_vec(), seg));
    }
    let total: usize = nsub.iter().map(|&s| s as usize).sum::<usize>() + 1;
    let (mut op, mut on, mut os) = (
        Vec::with_capacity(total),
        Vec::with_capacity(total),
        Vec::with_capacity(total),
    );
    for s in 0..segs {
        let (p0, p1, a0, a1) = (&p[s], &p[s + 1], &n[s], &n[s + 1]);
        let (c, om, m) = (cos[s], ang[s], nsub[s]);
        // sin Ω only where a point is inserted or the normals may be anti-parallel: the
        // segment's first point (t = 0) has the weights (1, 0) on either branch (sin Ω / sin Ω
        // is exactly 1, sin 0 / sin Ω is +0), NaN where Ω is — and most segments have no
        // other point (on Rotor 37 98 %: two of every three sines saved)
        let so = if m > 1 || c < 0.0 { om.sin() } else { f64::NAN };
        let small = so < 1e-9;
        if small && c < 0.0 {
            return None;
        }
        let d = [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]];
        for j in 0..m {
            let t = j as f64 / m as f64;
            op.push([p0[0] + t * d[0], p0[1] + t * d[1], p0[2] + t * d[2]]);
            let (w0, w1) = if j == 0 {
                if om.is_nan() {
                    (f64::NAN, f64::NAN)
                } else {
                    (1.0, 0.0)
                }
            } else if small {
                (1.0 - t, t)
            } else {
                (((1.0 - t) * om).sin() / so, (t * om).sin() / so)
            };
            let v = [
                w0 * a0[0] + w1 * a1[0],
                w0 * a0[1] + w1 * a1[1],
                w0 * a0[2] + w1 * a1[2],
            ];
            let l = norm(&v);
            on.push([v[0] / l, v[1] / l, v[2] / l]);
            os.push(s as i64);
        }
    }
    op.push(p[p.len() - 1]);
    on.push(n[n.len() - 1]);
    os.push(segs as i64 - 1);
    Some((op, on, os))
}

fn array2<'py>(py: Python<'py>, rows: Vec<P3>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let k = rows.len();
    let flat: Vec<f64> = rows.into_iter().flatten().collect();
    PyArray1::from_vec(py, flat).reshape([k, 3])
}

/// The first half of `densify_by_normal_turn`: (unit normals (k', 3), clipped cosines
/// (k' − 1,)) of `normals` (k, 3), k' = k + 1 when `closed` (the first normal repeated).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn densify_cosines<'py>(
    py: Python<'py>,
    normals: PyReadonlyArray2<'py, f64>,
    closed: bool,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>)> {
    let nn = crate::points(&normals, "normals")?;
    let (n, c) = py.detach(|| unit_cosines(nn, closed));
    Ok((array2(py, n)?, PyArray1::from_vec(py, c)))
}

/// The second half: (points (q, 3) mm, normals (q, 3), segment (q,) int64) from `points`
/// (k, 3) mm and [`densify_cosines`]'s normals and cosines with their `np.arccos` `ang`,
/// radians; None when a segment's normals are anti-parallel (the caller runs the numpy
/// reference).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn densify_by_turn<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    normals: PyReadonlyArray2<'py, f64>,
    cos: PyReadonlyArray1<'py, f64>,
    ang: PyReadonlyArray1<'py, f64>,
    closed: bool,
    max_turn: f64,
) -> PyResult<
    Option<(
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<i64>>,
    )>,
> {
    let pp = crate::points(&points, "points")?;
    let k = pp.len() + closed as usize;
    let nn = crate::arrays::points_n(&normals, "normals", k)?;
    if k < 2 {
        return Err(PyValueError::new_err(
            "densify_by_turn needs two points or more",
        ));
    }
    let cc = crate::arrays::values_n(&cos, "cos", k - 1)?;
    let aa = crate::arrays::values_n(&ang, "ang", k - 1)?;
    let out = py.detach(|| densify(pp, nn, cc, aa, closed, max_turn));
    match out {
        None => Ok(None),
        Some((p, n, s)) => Ok(Some((
            array2(py, p)?,
            array2(py, n)?,
            PyArray1::from_vec(py, s),
        ))),
    }
}
