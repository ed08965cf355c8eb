//! Step 4 of the swept cutter's "fast" method (`blisk_cam/core/verify/sweep.py`,
//! `_golden_pairs`): the golden-section search of the cutter's signed distance along each
//! (point, move) pair's bracket, each point's pairs stepped together as numpy steps them (the
//! same pruning by the point's best after every step, the same pairs dropped), the points
//! in parallel. The cutter's distance is `Cutter.signed_distance_rz` operation for operation.

use crate::numpy_ops::einsum_dot as dot3;
use crate::numpy_ops::nanmin;
use numpy::{PyArray1, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

#[path = "swept_prune.rs"]
mod prune;
use prune::fast_point;

/// A cutter's meridional profile (`Cutter.signed_distance_rz`'s constants).
#[derive(Clone, Copy)]
pub struct Profile {
    e: f64,
    f: f64,
    r: f64,
    h: f64,
    b: [f64; 2],
    s: [f64; 2],
    t: [f64; 2],
    sa: f64,
    ca: f64,
    sb: f64,
    cb: f64,
    tan_a: f64,
    cos_b: f64,
    sin_b: f64,
}

/// `closest.segment_distance2_2d` for one point.
#[inline(always)]
pub fn seg2(px: f64, py: f64, ax: f64, ay: f64, bx: f64, by: f64) -> f64 {
    let (dx, dy) = (bx - ax, by - ay);
    let dd = dx * dx + dy * dy;
    let (qx, qy) = (px - ax, py - ay);
    let t = (qx * dx + qy * dy) / (if dd > 0.0 { dd } else { 1.0 });
    let t = if t < 0.0 { 0.0 } else { t };
    let t = if t > 1.0 { 1.0 } else { t };
    let (ex, ey) = (qx - t * dx, qy - t * dy);
    ex * ex + ey * ey
}

impl Profile {
    /// From the 17 floats of `sweep._profile` (e, f, r, h, B, S, T, sin/cos of the arc's
    /// sector bounds, tan α, cos β, sin β).
    pub fn from_slice(p: &[f64]) -> Profile {
        Profile {
            e: p[0],
            f: p[1],
            r: p[2],
            h: p[3],
            b: [p[4], p[5]],
            s: [p[6], p[7]],
            t: [p[8], p[9]],
            sa: p[10],
            ca: p[11],
            sb: p[12],
            cb: p[13],
            tan_a: p[14],
            cos_b: p[15],
            sin_b: p[16],
        }
    }

    /// `Cutter.signed_distance_rz` of one meridional point.
    #[inline]
    pub fn sd_rz(&self, rho: f64, z: f64) -> f64 {
        let rho = rho.abs();
        let mut d2 = seg2(rho, z, 0.0, 0.0, self.b[0], self.b[1]);
        d2 = nanmin(d2, seg2(rho, z, self.s[0], self.s[1], self.t[0], self.t[1]));
        d2 = nanmin(d2, seg2(rho, z, self.t[0], self.t[1], 0.0, self.h));
        let (vr, vz) = (rho - self.e, z - self.f);
        let in_sector =
            (vr * self.ca - vz * self.sa >= 0.0) && (vr * self.cb + vz * self.sb <= 0.0);
        // |v| is read only inside the arc's sector (libm's hypot is the costly step)
        let vl = if in_sector {
            crate::hypot::hypot(vr, vz)
        } else {
            0.0
        };
        let mut dist = d2.sqrt();
        if in_sector {
            dist = nanmin(dist, (vl - self.r).abs());
        }
        let inside = (z >= rho * self.tan_a)
            && (z <= self.h)
            && ((rho - self.s[0]) * self.cos_b - (z - self.s[1]) * self.sin_b <= 0.0)
            && !(in_sector && vl > self.r);
        if inside {
            -dist
        } else {
            dist
        }
    }
}

/// The constants of one pair: z(t) = cos tφ (za − t Ta) + sin tφ (zb − t Tb),
/// |d(t)|² = n0 − t m2 + t² L2.
#[derive(Clone, Copy)]
struct Pair {
    za: f64,
    zb: f64,
    ta: f64,
    tb: f64,
    n0: f64,
    m2: f64,
    l2: f64,
    phi: f64,
    d: f64,
}

impl Pair {
    #[inline(always)]
    fn f(&self, prof: &Profile, t: f64) -> f64 {
        let tp = t * self.phi;
        let (c, s) = (tp.cos(), tp.sin());
        let z = c * (self.za - t * self.ta) + s * (self.zb - t * self.tb);
        let n = self.n0 - t * self.m2 + t * t * self.l2;
        let rr = n - z * z;
        prof.sd_rz((if rr > 0.0 || rr.is_nan() { rr } else { 0.0 }).sqrt(), z)
    }
}

#[derive(Clone, Copy)]
pub(crate) struct State {
    i: usize, // the pair's index in the caller's arrays
    lo: f64,
    hi: f64,
    x1: f64,
    x2: f64,
    f1: f64,
    f2: f64,
}

/// One point's pairs `i0..i1`, stepped together: (best, pair achieving it or −1).
#[allow(clippy::too_many_arguments)]
fn search_point(
    prof: &Profile,
    pairs: &[Pair],
    lo0: &[f64],
    hi0: &[f64],
    i0: usize,
    i1: usize,
    u0: f64,
    xtol: f64,
    live: &mut Vec<State>,
) -> (f64, i64) {
    let gold = 0.5 * (5.0f64.sqrt() - 1.0);
    live.clear();
    live.extend((i0..i1).map(|i| {
        let (lo, hi) = (lo0[i], hi0[i]);
        let x1 = hi - gold * (hi - lo);
        let x2 = lo + gold * (hi - lo);
        State {
            i,
            lo,
            hi,
            x1,
            x2,
            f1: pairs[i].f(prof, x1),
            f2: pairs[i].f(prof, x2),
        }
    }));
    let (mut u, mut arg) = (u0, -1i64);
    for _ in 0..200 {
        // the best among the pairs that may beat the point's best (NaN: no update, as
        // numpy's minimum over the group is then NaN)
        let (mut gmin, mut gi, mut any, mut nan) = (f64::INFINITY, -1i64, false, false);
        for st in live.iter() {
            let fb = nanmin(st.f1, st.f2);
            if !(fb >= u) {
                any = true;
                if fb.is_nan() {
                    nan = true;
                } else if fb <= gmin {
                    gmin = fb;
                    gi = st.i as i64;
                }
            }
        }
        if any && !nan && gmin < u {
            u = gmin;
            arg = gi;
        }
        live.retain(|st| {
            let wd = (st.hi - st.lo) * pairs[st.i].d;
            (wd > xtol) && (nanmin(st.f1, st.f2) - wd <= u)
        });
        if live.is_empty() {
            break;
        }
        for st in live.iter_mut() {
            let left = st.f1 < st.f2;
            if left {
                st.hi = st.x2;
            } else {
                st.lo = st.x1;
            }
            let nx = if left {
                st.hi - gold * (st.hi - st.lo)
            } else {
                st.lo + gold * (st.hi - st.lo)
            };
            let fnx = pairs[st.i].f(prof, nx);
            if left {
                st.x2 = st.x1;
                st.f2 = st.f1;
                st.x1 = nx;
                st.f1 = fnx;
            } else {
                st.x1 = st.x2;
                st.f1 = st.f2;
                st.x2 = nx;
                st.f2 = fnx;
            }
        }
    }
    (u, arg)
}

/// `_golden_pairs` on pairs sorted by point `q`; (best per point (kc,), pair index or −1).
#[pyfunction]
#[pyo3(signature = (profile, q, u, scal, lo, hi, xtol, threads))]
#[allow(clippy::too_many_arguments)]
pub fn golden_pairs<'py>(
    py: Python<'py>,
    profile: Vec<f64>,
    q: PyReadonlyArray1<'py, i64>,
    u: PyReadonlyArray1<'py, f64>,
    scal: Vec<PyReadonlyArray1<'py, f64>>,
    lo: PyReadonlyArray1<'py, f64>,
    hi: PyReadonlyArray1<'py, f64>,
    xtol: f64,
    threads: usize,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>)> {
    if profile.len() != 17 {
        return Err(PyValueError::new_err("profile must hold 17 numbers"));
    }
    let prof = Profile::from_slice(&profile);
    let qq = crate::slice1(&q, "q")?;
    let uu = crate::slice1(&u, "u")?;
    let (ll, hh) = (crate::slice1(&lo, "lo")?, crate::slice1(&hi, "hi")?);
    if scal.len() != 9 {
        return Err(PyValueError::new_err(
            "scal must be (za, zb, Ta, Tb, n0, m2, L2, phi, D)",
        ));
    }
    let cols: Vec<&[f64]> = scal
        .iter()
        .map(|c| crate::slice1(c, "scal"))
        .collect::<PyResult<_>>()?;
    let m = qq.len();
    if cols.iter().any(|c| c.len() != m) || ll.len() != m || hh.len() != m {
        return Err(PyValueError::new_err(
            "q, scal, lo and hi must describe the same pairs",
        ));
    }
    let kc = uu.len();
    if qq.iter().any(|&x| x < 0 || x as usize >= kc) || qq.windows(2).any(|w| w[1] < w[0]) {
        return Err(PyValueError::new_err(
            "q must be sorted point ids in 0..len(u)",
        ));
    }
    let pairs: Vec<Pair> = (0..m)
        .map(|i| Pair {
            za: cols[0][i],
            zb: cols[1][i],
            ta: cols[2][i],
            tb: cols[3][i],
            n0: cols[4][i],
            m2: cols[5][i],
            l2: cols[6][i],
            phi: cols[7][i],
            d: cols[8][i],
        })
        .collect();
    // the runs of pairs of one point
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut s = 0;
    for i in 1..=m {
        if i == m || qq[i] != qq[s] {
            runs.push((s, i));
            s = i;
        }
    }
    let pl = crate::pool(threads)?;
    let res: Vec<(f64, i64)> = py.detach(|| {
        pl.install(|| {
            runs.par_iter()
                .with_min_len(8)
                .map_init(Vec::new, |live, &(a, b)| {
                    search_point(&prof, &pairs, ll, hh, a, b, uu[qq[a] as usize], xtol, live)
                })
                .collect()
        })
    });
    let mut best = uu.to_vec();
    let mut arg = vec![-1i64; kc];
    for (&(a, _), &(v, i)) in runs.iter().zip(res.iter()) {
        let k = qq[a] as usize;
        best[k] = v;
        arg[k] = i;
    }
    Ok((PyArray1::from_vec(py, best), PyArray1::from_vec(py, arg)))
}

