//! Compiled kernels of Blisk CAM, one Python extension module `blisk_cam_kernels`.
//!
//! Only `blisk_cam/core/kernels/` imports this module; the numpy code in `blisk_cam/core` is
//! the reference and the fallback. Every kernel releases the GIL; the parallel ones run on
//! a rayon pool of the caller's thread count (the user's `--threads`).

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

mod step;
mod weld;

/// Rows of a C-contiguous (n, 3) float64 array as points.
fn points<'a>(a: &'a PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<&'a [[f64; 3]]> {
    if a.shape()[1] != 3 {
        return Err(PyValueError::new_err(format!("{what} must be (n, 3), got {:?}", a.shape())));
    }
    let s = a
        .as_slice()
        .map_err(|_| PyValueError::new_err(format!("{what} must be C-contiguous")))?;
    // SAFETY: [f64; 3] has the size and alignment of three f64 in a row
    Ok(unsafe { std::slice::from_raw_parts(s.as_ptr() as *const [f64; 3], s.len() / 3) })
}

fn slice1<'a, T: numpy::Element>(a: &'a PyReadonlyArray1<'_, T>, what: &str) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{what} must be C-contiguous")))
}

/// Greedy forward step (see `sampling.forward_step_indices`): (keep (q,) int64, trace (k, 3)
/// int64: per search start its first step, outcome and farthest end tested, -1 elsewhere).
#[pyfunction]
#[pyo3(signature = (p, c, tol_p, tol_c, old_trace=None, unchanged_to=None))]
fn forward_step<'py>(
    py: Python<'py>,
    p: PyReadonlyArray2<'py, f64>,
    c: PyReadonlyArray2<'py, f64>,
    tol_p: f64,
    tol_c: f64,
    old_trace: Option<PyReadonlyArray2<'py, i64>>,
    unchanged_to: Option<PyReadonlyArray1<'py, i64>>,
) -> PyResult<(Bound<'py, PyArray1<i64>>, Bound<'py, PyArray2<i64>>)> {
    let pp = points(&p, "p")?;
    let cc = points(&c, "c")?;
    if pp.len() != cc.len() {
        return Err(PyValueError::new_err("p and c must have the same length"));
    }
    let k = pp.len();
    let old = match (&old_trace, &unchanged_to) {
        (Some(t), Some(u)) => {
            if t.shape() != [k, 3] || u.len() != k + 1 {
                return Err(PyValueError::new_err("old_trace must be (k, 3), unchanged_to (k + 1,)"));
            }
            let ts = t
                .as_slice()
                .map_err(|_| PyValueError::new_err("old_trace must be C-contiguous"))?;
            // SAFETY: as in `points`
            let ts = unsafe { std::slice::from_raw_parts(ts.as_ptr() as *const [i64; 3], k) };
            Some((ts, slice1(u, "unchanged_to")?))
        }
        (None, None) => None,
        _ => return Err(PyValueError::new_err("old_trace and unchanged_to go together")),
    };
    let out = py.detach(|| step::forward_step(pp, cc, tol_p, tol_c, old));
    let trace: Vec<i64> = out.trace.iter().flatten().copied().collect();
    let trace = PyArray1::from_vec(py, trace).reshape([k, 3])?;
    Ok((PyArray1::from_vec(py, out.keep), trace))
}

/// For each point of the columns x, y, z (float64, no -0.0), the index of the first point
/// with the same coordinates (see `weld._first_equal_point`), (k,) int64.
#[pyfunction]
fn first_equal_point<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    y: PyReadonlyArray1<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let (xs, ys, zs) = (slice1(&x, "x")?, slice1(&y, "y")?, slice1(&z, "z")?);
    if xs.len() != ys.len() || xs.len() != zs.len() {
        return Err(PyValueError::new_err("x, y and z must have the same length"));
    }
    let bits = |s: &[f64]| -> &[u64] {
        // SAFETY: f64 and u64 have the same size and alignment
        unsafe { std::slice::from_raw_parts(s.as_ptr() as *const u64, s.len()) }
    };
    let (bx, by, bz) = (bits(xs), bits(ys), bits(zs));
    let first = py.detach(|| weld::first_equal_point(bx, by, bz));
    Ok(PyArray1::from_vec(py, first))
}

#[pymodule]
fn blisk_cam_kernels(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(forward_step, m)?)?;
    m.add_function(wrap_pyfunction!(first_equal_point, m)?)?;
    Ok(())
}
