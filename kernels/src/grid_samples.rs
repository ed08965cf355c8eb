//! The barycentric sample grids of `verify.samples._grid_samples`, in one pass: the mesh
//! vertices of the faces once (ascending), then for each segment count n (ascending) the
//! inner grid points of its faces (face after face), their grid edges as (lower, higher)
//! sample ids, and the first copy only of the mesh edges of the n = 1 faces. The points are
//! the very sums of the numpy reference, `(b0 a + b1 b) + b2 c` per coordinate (Rust does
//! not fuse them into FMAs), so the same bits; the order of every array is the reference's.

use std::collections::HashSet;

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// The grid of a triangle with n segments per side (`_grid_template`): barycentric
/// coordinates of the points (i, j), i + j ≤ n, i outer and j inner; the corner of each
/// (0, 1, 2 or −1); the edges as sorted (low, high) pairs in ascending order.
pub struct Template {
    pub bary: Vec<[f64; 3]>,
    pub corner: Vec<i8>,
    pub edges: Vec<(usize, usize)>,
}

pub fn template(n: usize) -> Template {
    let w = n + 2;
    let mut idx = vec![usize::MAX; w * w];
    let mut bary = Vec::new();
    let mut corner = Vec::new();
    let nf = n as f64;
    for i in 0..=n {
        for j in 0..=(n - i) {
            idx[i * w + j] = bary.len();
            bary.push([(n - i - j) as f64 / nf, i as f64 / nf, j as f64 / nf]);
            corner.push(match (i, j) {
                (0, 0) => 0,
                (a, 0) if a == n => 1,
                (0, b) if b == n => 2,
                _ => -1,
            });
        }
    }
    let mut edges = Vec::new();
    for i in 0..=n {
        for j in 0..=(n - i) {
            let a = idx[i * w + j];
            for (p, q) in [
                (a, idx[(i + 1) * w + j]),
                (a, idx[i * w + j + 1]),
                (idx[(i + 1) * w + j], idx[i * w + j + 1]),
            ] {
                if p != usize::MAX && q != usize::MAX {
                    edges.push((p.min(q), p.max(q)));
                }
            }
        }
    }
    edges.sort_unstable();
    edges.dedup();
    Template {
        bary,
        corner,
        edges,
    }
}

/// The arrays of `_grid_samples`, flat: points (p, 3), face (p,), bary (p, 3), vertex (p,),
/// edges (e, 2), edge face (e,).
pub struct Grid {
    pub points: Vec<f64>,
    pub face: Vec<i64>,
    pub bary: Vec<f64>,
    pub vertex: Vec<i64>,
    pub edges: Vec<i64>,
    pub eface: Vec<i64>,
}