/// The tables of `_fast_search` (a SweptCutter's or a SweptForest's).
pub struct Tables<'a> {
    lt: &'a [[f64; 3]],
    la: &'a [[f64; 3]],
    ls: &'a [i64],
    lphi: &'a [f64],
    ldt: &'a [f64],
    nb: usize,
    ta: &'a [[f64; 3]],
    tb: &'a [[f64; 3]],
    kk: &'a [[f64; 3]],
    bb: &'a [[f64; 3]],
    chord_ok: &'a [bool],
}

/// `_sd_in_frame` of one point.
#[inline]
fn sd_in_frame(prof: &Profile, x: &[f64; 3], axis: &[f64; 3]) -> f64 {
    let z = dot3(x, axis);
    let rr = dot3(x, x) - z * z;
    prof.sd_rz((if rr > 0.0 || rr.is_nan() { rr } else { 0.0 }).sqrt(), z)
}

/// The arrays both searches read: the cutter's profile, the points (k, 3) with their first
/// bounds `u`, segments `arg` and rounding slack (k,), and the segment and leaf tables (NC
/// leaves of B moves), checked against one another.
struct SearchArgs<'a> {
    prof: Profile,
    pts: &'a [[f64; 3]],
    u: &'a [f64],
    arg: &'a [i64],
    slack: &'a [f64],
    tab: Tables<'a>,
    /// NC, the leaves
    nc: usize,
}

