//! Compiled kernels of Blisk CAM, one Python extension module `blisk_cam_kernels`.
//!
//! Only `blisk_cam/core/kernels/` imports this module; the numpy code in `blisk_cam/core` is
//! the reference and the fallback. Every kernel releases the GIL; the parallel ones run on
//! a rayon pool of the caller's thread count (the user's `--threads`).

use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadwriteArray2,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

mod arrays;
mod closest;
mod collision_refine;
mod collision_tree;
mod collision_walk;
mod densify;
mod face_bvh;
mod face_gradient;
mod facet_lift;
mod float_text;
mod grid_samples;
mod hypot;
mod intrusion_probes;
mod knn;
mod level_chains;
mod lift;
mod mesh_orient;
mod mesh_samples;
mod mesh_topology;
mod morton;
mod numpy_ops;
mod polyline_distance;
mod prefetch;
mod probe;
mod resample;
mod slice_candidates;
mod slice_roots;
mod slice_setup;
mod split;
mod step;
mod stock;
mod swept_ball;
mod swept_cutter;
mod weld;
mod weld_near;

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// Below this many items a query runs on the calling thread (its own pool) whatever the
/// threads asked: handing a small job to the shared pool and back costs more than it saves,
/// and the pool's workers spin after it on the cores the caller's Python needs (planning
/// Rotor 37's 20k triangles makes ~2000 such calls: 1.25–1.31 s on one worker, 1.44–1.65 s
/// on two). The answers do not depend on the threads.
const PARALLEL_MIN: usize = 2048;

/// [`pool`] for a job of `items` items: the calling thread's own below [`PARALLEL_MIN`].
pub(crate) fn pool_for(threads: usize, items: usize) -> PyResult<Arc<rayon::ThreadPool>> {
    pool(if items < PARALLEL_MIN { 1 } else { threads })
}

/// A rayon pool of `threads` workers (made once per count and kept; one worker: a pool of the
/// calling thread's own).
fn pool(threads: usize) -> PyResult<Arc<rayon::ThreadPool>> {
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<rayon::ThreadPool>>>> = OnceLock::new();
    thread_local! {
        // one single-worker pool per calling thread: Python threads that each ask for one
        // worker (the chunks `runtime.map_chunks` spreads over its threads) would otherwise
        // queue on one shared worker and run one after another
        static OWN: std::cell::RefCell<Option<Arc<rayon::ThreadPool>>> =
            const { std::cell::RefCell::new(None) };
    }
    let n = threads.max(1);
    if n == 1 {
        return OWN.with(|own| {
            let mut own = own.borrow_mut();
            if let Some(p) = own.as_ref() {
                return Ok(p.clone());
            }
            // the calling thread is the pool's one worker: a kernel runs on it directly, with
            // no hand-off to another thread and back (and no worker spinning after each job —
            // ~50–100 µs of CPU per call, which the plan's thousands of small calls at 20k
            // triangles added up to ~0.1–0.2 s). Rayon leaks such a pool's registry (a few
            // hundred bytes, once per Python thread that calls a kernel with one worker).
            let p = Arc::new(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .use_current_thread()
                    .build()
                    .map_err(|e| PyValueError::new_err(format!("cannot start a thread: {e}")))?,
            );
            *own = Some(p.clone());
            Ok(p)
        });
    }
    let mut pools = POOLS
        .get_or_init(|| Mutex::new(HashMap::new()))
        .lock()
        .unwrap();
    if let Some(p) = pools.get(&n) {
        return Ok(p.clone());
    }
    let p = rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .thread_name(|i| format!("blisk_cam-kernels-{i}"))
        .build()
        .map_err(|e| PyValueError::new_err(format!("cannot start {n} threads: {e}")))?;
    let p = Arc::new(p);
    pools.insert(n, p.clone());
    Ok(p)
}

/// Which rayon pool a kernel called from this thread with `threads` workers runs on (an
/// opaque number: equal numbers, the same pool), for the test that Python threads asking for
/// one worker each get pools of their own.
#[pyfunction]
fn pool_identity(threads: usize) -> PyResult<usize> {
    Ok(Arc::as_ptr(&pool(threads)?) as usize)
}

