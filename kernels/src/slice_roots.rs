//! The slicing roots of `slicing.MeshConeSlicer._edge_roots` for a linear morphing cone
//! (one meridional line α r + β z + γ = 0; paper 001 §3.1.2, Eq. 9 generalised): each mesh
//! edge's crossing parameter t and point, operation for operation as the numpy reference
//! (`vertex_side`, `_roots_on_lines` without the residual, the snapping to the vertices on
//! the level): every three-term dot product summed as numpy's einsum sums it,
//! `(x0 y0 + x2 y2) + x1 y1`, every norm as np.linalg.norm, `(x0² + x1²) + x2²`, NaN through
//! np.maximum as numpy, no fused multiply-add — the same floats.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::numpy_ops::einsum_dot as dot;
use crate::numpy_ops::nanmax;

type P3 = [f64; 3];

/// Fewer edges than this are solved on the calling thread.
const PARALLEL_MIN: usize = 16_384;

#[inline(always)]
fn norm(a: &P3) -> f64 {
    ((a[0] * a[0] + a[1] * a[1]) + a[2] * a[2]).sqrt()
}

/// The line's coefficients and α² (Python's `alpha**2`, passed in), the on-level tolerance.
#[derive(Clone, Copy)]
struct Line {
    alpha: f64,
    beta: f64,
    gamma: f64,
    alpha2: f64,
    on_tol: f64,
}

impl Line {
    /// From Python's `(alpha, beta, gamma, alpha**2)` and the on-level tolerance.
    fn new(line: (f64, f64, f64, f64), on_tol: f64) -> Line {
        Line {
            alpha: line.0,
            beta: line.1,
            gamma: line.2,
            alpha2: line.3,
            on_tol,
        }
    }

    /// `vertex_side`: the signed meridional distance, 0 within the tolerance.
    #[inline(always)]
    fn side(&self, r: f64, z: f64) -> f64 {
        let f = self.alpha * r + self.beta * z + self.gamma;
        if f.abs() <= self.on_tol {
            0.0
        } else {
            f
        }
    }

