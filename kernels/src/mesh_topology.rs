//! The topology `TriMesh` keeps (`blisk_cam/core/geometry/weld.py::_edge_table` and the face
//! components of `mesh.TriMesh._orient`), in one pass each instead of numpy's sort of the
//! 3m half-edges and scipy's sparse graph: the same arrays, value for value.
//!
//! The edge table: half-edge 3f + k runs from corner k to corner k + 1 of face f; its edge
//! key is (lower vertex, higher vertex). numpy sorts the keys `lower · n + higher` stably;
//! here a counting sort by the lower vertex (stable: half-edges ascending in each bucket)
//! and a sort of each (small) bucket by (higher vertex, half-edge) give that very order.

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// The arrays of `_edge_table`, flat (each (e, 2) or (m, 3) row-major).
pub struct EdgeTable {
    pub edges: Vec<i64>,
    pub face_edges: Vec<i64>,
    pub edge_halfedges: Vec<i64>,
    pub edge_faces: Vec<i64>,
}

/// The edge table of faces `f` (3m vertex ids, row-major, all in 0..n); None when an edge
/// has more than two half-edges (non-manifold: the caller's numpy reference says so) or the
/// mesh is too large for 32-bit ids.
pub fn edge_table(f: &[i64], n: usize) -> Option<EdgeTable> {
    let h = f.len();
    if h >= u32::MAX as usize || n >= u32::MAX as usize {
        return None;
    }
    let next = |i: usize| if i % 3 == 2 { i - 2 } else { i + 1 };
    // counting sort of the half-edges by their lower vertex
    let mut ptr = vec![0u32; n + 1];
    for i in 0..h {
        let lo = f[i].min(f[next(i)]) as usize;
        ptr[lo + 1] += 1;
    }
    for v in 0..n {
        ptr[v + 1] += ptr[v];
    }
    let mut fill: Vec<u32> = ptr[..n].to_vec();
    let mut bucket = vec![(0u32, 0u32); h]; // (higher vertex, half-edge)
    for i in 0..h {
        let (a, b) = (f[i], f[next(i)]);
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        let p = &mut fill[lo as usize];
        bucket[*p as usize] = (hi as u32, i as u32);
        *p += 1;
    }
    drop(fill);
    let mut edges = Vec::with_capacity(h / 2 + 2);
    let mut edge_halfedges = Vec::with_capacity(h / 2 + 2);
    let mut face_edges = vec![0i64; h];
    let mut e = 0i64;
    for lo in 0..n {
        let s = &mut bucket[ptr[lo] as usize..ptr[lo + 1] as usize];
        if s.len() > 1 {
            s.sort_unstable(); // (hi, half-edge) pairs are distinct: the stable order
        }
        let mut j = 0;
        while j < s.len() {
            let (hi, h0) = s[j];
            let mut k = j + 1;
            while k < s.len() && s[k].0 == hi {
                k += 1;
            }
            if k - j > 2 {
                return None;
            }
            edges.push(lo as i64);
            edges.push(hi as i64);
            edge_halfedges.push(h0 as i64);
            face_edges[h0 as usize] = e;
            if k - j == 2 {
                let h1 = s[j + 1].1;
                edge_halfedges.push(h1 as i64);
                face_edges[h1 as usize] = e;
            } else {
                edge_halfedges.push(-1);
            }
            e += 1;
            j = k;
        }
    }
    // floor division: −1 stays −1
    let edge_faces = edge_halfedges.iter().map(|&x| if x < 0 { -1 } else { x / 3 }).collect();
    Some(EdgeTable { edges, face_edges, edge_halfedges, edge_faces })
}

/// Connected components of the graph over `m` nodes with the undirected links (f0[i], f1[i]):
/// (count, labels) numbered as scipy's `csgraph.connected_components` numbers them — in the
/// order of each component's lowest node (union–find, then relabelled by first appearance).
pub fn components(m: usize, f0: &[i64], f1: &[i64]) -> (usize, Vec<i32>) {
    let mut parent: Vec<u32> = (0..m as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            let g = p[p[x as usize] as usize];
            p[x as usize] = g; // path halving
            x = g;
        }
        x
    }
    for (&a, &b) in f0.iter().zip(f1) {
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
    let mut labels = vec![0i32; m];
    let mut count = 0usize;
    for v in 0..m {
        let r = find(&mut parent, v as u32) as usize;
        labels[v] = if r == v {
            count += 1;
            (count - 1) as i32
        } else {
            labels[r] // r < v: labelled already
        };
    }
    (count, labels)
}

type Arr<'py> = Bound<'py, PyArray1<i64>>;

/// `_edge_table(F, n)` as (edges (e, 2), face_edges (m, 3), edge_halfedges (e, 2),
/// edge_faces (e, 2)) int64; None when an edge has more than two faces (or too many ids).
#[pyfunction]
pub fn edge_table_arrays<'py>(
    py: Python<'py>,
    f: PyReadonlyArray2<'py, i64>,
    n_vertices: usize,
) -> PyResult<Option<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)>> {
    let ff = crate::arrays::flat(&f, "F")?;
    if ff.len() % 3 != 0 {
        return Err(pyo3::exceptions::PyValueError::new_err("F must be (m, 3)"));
    }
    if ff.iter().any(|&v| v < 0 || v as usize >= n_vertices) {
        return Err(pyo3::exceptions::PyValueError::new_err("F holds vertex ids out of range"));
    }
    let Some(t) = py.detach(|| edge_table(ff, n_vertices)) else {
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

/// (count, labels (m,) int32): the connected components of the faces linked by (f0, f1), as
/// scipy's `csgraph.connected_components(directed=False)` gives them.
#[pyfunction]
pub fn face_components<'py>(
    py: Python<'py>,
    m: usize,
    f0: PyReadonlyArray1<'py, i64>,
    f1: PyReadonlyArray1<'py, i64>,
) -> PyResult<(usize, Bound<'py, PyArray1<i32>>)> {
    let (a, b) = (crate::slice1(&f0, "f0")?, crate::slice1(&f1, "f1")?);
    if a.len() != b.len() {
        return Err(pyo3::exceptions::PyValueError::new_err("f0 and f1 must have the same length"));
    }
    if m >= u32::MAX as usize || a.iter().chain(b).any(|&v| v < 0 || v as usize >= m) {
        return Err(pyo3::exceptions::PyValueError::new_err("face ids out of range"));
    }
    let (count, labels) = py.detach(|| components(m, a, b));
    Ok((count, PyArray1::from_vec(py, labels)))
}
