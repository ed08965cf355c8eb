//! The collision scene's triangle tree built compiled (`blisk_cam/core/collision/tri_tree.py::
//! _TriTree.__init__`, the reference): the triangles sorted along the Morton curve of their
//! centroids (a stable sort, as `np.argsort(kind="stable")`), gathered in that order with
//! their centroids, bounding radii and unit normals, and the implicit tree over them — leaves
//! of LEAF consecutive triangles, BRANCH consecutive children per node, each node's box,
//! sphere and representative point (its first child's). The arithmetic is numpy's operation
//! for operation (the same sums in the same order), so the arrays are numpy's bit for bit;
//! the sort, gathers and per-node reductions run in parallel (rayon, the GIL released). The
//! arrays go straight into the walk's [`Tree`] (no copy through numpy); Python gets the
//! Morton order, and the arrays themselves only when asked ([`collision_tree_arrays`]).

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyList;
use rayon::prelude::*;

use crate::arrays::{flat, points};
use crate::collision_refine::norm;
use crate::collision_walk::{CollisionTree, Node, Tree, Tri, BRANCH, LEAF};
use crate::numpy_ops::einsum_dot as dot;
use crate::numpy_ops::sub;
use crate::numpy_ops::{nanmax, nanmin};

type P3 = [f64; 3];

/// `np.einsum("ij,ij->i", e, e)` of one row, summed as numpy's einsum sums three products
/// (numpy 1.26 and 2.x alike): (x² + z²) + y² — `numpy_ops::einsum_dot`'s order.
#[inline(always)]
fn sq(e: &P3) -> f64 {
    dot(e, e)
}

#[inline(always)]
fn pmin(a: &P3, b: &P3) -> P3 {
    [nanmin(a[0], b[0]), nanmin(a[1], b[1]), nanmin(a[2], b[2])]
}

#[inline(always)]
fn pmax(a: &P3, b: &P3) -> P3 {
    [nanmax(a[0], b[0]), nanmax(a[1], b[1]), nanmax(a[2], b[2])]
}

/// A flat (n·3) array as (n, 3) numpy.
fn arr3<'py>(py: Python<'py>, v: Vec<P3>) -> PyResult<Bound<'py, PyAny>> {
    let n = v.len();
    let flat: Vec<f64> = v.into_iter().flatten().collect();
    Ok(PyArray1::from_vec(py, flat).reshape([n, 3])?.into_any())
}

/// Per triangle (Morton order): its box (`min(min(A, B), C)`, the max likewise).
#[inline(always)]
fn tri_box(t: &Tri) -> (P3, P3) {
    (pmin(&pmin(&t.a, &t.b), &t.c), pmax(&pmax(&t.a, &t.b), &t.c))
}

type Boxes = (Vec<P3>, Vec<P3>, Vec<P3>);

/// A level's boxes (lo, hi) and representatives from `q` groups: `group(i)` the i-th's.
fn boxes(q: usize, group: impl Fn(usize) -> (P3, P3, P3) + Sync) -> Boxes {
    let mut out = (vec![[0.0; 3]; q], vec![[0.0; 3]; q], vec![[0.0; 3]; q]);
    (
        out.0.par_iter_mut(),
        out.1.par_iter_mut(),
        out.2.par_iter_mut(),
    )
        .into_par_iter()
        .enumerate()
        .with_min_len(1024)
        .for_each(|(i, (l, h, r))| (*l, *h, *r) = group(i));
    out
}

/// The next level up (`np.minimum.reduceat` / `np.maximum.reduceat` over groups of `k`, the
/// representative of the group's first).
fn reduce(b: &Boxes, k: usize) -> Boxes {
    let (lo, hi, rep) = b;
    boxes(lo.len().div_ceil(k), |i| {
        let (s, e) = (k * i, (k * i + k).min(lo.len()));
        let (mut ll, mut hh) = (lo[s], hi[s]);
        for j in s + 1..e {
            ll = pmin(&ll, &lo[j]);
            hh = pmax(&hh, &hi[j]);
        }
        (ll, hh, rep[s])
    })
}

