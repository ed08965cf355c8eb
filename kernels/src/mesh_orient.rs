//! The orientation pass of `TriMesh` (`blisk_cam/core/geometry/mesh.py::_orient` and its
//! `_capped_volume`), compiled: the face components by union–find instead of scipy's sparse
//! graph, and one pass over the faces for their area vectors, norms, unit normals, areas
//! and the per-component sums of area and (uncapped) volume, instead of numpy's dozen
//! passes and their (m, 3) temporaries.
//!
//! Bit for bit the numpy reference's values: the area vectors are `triangle_normals`'
//! products and differences (`mesh_topology::normals`); a 3-term `np.einsum("ij,ij->i")`
//! adds its products in an order that depends on the SIMD loop numpy picks at run time
//! (AVX2: `(p0 + p1) + p2`; SSE and AVX-512: `(p0 + p2) + p1`), which the caller probes and
//! passes as [`Dot3`]; the component sums are `np.bincount`'s (faces in order, from 0.0) and
//! the reference point `V.mean(axis=0)`'s (rows in order, then one division).

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use std::mem::MaybeUninit;
use std::ops::Range;

use rayon::prelude::*;

use crate::mesh_topology::{area_vector, interior};
use crate::split;

/// The order in which numpy's einsum adds the three products of a row.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Dot3 {
    /// `(p0 + p1) + p2`
    InOrder,
    /// `(p0 + p2) + p1`
    OuterFirst,
}

impl Dot3 {
    #[inline(always)]
    fn dot(self, a: [f64; 3], b: [f64; 3]) -> f64 {
        let (p0, p1, p2) = (a[0] * b[0], a[1] * b[1], a[2] * b[2]);
        match self {
            Dot3::InOrder => (p0 + p1) + p2,
            Dot3::OuterFirst => (p0 + p2) + p1,
        }
    }
}

/// Connected components of the graph over `m` nodes with the undirected links `pairs`
/// (all in 0..m, m < 2³²): (count, labels) numbered as scipy's
/// `csgraph.connected_components(directed=False)` numbers them — in the order of each
/// component's lowest node (union–find whose roots are the lowest nodes, then each root
/// labelled as it comes).
pub fn components_of_pairs(m: usize, pairs: impl Iterator<Item = (i64, i64)>) -> (usize, Vec<i32>) {
    let mut parent: Vec<u32> = (0..m as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            let g = p[p[x as usize] as usize];
            p[x as usize] = g; // path halving
            x = g;
        }
        x
    }
    for (a, b) in pairs {
        let (ra, rb) = (find(&mut parent, a as u32), find(&mut parent, b as u32));
        if ra != rb {
            // the lower root wins: a component's root is its lowest node
            if ra < rb {
                parent[rb as usize] = ra
            } else {
                parent[ra as usize] = rb
            }
        }
    }
    // labels in place of the parents, in node order: a node's parent is the node itself (a
    // root: a new label) or a lower node (every link points down), whose entry holds the
    // label of its root by then
    let mut count = 0u32;
    for v in 0..m {
        let p = parent[v] as usize;
        parent[v] = if p == v {
            count += 1;
            count - 1
        } else {
            parent[p]
        };
    }
    let labels = parent.into_iter().map(|x| x as i32).collect();
    (count as usize, labels)
}

/// What [`face_terms`] gives: per face (row-major) the area vector `n2` (m, 3), its norm
/// `ln` (m,), the unit normal `unit` (m, 3) (zero where `ln` is not positive) and the area
/// `ln / 2` (m,); per component the summed volume terms and areas.
pub struct FaceTerms {
    pub n2: Vec<f64>,
    pub ln: Vec<f64>,
    pub unit: Vec<f64>,
    pub area: Vec<f64>,
    pub comp_volume: Vec<f64>,
    pub comp_area: Vec<f64>,
    /// `V.mean(axis=0)`, the volumes' reference point
    pub origin: [f64; 3],
}

