//! The topology `TriMesh` keeps (`blisk_cam/core/geometry/weld.py::_edge_table`, its interior
//! edge pairs), its face normals (`mesh.triangle_normals`) and vertex normals, in one pass
//! each instead of numpy's sort of the 3m half-edges, its gathers and its scatters: the same
//! arrays, value for value.
//! (The face components stay scipy's: a union–find here gave the same labels a little
//! faster but raised the CLI's resident high-water mark later in the run, by how the freed
//! memory of scipy's graph is reused.)
//!
//! The edge table: half-edge 3f + k runs from corner k to corner k + 1 of face f; its edge
//! key is (lower vertex, higher vertex). numpy sorts the keys `lower · n + higher` stably;
//! here a counting sort by the lower vertex (stable: half-edges ascending in each bucket)
//! and a sort of each (small) bucket by (higher vertex, half-edge) give that very order.

use std::mem::MaybeUninit;
use std::ops::Range;

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::split;

const _: () = assert!(std::mem::size_of::<(u32, u32)>() == std::mem::size_of::<i64>());

/// The arrays of `_edge_table`, flat (each (e, 2) or (m, 3) row-major).
pub struct EdgeTable {
    pub edges: Vec<i64>,
    pub face_edges: Vec<i64>,
    pub edge_halfedges: Vec<i64>,
    pub edge_faces: Vec<i64>,
}

