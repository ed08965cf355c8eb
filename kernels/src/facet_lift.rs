//! The candidate faces of the passes' lifts (`passes._Generator`, paper 001 §3: the ball kept
//! clear of the mesh around and away from its contact), gathered per point instead of as
//! numpy's padded (q, c) tables, and what is computed on them:
//!
//! * `facet_lift` — `_Generator.facet_lift` whole: the facet planes of the two mesh edges
//!   bounding each point's segment (`einsum` sums `(x0 y0 + x2 y2) + x1 y1`, `np.clip`,
//!   `max` with numpy's NaN), and where one is penetrated deeper than the facet tolerance the
//!   fixed-point lift (`lift::lift_one`) on the faces around the edges' four corners;
//! * `probe_candidates` — `_unique_per_row(_probe_faces(ids))`: the faces holding the probe
//!   samples (vertex ring, the two faces of an edge midpoint, a centroid's face), each row
//!   descending without repeats, −1 padded to the widest row;
//! * `candidate_shortfall` — `_pose_shortfall`'s ρ − nearest exact distance over such rows.
//!
//! The same floats as the numpy reference, bit for bit (a min over a candidate set does not
//! depend on its order; NaN propagates as in numpy).

use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::lift::{candidate_tris, face_tri, lift_one, point_triangle_distance, Tri, P3};
use crate::numpy_ops::{nanmax, nanmin};
use crate::prefetch::prefetch;

/// The face ids of a vertex–face table: int32 (`passes._narrow_table`) or int64.
#[derive(FromPyObject)]
pub enum FaceIds<'py> {
    I32(PyReadonlyArray1<'py, i32>),
    I64(PyReadonlyArray1<'py, i64>),
}

enum IdSlice<'a> {
    I32(&'a [i32]),
    I64(&'a [i64]),
}

/// The faces around each vertex: those of v are `face[ptr[v]..ptr[v + 1]]`.
struct VertexFaces<'a> {
    ptr: &'a [i64],
    face: IdSlice<'a>,
}

impl VertexFaces<'_> {
    /// Push the faces around vertex `v` onto `out`; false when `v` or the table is out of
    /// range.
    fn push(&self, v: i64, out: &mut Vec<i64>) -> bool {
        if v < 0 || v as usize + 1 >= self.ptr.len() {
            return false;
        }
        let (a, b) = (self.ptr[v as usize], self.ptr[v as usize + 1]);
        if a < 0 || b < a {
            return false;
        }
        let (a, b) = (a as usize, b as usize);
        match &self.face {
            IdSlice::I32(s) if b <= s.len() => out.extend(s[a..b].iter().map(|&x| x as i64)),
            IdSlice::I64(s) if b <= s.len() => out.extend_from_slice(&s[a..b]),
            _ => return false,
        }
        true
    }

    /// Fetch the faces around vertex `v` into the cache ahead of [`Self::push`]: `rows` 0
    /// their place in the table, 1 the ids, 2 their rows of F, 3 the rows of V at their
    /// corners (each needs the one before it in the cache to be cheap). A hint; ids out of
    /// range are skipped.
    #[inline]
    fn fetch(&self, v: i64, rows: u8, ff: &[i64], vv: &[P3]) {
        if v < 0 || v as usize + 1 >= self.ptr.len() {
            return;
        }
        if rows == 0 {
            return prefetch(self.ptr, v as usize);
        }
        let (a, b) = (self.ptr[v as usize], self.ptr[v as usize + 1]);
        if a < 0 || b <= a {
            return;
        }
        let (a, b) = (a as usize, b as usize);
        let each = |f: &mut dyn FnMut(usize)| match &self.face {
            IdSlice::I32(s) => s
                .get(a..b)
                .into_iter()
                .flatten()
                .for_each(|&x| f(x as usize)),
            IdSlice::I64(s) => s
                .get(a..b)
                .into_iter()
                .flatten()
                .for_each(|&x| f(x as usize)),
        };
        match rows {
            1 => match &self.face {
                IdSlice::I32(s) => {
                    prefetch(s, a);
                    prefetch(s, b - 1);
                }
                IdSlice::I64(s) => {
                    prefetch(s, a);
                    prefetch(s, b - 1);
                }
            },
            2 => each(&mut |fi| {
                prefetch(ff, 3 * fi);
                prefetch(ff, 3 * fi + 2);
            }),
            _ => each(&mut |fi| {
                for &x in ff.get(3 * fi..3 * fi + 3).into_iter().flatten() {
                    prefetch(vv, x as usize);
                }
            }),
        };
    }
}