/// The faces of a mesh in a bounding-volume tree (closest.rs, face_bvh.rs), for nearest-face
/// queries (see `distance.NearestFaces`).
#[pyclass(frozen)]
struct FaceTree {
    tree: closest::FaceTree,
}

#[pymethods]
impl FaceTree {
    /// V (n, 3) float64 mm, F (m, 3) int64 vertex ids (in range: checked); `disks`: keep
    /// a bound per face (15 floats a face) that makes queries far off the surface faster
    /// (the same answers).
    #[new]
    #[pyo3(signature = (v, f, disks = false))]
    fn new(
        py: Python<'_>,
        v: PyReadonlyArray2<'_, f64>,
        f: PyReadonlyArray2<'_, i64>,
        disks: bool,
    ) -> PyResult<Self> {
        let vv = points(&v, "V")?.to_vec();
        if f.shape()[1] != 3 {
            return Err(PyValueError::new_err("F must be (m, 3)"));
        }
        let fs = f
            .as_slice()
            .map_err(|_| PyValueError::new_err("F must be C-contiguous"))?;
        let n = vv.len() as i64;
        if fs.iter().any(|&i| i < 0 || i >= n) {
            return Err(PyValueError::new_err("F holds vertex ids out of range"));
        }
        let ff: Vec<[usize; 3]> = fs
            .chunks_exact(3)
            .map(|t| [t[0] as usize, t[1] as usize, t[2] as usize])
            .collect();
        let tree = py.detach(|| closest::FaceTree::new(vv, ff, disks));
        Ok(FaceTree { tree })
    }

    /// (k,) int64: the nearest face of each point (k, 3) (least squared distance as
    /// `closest_on_triangles` computes it, then the lowest id; -1 for a non-finite point),
    /// on `threads` threads.
    fn nearest<'py>(
        &self,
        py: Python<'py>,
        p: PyReadonlyArray2<'py, f64>,
        threads: usize,
    ) -> PyResult<Bound<'py, PyArray1<i64>>> {
        let pp = points(&p, "points")?;
        let pl = pool_for(threads, pp.len())?;
        let out = py.detach(|| pl.install(|| self.tree.nearest_many(pp)));
        Ok(PyArray1::from_vec(py, out))
    }

    /// (face (k,) int64, q (k, 3), d2 (k,), feature (k,) int8, bary (k, 3)): the nearest face
    /// of each point (k, 3) as `nearest` finds it, and `closest_on_triangles` of the point
    /// and that face (a non-finite point: face −1, the figures of numpy's face −1), on
    /// `threads` threads.
    #[allow(clippy::type_complexity)]
    fn nearest_closest<'py>(
        &self,
        py: Python<'py>,
        p: PyReadonlyArray2<'py, f64>,
        threads: usize,
    ) -> PyResult<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<i8>>,
        Bound<'py, PyArray2<f64>>,
    )> {
        let pp = points(&p, "points")?;
        let pl = pool_for(threads, pp.len())?;
        let (face, rows) = py.detach(|| {
            pl.install(|| {
                let face = self.tree.nearest_many(pp);
                let rows = self.tree.closest_many(pp, &face);
                (face, rows)
            })
        });
        let k = pp.len();
        let mut q = Vec::with_capacity(3 * k);
        let mut bary = Vec::with_capacity(3 * k);
        let (mut d2, mut feat) = (Vec::with_capacity(k), Vec::with_capacity(k));
        for (qi, di, fi, bi) in rows {
            q.extend_from_slice(&qi);
            d2.push(di);
            feat.push(fi);
            bary.extend_from_slice(&bi);
        }
        Ok((
            PyArray1::from_vec(py, face),
            PyArray1::from_vec(py, q).reshape([k, 3])?,
            PyArray1::from_vec(py, d2),
            PyArray1::from_vec(py, feat),
            PyArray1::from_vec(py, bary).reshape([k, 3])?,
        ))
    }
}

/// A k-d tree of points for k-nearest queries within a bound (see `passes._nearest_samples`).
#[pyclass(frozen)]
struct PointTree {
    tree: knn::PointTree,
}