/// The edge table of faces `f` (3m vertex ids, row-major, all in 0..n); None when an edge
/// has more than two half-edges (non-manifold: the caller's numpy reference says so) or the
/// mesh is too large for 32-bit ids. On the threads of the rayon pool it runs in, the same
/// arrays whatever their number: the half-edges are counted and scattered into the buckets
/// by consecutive ranges (each range's counts its own, the buckets filled range after range:
/// the stable order of one pass), the buckets sorted and their edges emitted by ranges of
/// vertices (the edge ids offset by the edges of the ranges before). The passes run on
/// `pl`, the arrays are allocated on the calling thread.
pub fn edge_table(f: &[i64], n: usize, pl: &rayon::ThreadPool) -> Option<EdgeTable> {
    let h = f.len();
    if h >= u32::MAX as usize || n >= u32::MAX as usize {
        return None;
    }
    let next = |i: usize| if i % 3 == 2 { i - 2 } else { i + 1 };
    let ends = |i: usize| {
        let (a, b) = (f[i], f[next(i)]);
        if a < b {
            (a as usize, b as u32)
        } else {
            (b as usize, a as u32)
        }
    };
    let parts = split::parts_for(pl.current_num_threads(), h, PART_MIN);
    // first: the mesh keeps it (see the buckets below); every item is written as a bucket
    // slot first (the counts are the slots), so no zeros before
    let mut face_edges = split::uninit::<i64>(h);
    // counting sort of the half-edges by their lower vertex: each range of half-edges
    // counted on its own, then per vertex the ranges' starts one after the other
    let ranges = split::even_ranges(h, parts);
    let mut fills: Vec<Vec<u32>> = (0..parts).map(|_| vec![0u32; n]).collect();
    pl.install(|| {
        ranges
            .par_iter()
            .zip(fills.par_iter_mut())
            .for_each(|(r, c)| {
                for i in r.clone() {
                    c[ends(i).0] += 1;
                }
            })
    });
    let mut ptr = Vec::with_capacity(n + 1);
    let mut run = 0u32;
    for v in 0..n {
        ptr.push(run);
        for c in fills.iter_mut() {
            let x = c[v];
            c[v] = run;
            run += x;
        }
    }
    ptr.push(run);
    // the buckets of (higher vertex, half-edge) pairs live in the memory of `face_edges`
    // (one i64 per half-edge, as one pair): no temporary of the half-edges' size, and the
    // arrays the mesh keeps come before anything freed (no hole left in the heap under them)
    {
        // SAFETY: (u32, u32) has the size of an i64 and an alignment it satisfies; the view
        // ends before `face_edges` is written as ids
        let bucket: &mut [(u32, u32)] = unsafe {
            std::slice::from_raw_parts_mut(face_edges.as_mut_ptr() as *mut (u32, u32), h)
        };
        let out = split::Scatter::new(bucket); // written before read: uninitialised is fine
        pl.install(|| {
            ranges
                .par_iter()
                .zip(fills.par_iter_mut())
                .for_each(|(r, fill)| {
                    for i in r.clone() {
                        let (lo, hi) = ends(i);
                        let p = &mut fill[lo];
                        // SAFETY: the ranges' slots of a bucket are disjoint, each written once
                        unsafe { out.put(*p as usize, (hi, i as u32)) };
                        *p += 1;
                    }
                })
        });
    }
    drop(fills);
    // SAFETY: every slot was written by the scatter (the counts are the slots)
    let mut face_edges: Vec<i64> = unsafe { split::assume_written(face_edges) };
    // SAFETY: as above; the last use of this view comes before `face_edges` is written
    let bucket: &mut [(u32, u32)] =
        unsafe { std::slice::from_raw_parts_mut(face_edges.as_mut_ptr() as *mut (u32, u32), h) };
    // ranges of vertices holding about as many half-edges each
    let cuts: Vec<usize> = (0..=parts)
        .map(|p| {
            if p == parts {
                n
            } else {
                ptr.partition_point(|&x| (x as usize) < p * h / parts)
                    .min(n)
            }
        })
        .collect();
    let vranges: Vec<Range<usize>> = cuts.windows(2).map(|w| w[0]..w[1]).collect();
    let lens = vranges.iter().map(|r| (ptr[r.end] - ptr[r.start]) as usize);
    let pieces = split::pieces(bucket, lens.collect::<Vec<_>>());
    // each bucket sorted and its edges counted first: the arrays are made at their size (the
    // mesh keeps them for the whole run; a grown Vec would hold up to twice the memory)
    let counted: Vec<Option<usize>> = pl.install(|| {
        vranges
            .par_iter()
            .zip(pieces)
            .map(|(r, piece)| {
                let base = ptr[r.start] as usize;
                let mut n_edges = 0usize;
                for lo in r.clone() {
                    let s = &mut piece[ptr[lo] as usize - base..ptr[lo + 1] as usize - base];
                    if s.len() > 1 {
                        s.sort_unstable(); // (hi, half-edge) pairs are distinct: the stable order
                    }
                    let mut j = 0;
                    while j < s.len() {
                        let mut k = j + 1;
                        while k < s.len() && s[k].0 == s[j].0 {
                            k += 1;
                        }
                        if k - j > 2 {
                            return None;
                        }
                        n_edges += 1;
                        j = k;
                    }
                }
                Some(n_edges)
            })
            .collect()
    });
    let counts: Vec<usize> = counted.into_iter().collect::<Option<_>>()?;
    let n_edges: usize = counts.iter().sum();
    let bucket: &[(u32, u32)] = bucket;
    let emit = |edges: &mut [MaybeUninit<i64>],
                hei: &mut [MaybeUninit<i64>],
                ef: &mut [MaybeUninit<i64>],
                r: &Range<usize>| {
        let mut e = 0;
        for lo in r.clone() {
            let s = &bucket[ptr[lo] as usize..ptr[lo + 1] as usize];
            let mut j = 0;
            while j < s.len() {
                let (hi, h0) = s[j];
                let two = j + 1 < s.len() && s[j + 1].0 == hi;
                let h1 = if two { s[j + 1].1 as i64 } else { -1 };
                edges[2 * e].write(lo as i64);
                edges[2 * e + 1].write(hi as i64);
                hei[2 * e].write(h0 as i64);
                hei[2 * e + 1].write(h1);
                // floor division: −1 stays −1
                ef[2 * e].write(h0 as i64 / 3);
                ef[2 * e + 1].write(if two { h1 / 3 } else { -1 });
                e += 1;
                j += 1 + usize::from(two);
            }
        }
    };
    let (mut edges, mut hei, mut ef) = (
        split::uninit(2 * n_edges),
        split::uninit(2 * n_edges),
        split::uninit(2 * n_edges),
    );
    let l2: Vec<usize> = counts.iter().map(|c| 2 * c).collect();
    let pieces = split::pieces(&mut edges, l2.clone())
        .into_iter()
        .zip(split::pieces(&mut hei, l2.clone()))
        .zip(split::pieces(&mut ef, l2))
        .zip(vranges.iter())
        .collect::<Vec<_>>();
    pl.install(|| {
        pieces
            .into_par_iter()
            .for_each(|(((a, b), c), r)| emit(a, b, c, r))
    });
    // SAFETY: each range wrote its edges' rows, and the ranges' rows are all the rows
    let (edges, edge_halfedges, edge_faces) = unsafe {
        (
            split::assume_written(edges),
            split::assume_written(hei),
            split::assume_written(ef),
        )
    };
    // the buckets are read: `face_edges` becomes the ids (each half-edge of one edge)
    let out = split::Scatter::new(&mut face_edges);
    let starts: Vec<usize> = counts
        .iter()
        .scan(0, |s, &c| {
            *s += c;
            Some(*s - c)
        })
        .collect();
    pl.install(|| {
        starts
            .par_iter()
            .zip(counts.par_iter())
            .for_each(|(&s, &c)| {
                for e in s..s + c {
                    let (h0, h1) = (edge_halfedges[2 * e], edge_halfedges[2 * e + 1]);
                    // SAFETY: every half-edge is in one edge: each position written once
                    unsafe { out.put(h0 as usize, e as i64) };
                    if h1 >= 0 {
                        unsafe { out.put(h1 as usize, e as i64) };
                    }
                }
            })
    });
    Some(EdgeTable {
        edges,
        face_edges,
        edge_halfedges,
        edge_faces,
    })
}

