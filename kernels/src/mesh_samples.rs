//! Tables of the passes' intrusion checks (`passes._Generator`), made from the mesh in one
//! pass each: the faces around every vertex (`_vertex_face_table`: numpy's stable argsort of
//! the corners by vertex, as a counting sort — the same permutation) and the k-d tree over
//! every vertex, edge midpoint `0.5 (u + v)` and face centroid `((a + b) + c) / 3` (the very
//! sums of `_ProbeSamples.all_points`, so the very points), without the (n + e + f, 3) array.

use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::knn;

fn ids_in_range(ids: &[i64], n: usize, what: &str) -> PyResult<()> {
    if ids.iter().any(|&i| i < 0 || i as usize >= n) {
        return Err(PyValueError::new_err(format!(
            "{what} holds vertex ids out of range"
        )));
    }
    Ok(())
}

/// The faces around each vertex of the faces `ff` (3m vertex ids in 0..n, row-major) by a
/// counting sort of the corners by vertex (stable: numpy's stable argsort of `F.ravel()`):
/// (ptr (n + 1,), face (3 m,), corner (3 m,)), face and corner as `face_id(f)` and
/// `corner_id(k)` of the face id f and the corner k in 0..3.
fn face_table<T: Copy + Default, C: Copy + Default>(
    ff: &[i64],
    n: usize,
    face_id: impl Fn(usize) -> T,
    corner_id: impl Fn(usize) -> C,
) -> (Vec<i64>, Vec<T>, Vec<C>) {
    let mut ptr = vec![0i64; n + 1];
    for &v in ff {
        ptr[v as usize + 1] += 1;
    }
    for i in 0..n {
        ptr[i + 1] += ptr[i];
    }
    let mut next: Vec<i64> = ptr[..n].to_vec();
    let mut face = vec![T::default(); ff.len()];
    let mut corner = vec![C::default(); ff.len()];
    for (i, &v) in ff.iter().enumerate() {
        let p = &mut next[v as usize];
        face[*p as usize] = face_id(i / 3);
        corner[*p as usize] = corner_id(i % 3);
        *p += 1;
    }
    (ptr, face, corner)
}

/// (ptr (n + 1,), face (3 m,), corner (3 m,)) int64: the faces around vertex v are
/// `face[ptr[v]:ptr[v + 1]]` (ascending), v being their corner `corner[...]`; F (m, 3).
#[pyfunction]
pub fn vertex_face_table<'py>(
    py: Python<'py>,
    f: PyReadonlyArray2<'py, i64>,
    n_vertices: usize,
) -> PyResult<(
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i64>>,
)> {
    let ff = crate::arrays::flat(&f, "F")?;
    ids_in_range(ff, n_vertices, "F")?;
    let (ptr, face, corner) = py.detach(|| face_table(ff, n_vertices, |x| x as i64, |k| k as i64));
    Ok((
        PyArray1::from_vec(py, ptr),
        PyArray1::from_vec(py, face),
        PyArray1::from_vec(py, corner),
    ))
}

/// [`vertex_face_table`] with the faces as int32 and the corners as int8 (the same values),
/// the table the passes keep (`passes._narrow_table`), made so at once: at 1M faces not the
/// two 24 MB int64 arrays first (faulted in, then cast and freed, on the side thread beside
/// the passes' first levels). F (m, 3) with 3 m below 2³¹.
#[pyfunction]
pub fn vertex_face_table_narrow<'py>(
    py: Python<'py>,
    f: PyReadonlyArray2<'py, i64>,
    n_vertices: usize,
) -> PyResult<(
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray1<i32>>,
    Bound<'py, PyArray1<i8>>,
)> {
    let ff = crate::arrays::flat(&f, "F")?;
    ids_in_range(ff, n_vertices, "F")?;
    if ff.len() >= i32::MAX as usize {
        return Err(PyValueError::new_err("too many faces for int32 face ids"));
    }
    let (ptr, face, corner) = py.detach(|| face_table(ff, n_vertices, |x| x as i32, |k| k as i8));
    Ok((
        PyArray1::from_vec(py, ptr),
        PyArray1::from_vec(py, face),
        PyArray1::from_vec(py, corner),
    ))
}