fn table<'a>(
    ptr: &'a PyReadonlyArray1<'_, i64>,
    face: &'a FaceIds<'_>,
) -> PyResult<VertexFaces<'a>> {
    Ok(VertexFaces {
        ptr: crate::slice1(ptr, "ptr")?,
        face: match face {
            FaceIds::I32(a) => IdSlice::I32(crate::slice1(a, "face")?),
            FaceIds::I64(a) => IdSlice::I64(crate::slice1(a, "face")?),
        },
    })
}

/// Sort `ids` descending and drop repeats and negatives (a row of `_unique_per_row`).
fn unique_desc(ids: &mut Vec<i64>) {
    ids.retain(|&x| x >= 0);
    ids.sort_unstable_by(|a, b| b.cmp(a));
    ids.dedup();
}

/// Whether every face id of `faces` is below m and its corners are vertex ids of V.
fn faces_ok(faces: &[i64], ff: &[i64], nv: usize) -> bool {
    let m = ff.len() / 3;
    faces.iter().all(|&fi| {
        fi >= 0
            && (fi as usize) < m
            && ff[3 * fi as usize..3 * fi as usize + 3]
                .iter()
                .all(|&x| x >= 0 && (x as usize) < nv)
    })
}

const OUT_OF_RANGE: &str = "edges, faces or the vertex-face table hold ids out of range";

/// Run `one(i)` for i in 0..q on `threads` threads (the calling thread below 256 items), in
/// order of i in the result; the first error, if any.
fn run_rows<T: Send>(
    py: Python<'_>,
    threads: usize,
    q: usize,
    one: impl Fn(usize) -> Option<T> + Sync,
) -> PyResult<Vec<T>> {
    let pl = crate::pool_for(threads, q)?;
    let got: Option<Vec<T>> = py.detach(|| {
        if threads <= 1 || q < 256 {
            (0..q).map(&one).collect()
        } else {
            pl.install(|| (0..q).into_par_iter().with_min_len(32).map(&one).collect())
        }
    });
    got.ok_or_else(|| PyValueError::new_err(OUT_OF_RANGE))
}

/// The candidate faces and triangles of the last lifted point of a run of points, kept for
/// the next one: consecutive points lie on the same or neighbouring segments, whose corners
/// (and so faces) they share. A [`Tri`] is a function of its face id alone, so one reused
/// is the one [`face_tri`] would make, to the bit.
#[derive(Default)]
struct Scratch {
    /// the corners of the two edges whose faces `cand` holds (None: none yet)
    key: Option<[i64; 4]>,
    /// the candidate faces, descending, without repeats
    cand: Vec<i64>,
    tris: Vec<Tri>,
    /// the previous point's, while the next are gathered
    old_cand: Vec<i64>,
    old_tris: Vec<Tri>,
    /// the points of a piece to lift (index in the piece, their edges)
    need: Vec<(usize, (usize, usize))>,
}

impl Scratch {
    /// Make `cand`, `tris` those of the faces around the corners `key` (the faces of
    /// `face_tri` for each id of `cand`), reusing the previous point's triangles; false when
    /// an id is out of range.
    fn gather(&mut self, key: [i64; 4], vv: &[P3], ff: &[i64], vf: &VertexFaces<'_>) -> bool {
        if self.key == Some(key) {
            return true;
        }
        self.key = None;
        std::mem::swap(&mut self.cand, &mut self.old_cand);
        std::mem::swap(&mut self.tris, &mut self.old_tris);
        self.cand.clear();
        for &c in &key {
            if !vf.push(c, &mut self.cand) {
                return false;
            }
        }
        unique_desc(&mut self.cand);
        if !faces_ok(&self.cand, ff, vv.len()) {
            return false;
        }
        // both descending: one merge finds the faces the previous point had
        self.tris.clear();
        let mut j = 0;
        for &fi in &self.cand {
            while j < self.old_cand.len() && self.old_cand[j] > fi {
                j += 1;
            }
            let had = j < self.old_cand.len() && self.old_cand[j] == fi;
            let t = if had {
                self.old_tris[j]
            } else {
                face_tri(vv, ff, fi)
            };
            self.tris.push(t);
        }
        self.key = Some(key);
        true
    }
}