/// The segment and leaf tables of a `SweptCutter` or `SweptForest`, one tuple from the
/// caller (`kernels.swept_cutter`'s `_tables`): lt, la (NC · (B + 1), 3) float64, ls (NC, B)
/// int64, lphi, ldt (NC, B) float64, ta, tb, k, b (ns, 3) float64, chord_ok (ns,) bool.
#[derive(FromPyObject)]
pub struct TablesIn<'py>(
    numpy::PyReadonlyArray2<'py, f64>,
    numpy::PyReadonlyArray2<'py, f64>,
    numpy::PyReadonlyArray2<'py, i64>,
    numpy::PyReadonlyArray2<'py, f64>,
    numpy::PyReadonlyArray2<'py, f64>,
    numpy::PyReadonlyArray2<'py, f64>,
    numpy::PyReadonlyArray2<'py, f64>,
    numpy::PyReadonlyArray2<'py, f64>,
    numpy::PyReadonlyArray2<'py, f64>,
    PyReadonlyArray1<'py, bool>,
);

/// The arguments [`fast_search`] and [`fast_search_boxes`] share, checked.
fn search_args<'a>(
    profile: &[f64],
    pc: &'a numpy::PyReadonlyArray2<'_, f64>,
    u: &'a PyReadonlyArray1<'_, f64>,
    arg: &'a PyReadonlyArray1<'_, i64>,
    slack: &'a PyReadonlyArray1<'_, f64>,
    tables: &'a TablesIn<'_>,
) -> PyResult<SearchArgs<'a>> {
    use crate::arrays::{flat, points, points_n, values_n};
    let TablesIn(lt, la, ls, lphi, ldt, ta, tb, kk, bb, chord_ok) = tables;
    if profile.len() != 17 {
        return Err(PyValueError::new_err("profile must hold 17 numbers"));
    }
    let pts = points(pc, "points")?;
    let k = pts.len();
    let (u, arg, slack) = (
        values_n(u, "u", k)?,
        values_n(arg, "arg", k)?,
        values_n(slack, "slack", k)?,
    );
    let (nc, nb) = (ls.shape()[0], ls.shape()[1]);
    let ta = points(ta, "ta")?;
    let ns = ta.len();
    let tab = Tables {
        lt: points_n(lt, "lt", nc * (nb + 1))?,
        la: points_n(la, "la", nc * (nb + 1))?,
        ls: flat(ls, "ls")?,
        lphi: flat(lphi, "lphi")?,
        ldt: flat(ldt, "ldt")?,
        nb,
        ta,
        tb: points_n(tb, "tb", ns)?,
        kk: points_n(kk, "k", ns)?,
        bb: points_n(bb, "b", ns)?,
        chord_ok: values_n(chord_ok, "chord_ok", ns)?,
    };
    if tab.lphi.len() != nc * nb
        || tab.ldt.len() != nc * nb
        || tab.ls.iter().any(|&s| s >= ns as i64)
    {
        return Err(PyValueError::new_err(
            "inconsistent tables (lphi and ldt (NC, B), segment ids in range)",
        ));
    }
    Ok(SearchArgs {
        prof: Profile::from_slice(profile),
        pts,
        u,
        arg,
        slack,
        tab,
        nc,
    })
}

