//! Reading the caller's numpy arrays: rows of points, flat C-contiguous data, one value or
//! row per item — each a clear error naming the array when its shape or layout is wrong.

use numpy::{Element, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pub type P3 = [f64; 3];

/// The data of a C-contiguous 2-D array, row after row.
pub fn flat<'a, T: Element>(a: &'a PyReadonlyArray2<'_, T>, what: &str) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{what} must be C-contiguous")))
}

/// Rows of a C-contiguous (m, 3) int64 array as triangles (vertex ids, not checked).
pub fn triangles<'a>(a: &'a PyReadonlyArray2<'_, i64>, what: &str) -> PyResult<&'a [[i64; 3]]> {
    let s = flat(a, what)?;
    if a.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!("{what} must be (m, 3)")));
    }
    // SAFETY: (m, 3) C-contiguous int64 rows are [i64; 3]s (same layout and alignment)
    Ok(unsafe { std::slice::from_raw_parts(s.as_ptr().cast(), s.len() / 3) })
}

/// Rows of a C-contiguous (n, N) float64 array as `[f64; N]`s (N the caller's columns:
/// 3 for points, 5 for a tool's primitives, 2 for ranges).
pub fn rows<'a, const N: usize>(
    a: &'a PyReadonlyArray2<'_, f64>,
    what: &str,
) -> PyResult<&'a [[f64; N]]> {
    if a.shape()[1] != N {
        return Err(PyValueError::new_err(format!(
            "{what} must be (n, {N}), got {:?}",
            a.shape()
        )));
    }
    let s = flat(a, what)?;
    // SAFETY: [f64; N] has the size and alignment of N f64 in a row
    Ok(unsafe { std::slice::from_raw_parts(s.as_ptr().cast(), s.len() / N) })
}

/// Rows of a C-contiguous (n, 3) float64 array as points.
pub fn points<'a>(a: &'a PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<&'a [P3]> {
    rows::<3>(a, what)
}

/// [`points`] that must hold `n` rows (one per item of the caller's other arrays).
pub fn points_n<'a>(a: &'a PyReadonlyArray2<'_, f64>, what: &str, n: usize) -> PyResult<&'a [P3]> {
    let p = points(a, what)?;
    if p.len() != n {
        return Err(PyValueError::new_err(format!(
            "{what} must have {n} rows, got {}",
            p.len()
        )));
    }
    Ok(p)
}

/// A C-contiguous 1-D array that must hold `n` values.
pub fn values_n<'a, T: Element>(
    a: &'a PyReadonlyArray1<'_, T>,
    what: &str,
    n: usize,
) -> PyResult<&'a [T]> {
    let s = crate::slice1(a, what)?;
    if s.len() != n {
        return Err(PyValueError::new_err(format!(
            "{what} must have {n} values, got {}",
            s.len()
        )));
    }
    Ok(s)
}
