//! The candidate faces of a level of the slicer (`paths.slicing.MeshConeSlicer.
//! _candidate_faces`) in one call: of the narrow faces in a range of their bucket order, those
//! whose least s lies in [lo, hi] and whose largest s is at least `below`, with the wide faces
//! whose s range meets [below, hi], ascending — the numpy reference's ids (the same
//! comparisons: a NaN fails each, as in numpy).

use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// (c,) int64 ascending: the ids `narrow[start..end]` (clamped as a Python slice) with
/// `lo ≤ smin ≤ hi` and `smax ≥ below`, and the ids `wide` with `smin ≤ hi` and
/// `smax ≥ below`; `smin`, `smax` (m,) float64 per face. The GIL released.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn slicer_candidates<'py>(
    py: Python<'py>,
    narrow: PyReadonlyArray1<'py, i64>,
    start: usize,
    end: usize,
    wide: PyReadonlyArray1<'py, i64>,
    smin: PyReadonlyArray1<'py, f64>,
    smax: PyReadonlyArray1<'py, f64>,
    lo: f64,
    hi: f64,
    below: f64,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let nn = crate::slice1(&narrow, "narrow")?;
    let ww = crate::slice1(&wide, "wide")?;
    let (a, b) = (crate::slice1(&smin, "smin")?, crate::slice1(&smax, "smax")?);
    if a.len() != b.len() {
        return Err(PyValueError::new_err(
            "smin and smax must have the same length",
        ));
    }
    let m = a.len() as i64;
    let end = end.min(nn.len());
    let near = &nn[start.min(end)..end];
    if near.iter().chain(ww.iter()).any(|&f| f < 0 || f >= m) {
        return Err(PyValueError::new_err("face ids out of range"));
    }
    let out = py.detach(|| {
        let mut out: Vec<i64> = near
            .iter()
            .copied()
            .filter(|&f| {
                let lo_f = a[f as usize];
                lo_f >= lo && lo_f <= hi && b[f as usize] >= below
            })
            .collect();
        out.extend(
            ww.iter()
                .copied()
                .filter(|&f| a[f as usize] <= hi && b[f as usize] >= below),
        );
        out.sort_unstable();
        out
    });
    Ok(PyArray1::from_vec(py, out))
}