#[pymethods]
impl PointTree {
    /// points (n, 3) float64 mm; built on `threads` threads.
    #[new]
    #[pyo3(signature = (points_, threads=1))]
    fn new(py: Python<'_>, points_: PyReadonlyArray2<'_, f64>, threads: usize) -> PyResult<Self> {
        let pts = points(&points_, "points")?.to_vec();
        if pts.len() >= u32::MAX as usize {
            return Err(PyValueError::new_err("too many points for one tree"));
        }
        let pl = pool_for(threads, pts.len())?;
        let tree = py.detach(|| pl.install(|| knn::PointTree::new(pts)));
        Ok(PointTree { tree })
    }

    /// Whether [`PointTree::query`] takes `packets` (a build before it has no such
    /// attribute).
    #[classattr]
    const PACKETS: bool = true;

    /// (ids (q, k) int64, -1 padded; tie (q,) bool): the k nearest points of each query
    /// (q, 3) closer than `bound` mm, by (distance, id); `tie`: the k-th and the next are at
    /// the same distance (scipy may choose another of them). On `threads` threads; in
    /// packets of consecutive queries when `packets` (queries in path order, each near the
    /// one before; a tree of `sample_point_tree` walks any so), the same answers.
    #[pyo3(signature = (q, k, bound, threads, packets=false))]
    fn query<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        k: usize,
        bound: f64,
        threads: usize,
        packets: bool,
    ) -> PyResult<(Bound<'py, PyArray2<i64>>, Bound<'py, PyArray1<bool>>)> {
        if k == 0 {
            return Err(PyValueError::new_err("k must be at least 1"));
        }
        let qq = points(&q, "queries")?;
        let pl = pool_for(threads, qq.len())?;
        let ub2 = bound * bound;
        let (ids, tie) = py.detach(|| pl.install(|| self.tree.knn_many(qq, k, ub2, packets)));
        let ids = PyArray1::from_vec(py, ids).reshape([qq.len(), k])?;
        Ok((ids, PyArray1::from_vec(py, tie)))
    }
}

/// The squared distances of `closest_on_triangles` (pairwise rows of p, a, b, c), (k,).
#[pyfunction]
fn triangle_d2<'py>(
    py: Python<'py>,
    p: PyReadonlyArray2<'py, f64>,
    a: PyReadonlyArray2<'py, f64>,
    b: PyReadonlyArray2<'py, f64>,
    c: PyReadonlyArray2<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let (pp, aa, bb, cc) = (
        points(&p, "p")?,
        points(&a, "a")?,
        points(&b, "b")?,
        points(&c, "c")?,
    );
    if aa.len() != pp.len() || bb.len() != pp.len() || cc.len() != pp.len() {
        return Err(PyValueError::new_err(
            "p, a, b, c must have the same length",
        ));
    }
    let out: Vec<f64> = (0..pp.len())
        .map(|i| closest::triangle_d2(&pp[i], &aa[i], &bb[i], &cc[i]))
        .collect();
    Ok(PyArray1::from_vec(py, out))
}

/// Rows of a C-contiguous (n, 3) float64 array as points ([`arrays::rows`]).
fn points<'a>(a: &'a PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<&'a [[f64; 3]]> {
    arrays::rows::<3>(a, what)
}

fn slice1<'a, T: numpy::Element>(a: &'a PyReadonlyArray1<'_, T>, what: &str) -> PyResult<&'a [T]> {
    a.as_slice()
        .map_err(|_| PyValueError::new_err(format!("{what} must be C-contiguous")))
}