/// `_fast_search` (steps 1–4 of the fast method) on a chunk: points (k, 3), their first
/// bounds and segments (k,), the candidate (point, leaf) pairs sorted by point, the points'
/// rounding slack (k,), the tables; (u (k,), arg (k,)).
#[pyfunction]
#[pyo3(signature = (profile, pc, u, arg, q, leaf, slack, tables, xtol, delta, threads))]
#[allow(clippy::too_many_arguments)]
pub fn fast_search<'py>(
    py: Python<'py>,
    profile: Vec<f64>,
    pc: numpy::PyReadonlyArray2<'py, f64>,
    u: PyReadonlyArray1<'py, f64>,
    arg: PyReadonlyArray1<'py, i64>,
    q: PyReadonlyArray1<'py, i64>,
    leaf: PyReadonlyArray1<'py, i64>,
    slack: PyReadonlyArray1<'py, f64>,
    tables: TablesIn<'py>,
    xtol: f64,
    delta: f64,
    threads: usize,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>)> {
    let sa = search_args(&profile, &pc, &u, &arg, &slack, &tables)?;
    let (prof, pp, uu, aa, sl, tab) = (sa.prof, sa.pts, sa.u, sa.arg, sa.slack, sa.tab);
    let (qq, ll) = (crate::slice1(&q, "q")?, crate::slice1(&leaf, "leaf")?);
    let k = pp.len();
    if qq.len() != ll.len()
        || ll.iter().any(|&l| l < 0 || l as usize >= sa.nc)
        || qq.iter().any(|&x| x < 0 || x as usize >= k)
        || qq.windows(2).any(|w| w[1] < w[0])
    {
        return Err(PyValueError::new_err(
            "q and leaf need one value per pair (q sorted, ids in range)",
        ));
    }
    // the runs of pairs of one point
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let mut s = 0;
    for i in 1..=qq.len() {
        if i == qq.len() || qq[i] != qq[s] {
            if i > s {
                runs.push((s, i));
            }
            s = i;
        }
    }
    let reach = prune::leaf_reach(&tab, sa.nc);
    let pl = crate::pool(threads)?;
    let res: Vec<(f64, i64)> = py.detach(|| {
        pl.install(|| {
            runs.par_iter()
                .with_min_len(4)
                .map_init(prune::Scratch::default, |sc, &(a, b)| {
                    let p = qq[a] as usize;
                    fast_point(
                        sc,
                        &prof,
                        &tab,
                        &reach,
                        &pp[p],
                        &ll[a..b],
                        uu[p],
                        aa[p],
                        sl[p],
                        xtol,
                        delta,
                    )
                })
                .collect()
        })
    });
    let mut uo = uu.to_vec();
    let mut ao = aa.to_vec();
    for (&(a, _), &(v, i)) in runs.iter().zip(res.iter()) {
        let p = qq[a] as usize;
        uo[p] = v;
        ao[p] = i;
    }
    Ok((PyArray1::from_vec(py, uo), PyArray1::from_vec(py, ao)))
}