/// The level's nodes from its boxes and representatives (`_TriTree`: centre ½(lo + hi),
/// radius ½|hi − lo|, half-sizes ½(hi − lo)).
fn nodes(b: &Boxes) -> Vec<Node> {
    let (lo, hi, rep) = b;
    (0..lo.len())
        .into_par_iter()
        .with_min_len(1024)
        .map(|i| {
            let (l, h) = (&lo[i], &hi[i]);
            let d = sub(h, l);
            Node {
                c: [
                    0.5 * (l[0] + h[0]),
                    0.5 * (l[1] + h[1]),
                    0.5 * (l[2] + h[2]),
                ],
                r: 0.5 * norm(&d),
                rep: rep[i],
                h: [0.5 * d[0], 0.5 * d[1], 0.5 * d[2]],
            }
        })
        .collect()
}

/// (Morton order, the tree) of triangles F over vertices V (indices checked by the caller).
fn build(v: &[P3], f: &[[i64; 3]]) -> (Vec<i64>, Tree) {
    let cen0: Vec<P3> = f
        .par_iter()
        .with_min_len(4096)
        .map(|t| {
            let (a, b, c) = (&v[t[0] as usize], &v[t[1] as usize], &v[t[2] as usize]);
            [
                (a[0] + b[0] + c[0]) / 3.0,
                (a[1] + b[1] + c[1]) / 3.0,
                (a[2] + b[2] + c[2]) / 3.0,
            ]
        })
        .collect();
    let inf = || ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    let (lo, hi) = cen0
        .par_iter()
        .with_min_len(4096)
        .fold(inf, |(l, h), p| (pmin(&l, p), pmax(&h, p)))
        .reduce(inf, |a, b| (pmin(&a.0, &b.0), pmax(&a.1, &b.1)));
    let span = (0..3)
        .map(|i| nanmax(hi[i] - lo[i], 1e-12))
        .fold(f64::NEG_INFINITY, nanmax);
    // key << 32 | index: an unstable sort of these is the stable argsort of the keys
    let mut keys: Vec<u64> = cen0
        .par_iter()
        .with_min_len(4096)
        .enumerate()
        .map(|(i, p)| {
            let q = |k: usize| ((p[k] - lo[k]) / span * 1023.0) as u64;
            let key = crate::morton::code3(q(0), q(1), q(2)); // `tri_tree._morton`'s
            (key << 32) | i as u64
        })
        .collect();
    keys.par_sort_unstable();
    let order: Vec<i64> = keys.iter().map(|k| (k & 0xFFFF_FFFF) as i64).collect();
    drop(keys);
    let tris: Vec<Tri> = order
        .par_iter()
        .with_min_len(4096)
        .map(|&o| {
            let t = &f[o as usize];
            let (a, b, c) = (v[t[0] as usize], v[t[1] as usize], v[t[2] as usize]);
            let cen = cen0[o as usize];
            let r2 = nanmax(
                nanmax(sq(&sub(&a, &cen)), sq(&sub(&b, &cen))),
                sq(&sub(&c, &cen)),
            );
            let rad = r2.sqrt();
            let (u, w) = (sub(&b, &a), sub(&c, &a));
            let n = [
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ];
            let ln = sq(&n).sqrt();
            let rr = nanmax(rad, 1e-300);
            let d = if ln > 0.0 { ln } else { 1.0 };
            Tri {
                cen,
                rad,
                a,
                b,
                c,
                nrm: [n[0] / d, n[1] / d, n[2] / d],
                ok: ln > 1e-14 * (rr * rr),
            }
        })
        .collect();
    drop(cen0);
    // leaves straight from the triangles, then BRANCH children per node up to the root
    let mut cur = boxes(tris.len().div_ceil(LEAF), |i| {
        let (s, e) = (LEAF * i, (LEAF * i + LEAF).min(tris.len()));
        let (mut ll, mut hh) = tri_box(&tris[s]);
        for t in &tris[s + 1..e] {
            let (tl, th) = tri_box(t);
            ll = pmin(&ll, &tl);
            hh = pmax(&hh, &th);
        }
        (ll, hh, tris[s].cen)
    });
    let mut levels = vec![nodes(&cur)];
    while cur.0.len() > 1 {
        cur = reduce(&cur, BRANCH);
        levels.push(nodes(&cur));
    }
    levels.reverse();
    (order, Tree { levels, tris })
}