    /// The crossing of the edge (i0, i1) (`_edge_roots` for one edge): its parameter t,
    /// returned, and its point, written to `p` (3 floats).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn crossing(
        &self,
        rr: &[f64],
        zz: &[f64],
        rad: &[P3],
        vv: &[P3],
        i0: usize,
        i1: usize,
        p: &mut [f64],
    ) -> f64 {
        let f0 = self.side(rr[i0], zz[i0]);
        let f1 = self.side(rr[i1], zz[i1]);
        let tr = self.root(&rad[i0], &rad[i1], zz[i0], zz[i1], f0, f1);
        // vertices on the level (snapped to zero): the crossing is the vertex
        let tv = if f0 == 0.0 {
            0.0
        } else if f1 == 0.0 {
            1.0
        } else {
            tr
        };
        let (a, b) = (&vv[i0], &vv[i1]);
        if tv == 1.0 {
            p.copy_from_slice(b); // exactly the vertex
        } else {
            for j in 0..3 {
                p[j] = a[j] + tv * (b[j] - a[j]);
            }
        }
        tv
    }

    /// `_roots_on_lines(..., residual=False)` for one edge.
    fn root(&self, q0: &P3, q1: &P3, z0: f64, z1: f64, f0: f64, f1: f64) -> f64 {
        let (alpha, beta, gamma, a2) = (self.alpha, self.beta, self.gamma, self.alpha2);
        let dq = [q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]];
        let dz = z1 - z0;
        let w0 = beta * z0 + gamma;
        let bdz = beta * dz;
        let a = a2 * dot(&dq, &dq) - bdz * bdz;
        let b = 2.0 * (a2 * dot(q0, &dq) - beta * dz * w0);
        let c = a2 * dot(q0, q0) - w0 * w0;
        let disc = nanmax(b * b - 4.0 * a * c, 0.0);
        let sq = disc.sqrt();
        let qq = -0.5 * (b + sq.copysign(b));
        let r12 = [
            if qq != 0.0 { c / qq } else { f64::NAN },
            if a != 0.0 { qq / a } else { f64::NAN },
        ];
        let lin = if f1 != f0 { f0 / (f0 - f1) } else { 0.5 };
        let mut tt = [0.0f64; 2];
        let mut rr = [0.0f64; 2];
        let mut e = [0.0f64; 2];
        for j in 0..2 {
            let x = r12[j];
            let inside = x.is_finite() && x >= -1e-9 && x <= 1.0 + 1e-9;
            let v = if inside { x } else { lin };
            let v = if v.is_nan() { -1.0 } else { v };
            // np.clip as numpy computes it: (x > lo ? x : lo), then (y < hi ? y : hi)
            let y = if v > 0.0 { v } else { 0.0 };
            let tv = if y < 1.0 { y } else { 1.0 };
            let p = [q0[0] + tv * dq[0], q0[1] + tv * dq[1], q0[2] + tv * dq[2]];
            let rv = norm(&p);
            tt[j] = tv;
            rr[j] = rv;
            e[j] = (alpha * rv + beta * (z0 + tv * dz) + gamma).abs();
        }
        let pick = e[0] <= e[1];
        let t = if pick { tt[0] } else { tt[1] };
        let r = if pick { rr[0] } else { rr[1] };
        // one Newton step on the unsquared residual
        let qt = [q0[0] + t * dq[0], q0[1] + t * dq[1], q0[2] + t * dq[2]];
        let g = alpha * r + beta * (z0 + t * dz) + gamma;
        let dg = alpha * dot(&qt, &dq) / nanmax(r, 1e-300) + beta * dz;
        let tn = if dg.abs() > 1e-300 { t - g / dg } else { t };
        if tn.is_finite() && tn >= 0.0 && tn <= 1.0 {
            tn
        } else {
            t
        }
    }
}

/// The vertices' meridional r, z (n,), radial vectors (n, 3) and positions V (n, 3), the
/// lengths checked against r's.
#[allow(clippy::type_complexity)]
fn cone_vertices<'a>(
    r: &'a PyReadonlyArray1<'_, f64>,
    z: &'a PyReadonlyArray1<'_, f64>,
    radial: &'a PyReadonlyArray2<'_, f64>,
    v: &'a PyReadonlyArray2<'_, f64>,
) -> PyResult<(&'a [f64], &'a [f64], &'a [P3], &'a [P3])> {
    let rr = crate::slice1(r, "r")?;
    let n = rr.len();
    let zz = crate::arrays::values_n(z, "z", n)?;
    let rad = crate::arrays::points_n(radial, "radial", n)?;
    let vv = crate::arrays::points_n(v, "V", n)?;
    Ok((rr, zz, rad, vv))
}

/// Edge `e` is a row of `edges` (flat, 2 a row) joining two of the n vertices.
#[inline]
fn edge_ok(edges: &[i64], e: i64, n: usize) -> bool {
    let ok = |i: i64| i >= 0 && (i as usize) < n;
    e >= 0
        && (e as usize) < edges.len() / 2
        && ok(edges[2 * e as usize])
        && ok(edges[2 * e as usize + 1])
}