/// The grids of `faces` (ids into `f`) with `nf` segments per side; None when an id is out
/// of range or a count is below 1 (the numpy reference then says so, or does what it does).
pub fn grid(v: &[[f64; 3]], f: &[[i64; 3]], faces: &[i64], nf: &[i64]) -> Option<Grid> {
    let nv_all = v.len();
    if faces.iter().any(|&x| x < 0 || x as usize >= f.len()) || nf.iter().any(|&n| n < 1) {
        return None;
    }
    if faces
        .iter()
        .any(|&x| f[x as usize].iter().any(|&i| i < 0 || i as usize >= nv_all))
    {
        return None;
    }
    // the mesh vertices of the faces, ascending (np.unique), and their sample ids
    let mut vmap = vec![-1i64; nv_all];
    for &x in faces {
        for &i in &f[x as usize] {
            vmap[i as usize] = 0;
        }
    }
    let mut verts = Vec::new();
    for (i, m) in vmap.iter_mut().enumerate() {
        if *m == 0 {
            *m = verts.len() as i64;
            verts.push(i);
        }
    }
    // a face of each vertex: the reference's assignments for corners 2, 1, 0 in turn (the
    // last write wins)
    let mut vface = vec![-1i64; nv_all];
    let mut vcorner = vec![0usize; nv_all];
    for k in [2usize, 1, 0] {
        for &x in faces {
            let i = f[x as usize][k] as usize;
            vface[i] = x;
            vcorner[i] = k;
        }
    }
    let mut g = Grid {
        points: Vec::new(),
        face: Vec::new(),
        bary: Vec::new(),
        vertex: Vec::new(),
        edges: Vec::new(),
        eface: Vec::new(),
    };
    for &i in &verts {
        g.points.extend_from_slice(&v[i]);
        g.face.push(vface[i]);
        let mut b = [0.0f64; 3];
        b[vcorner[i]] = 1.0;
        g.bary.extend_from_slice(&b);
        g.vertex.push(i as i64);
    }
    let mut ns: Vec<i64> = nf.to_vec();
    ns.sort_unstable();
    ns.dedup();
    let mut base = verts.len() as i64;
    let mut n1 = 0usize;
    for &n in &ns {
        let t = template(n as usize);
        let inner: Vec<usize> = (0..t.bary.len()).filter(|&p| t.corner[p] < 0).collect();
        let mut rank = vec![0i64; t.bary.len()];
        for (r, &p) in inner.iter().enumerate() {
            rank[p] = r as i64;
        }
        let npt = inner.len() as i64;
        let mut lmap = vec![0i64; t.bary.len()];
        for (&x, _) in faces.iter().zip(nf).filter(|(_, &m)| m == n) {
            let c = &f[x as usize];
            let (a, b, cc) = (&v[c[0] as usize], &v[c[1] as usize], &v[c[2] as usize]);
            for &p in &inner {
                let w = &t.bary[p];
                for d in 0..3 {
                    g.points.push((w[0] * a[d] + w[1] * b[d]) + w[2] * cc[d]);
                }
                g.face.push(x);
                g.bary.extend_from_slice(w);
                g.vertex.push(-1);
            }
            for (p, l) in lmap.iter_mut().enumerate() {
                *l = match t.corner[p] {
                    k if k >= 0 => vmap[c[k as usize] as usize],
                    _ => base + rank[p],
                };
            }
            base += npt;
            for &(p, q) in &t.edges {
                let (lo, hi) = (lmap[p], lmap[q]);
                g.edges.push(lo.min(hi));
                g.edges.push(lo.max(hi));
                g.eface.push(x);
            }
            if n == 1 {
                n1 += t.edges.len();
            }
        }
    }
    // the mesh edges of the n = 1 faces (they come first): the first copy of each
    if n1 > 0 {
        let mut seen = HashSet::with_capacity(n1);
        let mut edges = Vec::with_capacity(g.edges.len());
        let mut eface = Vec::with_capacity(g.eface.len());
        for e in 0..g.eface.len() {
            let key = (g.edges[2 * e], g.edges[2 * e + 1]);
            if e >= n1 || seen.insert(key) {
                edges.push(key.0);
                edges.push(key.1);
                eface.push(g.eface[e]);
            }
        }
        g.edges = edges;
        g.eface = eface;
    }
    Some(g)
}

type Arr<'py> = Bound<'py, PyAny>;
/// The six arrays of [`grid_samples`].
type GridArrays<'py> = (Arr<'py>, Arr<'py>, Arr<'py>, Arr<'py>, Arr<'py>, Arr<'py>);

/// `_grid_samples(V, F, faces, nf)`: (points (p, 3), face (p,), bary (p, 3), vertex (p,),
/// edges (e, 2), edge face (e,)) or None (see [`grid`]). V (n, 3) mm, F (m, 3), faces (k,),
/// nf (k,) segments per side.
#[pyfunction]
pub fn grid_samples<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
    faces: PyReadonlyArray1<'py, i64>,
    nf: PyReadonlyArray1<'py, i64>,
) -> PyResult<Option<GridArrays<'py>>> {
    let pts = crate::points(&v, "V")?;
    let tri = crate::arrays::triangles(&f, "F")?;
    let fc = crate::slice1(&faces, "faces")?;
    let ns = crate::arrays::values_n(&nf, "nf", fc.len())?;
    let Some(g) = py.detach(|| grid(pts, tri, fc, ns)) else {
        return Ok(None);
    };
    let p = g.face.len();
    let e = g.eface.len();
    let two = |a: Vec<f64>, k: usize| -> PyResult<Arr<'py>> {
        Ok(PyArray1::from_vec(py, a).reshape([k, 3])?.into_any())
    };
    Ok(Some((
        two(g.points, p)?,
        PyArray1::from_vec(py, g.face).into_any(),
        two(g.bary, p)?,
        PyArray1::from_vec(py, g.vertex).into_any(),
        PyArray1::from_vec(py, g.edges).reshape([e, 2])?.into_any(),
        PyArray1::from_vec(py, g.eface).into_any(),
    )))
}