/// Points per piece of [`facet_lift`]'s work (~10–20 µs each on Rotor 37): the threads take
/// pieces in turn, and a piece's points share their candidate faces ([`Scratch`]).
const FACET_PIECE: usize = 64;

/// Below this many points [`facet_lift`] runs on the calling thread alone, whatever the
/// threads asked (~0.25 µs a point on Rotor 37: ~4 ms here). A Rotor 37 level's ~3200 points
/// (~0.8 ms) took 0.07 s a plan on the calling thread, 0.23–0.27 s wall with a worker
/// taking pieces beside it (the caller waits for the worker's job to start and end, which
/// the side thread and other processes keep off the cores for a time slice), 0.31–0.38 s
/// handed whole to the 2-worker pool (Rotor 37 1.29M, measured in the plan on a
/// loaded 2-core machine; the lead's quiet-machine figure for the pool: 0.20 s).
const FACET_PARALLEL_MIN: usize = 16384;

/// Points looked ahead by [`facet_lift`]'s facet planes: their edges' rows are fetched into
/// the cache meanwhile (and halfway there, their faces' normals).
const FETCH_AHEAD: usize = 16;

/// `_Generator.facet_lift`: (q,) λ (mm) of the points `d` with unit normals `dn` (q, 3) on
/// the segments `seg` (q,) of the level polyline whose points lie on the mesh edges `edge`
/// (k,) (`closed`: the last segment runs back to the first point). Mesh: V (n, 3), F (m, 3),
/// its edges and their faces (e, 2) (−1: none), unit face normals (m, 3), the vertex–face
/// table (`ptr`, `face`). `consts` = (ρ, facet tolerance, lift tolerance, gain, plane slack),
/// mm; `steps` fixed-point steps. The GIL released; from [`FACET_PARALLEL_MIN`] points on,
/// pieces of [`FACET_PIECE`] points on `threads` workers of the pool.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn facet_lift<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
    edges: PyReadonlyArray2<'py, i64>,
    edge_faces: PyReadonlyArray2<'py, i64>,
    face_normals: PyReadonlyArray2<'py, f64>,
    ptr: PyReadonlyArray1<'py, i64>,
    face: FaceIds<'py>,
    d: PyReadonlyArray2<'py, f64>,
    dn: PyReadonlyArray2<'py, f64>,
    edge: PyReadonlyArray1<'py, i64>,
    seg: PyReadonlyArray1<'py, i64>,
    closed: bool,
    consts: (f64, f64, f64, f64, f64),
    steps: usize,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let vv = crate::points(&v, "V")?;
    let ff = crate::arrays::flat(&f, "F")?;
    let ee = crate::arrays::flat(&edges, "edges")?;
    let ef = crate::arrays::flat(&edge_faces, "edge_faces")?;
    let fnn = crate::points(&face_normals, "face_normals")?;
    let vf = table(&ptr, &face)?;
    let pp = crate::points(&d, "D")?;
    let q = pp.len();
    let nn = crate::arrays::points_n(&dn, "DN", q)?;
    let ed = crate::slice1(&edge, "edge")?;
    let sg = crate::arrays::values_n(&seg, "seg", q)?;
    let k = ed.len() as i64;
    if q > 0 && k == 0 {
        return Err(PyValueError::new_err("edge must not be empty"));
    }
    if ee.len() != ef.len() || fnn.len() * 3 != ff.len() {
        return Err(PyValueError::new_err(
            "edges and edge_faces must be (e, 2), face_normals one row per face",
        ));
    }
    let (rho, facet_tol, tol, gain, slack) = consts;
    let limit = rho - tol + slack;
    let ne = ee.len() / 2;
    // numpy's index rules: edge[min(seg, k − 1)], a negative index from the end
    let at = |j: i64| -> Option<usize> {
        let j = if j < 0 { j + k } else { j };
        let e = *ed.get(usize::try_from(j).ok()?)?;
        (e >= 0 && (e as usize) < ne).then_some(e as usize)
    };
    // the mesh edges bounding point i's segment
    let edges_of = |i: usize| -> Option<(usize, usize)> {
        let s = *sg.get(i)?;
        let e0 = at(s.min(k - 1))?;
        let e1 = if closed {
            at((s + 1).rem_euclid(k))?
        } else {
            at((s + 1).min(k - 1))?
        };
        Some((e0, e1))
    };
    let corners =
        |(e0, e1): (usize, usize)| [ee[2 * e0], ee[2 * e0 + 1], ee[2 * e1], ee[2 * e1 + 1]];
    // whether a facet plane of the faces of edges e0, e1 is penetrated deeper than the
    // tolerance at point i
    let penetrated = |i: usize, (e0, e1): (usize, usize)| -> Option<bool> {
        let faces = [ef[2 * e0], ef[2 * e0 + 1], ef[2 * e1], ef[2 * e1 + 1]];
        let n = &nn[i];
        let mut plane = f64::NAN;
        for (j, &fi) in faces.iter().enumerate() {
            let x = if fi >= 0 {
                let fv: &P3 = fnn.get(fi as usize)?;
                // einsum("qj,qfj->qf"): (x0 y0 + x2 y2) + x1 y1; np.clip(-1, 1) keeps NaN
                let cos = (n[0] * fv[0] + n[2] * fv[2]) + n[1] * fv[1];
                let c = nanmin(nanmax(cos, -1.0), 1.0);
                rho * (1.0 - c)
            } else {
                0.0
            };
            plane = if j == 0 { x } else { nanmax(plane, x) };
        }
        // not penetrated deeper than the tolerance (or NaN): λ = 0
        Some(plane.partial_cmp(&facet_tol) == Some(std::cmp::Ordering::Greater))
    };
    let mut out = vec![0.0; q];
    let ok = py.detach(|| {
        take_pieces(threads, q, &mut out, |start, piece, sc| {
            // the facet planes, the rows of points FETCH_AHEAD on fetched meanwhile (the
            // edges' faces, then their normals); the points to lift noted
            sc.need.clear();
            for (j, x) in piece.iter_mut().enumerate() {
                let i = start + j;
                if let Some((a, b)) = edges_of(i + FETCH_AHEAD) {
                    for r in [2 * a, 2 * b] {
                        prefetch(ef, r);
                        prefetch(ee, r);
                    }
                }
                if let Some((a, b)) = edges_of(i + FETCH_AHEAD / 2) {
                    for fi in [ef[2 * a], ef[2 * a + 1], ef[2 * b], ef[2 * b + 1]] {
                        prefetch(fnn, fi as usize);
                    }
                }
                let e = edges_of(i)?;
                *x = 0.0;
                if penetrated(i, e)? {
                    sc.need.push((j, e));
                }
            }
            // the lifts: the faces around the corners of the points 1–4 lifts on fetched
            // meanwhile, a stage further each (the table, the ids, F's rows, V's rows); the
            // corners the point before shares skipped
            for t in 0..sc.need.len() {
                for ahead in 1..=4 {
                    if let Some(&(_, e)) = sc.need.get(t + ahead) {
                        let before = corners(sc.need[t + ahead - 1].1);
                        for v in corners(e) {
                            if !before.contains(&v) {
                                vf.fetch(v, 4 - ahead as u8, ff, vv);
                            }
                        }
                    }
                }
                let (j, e) = sc.need[t];
                if !sc.gather(corners(e), vv, ff, &vf) {
                    return None;
                }
                let i = start + j;
                piece[j] = lift_one(
                    &sc.tris,
                    &pp[i],
                    &nn[i],
                    0.0,
                    (rho, tol, gain, limit),
                    steps,
                );
            }
            Some(())
        })
    })?;
    if !ok {
        return Err(PyValueError::new_err(OUT_OF_RANGE));
    }
    Ok(PyArray1::from_vec(py, out))
}