/// `V.mean(axis=0)` as numpy reduces it: each column summed row after row from 0.0, then
/// divided by the row count.
pub fn mean_rows(v: &[[f64; 3]]) -> [f64; 3] {
    let mut s = [0.0f64; 3];
    for p in v {
        s[0] += p[0];
        s[1] += p[1];
        s[2] += p[2];
    }
    let n = v.len() as f64;
    [s[0] / n, s[1] / n, s[2] / n]
}

/// The rows of [`face_terms`]' per-face arrays a range of faces writes.
struct FaceRows<'a> {
    n2: &'a mut [MaybeUninit<f64>],
    unit: &'a mut [MaybeUninit<f64>],
    ln: &'a mut [MaybeUninit<f64>],
    area: &'a mut [MaybeUninit<f64>],
}

/// The per-face terms of the faces `r` into `out` (its rows from 0), and for each face i,
/// in face order, `sums(i, ((a − o) · n2) / 6, area)`.
fn face_rows(
    v: &[[f64; 3]],
    f: &[[i64; 3]],
    o: [f64; 3],
    order: Dot3,
    r: Range<usize>,
    out: FaceRows<'_>,
    mut sums: impl FnMut(usize, f64, f64),
) {
    let s = r.start;
    for (j, t) in f[r].iter().enumerate() {
        let (a, b, c) = (&v[t[0] as usize], &v[t[1] as usize], &v[t[2] as usize]);
        let nv = area_vector(a, b, c);
        let l = order.dot(nv, nv).sqrt();
        let d = if l > 0.0 { l } else { 1.0 };
        for (q, &x) in nv.iter().enumerate() {
            out.n2[3 * j + q].write(x);
            out.unit[3 * j + q].write(x / d);
        }
        out.ln[j].write(l);
        let ar = l * 0.5;
        out.area[j].write(ar);
        let corner = [a[0] - o[0], a[1] - o[1], a[2] - o[2]];
        sums(s + j, order.dot(corner, nv) / 6.0, ar);
    }
}

/// The faces' terms of `_capped_volume` (before the caps): with `a, b, c` a face's corners
/// and `o = V.mean(axis=0)`, `n2 = (b − a) × (c − a)`, `ln = sqrt(n2 · n2)`,
/// `unit = n2 / (ln if ln > 0 else 1)`, `area = ln · 0.5`, and per component (`labels`, all
/// in 0..ncomp) Σ ((a − o) · n2) / 6 and Σ area over its faces in face order. None when a
/// face holds a vertex id outside 0..n or `labels` is not one per face. The per-face terms
/// on the threads of the rayon pool it runs in, by ranges of faces (each face's terms are
/// its own); the sums on one, in face order (the same bits whatever the threads).
pub fn face_terms(
    v: &[[f64; 3]],
    f: &[[i64; 3]],
    labels: &[i32],
    ncomp: usize,
    order: Dot3,
    pl: &rayon::ThreadPool,
) -> Option<FaceTerms> {
    let n = v.len();
    let m = f.len();
    if labels.len() != m {
        return None;
    }
    let parts = split::parts_for(pl.current_num_threads(), m, FACES_MIN);
    let ranges = split::even_ranges(m, parts);
    let bad = |r: &Range<usize>| {
        f[r.clone()]
            .iter()
            .flatten()
            .any(|&i| i < 0 || i as usize >= n)
            || labels[r.clone()]
                .iter()
                .any(|&c| c < 0 || c as usize >= ncomp)
    };
    if pl.install(|| ranges.par_iter().any(bad)) {
        return None;
    }
    let o = mean_rows(v);
    let (mut n2, mut ln, mut unit, mut area) = (
        split::uninit(3 * m),
        split::uninit(m),
        split::uninit(3 * m),
        split::uninit(m),
    );
    // np.bincount's sums: faces in order, from 0.0
    let mut comp_volume = vec![0.0f64; ncomp];
    let mut comp_area = vec![0.0f64; ncomp];
    let lens: Vec<usize> = ranges.iter().map(|r| r.len()).collect();
    let l3: Vec<usize> = lens.iter().map(|l| 3 * l).collect();
    let outs: Vec<FaceRows> = split::pieces(&mut n2, l3.clone())
        .into_iter()
        .zip(split::pieces(&mut unit, l3))
        .zip(split::pieces(&mut ln, lens.clone()))
        .zip(split::pieces(&mut area, lens.clone()))
        .map(|(((n2, unit), ln), area)| FaceRows { n2, unit, ln, area })
        .collect();
    // one range: the sums as the faces come (no array of the volume terms); several: each
    // range writes its faces' volume terms, summed below in face order
    let vol = if parts == 1 {
        for out in outs {
            face_rows(v, f, o, order, 0..m, out, |i, x, a| {
                let k = labels[i] as usize;
                comp_volume[k] += x;
                comp_area[k] += a;
            });
        }
        None
    } else {
        let mut vol = split::uninit(m);
        let vols = split::pieces(&mut vol, lens);
        pl.install(|| {
            outs.into_par_iter()
                .zip(vols)
                .zip(ranges.par_iter())
                .for_each(|((out, vol), r)| {
                    let s = r.start;
                    face_rows(v, f, o, order, r.clone(), out, |i, x, _| {
                        vol[i - s].write(x);
                    });
                })
        });
        // SAFETY: each range wrote its faces' volume terms, and the ranges are all the faces
        Some(unsafe { split::assume_written(vol) })
    };
    // SAFETY: each range wrote its faces' items, and the ranges are all the faces
    let (n2, ln, unit, area) = unsafe {
        (
            split::assume_written(n2),
            split::assume_written(ln),
            split::assume_written(unit),
            split::assume_written(area),
        )
    };
    if let Some(vol) = vol {
        for ((&k, &x), &a) in labels.iter().zip(&vol).zip(&area) {
            comp_volume[k as usize] += x;
            comp_area[k as usize] += a;
        }
    }
    Some(FaceTerms {
        n2,
        ln,
        unit,
        area,
        comp_volume,
        comp_area,
        origin: o,
    })
}

