//! The intrusion screens of `passes._Generator` (`_ProbeSamples.any_within`): whether a
//! surface sample (vertex, edge midpoint, face centroid) lies closer than a bound to each
//! ball centre, on the k-d tree of all samples that the lift's 8-nearest search uses
//! (`knn::PointTree`). Squared distances are summed as scipy's k-d tree sums them and a
//! sample counts when below the bound's square, as in scipy: the answers of the full tree.

use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// (q,) bool: a point of `tree` lies closer than `bound` mm to the query (q, 3); on
/// `threads` threads, the GIL released.
#[pyfunction]
pub fn points_within<'py>(
    py: Python<'py>,
    tree: &Bound<'py, crate::PointTree>,
    q: PyReadonlyArray2<'py, f64>,
    bound: f64,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let qq = crate::points(&q, "queries")?;
    let pl = crate::pool_for(threads, qq.len())?;
    let t = &tree.get().tree;
    let ub2 = bound * bound;
    let out: Vec<bool> = py.detach(|| pl.install(|| t.any_below_many(qq, ub2)));
    Ok(PyArray1::from_vec(py, out))
}