/// Fill `out` (q,) piece by piece ([`FACET_PIECE`] items, `work(first index, piece,
/// scratch)`), each run of pieces with a [`Scratch`] of its own; false when a piece failed
/// (the rest may then be left). On the calling thread below [`FACET_PARALLEL_MIN`] items
/// or with one thread, else on the pool's `threads` workers.
fn take_pieces(
    threads: usize,
    q: usize,
    out: &mut [f64],
    work: impl Fn(usize, &mut [f64], &mut Scratch) -> Option<()> + Sync,
) -> PyResult<bool> {
    let piece = |sc: &mut Scratch, (c, p): (usize, &mut [f64])| work(c * FACET_PIECE, p, sc);
    if q < FACET_PARALLEL_MIN || threads <= 1 {
        let mut sc = Scratch::default();
        let mut pieces = out.chunks_mut(FACET_PIECE).enumerate();
        return Ok(pieces.try_for_each(|c| piece(&mut sc, c)).is_some());
    }
    let pl = crate::pool_for(threads, q)?;
    Ok(pl
        .install(|| {
            out.par_chunks_mut(FACET_PIECE)
                .enumerate()
                .try_for_each_init(Scratch::default, piece)
        })
        .is_some())
}

/// The candidate faces of one row of probe-sample ids (`_probe_faces` then
/// `_unique_per_row`'s row): descending, no repeats; None when an id is out of range.
fn probe_row(
    ids: &[i64],
    nv: i64,
    ne: i64,
    m: i64,
    ef: &[i64],
    vf: &VertexFaces<'_>,
    out: &mut Vec<i64>,
) -> Option<()> {
    out.clear();
    for &s in ids {
        if s < 0 {
            continue; // no sample (outside the search bound)
        } else if s < nv {
            if !vf.push(s, out) {
                return None;
            }
        } else if s < nv + ne {
            let e = (s - nv) as usize;
            out.extend_from_slice(&ef[2 * e..2 * e + 2]);
        } else if s < nv + ne + m {
            out.push(s - nv - ne);
        } else {
            return None;
        }
    }
    unique_desc(out);
    Some(())
}