/// Half-edges per thread below which the edge table stays on fewer threads.
const PART_MIN: usize = 1 << 16;

type Arr<'py> = Bound<'py, PyArray1<i64>>;

/// `_edge_table(F, n)` as (edges (e, 2), face_edges (m, 3), edge_halfedges (e, 2),
/// edge_faces (e, 2)) int64; None when an edge has more than two faces (or too many ids).
/// On `threads` threads (the same arrays).
#[pyfunction]
#[pyo3(signature = (f, n_vertices, threads=1))]
pub fn edge_table_arrays<'py>(
    py: Python<'py>,
    f: PyReadonlyArray2<'py, i64>,
    n_vertices: usize,
    threads: usize,
) -> PyResult<
    Option<(
        Bound<'py, PyAny>,
        Bound<'py, PyAny>,
        Bound<'py, PyAny>,
        Bound<'py, PyAny>,
    )>,
> {
    let ff = crate::arrays::flat(&f, "F")?;
    if ff.len() % 3 != 0 {
        return Err(pyo3::exceptions::PyValueError::new_err("F must be (m, 3)"));
    }
    if ff.iter().any(|&v| v < 0 || v as usize >= n_vertices) {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "F holds vertex ids out of range",
        ));
    }
    let pl = crate::pool_for(threads, ff.len())?;
    let Some(t) = py.detach(|| edge_table(ff, n_vertices, &pl)) else {
        return Ok(None);
    };
    let two = |v: Vec<i64>, c: usize| -> PyResult<Bound<'py, PyAny>> {
        let k = v.len() / c;
        let a: Arr<'py> = PyArray1::from_vec(py, v);
        Ok(a.reshape([k, c])?.into_any())
    };
    Ok(Some((
        two(t.edges, 2)?,
        two(t.face_edges, 3)?,
        two(t.edge_halfedges, 2)?,
        two(t.edge_faces, 2)?,
    )))
}

/// `(b − a) × (c − a)` of every face (a, b, c) of `f` over the points `v`, row-major (m, 3):
/// the very products and differences of `mesh.triangle_normals` (Rust does not fuse them into
/// FMAs), so the same bits. None when a face holds an id outside 0..n (numpy then says so, or
/// wraps a negative id as it does).
pub fn normals(v: &[[f64; 3]], f: &[i64]) -> Option<Vec<f64>> {
    let n = v.len();
    if f.iter().any(|&i| i < 0 || i as usize >= n) {
        return None;
    }
    let mut out = vec![0.0f64; f.len()];
    for (o, t) in out.chunks_exact_mut(3).zip(f.chunks_exact(3)) {
        let (a, b, c) = (&v[t[0] as usize], &v[t[1] as usize], &v[t[2] as usize]);
        o.copy_from_slice(&area_vector(a, b, c));
    }
    Some(out)
}

/// `(b − a) × (c − a)` of one face, twice its area vector: `mesh.triangle_normals`'
/// differences and products in its order (the same bits; no FMA).
#[inline(always)]
pub fn area_vector(a: &[f64; 3], b: &[f64; 3], c: &[f64; 3]) -> [f64; 3] {
    let (u0, u1, u2) = (b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    let (v0, v1, v2) = (c[0] - a[0], c[1] - a[1], c[2] - a[2]);
    [u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0]
}

/// `triangle_normals(V, F)`: (m, 3) float64, or None (an id out of range: numpy's turn).
#[pyfunction]
pub fn triangle_normals<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    let pts = crate::points(&v, "V")?;
    let ff = crate::arrays::flat(&f, "F")?;
    if f.shape()[1] != 3 {
        return Err(pyo3::exceptions::PyValueError::new_err("F must be (m, 3)"));
    }
    let Some(out) = py.detach(|| normals(pts, ff)) else {
        return Ok(None);
    };
    let k = out.len() / 3;
    let a: Bound<'py, PyArray1<f64>> = PyArray1::from_vec(py, out);
    Ok(Some(a.reshape([k, 3])?.into_any()))
}