/// (points (k, 3), t (k,)): the crossings of the cone line on the edges `edge_ids` (k,) of
/// `edges` (ne, 2), from the vertices' meridional r, z (n,), radial vectors (n, 3) and
/// positions V (n, 3); on `threads` threads with the GIL released.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn cone_edge_roots<'py>(
    py: Python<'py>,
    r: PyReadonlyArray1<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
    radial: PyReadonlyArray2<'py, f64>,
    v: PyReadonlyArray2<'py, f64>,
    edges: PyReadonlyArray2<'py, i64>,
    edge_ids: PyReadonlyArray1<'py, i64>,
    line: (f64, f64, f64, f64),
    on_tol: f64,
    threads: usize,
) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>)> {
    let (rr, zz, rad, vv) = cone_vertices(&r, &z, &radial, &v)?;
    let n = rr.len();
    let ee = crate::arrays::flat(&edges, "edges")?;
    let ids = crate::slice1(&edge_ids, "edge_ids")?;
    // only the edges asked for are checked (a level crosses a few thousand of millions)
    if ids.iter().any(|&e| !edge_ok(ee, e, n)) {
        return Err(PyValueError::new_err("edge or vertex ids out of range"));
    }
    let ln = Line::new(line, on_tol);
    let pl = crate::pool_for(threads, ids.len())?;
    let k = ids.len();
    let mut pts = vec![0.0f64; 3 * k];
    let mut ts = vec![0.0f64; k];
    let one = |((p, t), &e): ((&mut [f64], &mut f64), &i64)| {
        let (i0, i1) = (ee[2 * e as usize] as usize, ee[2 * e as usize + 1] as usize);
        *t = ln.crossing(rr, zz, rad, vv, i0, i1, p);
    };
    py.detach(|| {
        if threads <= 1 || k < PARALLEL_MIN {
            // a level's few thousand edges: less than the threads' start-up
            pts.chunks_mut(3)
                .zip(ts.iter_mut())
                .zip(ids.iter())
                .for_each(one);
        } else {
            pl.install(|| {
                pts.par_chunks_mut(3)
                    .zip(ts.par_iter_mut())
                    .zip(ids.par_iter())
                    .with_min_len(1024)
                    .for_each(one)
            });
        }
    });
    let pts = PyArray1::from_vec(py, pts).reshape([k, 3])?;
    Ok((pts, PyArray1::from_vec(py, ts)))
}