/// `_TriTree.__init__` compiled: V (n, 3) float64 mm, F (m, 3) int64 (indices into V, m ≥ 1).
/// Returns (the compiled tree, order (m,) int64 — F's Morton order, `_TriTree`'s —).
#[pyfunction]
#[pyo3(signature = (v, f, threads))]
pub fn collision_tree_build<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
    threads: usize,
) -> PyResult<(Bound<'py, CollisionTree>, Bound<'py, PyArray1<i64>>)> {
    let vv = points(&v, "V")?;
    let ff = flat(&f, "F")?;
    if f.shape()[1] != 3 || ff.is_empty() {
        return Err(PyValueError::new_err("F must be (m, 3) triangles, m ≥ 1"));
    }
    let n = vv.len() as i64;
    if ff.iter().any(|&i| i < 0 || i >= n) {
        return Err(PyValueError::new_err(format!(
            "face indices out of range 0..{}",
            n - 1
        )));
    }
    // SAFETY: [i64; 3] has the size and alignment of three i64 in a row
    let fr: &[[i64; 3]] =
        unsafe { std::slice::from_raw_parts(ff.as_ptr() as *const [i64; 3], ff.len() / 3) };
    let pool = crate::pool(threads)?;
    let (order, t) = py.detach(|| pool.install(|| build(vv, fr)));
    Ok((
        Bound::new(py, CollisionTree { t })?,
        PyArray1::from_vec(py, order),
    ))
}

type Arrays<'py> = (Vec<Bound<'py, PyAny>>, Bound<'py, PyList>);

/// A compiled tree's arrays as `_TriTree` holds them: ([centroids (m, 3), radii (m,), A, B,
/// C (m, 3), unit normals (m, 3), ok (m,)], levels [(centre (q, 3), radius (q,),
/// representative (q, 3), half-sizes (q, 3))] root first).
#[pyfunction]
pub fn collision_tree_arrays<'py>(
    py: Python<'py>,
    tree: PyRef<'py, CollisionTree>,
) -> PyResult<Arrays<'py>> {
    let t = &tree.t.tris;
    let p3 = |f: &dyn Fn(&Tri) -> P3| arr3(py, t.iter().map(f).collect());
    let tris = vec![
        p3(&|x| x.cen)?,
        PyArray1::from_vec(py, t.iter().map(|x| x.rad).collect()).into_any(),
        p3(&|x| x.a)?,
        p3(&|x| x.b)?,
        p3(&|x| x.c)?,
        p3(&|x| x.nrm)?,
        PyArray1::from_vec(py, t.iter().map(|x| x.ok).collect()).into_any(),
    ];
    let lv = PyList::empty(py);
    for l in &tree.t.levels {
        lv.append((
            arr3(py, l.iter().map(|n| n.c).collect())?,
            PyArray1::from_vec(py, l.iter().map(|n| n.r).collect()),
            arr3(py, l.iter().map(|n| n.rep).collect())?,
            arr3(py, l.iter().map(|n| n.h).collect())?,
        ))?;
    }
    Ok((tris, lv))
}

/// The unit normals (k, 3) of a compiled tree's triangles `t` (k,) (Morton-order indices).
#[pyfunction]
pub fn collision_tree_normals<'py>(
    py: Python<'py>,
    tree: PyRef<'py, CollisionTree>,
    t: PyReadonlyArray1<'py, i64>,
) -> PyResult<Bound<'py, PyAny>> {
    let ts = crate::slice1(&t, "triangle indices")?;
    let tris = &tree.t.tris;
    if ts.iter().any(|&i| i < 0 || i as usize >= tris.len()) {
        return Err(PyValueError::new_err("triangle index out of range"));
    }
    arr3(py, ts.iter().map(|&i| tris[i as usize].nrm).collect())
}