/// Boxes bounding the volume a cutter sweeps along each leaf (a run of moves) of a swept
/// cutter or forest, in parry3d-f64's bounding-volume trees: the candidate leaves of a point
/// are those whose box comes within its upper bound (a superset of the leaves that can hold
/// its minimum: the others' moves are all farther than the bound, so they change nothing).
/// A forest's members (runs of leaves, `starts`) each get a tree of their own: a point asks
/// its member's only (one tree over all members walked the neighbouring levels' leaves too,
/// nine in ten of those it met on Rotor 37's scallops); the leaves found are the same. A leaf
/// may have several boxes (`pieces`, along the tool: together tighter than one box of a
/// whole tilted tool); it is found when one of them is.
#[pyclass(frozen)]
pub struct LeafBoxes {
    /// (first leaf, tree of the member's leaves numbered from it)
    trees: Vec<(usize, parry3d_f64::partitioning::Bvh)>,
    n: usize,
    pieces: usize,
}

#[pymethods]
impl LeafBoxes {
    /// lo, hi (NC, 3) float64 mm: each leaf's box (already padded by the cutter's reach);
    /// `starts` (M,) int64, optional: the first leaf of each member, ascending from 0;
    /// `pieces`: boxes per leaf (rows `pieces · l ..` are leaf l's).
    #[new]
    #[pyo3(signature = (lo, hi, starts=None, pieces=1))]
    fn new(
        py: Python<'_>,
        lo: numpy::PyReadonlyArray2<'_, f64>,
        hi: numpy::PyReadonlyArray2<'_, f64>,
        starts: Option<PyReadonlyArray1<'_, i64>>,
        pieces: usize,
    ) -> PyResult<Self> {
        use parry3d_f64::bounding_volume::Aabb;
        use parry3d_f64::math::Vector;
        use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy};
        let (l3, h3) = (
            crate::arrays::points(&lo, "lo")?,
            crate::arrays::points(&hi, "hi")?,
        );
        if l3.len() != h3.len() {
            return Err(PyValueError::new_err("lo and hi must have the same rows"));
        }
        let boxes: Vec<Aabb> = l3
            .iter()
            .zip(h3.iter())
            .map(|(a, b)| Aabb::new(Vector::new(a[0], a[1], a[2]), Vector::new(b[0], b[1], b[2])))
            .collect();
        if pieces == 0 || boxes.len() % pieces != 0 {
            return Err(PyValueError::new_err(
                "lo and hi must hold `pieces` rows per leaf",
            ));
        }
        let n = boxes.len() / pieces;
        let mut cuts: Vec<usize> = match &starts {
            Some(st) => {
                let st = crate::slice1(st, "starts")?;
                if st.first().is_some_and(|&s| s != 0)
                    || st.windows(2).any(|w| w[1] < w[0])
                    || st.iter().any(|&s| s < 0 || s as usize > n)
                {
                    return Err(PyValueError::new_err(
                        "starts must ascend from 0 within the leaves",
                    ));
                }
                st.iter().map(|&s| s as usize).collect()
            }
            None => vec![0],
        };
        cuts.push(n);
        cuts.dedup();
        let trees = py.detach(|| {
            cuts.windows(2)
                .filter(|w| w[1] > w[0])
                .map(|w| {
                    (
                        w[0],
                        Bvh::from_leaves(
                            BvhBuildStrategy::Binned,
                            &boxes[w[0] * pieces..w[1] * pieces],
                        ),
                    )
                })
                .collect()
        });
        Ok(LeafBoxes { trees, n, pieces })
    }
}