/// The crossing part of `slicing.MeshConeSlicer.slice` for a linear morphing cone, in one
/// call: of the candidate faces `cand` (c,) (of F (m, 3), whose edges v0v1, v1v2, v2v0 are
/// `face_edges` (m, 3) of `edges` (ne, 2)), those the line crosses (`vertex_side` of every
/// corner, above the level where f > 0, or f ≥ 0 with `end_above_zero`: the end level s = 1),
/// the links from the edge each is entered by below → above to the edge it is left by
/// (counter-clockwise in the face), the crossed edges (ascending, unique), their crossings
/// (`cone_edge_roots`) and the smooth normals there (the vertex normals `vn` (n, 3)
/// interpolated along the edge, unit as numpy's norm makes them). Operation for operation
/// the numpy reference's, so the same floats.
///
/// Returns (edges (u,) int64, links (f, 2) int64 — indices into edges, points (u, 3),
/// t (u,), normals (u, 3)); on the calling thread (a level crosses a few thousand faces),
/// the GIL released.
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn cone_level<'py>(
    py: Python<'py>,
    r: PyReadonlyArray1<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
    radial: PyReadonlyArray2<'py, f64>,
    v: PyReadonlyArray2<'py, f64>,
    vn: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
    edges: PyReadonlyArray2<'py, i64>,
    face_edges: PyReadonlyArray2<'py, i64>,
    cand: PyReadonlyArray1<'py, i64>,
    line: (f64, f64, f64, f64),
    on_tol: f64,
    end_above_zero: bool,
) -> PyResult<(
    Bound<'py, PyArray1<i64>>,
    Bound<'py, PyArray2<i64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
)> {
    let (rr, zz, rad, vv) = cone_vertices(&r, &z, &radial, &v)?;
    let n = rr.len();
    let nn = crate::arrays::points_n(&vn, "vn", n)?;
    let ff = crate::arrays::flat(&f, "F")?;
    let ee = crate::arrays::flat(&edges, "edges")?;
    let fe = crate::arrays::flat(&face_edges, "face_edges")?;
    let cc = crate::slice1(&cand, "cand")?;
    let m = ff.len() / 3;
    if fe.len() != 3 * m {
        return Err(PyValueError::new_err(
            "face_edges must have a row per face of F",
        ));
    }
    // only the faces asked for (and their edges) are checked
    if cc.iter().any(|&c| {
        c < 0 || c as usize >= m || {
            let k = 3 * c as usize;
            ff[k..k + 3].iter().any(|&x| x < 0 || x as usize >= n)
                || fe[k..k + 3].iter().any(|&e| !edge_ok(ee, e, n))
        }
    }) {
        return Err(PyValueError::new_err(
            "face, edge or vertex ids out of range",
        ));
    }
    let ln = Line::new(line, on_tol);
    let (uedges, links, pts, ts, nrm) = py.detach(|| {
        // the crossed faces, in the candidates' order: the links up → dn (edge ids)
        let mut up: Vec<i64> = Vec::new();
        let mut dn: Vec<i64> = Vec::new();
        for &c in cc {
            let k = 3 * c as usize;
            let mut ab = [false; 3];
            for j in 0..3 {
                let x = ff[k + j] as usize;
                let s = ln.side(rr[x], zz[x]);
                ab[j] = if end_above_zero { s >= 0.0 } else { s > 0.0 };
            }
            if (ab[0] && ab[1] && ab[2]) || !(ab[0] || ab[1] || ab[2]) {
                continue;
            }
            // edge j joins corner j and j + 1; exactly two of the three cross
            let mut kk = [0usize; 2];
            let mut q = 0;
            for j in 0..3 {
                if ab[j] != ab[(j + 1) % 3] {
                    kk[q] = j;
                    q += 1;
                }
            }
            let (e0, e1) = (fe[k + kk[0]], fe[k + kk[1]]);
            if !ab[kk[0]] {
                up.push(e0); // corner k below → corner k + 1 above: going up
                dn.push(e1);
            } else {
                up.push(e1);
                dn.push(e0);
            }
        }
        let mut uedges: Vec<i64> = up.iter().chain(dn.iter()).copied().collect();
        uedges.sort_unstable();
        uedges.dedup();
        let at = |e: i64| uedges.binary_search(&e).unwrap() as i64;
        let links: Vec<i64> = up
            .iter()
            .zip(dn.iter())
            .flat_map(|(&a, &b)| [at(a), at(b)])
            .collect();
        let u = uedges.len();
        let mut pts = vec![0.0f64; 3 * u];
        let mut ts = vec![0.0f64; u];
        let mut nrm = vec![0.0f64; 3 * u];
        for (i, &e) in uedges.iter().enumerate() {
            let (i0, i1) = (ee[2 * e as usize] as usize, ee[2 * e as usize + 1] as usize);
            let t = ln.crossing(rr, zz, rad, vv, i0, i1, &mut pts[3 * i..3 * i + 3]);
            ts[i] = t;
            // (1 − t) n0 + t n1, divided by its norm ((x0² + x1²) + x2², 1 where it is 0)
            let w = 1.0 - t;
            let x = [
                w * nn[i0][0] + t * nn[i1][0],
                w * nn[i0][1] + t * nn[i1][1],
                w * nn[i0][2] + t * nn[i1][2],
            ];
            let l = norm(&x);
            let l = if l > 0.0 { l } else { 1.0 };
            for j in 0..3 {
                nrm[3 * i + j] = x[j] / l;
            }
        }
        (uedges, links, pts, ts, nrm)
    });
    let nf = links.len() / 2;
    let u = uedges.len();
    Ok((
        PyArray1::from_vec(py, uedges),
        PyArray1::from_vec(py, links).reshape([nf, 2])?,
        PyArray1::from_vec(py, pts).reshape([u, 3])?,
        PyArray1::from_vec(py, ts),
        PyArray1::from_vec(py, nrm).reshape([u, 3])?,
    ))
}