/// The interior edges of an edge table's `edge_halfedges` (e, 2) rows, flat: (h0, h1) of
/// each row with a second half-edge, in edge order.
pub fn interior(hei: &[i64]) -> impl Iterator<Item = (i64, i64)> + '_ {
    hei.chunks_exact(2)
        .filter(|r| r[1] >= 0)
        .map(|r| (r[0], r[1]))
}

/// `_interior_pairs` of an edge table: from `edge_halfedges` (e, 2) the two half-edges of
/// each edge of two faces, in edge order, and their faces: (h0, h1, f0, f1) (p,) int64.
#[pyfunction]
pub fn interior_pairs<'py>(
    py: Python<'py>,
    hei: PyReadonlyArray2<'py, i64>,
) -> PyResult<(Arr<'py>, Arr<'py>, Arr<'py>, Arr<'py>)> {
    let h = crate::arrays::flat(&hei, "edge_halfedges")?;
    if hei.shape()[1] != 2 {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "edge_halfedges must be (e, 2)",
        ));
    }
    let (h0, h1, f0, f1) = py.detach(|| {
        let p = interior(h).count();
        let (mut h0, mut h1) = (Vec::with_capacity(p), Vec::with_capacity(p));
        let (mut f0, mut f1) = (Vec::with_capacity(p), Vec::with_capacity(p));
        for (a, b) in interior(h) {
            h0.push(a);
            h1.push(b);
            f0.push(a.div_euclid(3));
            f1.push(b.div_euclid(3));
        }
        (h0, h1, f0, f1)
    });
    Ok((
        PyArray1::from_vec(py, h0),
        PyArray1::from_vec(py, h1),
        PyArray1::from_vec(py, f0),
        PyArray1::from_vec(py, f1),
    ))
}

/// `n` zeros, written (not `vec![0.0; n]`, which is `calloc`: fresh pages that the first
/// `+=` reads map the shared zero page and then fault again to write, two page faults per
/// 4 KiB instead of one; at 1M faces the vertex sums' 24 MB took ~12k faults, most of the
/// kernel's time, and more still beside the passes' side thread faulting in its own tables).
fn zeros_written(n: usize) -> Vec<f64> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, 0.0);
    v
}

/// Adds the area vectors `n2` (m, 3) of the faces `f` (m, 3) to the rows of their corner
/// `k` in `acc` (n, 3), faces in order: numpy's weighted `bincount` of that corner.
fn add_corner(acc: &mut [f64], f: &[i64], n2: &[f64], k: usize) {
    for (t, w) in f.chunks_exact(3).zip(n2.chunks_exact(3)) {
        let v = 3 * t[k] as usize;
        acc[v] += w[0];
        acc[v + 1] += w[1];
        acc[v + 2] += w[2];
    }
}

/// `TriMesh.vertex_normals` of the faces `f` (m, 3, ids in 0..n) and their area vectors `n2`
/// (m, 3), (n, 3) row-major, as the numpy reference computes them: per corner k the sums of
/// a weighted `bincount` (faces in order, from 0.0), the corners' sums added in order to
/// 0.0, ((0 + s₀) + s₁) + s₂ (0 + s₀ is s₀: a sum from +0.0 is never −0.0); each row then
/// divided by its norm as `np.linalg.norm(acc, axis=1)` sums it, (x² + y²) + z² (numpy's
/// reduction over the rows' 3 columns, the same on AVX-512; tested), or by 1.0 where that
/// is not positive. The same operations in the same order, so the same bits. Corner 0 sums
/// into the result itself, corners 1 and 2 into one scratch of (n, 3) in turn; the norms
/// and quotients in place. None when a face holds an id outside 0..n or the shapes differ.
pub fn vertex_normals(n: usize, f: &[i64], n2: &[f64]) -> Option<Vec<f64>> {
    if f.len() != n2.len() || f.iter().any(|&i| i < 0 || i as usize >= n) {
        return None;
    }
    let mut acc = zeros_written(3 * n);
    add_corner(&mut acc, f, n2, 0); // 0 + s₀ = s₀
    let mut s = zeros_written(3 * n);
    for k in 1..3 {
        if k > 1 {
            s.fill(0.0);
        }
        add_corner(&mut s, f, n2, k);
        for (a, b) in acc.iter_mut().zip(&s) {
            *a += *b;
        }
    }
    drop(s);
    for r in acc.chunks_exact_mut(3) {
        let ln = ((r[0] * r[0] + r[1] * r[1]) + r[2] * r[2]).sqrt();
        let d = if ln > 0.0 { ln } else { 1.0 };
        r[0] /= d;
        r[1] /= d;
        r[2] /= d;
    }
    Some(acc)
}