/// Faces per thread below which the face terms stay on fewer threads.
const FACES_MIN: usize = 1 << 15;

type F1<'py> = Bound<'py, PyArray1<f64>>;

/// `edge_halfedges` (e, 2) of a mesh of `m` faces, checked: every id in −1..3m, the first of
/// each row not −1.
fn halfedge_rows<'a>(hei: &'a PyReadonlyArray2<'_, i64>, m: usize) -> PyResult<&'a [i64]> {
    let h = crate::arrays::flat(hei, "edge_halfedges")?;
    if hei.shape()[1] != 2 {
        return Err(PyValueError::new_err("edge_halfedges must be (e, 2)"));
    }
    if m >= u32::MAX as usize
        || h.chunks_exact(2)
            .any(|r| r[0] < 0 || r[0] as usize >= 3 * m || r[1] < -1 || r[1] >= 3 * m as i64)
    {
        return Err(PyValueError::new_err("half-edge ids out of range"));
    }
    Ok(h)
}

/// `weld._repeats_on_edges`: whether the two faces of an interior edge (rows of
/// `edge_halfedges` (e, 2) with a second half-edge) have the same sum of vertex ids, for
/// the faces F (m, 3) int64.
/// On `threads` threads, by ranges of edges (the answer is an "any").
#[pyfunction]
#[pyo3(signature = (f, hei, threads=1))]
pub fn repeats_on_edges<'py>(
    py: Python<'py>,
    f: PyReadonlyArray2<'py, i64>,
    hei: PyReadonlyArray2<'py, i64>,
    threads: usize,
) -> PyResult<bool> {
    let tri = crate::arrays::triangles(&f, "F")?;
    let h = halfedge_rows(&hei, tri.len())?;
    let pl = crate::pool_for(threads, h.len() / 2)?;
    Ok(py.detach(|| {
        pl.install(|| {
            let total = |x: i64| {
                let t = &tri[(x / 3) as usize];
                t[0].wrapping_add(t[1]).wrapping_add(t[2])
            };
            h.par_chunks(2 * EDGES_MIN)
                .any(|c| interior(c).any(|(a, b)| total(a) == total(b)))
        })
    }))
}