/// `_unique_per_row(_probe_faces(ids))`: (q, c) int64, the faces holding the probe samples
/// `ids` (q, k) (vertices 0..nv, then the midpoints of the edges (e, 2), then the centroids
/// of the m faces; −1: none), each row descending without repeats, −1 padded to the widest
/// row (at least one column). On `threads` threads, the GIL released.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn probe_candidates<'py>(
    py: Python<'py>,
    ids: PyReadonlyArray2<'py, i64>,
    n_vertices: usize,
    n_faces: usize,
    edge_faces: PyReadonlyArray2<'py, i64>,
    ptr: PyReadonlyArray1<'py, i64>,
    face: FaceIds<'py>,
    threads: usize,
) -> PyResult<Bound<'py, PyArray2<i64>>> {
    let flat = crate::arrays::flat(&ids, "ids")?;
    let kk = ids.shape()[1];
    let q = ids.shape()[0];
    let ef = crate::arrays::flat(&edge_faces, "edge_faces")?;
    let vf = table(&ptr, &face)?;
    let (nv, ne, m) = (n_vertices as i64, (ef.len() / 2) as i64, n_faces as i64);
    let rows = run_rows(py, threads, q, |i| {
        let mut row = Vec::new();
        probe_row(&flat[i * kk..(i + 1) * kk], nv, ne, m, ef, &vf, &mut row)?;
        Some(row)
    })?;
    let width = rows.iter().map(Vec::len).max().unwrap_or(0).max(1);
    let mut out = vec![-1i64; q * width];
    for (i, r) in rows.iter().enumerate() {
        out[i * width..i * width + r.len()].copy_from_slice(r);
    }
    PyArray1::from_vec(py, out).reshape([q, width])
}

/// `_pose_shortfall`'s last step: (q,) ρ − the least exact distance from the ball centres
/// `c` (q, 3) to their candidate faces `cand` (q, w) of V, F (−1 padding; −inf for a row
/// without one), `passes._point_triangle_distance` operation for operation. On `threads`
/// threads, the GIL released.
#[pyfunction]
pub fn candidate_shortfall<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
    f: PyReadonlyArray2<'py, i64>,
    cand: PyReadonlyArray2<'py, i64>,
    c: PyReadonlyArray2<'py, f64>,
    rho: f64,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let vv = crate::points(&v, "V")?;
    let ff = crate::arrays::flat(&f, "F")?;
    let cc = crate::points(&c, "centres")?;
    let q = cc.len();
    let cf = crate::arrays::flat(&cand, "cand")?;
    if cand.shape()[0] != q {
        return Err(PyValueError::new_err("cand must have one row per centre"));
    }
    let w = cand.shape()[1];
    let nv = vv.len();
    let out = run_rows(py, threads, q, |i| {
        let row: Vec<i64> = cf[i * w..(i + 1) * w]
            .iter()
            .copied()
            .filter(|&x| x >= 0)
            .collect();
        if !faces_ok(&row, ff, nv) {
            return None;
        }
        let mut dmin = f64::INFINITY;
        for (a, b, t, nrm, n2, _, _) in candidate_tris(vv, ff, row.iter().copied()) {
            dmin = nanmin(dmin, point_triangle_distance(&cc[i], &a, &b, &t, &nrm, n2));
        }
        Some(rho - dmin)
    })?;
    Ok(PyArray1::from_vec(py, out))
}