/// [`vertex_normals`] for Python: (n, 3) float64 unit vertex normals of F (m, 3) int64 and
/// the area vectors n2 (m, 3) float64, or None (an id out of range: numpy's turn).
#[pyfunction]
pub fn vertex_normals_of<'py>(
    py: Python<'py>,
    n_vertices: usize,
    f: PyReadonlyArray2<'py, i64>,
    n2: PyReadonlyArray2<'py, f64>,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    let ff = crate::arrays::flat(&f, "F")?;
    let ww = crate::arrays::flat(&n2, "n2")?;
    if f.shape()[1] != 3 || n2.shape()[1] != 3 {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "F and n2 must be (m, 3)",
        ));
    }
    let Some(out) = py.detach(|| vertex_normals(n_vertices, ff, ww)) else {
        return Ok(None);
    };
    let a: Bound<'py, PyArray1<f64>> = PyArray1::from_vec(py, out);
    Ok(Some(a.reshape([n_vertices, 3])?.into_any()))
}

/// `TriMesh.interpolate_normals`: per point the corners' vertex normals weighted by the
/// barycentric coordinates and added in the corners' order, `(n_a b0 + n_b b1) + n_c b2`,
/// divided by its norm as np.linalg.norm sums it, `(x0² + x1²) + x2²` (left as it is when
/// that is not positive): the same products, sums and quotients, so the same bits. None
/// when a face id is outside 0..m or a corner outside 0..n.
pub fn smooth_normals(
    vn: &[[f64; 3]],
    f: &[[i64; 3]],
    faces: &[i64],
    bary: &[[f64; 3]],
) -> Option<Vec<f64>> {
    let (n, m) = (vn.len(), f.len());
    if faces.iter().any(|&x| x < 0 || x as usize >= m) {
        return None;
    }
    let mut out = Vec::with_capacity(3 * faces.len());
    for (&x, b) in faces.iter().zip(bary) {
        let t = &f[x as usize];
        if t.iter().any(|&i| i < 0 || i as usize >= n) {
            return None;
        }
        let (a, p, c) = (&vn[t[0] as usize], &vn[t[1] as usize], &vn[t[2] as usize]);
        let s = [
            (a[0] * b[0] + p[0] * b[1]) + c[0] * b[2],
            (a[1] * b[0] + p[1] * b[1]) + c[1] * b[2],
            (a[2] * b[0] + p[2] * b[1]) + c[2] * b[2],
        ];
        let ln = ((s[0] * s[0] + s[1] * s[1]) + s[2] * s[2]).sqrt();
        let d = if ln > 0.0 { ln } else { 1.0 };
        out.extend_from_slice(&[s[0] / d, s[1] / d, s[2] / d]);
    }
    Some(out)
}

/// [`smooth_normals`] for Python: (k, 3) float64 of vertex normals vn (n, 3), faces F (m, 3),
/// face ids (k,) and barycentric coordinates (k, 3); None (an id out of range: numpy's turn).
#[pyfunction]
pub fn interpolate_normals<'py>(
    py: Python<'py>,
    vn: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
    faces: numpy::PyReadonlyArray1<'py, i64>,
    bary: PyReadonlyArray2<'py, f64>,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    let v = crate::points(&vn, "vertex normals")?;
    let tri = crate::arrays::triangles(&f, "F")?;
    let fc = crate::slice1(&faces, "faces")?;
    let b = crate::arrays::points_n(&bary, "bary", fc.len())?;
    let Some(out) = py.detach(|| smooth_normals(v, tri, fc, b)) else {
        return Ok(None);
    };
    let k = out.len() / 3;
    let a: Bound<'py, PyArray1<f64>> = PyArray1::from_vec(py, out);
    Ok(Some(a.reshape([k, 3])?.into_any()))
}