/// The k-d tree (`PointTree`) over the samples of the mesh V (n, 3), edges E (e, 2), faces
/// F (m, 3): vertices, then edge midpoints, then face centroids (ids n + e + f order), built
/// on `threads` threads, its splits made on the vertices (each owning its samples, see
/// `knn::PointTree::grouped`: the answers of `PointTree::new` over the same points).
#[pyfunction]
pub fn sample_point_tree(
    py: Python<'_>,
    v: PyReadonlyArray2<'_, f64>,
    e: PyReadonlyArray2<'_, i64>,
    f: PyReadonlyArray2<'_, i64>,
    threads: usize,
) -> PyResult<crate::PointTree> {
    let vv = crate::points(&v, "V")?;
    let ee = crate::arrays::flat(&e, "E")?;
    let ff = crate::arrays::flat(&f, "F")?;
    ids_in_range(ee, vv.len(), "E")?;
    ids_in_range(ff, vv.len(), "F")?;
    let total = vv.len() + ee.len() / 2 + ff.len() / 3;
    if total >= u32::MAX as usize {
        return Err(PyValueError::new_err("too many points for one tree"));
    }
    let pl = crate::pool(threads)?;
    let tree = py.detach(|| {
        let (n, ne) = (vv.len(), ee.len() / 2);
        // each sample in the group of a vertex (the vertex itself, the edges whose first
        // vertex it is, the faces whose first corner it is; ascending ids): the tree's splits
        // are made on the vertices alone (`knn::PointTree::grouped`)
        let mut ptr = vec![1u32; n + 1];
        ptr[0] = 0;
        for w in ee.chunks_exact(2) {
            ptr[w[0] as usize + 1] += 1;
        }
        for t in ff.chunks_exact(3) {
            ptr[t[0] as usize + 1] += 1;
        }
        for v in 0..n {
            ptr[v + 1] += ptr[v];
        }
        let mut next: Vec<u32> = ptr[..n].to_vec();
        let mut members = vec![0u32; total];
        for (v, o) in next.iter_mut().enumerate() {
            members[*o as usize] = v as u32;
            *o += 1;
        }
        for (j, w) in ee.chunks_exact(2).enumerate() {
            let o = &mut next[w[0] as usize];
            members[*o as usize] = (n + j) as u32;
            *o += 1;
        }
        for (k, t) in ff.chunks_exact(3).enumerate() {
            let o = &mut next[t[0] as usize];
            members[*o as usize] = (n + ne + k) as u32;
            *o += 1;
        }
        drop(next);
        // the very sums of `_ProbeSamples.all_points`
        let point = |id: u32| -> [f64; 3] {
            let i = id as usize;
            if i < n {
                vv[i]
            } else if i < n + ne {
                let w = &ee[2 * (i - n)..2 * (i - n) + 2];
                let (a, b) = (&vv[w[0] as usize], &vv[w[1] as usize]);
                [
                    0.5 * (a[0] + b[0]),
                    0.5 * (a[1] + b[1]),
                    0.5 * (a[2] + b[2]),
                ]
            } else {
                let k = i - n - ne;
                let t = &ff[3 * k..3 * k + 3];
                let (a, b, c) = (&vv[t[0] as usize], &vv[t[1] as usize], &vv[t[2] as usize]);
                [
                    ((a[0] + b[0]) + c[0]) / 3.0,
                    ((a[1] + b[1]) + c[1]) / 3.0,
                    ((a[2] + b[2]) + c[2]) / 3.0,
                ]
            }
        };
        pl.install(|| knn::PointTree::grouped(vv, ptr, members, &point))
    });
    Ok(crate::PointTree { tree })
}
