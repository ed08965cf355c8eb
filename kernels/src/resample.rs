//! The level samples of the passes' scallop measurement (`paths/passes.py`, `_resample` with
//! normals and an offset): points ≤ `spacing` apart along a level polyline, the spacing
//! measured along the offset polyline p + ρ n, and the normals there — operation for operation
//! as the numpy reference: the norms as np.linalg.norm sums them, `(x0² + x1²) + x2²`, the
//! running lengths as np.cumsum, the parameters as np.linspace (`i · (length / div)`, the
//! last set to the length when the polyline is open), the segments as np.searchsorted
//! (side="right") − 1 kept in range, no fused multiply-add — the same floats.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::prelude::*;

type P3 = [f64; 3];

#[inline(always)]
fn norm(a: &P3) -> f64 {
    ((a[0] * a[0] + a[1] * a[1]) + a[2] * a[2]).sqrt()
}

/// (points (q, 3), normals (q, 3)) resampled along the polyline `p` (k, 3) with unit normals
/// `n` (k, 3) (`closed`: the segment from the last point back to the first too) at most
/// `spacing` mm apart along `p + offset n`; None where the numpy reference must answer (fewer
/// than two points, a length that is not finite). On the calling thread, the GIL released.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn resample_offset<'py>(
    py: Python<'py>,
    p: PyReadonlyArray2<'py, f64>,
    n: PyReadonlyArray2<'py, f64>,
    closed: bool,
    spacing: f64,
    offset: f64,
) -> PyResult<Option<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>)>> {
    let pp = crate::arrays::points(&p, "points")?;
    let nn = crate::arrays::points_n(&n, "normals", pp.len())?;
    let k = pp.len();
    if k + usize::from(closed) < 2 {
        return Ok(None);
    }
    let got = py.detach(|| {
        // the polyline, closed by its first point again
        let at = |i: usize| if i == k { &pp[0] } else { &pp[i] };
        let nat = |i: usize| if i == k { &nn[0] } else { &nn[i] };
        let m = if closed { k + 1 } else { k }; // points
        let segs = m - 1;
        let q = |i: usize| -> P3 {
            let (a, b) = (at(i), nat(i));
            [
                a[0] + offset * b[0],
                a[1] + offset * b[1],
                a[2] + offset * b[2],
            ]
        };
        let mut l = vec![0.0f64; segs];
        let mut cum = vec![0.0f64; segs + 1];
        for i in 0..segs {
            let d = if offset == 0.0 {
                let (a, b) = (at(i), at(i + 1));
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
            } else {
                let (a, b) = (q(i), q(i + 1));
                [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
            };
            l[i] = norm(&d);
            cum[i + 1] = if i == 0 { l[0] } else { cum[i] + l[i] };
        }
        let total = cum[segs];
        if !total.is_finite() {
            return None;
        }
        let count = ((total / spacing).ceil() as i64 + 1).max(2) as usize;
        // np.linspace(0, total, count, endpoint=not closed)
        let div = if closed { count } else { count - 1 };
        let step = total / div as f64;
        let u = |i: usize| -> f64 {
            if !closed && i == count - 1 {
                total
            } else if step == 0.0 {
                (i as f64 / div as f64) * total
            } else {
                i as f64 * step
            }
        };
        let mut out = vec![0.0f64; 3 * count];
        let mut nrm = vec![0.0f64; 3 * count];
        for i in 0..count {
            let ui = u(i);
            // searchsorted(cum, u, side="right"): the running lengths ≤ u (cum ascends)
            let s = cum.partition_point(|&c| c <= ui);
            let seg = (s as i64 - 1).clamp(0, segs as i64 - 1) as usize;
            let len = if l[seg] > 0.0 { l[seg] } else { 1.0 };
            let w = (ui - cum[seg]) / len;
            let (a, b) = (at(seg), at(seg + 1));
            let (na, nb) = (nat(seg), nat(seg + 1));
            let mut x = [0.0f64; 3];
            for j in 0..3 {
                out[3 * i + j] = a[j] + w * (b[j] - a[j]);
                x[j] = na[j] + w * (nb[j] - na[j]);
            }
            let ln = norm(&x);
            let ln = if ln > 0.0 { ln } else { 1.0 };
            for j in 0..3 {
                nrm[3 * i + j] = x[j] / ln;
            }
        }
        Some((out, nrm, count))
    });
    match got {
        None => Ok(None),
        Some((out, nrm, count)) => Ok(Some((
            PyArray1::from_vec(py, out).reshape([count, 3])?,
            PyArray1::from_vec(py, nrm).reshape([count, 3])?,
        ))),
    }
}