/// Greedy forward step (see `sampling.forward_step_indices`): (keep (q,) int64, trace (k, 3)
/// int64: per search start its first step, outcome and farthest end tested, -1 elsewhere).
#[pyfunction]
#[pyo3(signature = (p, c, tol_p, tol_c, old_trace=None, unchanged_to=None))]
fn forward_step<'py>(
    py: Python<'py>,
    p: PyReadonlyArray2<'py, f64>,
    c: PyReadonlyArray2<'py, f64>,
    tol_p: f64,
    tol_c: f64,
    old_trace: Option<PyReadonlyArray2<'py, i64>>,
    unchanged_to: Option<PyReadonlyArray1<'py, i64>>,
) -> PyResult<(Bound<'py, PyArray1<i64>>, Bound<'py, PyArray2<i64>>)> {
    let pp = points(&p, "p")?;
    let cc = points(&c, "c")?;
    if pp.len() != cc.len() {
        return Err(PyValueError::new_err("p and c must have the same length"));
    }
    let k = pp.len();
    let old = match (&old_trace, &unchanged_to) {
        (Some(t), Some(u)) => {
            if t.shape() != [k, 3] || u.len() != k + 1 {
                return Err(PyValueError::new_err(
                    "old_trace must be (k, 3), unchanged_to (k + 1,)",
                ));
            }
            let ts = t
                .as_slice()
                .map_err(|_| PyValueError::new_err("old_trace must be C-contiguous"))?;
            // SAFETY: as in `points`
            let ts = unsafe { std::slice::from_raw_parts(ts.as_ptr() as *const [i64; 3], k) };
            Some((ts, slice1(u, "unchanged_to")?))
        }
        (None, None) => None,
        _ => {
            return Err(PyValueError::new_err(
                "old_trace and unchanged_to go together",
            ))
        }
    };
    let out = py.detach(|| step::forward_step(pp, cc, tol_p, tol_c, old));
    let trace: Vec<i64> = out.trace.iter().flatten().copied().collect();
    let trace = PyArray1::from_vec(py, trace).reshape([k, 3])?;
    Ok((PyArray1::from_vec(py, out.keep), trace))
}

/// For each point of the columns x, y, z (float64, no -0.0), the index of the first point
/// with the same coordinates (see `weld._first_equal_point`), (k,) int64.
#[pyfunction]
fn first_equal_point<'py>(
    py: Python<'py>,
    x: PyReadonlyArray1<'py, f64>,
    y: PyReadonlyArray1<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let (xs, ys, zs) = (slice1(&x, "x")?, slice1(&y, "y")?, slice1(&z, "z")?);
    if xs.len() != ys.len() || xs.len() != zs.len() {
        return Err(PyValueError::new_err(
            "x, y and z must have the same length",
        ));
    }
    let bits = |s: &[f64]| -> &[u64] {
        // SAFETY: f64 and u64 have the same size and alignment
        unsafe { std::slice::from_raw_parts(s.as_ptr() as *const u64, s.len()) }
    };
    let (bx, by, bz) = (bits(xs), bits(ys), bits(zs));
    let first = py.detach(|| weld::first_equal_point(bx, by, bz));
    Ok(PyArray1::from_vec(py, first))
}

/// For each row of `v` (n, 3) float64, the index of the first row with the same coordinates
/// (−0.0 as 0.0; see `weld._welded`), (n,) int64; None when there are too many rows (the
/// caller takes the columns' kernel).
#[pyfunction]
fn first_equal_rows<'py>(
    py: Python<'py>,
    v: PyReadonlyArray2<'py, f64>,
) -> PyResult<Option<Bound<'py, PyArray1<i64>>>> {
    let rows = points(&v, "v")?;
    let first = py.detach(|| weld::first_equal_rows(rows));
    Ok(first.map(|f| PyArray1::from_vec(py, f)))
}

/// A binary STL's records (the file's bytes from offset 84, `n` records of 50 bytes) welded
/// exactly as read (see `weld::stl_corners_welded`): (vertices (k × 3,) float64 flat,
/// corner → vertex (3n,) int64), or None (a NaN/infinite coordinate, short records, too
/// many corners: the numpy reader runs).
#[pyfunction]
fn stl_corners_welded<'py>(
    py: Python<'py>,
    records: PyReadonlyArray1<'py, u8>,
    n: usize,
) -> PyResult<Option<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>)>> {
    let bytes = records
        .as_slice()
        .map_err(|_| PyValueError::new_err("records must be a contiguous uint8 array"))?;
    let got = py.detach(|| weld::stl_corners_welded(bytes, n));
    Ok(got.map(|(v, c)| (PyArray1::from_vec(py, v), PyArray1::from_vec(py, c))))
}