impl LeafBoxes {
    /// The leaves in `lo..hi` whose box comes within `r` of the point, ascending, into
    /// `out` (cleared first).
    fn near(&self, p: &[f64; 3], r: f64, lo: i64, hi: i64, out: &mut Vec<i64>) {
        use parry3d_f64::math::Vector;
        use parry3d_f64::query::PointQuery;
        let pv = Vector::new(p[0], p[1], p[2]);
        out.clear();
        if self.n == 0 || hi <= lo {
            return;
        }
        // a point inside the swept volume (u < 0): the leaves whose box holds it
        let r = if r > 0.0 { r } else { 0.0 };
        // the trees whose leaves meet lo..hi (the first one starting at or before lo)
        let first = self
            .trees
            .partition_point(|&(s, _)| s as i64 <= lo)
            .saturating_sub(1);
        for (s, bvh) in self.trees[first..].iter() {
            if *s as i64 >= hi {
                break;
            }
            for leaf in bvh.leaves(|node| node.aabb().distance_to_local_point(pv, true) <= r) {
                let l = (leaf as usize / self.pieces + s) as i64;
                if l >= lo && l < hi {
                    out.push(l);
                }
            }
        }
        out.sort_unstable();
        if self.pieces > 1 {
            out.dedup();
        }
    }
}

/// `_fast_search` with the candidate leaves found here (see [`LeafBoxes`]): each point's
/// leaves within its bound u of the boxes of leaves `cl_lo..cl_hi` (its member's); then steps
/// 1–4 as [`fast_search`]. Returns (u (k,), arg (k,)).
#[pyfunction]
#[pyo3(signature = (profile, pc, u, arg, slack, boxes, cl_lo, cl_hi, tables, xtol, delta,
                    threads))]
#[allow(clippy::too_many_arguments)]
pub fn fast_search_boxes<'py>(
    py: Python<'py>,
    profile: Vec<f64>,
    pc: numpy::PyReadonlyArray2<'py, f64>,
    u: PyReadonlyArray1<'py, f64>,
    arg: PyReadonlyArray1<'py, i64>,
    slack: PyReadonlyArray1<'py, f64>,
    boxes: PyRef<'py, LeafBoxes>,
    cl_lo: PyReadonlyArray1<'py, i64>,
    cl_hi: PyReadonlyArray1<'py, i64>,
    tables: TablesIn<'py>,
    xtol: f64,
    delta: f64,
    threads: usize,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>)> {
    let sa = search_args(&profile, &pc, &u, &arg, &slack, &tables)?;
    let (prof, pp, uu, aa, sl, tab) = (sa.prof, sa.pts, sa.u, sa.arg, sa.slack, sa.tab);
    let k = pp.len();
    let (clo, chi) = (
        crate::arrays::values_n(&cl_lo, "cl_lo", k)?,
        crate::arrays::values_n(&cl_hi, "cl_hi", k)?,
    );
    if boxes.n != sa.nc
        || clo
            .iter()
            .zip(chi.iter())
            .any(|(&a, &b)| a < 0 || b < a || b as usize > sa.nc)
    {
        return Err(PyValueError::new_err("inconsistent boxes or leaf ranges"));
    }
    let bx: &LeafBoxes = &boxes;
    let reach = prune::leaf_reach(&tab, sa.nc);
    let pl = crate::pool(threads)?;
    let res: Vec<(f64, i64)> = py.detach(|| {
        pl.install(|| {
            (0..k)
                .into_par_iter()
                .with_min_len(4)
                .map_init(
                    || (prune::Scratch::default(), Vec::new()),
                    |(sc, leaves), i| {
                        let r = uu[i] * (1.0 + 1e-9) + 1e-9 + sl[i];
                        bx.near(&pp[i], r, clo[i], chi[i], leaves);
                        if leaves.is_empty() {
                            return (uu[i], aa[i]);
                        }
                        fast_point(
                            sc, &prof, &tab, &reach, &pp[i], leaves, uu[i], aa[i], sl[i], xtol,
                            delta,
                        )
                    },
                )
                .collect()
        })
    });
    let (uo, ao): (Vec<f64>, Vec<i64>) = res.into_iter().unzip();
    Ok((PyArray1::from_vec(py, uo), PyArray1::from_vec(py, ao)))
}

