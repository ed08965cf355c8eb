//! The tolerance pass of the weld (`blisk_cam/core/geometry/weld.py::_welded`) for points
//! that are all distinct (an STL welded exactly as it is read): whether numpy's scan
//! (`_close_pairs`: the points sorted by their projection on `_WELD_DIRECTION`, each
//! measured against its neighbours in that order within the tolerance of projection) finds
//! no pair at all — the common answer, which then needs none of numpy's column copies,
//! projections and its stable argsort of the points. Anything else (a pair, two equal
//! projections, points crowding one plane across the direction) is left to numpy, which
//! then finds the pairs as before.
//!
//! The projections are numpy's `(x d0 + y d1) + z d2` of the coordinates with −0.0 made 0.0,
//! sorted by a counting sort into even buckets and a sort of each bucket (the order of
//! numpy's stable argsort whenever no two are equal; when two are, the caller is told to run
//! numpy).

use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// `c.max() − c.min()` of each coordinate column of `v` (with −0.0 made 0.0, as numpy's
/// `(V + 0.0)` columns: a max or min is one of the values, the same whatever the order).
pub fn extents(v: &[[f64; 3]]) -> [f64; 3] {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in v {
        for j in 0..3 {
            let x = p[j] + 0.0;
            lo[j] = lo[j].min(x);
            hi[j] = hi[j].max(x);
        }
    }
    [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]]
}

/// The indices 0..n sorted by `u` (finite, not all equal): a counting sort into n buckets
/// splitting [min, max] evenly (a bucket is a monotone function of u), then each bucket
/// sorted by value (equal values end up next to each other, in some order).
fn sorted_order(u: &[f64]) -> Vec<u32> {
    let n = u.len();
    let (lo, hi) = u
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let scale = n as f64 / (hi - lo);
    let bucket = |x: f64| (((x - lo) * scale) as usize).min(n - 1);
    let mut start = vec![0u32; n + 1];
    for &x in u {
        start[bucket(x) + 1] += 1;
    }
    for b in 0..n {
        start[b + 1] += start[b];
    }
    let mut fill = start[..n].to_vec();
    let mut order = vec![0u32; n];
    for (i, &x) in u.iter().enumerate() {
        let p = &mut fill[bucket(x)];
        order[*p as usize] = i as u32;
        *p += 1;
    }
    drop(fill);
    for b in 0..n {
        let s = &mut order[start[b] as usize..start[b + 1] as usize];
        if s.len() > 1 {
            s.sort_unstable_by(|&a, &c| u[a as usize].partial_cmp(&u[c as usize]).unwrap());
        }
    }
    order
}

/// Whether `_close_pairs` of the (distinct, finite) points `v` with tolerance `tol` > 0
/// along the unit direction `d` finds no pair (and runs: no two equal projections, no
/// point with more than `scan_max` neighbours within the slack of projection).
pub fn no_close_pairs(v: &[[f64; 3]], d: [f64; 3], tol: f64, scan_max: usize) -> bool {
    let n = v.len();
    if n < 2 {
        return true;
    }
    let u: Vec<f64> = v
        .iter()
        .map(|p| ((p[0] + 0.0) * d[0] + (p[1] + 0.0) * d[1]) + (p[2] + 0.0) * d[2])
        .collect();
    if n >= u32::MAX as usize || u.iter().all(|&x| x == u[0]) {
        return false; // numpy's turn
    }
    let order = sorted_order(&u);
    let us: Vec<f64> = order.iter().map(|&i| u[i as usize]).collect();
    drop(u);
    if us.windows(2).any(|w| w[0] == w[1]) {
        return false; // numpy's turn: it asks a k-d tree
    }
    let slack = tol * (1.0 + 1e-9) + 1e-12 * us[n - 1].max(-us[0]).max(0.0);
    let tol2 = tol * tol;
    for i in 0..n {
        let mut j = i + 1;
        while j < n && us[j] - us[i] <= slack {
            if j - i > scan_max {
                return false; // crowding: numpy's turn (a k-d tree)
            }
            let (a, b) = (&v[order[i] as usize], &v[order[j] as usize]);
            let (x, y, z) = (b[0] - a[0], b[1] - a[1], b[2] - a[2]);
            if x * x + y * y + z * z <= tol2 {
                return false; // a pair: numpy welds it
            }
            j += 1;
        }
    }
    true
}

/// [`extents`] of the rows of V (n, 3) float64: (3,) float64.
#[pyfunction]
pub fn weld_extents<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let pts = crate::points(&v, "V")?;
    let e = py.detach(|| extents(pts));
    Ok(PyArray1::from_slice(py, &e))
}

/// [`no_close_pairs`] of the rows of V (n, 3) float64 (distinct, finite).
#[pyfunction]
pub fn weld_no_close_pairs<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    d: [f64; 3],
    tol: f64,
    scan_max: usize,
) -> PyResult<bool> {
    let pts = crate::points(&v, "V")?;
    Ok(py.detach(|| no_close_pairs(pts, d, tol, scan_max)))
}