/// Remove posed solids from the stock (see `stock::remove` and `removal.simulate_moves`):
/// `lo`, `hi` (n_rays, K) float64 changed in place; `grid` = (θ0, Δθ, z0, Δz), `frame`
/// (4, 3) = origin, e1, e2, d; per solid its tip and axis (m, 3), group (m,) int64 in
/// 0..n_groups and box `boxes` (m, 4) int64 = (c0, c1, w0, w1) (unwrapped columns); the
/// solid's half-planes (q, 3), its bounding z range and radius. Returns (removed Σ (hi² −
/// lo²)/2 mm², per group the material its union met (n_groups,) mm² and the longest stretch
/// (n_groups,) mm — zeros unless `measure` —, the candidate pairs, and the rays that needed
/// more than K intervals: (ray ids (p,), counts (p,), lo and hi flat) for the caller to write).
/// `planes_in` (p, 3): the solid shrunk by the crash tolerance; with `measure`, per group also
/// the material its union met (returned after the first per-group array), for the crash
/// decision. `rho` (q, 2): the ρ range of each plane's edge, for a profile whose boundary below the
/// top rises with ρ (only the edges a ray's ρ range meets are evaluated); None: every plane.
#[pyfunction]
#[pyo3(signature = (lo, hi, n_theta, grid, frame, tips, axes, group, n_groups, boxes, planes,
                    bounds, measure, threads, rho=None, planes_in=None))]
#[allow(clippy::too_many_arguments)]
fn stock_remove<'py>(
    py: Python<'py>,
    mut lo: PyReadwriteArray2<'py, f64>,
    mut hi: PyReadwriteArray2<'py, f64>,
    n_theta: usize,
    grid: (f64, f64, f64, f64),
    frame: PyReadonlyArray2<'py, f64>,
    tips: PyReadonlyArray2<'py, f64>,
    axes: PyReadonlyArray2<'py, f64>,
    group: PyReadonlyArray1<'py, i64>,
    n_groups: usize,
    boxes: PyReadonlyArray2<'py, i64>,
    planes: PyReadonlyArray2<'py, f64>,
    bounds: (f64, f64, f64),
    measure: bool,
    threads: usize,
    rho: Option<PyReadonlyArray2<'py, f64>>,
    planes_in: Option<PyReadonlyArray2<'py, f64>>,
) -> PyResult<stock::Removed<'py>> {
    let g = stock::grid_of(&lo, &hi, n_theta, grid, &frame)?;
    let (tt, aa) = (points(&tips, "tips")?, points(&axes, "axes")?);
    let gg = slice1(&group, "group")?;
    let m = tt.len();
    if aa.len() != m || gg.len() != m || boxes.shape() != [m, 4] {
        return Err(PyValueError::new_err(
            "tips, axes, group and boxes must describe the same solids",
        ));
    }
    let cols = stock::box_columns(&boxes, gg, n_groups)?;
    let pl = points(&planes, "planes")?;
    let rr = match &rho {
        Some(r) => Some(stock::plane_ranges(r, pl)?),
        None => None,
    };
    let sol = stock::Solids {
        tips: tt,
        axes: aa,
        boxes: stock::ItemBoxes::new(gg, &cols),
        planes: pl,
        z_lo: bounds.0,
        z_hi: bounds.1,
        radius: bounds.2,
        rho: rr,
        planes_in: match &planes_in {
            Some(p) => Some(points(p, "planes_in")?),
            None => None,
        },
    };
    stock::run_on_stock(py, &mut lo, &mut hi, threads, |ls, hs| {
        stock::remove(&g, &sol, n_groups, measure, ls, hs)
    })
}