/// `SweptCutter._upper_bound`'s values and minimum: point i against the cutter posed at the
/// tip and axis of each of its segments `seg[i, :]` (numpy's indexing: −n..n−1), as
/// `Cutter.signed_distance` computes them; then `bvh.group_argmin` (NaN-propagating minimum;
/// the segment is the last listed of those at the minimum, −1 when none is). Returns
/// (u (k,), arg (k,)).
#[pyfunction]
#[pyo3(signature = (profile, pc, seg, ta, aa, threads))]
pub fn pose_bound<'py>(
    py: Python<'py>,
    profile: Vec<f64>,
    pc: numpy::PyReadonlyArray2<'py, f64>,
    seg: numpy::PyReadonlyArray2<'py, i64>,
    ta: numpy::PyReadonlyArray2<'py, f64>,
    aa: numpy::PyReadonlyArray2<'py, f64>,
    threads: usize,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>)> {
    use crate::arrays::{flat, points, points_n};
    if profile.len() != 17 {
        return Err(PyValueError::new_err("profile must hold 17 numbers"));
    }
    let prof = Profile::from_slice(&profile);
    let pts = points(&pc, "points")?;
    let k = pts.len();
    let kk = seg.shape()[1];
    let sg = flat(&seg, "seg")?;
    let tt = points(&ta, "ta")?;
    let ns = tt.len() as i64;
    let ax = points_n(&aa, "aa", tt.len())?;
    if sg.len() != k * kk || sg.iter().any(|&s| s < -ns || s >= ns) {
        return Err(PyValueError::new_err(
            "seg must give (k, kk) segment ids within -len(ta)..len(ta)",
        ));
    }
    let pl = crate::pool(threads)?;
    let res: Vec<(f64, i64)> = py.detach(|| {
        pl.install(|| {
            (0..k)
                .into_par_iter()
                .with_min_len(256)
                .map(|i| {
                    let p = &pts[i];
                    let ids = &sg[i * kk..(i + 1) * kk];
                    let val = |s: i64| {
                        let j = (if s < 0 { s + ns } else { s }) as usize;
                        let t = &tt[j];
                        sd_in_frame(&prof, &[p[0] - t[0], p[1] - t[1], p[2] - t[2]], &ax[j])
                    };
                    // np.minimum.at from inf: a NaN stays
                    let mut best = f64::INFINITY;
                    let mut vals = [0.0f64; 8];
                    for (n, &s) in ids.iter().enumerate() {
                        let v = val(s);
                        if n < 8 {
                            vals[n] = v;
                        }
                        best = if v.is_nan() || best.is_nan() {
                            f64::NAN
                        } else {
                            best.min(v)
                        };
                    }
                    let mut arg = -1i64;
                    for (n, &s) in ids.iter().enumerate() {
                        let v = if n < 8 { vals[n] } else { val(s) };
                        if v <= best {
                            arg = s;
                        }
                    }
                    (best, arg)
                })
                .collect()
        })
    });
    let (u, a): (Vec<f64>, Vec<i64>) = res.into_iter().unzip();
    Ok((PyArray1::from_vec(py, u), PyArray1::from_vec(py, a)))
}
