//! `expansion.face_gradient_and_curvature` (the side-step prediction of paper 001 Eqs. 11–14,
//! `passes._Generator.predict_step`): per face the surface gradient of a vertex field and
//! the normal curvature along it, the numpy reference's operations in its order — `np.cross`
//! (u1 v2 − u2 v1, …), the sums started from 0, `np.linalg.norm` as ((x0² + x1²) + x2²),
//! and `einsum("ia,iab,ib->i")` as Σ over (a, b) in C order of (u_a J_ab) u_b from 0 — so the
//! same floats bit for bit.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::lift::P3;
use crate::numpy_ops::cross;

/// (grad, κ) of one face: corners `x`, vertex normals `vn`, field values `val` (non-finite
/// taken as 0), unit face normal `fnrm`, face area `area` (mm²).
fn one_face(x: [&P3; 3], vn: [&P3; 3], val: [f64; 3], fnrm: &P3, area: f64) -> (P3, f64) {
    let area2 = area * 2.0;
    let inv = if area2 > 0.0 { 1.0 / area2 } else { 0.0 };
    let mut grad = [0.0f64; 3];
    let mut jac = [[0.0f64; 3]; 3];
    for i in 0..3 {
        let (a, b) = (x[(i + 2) % 3], x[(i + 1) % 3]);
        let e = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
        let c = cross(fnrm, &e);
        let g = [c[0] * inv, c[1] * inv, c[2] * inv];
        let v = if val[i].is_finite() { val[i] } else { 0.0 };
        for j in 0..3 {
            grad[j] += v * g[j];
        }
        for (ja, row) in jac.iter_mut().enumerate() {
            for jb in 0..3 {
                row[jb] += vn[i][ja] * g[jb];
            }
        }
    }
    let gl = ((grad[0] * grad[0] + grad[1] * grad[1]) + grad[2] * grad[2]).sqrt();
    let den = if gl > 0.0 { gl } else { 1.0 };
    let u = [grad[0] / den, grad[1] / den, grad[2] / den];
    let mut kappa = 0.0f64;
    for a in 0..3 {
        for b in 0..3 {
            kappa += (u[a] * jac[a][b]) * u[b];
        }
    }
    (grad, kappa)
}

/// (grad (q, 3), κ (q,)) of `face_gradient_and_curvature(mesh, values, faces)`: V (n, 3),
/// F (m, 3), unit face normals (m, 3), face areas (m,) mm², unit vertex normals (n, 3), the
/// field `values` (n,), the faces (q,). The GIL released (one thread: a level's faces).
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn face_gradient_curvature<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
    face_normals: PyReadonlyArray2<'py, f64>,
    face_areas: PyReadonlyArray1<'py, f64>,
    vertex_normals: PyReadonlyArray2<'py, f64>,
    values: PyReadonlyArray1<'py, f64>,
    faces: PyReadonlyArray1<'py, i64>,
) -> PyResult<(Bound<'py, numpy::PyArray2<f64>>, Bound<'py, PyArray1<f64>>)> {
    let vv = crate::points(&v, "V")?;
    let ff = crate::arrays::triangles(&f, "F")?;
    let m = ff.len();
    let fnn = crate::arrays::points_n(&face_normals, "face_normals", m)?;
    let ar = crate::arrays::values_n(&face_areas, "face_areas", m)?;
    let nv = vv.len();
    let vn = crate::arrays::points_n(&vertex_normals, "vertex_normals", nv)?;
    let vals = crate::arrays::values_n(&values, "values", nv)?;
    let sel = crate::slice1(&faces, "faces")?;
    if sel.iter().any(|&i| i < 0 || i as usize >= m) {
        return Err(PyValueError::new_err("faces holds face ids out of range"));
    }
    if sel
        .iter()
        .any(|&i| ff[i as usize].iter().any(|&x| x < 0 || x as usize >= nv))
    {
        return Err(PyValueError::new_err("F holds vertex ids out of range"));
    }
    let (grad, kappa) = py.detach(|| {
        let mut grad = Vec::with_capacity(3 * sel.len());
        let mut kappa = Vec::with_capacity(sel.len());
        for &fi in sel {
            let t = &ff[fi as usize];
            let c = [t[0] as usize, t[1] as usize, t[2] as usize];
            let (g, k) = one_face(
                [&vv[c[0]], &vv[c[1]], &vv[c[2]]],
                [&vn[c[0]], &vn[c[1]], &vn[c[2]]],
                [vals[c[0]], vals[c[1]], vals[c[2]]],
                &fnn[fi as usize],
                ar[fi as usize],
            );
            grad.extend_from_slice(&g);
            kappa.push(k);
        }
        (grad, kappa)
    });
    let q = sel.len();
    Ok((
        PyArray1::from_vec(py, grad).reshape([q, 3])?,
        PyArray1::from_vec(py, kappa),
    ))
}