#[pymodule]
fn blisk_cam_kernels(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // the wheel's package __init__ re-exports with `import *`, which skips dunder names
    m.add("VERSION", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(forward_step, m)?)?;
    m.add_function(wrap_pyfunction!(densify::densify_cosines, m)?)?;
    m.add_function(wrap_pyfunction!(densify::densify_by_turn, m)?)?;
    m.add_function(wrap_pyfunction!(first_equal_point, m)?)?;
    m.add_function(wrap_pyfunction!(first_equal_rows, m)?)?;
    m.add_function(wrap_pyfunction!(stl_corners_welded, m)?)?;
    m.add_function(wrap_pyfunction!(triangle_d2, m)?)?;
    m.add_function(wrap_pyfunction!(stock_remove, m)?)?;
    m.add_function(wrap_pyfunction!(pool_identity, m)?)?;
    m.add_function(wrap_pyfunction!(stock::stock_sweep, m)?)?;
    m.add("STOCK_SWEEP_REVISION", stock::SWEEP_REVISION)?;
    m.add_class::<FaceTree>()?;
    m.add_class::<PointTree>()?;
    m.add_class::<swept_ball::SweptBallTree>()?;
    m.add_function(wrap_pyfunction!(swept_ball::forest_nearest, m)?)?;
    m.add_function(wrap_pyfunction!(swept_ball::forest_first_hits, m)?)?;
    m.add_function(wrap_pyfunction!(swept_ball::ridge_steps, m)?)?;
    m.add_function(wrap_pyfunction!(swept_cutter::golden_pairs, m)?)?;
    m.add_function(wrap_pyfunction!(swept_cutter::fast_search, m)?)?;
    m.add_function(wrap_pyfunction!(swept_cutter::fast_search_boxes, m)?)?;
    m.add_function(wrap_pyfunction!(swept_cutter::pose_bound, m)?)?;
    m.add_class::<swept_cutter::LeafBoxes>()?;
    // 2: LeafBoxes takes a forest's member starts and several boxes per leaf
    m.add("LEAF_BOXES_REVISION", 2)?;
    // 2: fast_search and fast_search_boxes take the tables as one tuple
    m.add("SWEPT_SEARCH_REVISION", 2)?;
    m.add_function(wrap_pyfunction!(collision_refine::refine_pairs, m)?)?;
    m.add_function(wrap_pyfunction!(collision_walk::collision_detect, m)?)?;
    m.add_class::<collision_walk::CollisionTree>()?;
    m.add_function(wrap_pyfunction!(collision_tree::collision_tree_build, m)?)?;
    m.add_function(wrap_pyfunction!(collision_tree::collision_tree_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(collision_tree::collision_tree_normals, m)?)?;
    m.add_function(wrap_pyfunction!(probe::points_within, m)?)?;
    m.add_function(wrap_pyfunction!(lift::fixed_point_lift, m)?)?;
    m.add_function(wrap_pyfunction!(facet_lift::facet_lift, m)?)?;
    m.add_function(wrap_pyfunction!(intrusion_probes::intrusion_probes, m)?)?;
    m.add_function(wrap_pyfunction!(facet_lift::probe_candidates, m)?)?;
    m.add_function(wrap_pyfunction!(facet_lift::candidate_shortfall, m)?)?;
    m.add_function(wrap_pyfunction!(face_gradient::face_gradient_curvature, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_samples::vertex_face_table, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_samples::vertex_face_table_narrow, m)?)?;
    m.add_function(wrap_pyfunction!(grid_samples::grid_samples, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_samples::sample_point_tree, m)?)?;
    m.add_function(wrap_pyfunction!(slice_roots::cone_edge_roots, m)?)?;
    m.add_function(wrap_pyfunction!(slice_roots::cone_level, m)?)?;
    m.add_function(wrap_pyfunction!(slice_setup::cone_slicer_field, m)?)?;
    m.add_function(wrap_pyfunction!(slice_setup::slicer_face_index, m)?)?;
    m.add_function(wrap_pyfunction!(slice_candidates::slicer_candidates, m)?)?;
    m.add_function(wrap_pyfunction!(resample::resample_offset, m)?)?;
    m.add_function(wrap_pyfunction!(polyline_distance::polyline_distance, m)?)?;
    m.add_function(wrap_pyfunction!(level_chains::chain_directed, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_topology::edge_table_arrays, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_orient::face_components, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_orient::orient_face_terms, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_orient::repeats_on_edges, m)?)?;
    m.add_function(wrap_pyfunction!(weld_near::weld_extents, m)?)?;
    m.add_function(wrap_pyfunction!(weld_near::weld_no_close_pairs, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_topology::triangle_normals, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_topology::interior_pairs, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_topology::vertex_normals_of, m)?)?;
    m.add_function(wrap_pyfunction!(mesh_topology::interpolate_normals, m)?)?;
    m.add_function(wrap_pyfunction!(float_text::json_float_array, m)?)?;
    Ok(())
}
