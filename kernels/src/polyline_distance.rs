//! The distance from surface points to a pass's ball-centre polylines
//! (`blisk_cam/core/paths/expansion.py`, `PolylineDistance._distance`): the k samples
//! (along the segments) nearest a hint point name the candidate segments, and the distance is
//! the least over those segments, exact to each. The k nearest are those of the k-d tree of
//! `knn.rs` (scipy's set wherever the k-th and the next are not at the same distance; such a
//! row — and a row with fewer than k samples found — is flagged for the caller's scipy
//! answer). The distances are those of the numpy reference, operation for operation:
//! `ap = p − a`, `t = clip((ap·ab) / |ab|², 0, 1)`, `d = ap − t ab`, the least `d·d` (three-term
//! dot products summed as numpy's einsum, `(x0 y0 + x2 y2) + x1 y1`; a NaN wins the minimum
//! as in `np.minimum`), then its square root.

use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::closest::clip01;
use crate::numpy_ops::einsum_dot as dot;
use crate::numpy_ops::nanmin;

pub type P3 = [f64; 3];

/// Squared distance from `p` to the segment `a + t ab` (`l2` = |ab|², 0 replaced by 1).
#[inline(always)]
pub fn segment_d2(p: &P3, a: &P3, ab: &P3, l2: f64) -> f64 {
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let t = clip01(dot(&ap, ab) / l2);
    let d = [ap[0] - t * ab[0], ap[1] - t * ab[1], ap[2] - t * ab[2]];
    dot(&d, &d)
}

/// The distance of `p` to the segments of the samples `row` (`seg_of_sample`: the segment
/// of each): the least over them is the same in any order and with a segment measured
/// twice (a NaN wins as in `np.minimum`), so no sort as the numpy reference's; a segment
/// among the last 16 measured is not measured again (the k nearest samples of a hint
/// lie on one or two segments).
#[inline(always)]
pub fn least_distance(
    p: &P3,
    row: &[i64],
    seg_of_sample: &[i64],
    a: &[P3],
    ab: &[P3],
    l2: &[f64],
) -> f64 {
    let mut best = f64::INFINITY; // nanmin(∞, d2) is d2, NaN included
    let (mut segs, mut n) = ([0usize; 16], 0); // the segments measured (the last 16)
    for &x in row {
        let i = seg_of_sample[x as usize] as usize;
        if segs[..n.min(16)].contains(&i) {
            continue;
        }
        segs[n % 16] = i;
        n += 1;
        best = nanmin(best, segment_d2(p, &a[i], &ab[i], l2[i]));
    }
    best.sqrt()
}

/// (d (q,) float64 mm, fallback (q,) bool): the distance of each point `p` to the segments
/// (`a` (s, 3), `ab` (s, 3) = b − a, `l2` (s,) = |ab|² with 0 replaced by 1) of the k samples
/// of `tree` nearest its `hint` (`seg_of_sample` (n,) int64: the segment of each sample).
/// `fallback` rows (a tie at the k-th nearest, or fewer than k found) hold NaN: the caller
/// answers them. On `threads` threads, the GIL released.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn polyline_distance<'py>(
    py: Python<'py>,
    tree: &Bound<'py, crate::PointTree>,
    p: PyReadonlyArray2<'py, f64>,
    hint: PyReadonlyArray2<'py, f64>,
    k: usize,
    seg_of_sample: PyReadonlyArray1<'py, i64>,
    a: PyReadonlyArray2<'py, f64>,
    ab: PyReadonlyArray2<'py, f64>,
    l2: PyReadonlyArray1<'py, f64>,
    threads: usize,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<bool>>)> {
    if k == 0 {
        return Err(PyValueError::new_err("k must be at least 1"));
    }
    let (pp, hh) = (crate::points(&p, "p")?, crate::points(&hint, "hint")?);
    let (aa, abab) = (crate::points(&a, "a")?, crate::points(&ab, "ab")?);
    let sos = crate::slice1(&seg_of_sample, "seg_of_sample")?;
    let ll = crate::slice1(&l2, "l2")?;
    if hh.len() != pp.len() {
        return Err(PyValueError::new_err(
            "p and hint must have the same length",
        ));
    }
    if abab.len() != aa.len() || ll.len() != aa.len() {
        return Err(PyValueError::new_err(
            "a, ab and l2 must have the same length",
        ));
    }
    let ns = aa.len() as i64;
    if sos.iter().any(|&s| s < 0 || s >= ns) {
        return Err(PyValueError::new_err(
            "seg_of_sample holds segment ids out of range",
        ));
    }
    let t = &tree.get().tree;
    let pl = crate::pool_for(threads, pp.len())?;
    let mut d = vec![f64::NAN; pp.len()];
    let mut fb = vec![false; pp.len()];
    py.detach(|| {
        pl.install(|| {
            // the hints in packets of consecutive ones (a level's points come in path
            // order: on a Rotor 37 plan's calls replayed, 0.22 s of CPU one by one, 0.15 in
            // packets with no sort of the segments)
            let visit = |first: usize, ids: &[i64], tie: &[bool], d: &mut [f64], f: &mut [bool]| {
                for (j, (dj, fj)) in d.iter_mut().zip(f.iter_mut()).enumerate() {
                    let row = &ids[j * k..(j + 1) * k];
                    if tie[j] || row.iter().any(|&x| x < 0 || x as usize >= sos.len()) {
                        *fj = true;
                    } else {
                        *dj = least_distance(&pp[first + j], row, sos, aa, abab, ll);
                    }
                }
            };
            t.knn_runs(hh, k, f64::INFINITY, (&mut d, 1), (&mut fb, 1), visit);
        })
    });
    Ok((PyArray1::from_vec(py, d), PyArray1::from_vec(py, fb)))
}