/// Edges per task of the passes over an edge table's rows.
const EDGES_MIN: usize = 1 << 16;

/// `(count, labels (m,) int32, inconsistent)` of a mesh's faces F (m, 3) int64 and its edge
/// table's `edge_halfedges` (e, 2): the components of the faces linked by their interior
/// edges, numbered as scipy numbers them, and how many interior edges the two faces run the
/// same way (their half-edges start at the same vertex: `F.ravel()[h0] == F.ravel()[h1]`).
/// On `threads` threads: the count beside the union–find (which stays on one, in edge
/// order: the same labels).
#[pyfunction]
#[pyo3(signature = (f, hei, threads=1))]
pub fn face_components<'py>(
    py: Python<'py>,
    f: PyReadonlyArray2<'py, i64>,
    hei: PyReadonlyArray2<'py, i64>,
    threads: usize,
) -> PyResult<(usize, Bound<'py, PyArray1<i32>>, usize)> {
    let tri = crate::arrays::triangles(&f, "F")?;
    let m = tri.len();
    let h = halfedge_rows(&hei, m)?;
    let pl = crate::pool_for(threads, h.len() / 2)?;
    let (count, labels, inconsistent) = py.detach(|| {
        let flat = tri.as_flattened();
        let count = |c: &[i64]| {
            interior(c)
                .filter(|&(a, b)| flat[a as usize] == flat[b as usize])
                .count()
        };
        let components = || components_of_pairs(m, interior(h).map(|(a, b)| (a / 3, b / 3)));
        if pl.current_num_threads() == 1 {
            let (c, l) = components();
            return (c, l, count(h));
        }
        // the count on the pool; the union–find (and its labels) on the calling thread
        let mut inc = 0;
        let (c, l) = pl.in_place_scope(|sc| {
            sc.spawn(|_| inc = count(h));
            components()
        });
        (c, l, inc)
    });
    Ok((count, PyArray1::from_vec(py, labels), inconsistent))
}

/// [`face_terms`] for Python: (n2 (m, 3), ln (m,), unit normals (m, 3), areas (m,),
/// volume (ncomp,), area (ncomp,), V.mean(axis=0) (3,)) float64 of V (n, 3) float64, F (m, 3) int64 and the
/// face components `labels` (m,) int32 in 0..ncomp; `outer_first`: numpy's einsum adds a
/// row's products as `(p0 + p2) + p1` (else in order). None when an id is out of range.
/// On `threads` threads (the same arrays).
#[pyfunction]
#[pyo3(signature = (v, f, labels, ncomp, outer_first, threads=1))]
#[allow(clippy::type_complexity)]
pub fn orient_face_terms<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
    labels: PyReadonlyArray1<'py, i32>,
    ncomp: usize,
    outer_first: bool,
    threads: usize,
) -> PyResult<
    Option<(
        Bound<'py, PyAny>,
        F1<'py>,
        Bound<'py, PyAny>,
        F1<'py>,
        F1<'py>,
        F1<'py>,
        F1<'py>,
    )>,
> {
    let pts = crate::points(&v, "V")?;
    let tri = crate::arrays::triangles(&f, "F")?;
    let lab = crate::arrays::values_n(&labels, "labels", tri.len())?;
    let order = if outer_first {
        Dot3::OuterFirst
    } else {
        Dot3::InOrder
    };
    let pl = crate::pool_for(threads, tri.len())?;
    let Some(t) = py.detach(|| face_terms(pts, tri, lab, ncomp, order, &pl)) else {
        return Ok(None);
    };
    let m = t.ln.len();
    let rows = |x: Vec<f64>| -> PyResult<Bound<'py, PyAny>> {
        Ok(PyArray1::from_vec(py, x).reshape([m, 3])?.into_any())
    };
    Ok(Some((
        rows(t.n2)?,
        PyArray1::from_vec(py, t.ln),
        rows(t.unit)?,
        PyArray1::from_vec(py, t.area),
        PyArray1::from_vec(py, t.comp_volume),
        PyArray1::from_vec(py, t.comp_area),
        PyArray1::from_slice(py, &t.origin),
    )))
}
