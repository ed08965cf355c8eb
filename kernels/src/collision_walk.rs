//! Collision detection's broad phase and refine in one call
//! (`blisk_cam/core/collision/scene.py::CollisionScene._chunk` with
//! `tri_tree.py::_TriTree.candidates`): per chunk of poses, the walk of each part over each
//! obstacle group's triangle tree (the implicit 4-ary tree over Morton-ordered triangles that
//! `_TriTree` builds; its arrays are handed over once, [`CollisionTree`]), level by level for
//! the whole chunk as numpy steps it — the same lower bounds (sd(centre) − radius, the
//! frustums' tangent planes over small boxes and over triangles), the same upper bounds from
//! the nodes' representative points, the same beams for poses certainly clear or known to
//! penetrate (numpy decides whether to beam a level on the chunk's frontier size, so the
//! chunks are numpy's) — then the pruning, ranking and exact refine of the candidate pairs
//! ([`crate::collision_refine::refine_pose`]). Chunks run in parallel (rayon, the GIL
//! released); each chunk is computed as on one thread.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::arrays::{points, points_n, values_n};
use crate::collision_refine::{hypot_exact, refine_pose, Pair, Part};
use crate::numpy_ops::einsum_dot as dot;
use crate::numpy_ops::sub;
use crate::numpy_ops::{nanmax, nanmin};

type P3 = [f64; 3];

/// children per node of the tree (`tri_tree._BRANCH`)
pub(crate) const BRANCH: usize = 4;
/// triangles per leaf (`tri_tree._LEAF`)
pub(crate) const LEAF: usize = 8;
const GRAD_RADIUS: f64 = 2.0;
const REP_FACTOR: f64 = 4.0;
const DEEP_BEAM: usize = 8;
const FAR_BEAM: usize = 8;
const FAR_MARGIN: f64 = 1.0;
const PENETRATION_PAIRS: usize = 16;
const FAR_PAIRS: usize = 8;

#[inline(always)]
fn clip01(t: f64) -> f64 {
    let t = if t < 0.0 { 0.0 } else { t };
    if t > 1.0 {
        1.0
    } else {
        t
    }
}

/// `posed_tool._seg_near`: (squared distance, nearest ρ, nearest z) to the segment a → b.
#[inline(always)]
fn seg_near(px: f64, py: f64, ax: f64, ay: f64, bx: f64, by: f64) -> (f64, f64, f64) {
    let (dx, dy) = (bx - ax, by - ay);
    let dd = dx * dx + dy * dy;
    let t = clip01(((px - ax) * dx + (py - ay) * dy) / (if dd > 0.0 { dd } else { 1.0 }));
    let (qx, qy) = (ax + t * dx, ay + t * dy);
    let (ex, ey) = (px - qx, py - qy);
    (ex * ex + ey * ey, qx, qy)
}

/// `_Frustum.sd_grad_rz`: (sd, ∂sd/∂ρ, ∂sd/∂z).
fn frustum_grad(z0: f64, r0: f64, z1: f64, r1: f64, rho: f64, z: f64) -> (f64, f64, f64) {
    if r0 == r1 {
        let dr = rho - r0;
        let (dlo, dhi) = (z0 - z, z - z1);
        let dz = nanmax(dlo, dhi);
        let (er, ez) = (nanmax(dr, 0.0), nanmax(dz, 0.0));
        let out = hypot_exact(er, ez);
        let outside = out > 0.0;
        let inv = if outside { 1.0 / out } else { 0.0 };
        let radial = dr >= dz;
        let gz = if outside {
            ez * inv
        } else if radial {
            0.0
        } else {
            1.0
        };
        let sd = if outside { out } else { nanmax(dr, dz) };
        let gr = if outside {
            er * inv
        } else if radial {
            1.0
        } else {
            0.0
        };
        return (sd, gr, if dlo > dhi { -gz } else { gz });
    }
    let mut best = seg_near(rho, z, 0.0, z0, r0, z0);
    for (a0, b0, a1, b1) in [(r0, z0, r1, z1), (r1, z1, 0.0, z1)] {
        let c = seg_near(rho, z, a0, b0, a1, b1);
        if c.0 < best.0 {
            best = c;
        }
    }
    let (d2, qr, qz) = best;
    let t = clip01((z - z0) / (z1 - z0));
    let inside = z >= z0 && z <= z1 && rho <= r0 + t * (r1 - r0);
    let d = d2.sqrt();
    let sgn = if inside { -1.0 } else { 1.0 };
    let inv = if d > 1e-12 { sgn / d } else { 0.0 };
    (sgn * d, (rho - qr) * inv, (z - qz) * inv)
}

/// `posed_tool._posed_sd_ab` of a frustum: (sd, dv, α, β, valid).
#[inline]
fn posed_sd_ab(fr: &[f64; 4], x: &P3, tip: &P3, axis: &P3) -> (f64, P3, f64, f64, bool) {
    let dv = sub(x, tip);
    let z = dot(&dv, axis);
    let rr = dot(&dv, &dv) - z * z;
    let rho = (if rr > 0.0 || rr.is_nan() { rr } else { 0.0 }).sqrt();
    let (sd, gr, gz) = frustum_grad(fr[0], fr[1], fr[2], fr[3], rho, z);
    let valid = rho > 1e-9 && (gr != 0.0 || gz != 0.0);
    let al = gr / (if valid { rho } else { 1.0 });
    (sd, dv, al, gz - al * z, valid)
}

/// `posed_tool._box_bound` (a frustum): the lower bound of sd over the box (centre c,
/// half-sizes h, sphere radius r).
#[inline]
fn box_bound(fr: &[f64; 4], c: &P3, tip: &P3, axis: &P3, r: f64, h: &P3) -> f64 {
    let (sd, dv, al, be, valid) = posed_sd_ab(fr, c, tip, axis);
    let mut s = (al * dv[0] + be * axis[0]).abs() * h[0];
    s += (al * dv[1] + be * axis[1]).abs() * h[1];
    s += (al * dv[2] + be * axis[2]).abs() * h[2];
    nanmax(sd - r, if valid { sd - s } else { f64::NEG_INFINITY })
}

/// Margin of [`certainly_above`]: far above the rounding of the exact distances (mm).
const PREFILTER_EPS: f64 = 1e-9;

/// Whether the frustum's signed distance at `x` is certainly above `thr`, from the bounding
/// cylinder (z0 ≤ z ≤ z1, ρ ≤ rmax) alone: sd ≥ max(z0 − z, z − z1, ρ − rmax) (the frustum
/// lies inside that cylinder), tested with a margin of [`PREFILTER_EPS`] and without the
/// square root. A node or triangle it rejects is one the exact bound rejects too (its bound
/// sd − r is above the pose's bound, and its sd does not lower the bound): the walk's
/// decisions are unchanged, only the exact distances of far nodes are not computed.
#[inline(always)]
fn certainly_above(z0: f64, z1: f64, rmax: f64, x: &P3, tip: &P3, axis: &P3, thr: f64) -> bool {
    let thr = thr + PREFILTER_EPS;
    let dv = sub(x, tip);
    let z = dot(&dv, axis);
    if z0 - z > thr || z - z1 > thr {
        return true;
    }
    let t = thr + rmax;
    if t < 0.0 {
        return true;
    }
    dot(&dv, &dv) - z * z > t * t
}

/// A node: box centre, the radius of its sphere, representative point, half-sizes.
pub(crate) struct Node {
    pub(crate) c: P3,
    pub(crate) r: f64,
    pub(crate) rep: P3,
    pub(crate) h: P3,
}

/// A triangle: centroid, the radius of its sphere about it, corners, unit normal (`ok`: a
/// usable one).
pub(crate) struct Tri {
    pub(crate) cen: P3,
    pub(crate) rad: f64,
    pub(crate) a: P3,
    pub(crate) b: P3,
    pub(crate) c: P3,
    pub(crate) nrm: P3,
    pub(crate) ok: bool,
}

/// `tri_tree._TriTree`'s arrays: levels root first, triangles in Morton order.
pub(crate) struct Tree {
    pub(crate) levels: Vec<Vec<Node>>,
    pub(crate) tris: Vec<Tri>,
}

/// A `_TriTree`'s arrays, copied once (a scene reuses them for every detection).
#[pyclass(frozen)]
pub struct CollisionTree {
    pub(crate) t: Tree,
}

type LevelArrays<'py> = (
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
);

#[pymethods]
impl CollisionTree {
    /// levels: [(centre (q, 3), radius (q,), representative point (q, 3), half-sizes (q, 3))]
    /// root first, a node's children the BRANCH nodes from BRANCH·i on the next level, the
    /// last level's node i holding triangles LEAF·i …; the triangles' centroids (n, 3), radii
    /// (n,), corners A, B, C (n, 3), unit normals (n, 3), `ok` (n,) a usable normal.
    #[new]
    #[allow(clippy::too_many_arguments)]
    fn new(
        levels: Vec<LevelArrays<'_>>,
        cen: PyReadonlyArray2<'_, f64>,
        rad: PyReadonlyArray1<'_, f64>,
        a: PyReadonlyArray2<'_, f64>,
        b: PyReadonlyArray2<'_, f64>,
        c: PyReadonlyArray2<'_, f64>,
        nrm: PyReadonlyArray2<'_, f64>,
        ok: PyReadonlyArray1<'_, bool>,
    ) -> PyResult<Self> {
        let cen = points(&cen, "cen")?;
        let n = cen.len();
        let (rad, ok) = (values_n(&rad, "rad", n)?, values_n(&ok, "ok", n)?);
        if n == 0 || levels.is_empty() {
            return Err(PyValueError::new_err("the tree needs triangles and levels"));
        }
        let mut lv = Vec::with_capacity(levels.len());
        let mut prev = 1usize;
        for (i, (c, r, rep, h)) in levels.iter().enumerate() {
            let cc = points(c, "level centres")?;
            let q = cc.len();
            let r = values_n(r, "level radii", q)?;
            // each level has the nodes its parents' children can name, the leaves the triangles'
            let fits = if i == 0 {
                q == 1
            } else {
                q > BRANCH * (prev - 1) && q <= BRANCH * prev
            };
            if !fits {
                return Err(PyValueError::new_err(
                    "the tree's levels do not nest (BRANCH children per node, root first)",
                ));
            }
            let (rep, h) = (
                points_n(rep, "level representatives", q)?,
                points_n(h, "level half-sizes", q)?,
            );
            lv.push(
                (0..q)
                    .map(|j| Node {
                        c: cc[j],
                        r: r[j],
                        rep: rep[j],
                        h: h[j],
                    })
                    .collect::<Vec<_>>(),
            );
            prev = q;
        }
        if n > LEAF * prev || n <= LEAF * (prev - 1) {
            return Err(PyValueError::new_err(
                "the tree's leaves do not hold the triangles (LEAF per leaf)",
            ));
        }
        let (a, b, c, nrm) = (
            points_n(&a, "A", n)?,
            points_n(&b, "B", n)?,
            points_n(&c, "C", n)?,
            points_n(&nrm, "nrm", n)?,
        );
        let tris = (0..n)
            .map(|i| Tri {
                cen: cen[i],
                rad: rad[i],
                a: a[i],
                b: b[i],
                c: c[i],
                nrm: nrm[i],
                ok: ok[i],
            })
            .collect();
        let t = Tree { levels: lv, tris };
        Ok(CollisionTree { t })
    }
}

/// A part: its distance (and, for a frustum, gradient), the radius that sizes the
/// representative points' use.
struct WalkPart {
    part: Part,
    frustum: Option<[f64; 4]>,
    rmax: f64,
}

impl WalkPart {
    #[inline]
    fn sd(&self, x: &P3, tip: &P3, axis: &P3) -> f64 {
        self.part.posed_sd(x, tip, axis)
    }
}

/// The queries of one group for one chunk: rows `row0 + j` of the group's arrays, pose
/// `j % mc`, copy `first + j / mc`.
struct Queries<'a> {
    tq: &'a [P3],
    aq: &'a [P3],
    mc: usize,
}

/// A candidate pair: (query j, triangle, sd at its centroid, lower bound).
#[derive(Clone, Copy)]
struct Cand {
    q: u32,
    t: u32,
    sdc: f64,
    lb: f64,
}

/// Work buffers of the walks of one chunk (reused level after level, walk after walk).
#[derive(Default)]
struct Scratch {
    fr: Vec<(u32, u32)>,
    nx: Vec<(u32, u32)>,
    lb: Vec<f64>,
    srep: Vec<f64>,
    pose: Vec<u32>,
}

/// `_TriTree.candidates` for one chunk: the pairs that may hold the part's minimum; `ub`
/// (mc,) lowered in place.
fn candidates(
    tree: &Tree,
    wp: &WalkPart,
    qs: &Queries,
    ub: &mut [f64],
    far: f64,
    sc: &mut Scratch,
) -> Vec<Cand> {
    let nq = qs.tq.len();
    let mc = qs.mc;
    let Scratch {
        fr,
        nx,
        lb,
        srep,
        pose,
    } = sc;
    pose.clear();
    pose.extend((0..nq).map(|q| (q % mc) as u32));
    let pose = &pose[..];
    let pz = |q: u32| pose[q as usize] as usize;
    fr.clear();
    fr.extend((0..nq as u32).map(|q| (q, 0)));
    let nl = tree.levels.len();
    for (li, lev) in tree.levels.iter().enumerate() {
        let use_box = wp.frustum.is_some() && lev[0].r < GRAD_RADIUS;
        // the nodes whose lower bound reaches their pose's bound (ub does not change here)
        lb.clear();
        let mut k = 0;
        for i in 0..fr.len() {
            let (q, n) = fr[i];
            let (t, a, nd) = (&qs.tq[q as usize], &qs.aq[q as usize], &lev[n as usize]);
            let u = ub[pz(q)];
            let b = match (&wp.frustum, use_box) {
                (Some(f), _)
                    if certainly_above(f[0], f[2], f[1].max(f[3]), &nd.c, t, a, u + nd.r) =>
                {
                    continue
                }
                (Some(f), true) => box_bound(f, &nd.c, t, a, nd.r, &nd.h),
                _ => wp.sd(&nd.c, t, a) - nd.r,
            };
            if b <= u {
                fr[k] = fr[i];
                lb.push(b);
                k += 1;
            }
        }
        fr.truncate(k);
        if fr.is_empty() {
            return Vec::new();
        }
        let mut with_depth = false;
        if lev[0].r < REP_FACTOR * wp.rmax + 8.0 {
            srep.clear();
            // a representative certainly above max(bound, 0) lowers no bound and, in the
            // beam, is neither a depth nor within the bound: +∞ stands for it
            srep.extend(fr.iter().map(|&(q, n)| {
                let (x, t, a) = (&lev[n as usize].rep, &qs.tq[q as usize], &qs.aq[q as usize]);
                match &wp.frustum {
                    Some(f)
                        if certainly_above(
                            f[0],
                            f[2],
                            f[1].max(f[3]),
                            x,
                            t,
                            a,
                            nanmax(ub[pz(q)], 0.0),
                        ) =>
                    {
                        f64::INFINITY
                    }
                    _ => wp.sd(x, t, a),
                }
            }));
            for (&(q, _), &s) in fr.iter().zip(srep.iter()) {
                let u = &mut ub[pz(q)];
                *u = nanmin(*u, s);
            }
            let mut k = 0;
            for i in 0..fr.len() {
                if lb[i] <= ub[pz(fr[i].0)] {
                    fr[k] = fr[i];
                    lb[k] = lb[i];
                    srep[k] = srep[i];
                    k += 1;
                }
            }
            fr.truncate(k);
            lb.truncate(k);
            srep.truncate(k);
            with_depth = true;
        }
        if fr.len() > DEEP_BEAM * 4 {
            beam(
                fr,
                lb,
                if with_depth { Some(&srep[..]) } else { None },
                ub,
                mc,
                far,
            );
        }
        if li + 1 < nl {
            let nxt = tree.levels[li + 1].len();
            nx.clear();
            for &(q, n) in fr.iter() {
                for j in 0..BRANCH {
                    let c = BRANCH * n as usize + j;
                    if c < nxt {
                        nx.push((q, c as u32));
                    }
                }
            }
            std::mem::swap(fr, nx);
        }
    }
    // leaves → triangles
    let nt = tree.tris.len();
    let mut pairs: Vec<Cand> = Vec::with_capacity(fr.len() * LEAF);
    for &(q, n) in fr.iter() {
        let (tip, ax) = (&qs.tq[q as usize], &qs.aq[q as usize]);
        for j in 0..LEAF {
            let t = LEAF * n as usize + j;
            if t >= nt {
                break;
            }
            let tr = &tree.tris[t];
            let cen = &tr.cen;
            let (sdc, lb) = match &wp.frustum {
                // below: lb ≥ sdc − rad > ub now ≥ ub at the end, and sdc > ub lowers nothing
                Some(f)
                    if certainly_above(
                        f[0],
                        f[2],
                        f[1].max(f[3]),
                        cen,
                        tip,
                        ax,
                        ub[pz(q)] + tr.rad,
                    ) =>
                {
                    continue
                }
                Some(f) => {
                    let (sdc, dv, al, be, valid) = posed_sd_ab(f, cen, tip, ax);
                    let lb = sdc - tr.rad;
                    if valid {
                        let g = [
                            al * dv[0] + be * ax[0],
                            al * dv[1] + be * ax[1],
                            al * dv[2] + be * ax[2],
                        ];
                        let lin = nanmin(
                            nanmin(dot(&g, &sub(&tr.a, cen)), dot(&g, &sub(&tr.b, cen))),
                            dot(&g, &sub(&tr.c, cen)),
                        );
                        (sdc, nanmax(lb, sdc + lin))
                    } else {
                        (sdc, lb)
                    }
                }
                None => {
                    let sdc = wp.sd(cen, tip, ax);
                    (sdc, sdc - tr.rad)
                }
            };
            pairs.push(Cand {
                q,
                t: t as u32,
                sdc,
                lb,
            });
        }
    }
    for c in &pairs {
        let u = &mut ub[pz(c.q)];
        *u = nanmin(*u, c.sdc);
    }
    pairs.retain(|c| c.lb <= ub[pz(c.q)]);
    pairs
}

/// `candidates`' beam step and `tri_tree._beam`: per query (a run of `fr`, which is sorted
/// by query), a pose known to penetrate keeps its DEEP_BEAM nodes with the deepest
/// representatives, a query whose nodes are all ≥ `far` its FAR_BEAM nodes with the least
/// lower bound (the node that gave the pose's bound first); order kept.
fn beam(
    fr: &mut Vec<(u32, u32)>,
    lb: &mut Vec<f64>,
    depth: Option<&[f64]>,
    ub: &[f64],
    mc: usize,
    far: f64,
) {
    let n = fr.len();
    let mut keep = vec![true; n];
    let mut any = false;
    let mut s = 0;
    while s < n {
        let q = fr[s].0;
        let mut e = s + 1;
        while e < n && fr[e].0 == q {
            e += 1;
        }
        let ubp = ub[q as usize % mc];
        let deep = ubp < 0.0;
        let lbmin = lb[s..e].iter().copied().fold(f64::INFINITY, nanmin);
        let width = if deep {
            DEEP_BEAM
        } else if lbmin >= far {
            FAR_BEAM
        } else {
            0
        };
        if width > 0 && e - s > width {
            any = true;
            let key = |i: usize| -> f64 {
                match depth {
                    None => lb[i],
                    Some(dq) => {
                        if deep {
                            if dq[i] < 0.0 {
                                dq[i] - 1e3
                            } else {
                                lb[i]
                            }
                        } else if dq[i] <= ubp + 1e-12 {
                            -2e3
                        } else {
                            lb[i]
                        }
                    }
                }
            };
            let mut idx: Vec<usize> = (s..e).collect();
            idx.sort_by(|&x, &y| {
                key(x)
                    .partial_cmp(&key(y))
                    .unwrap_or(std::cmp::Ordering::Equal)
            });
            for &i in &idx[width..] {
                keep[i] = false;
            }
        }
        s = e;
    }
    if any {
        let mut k = 0;
        for i in 0..n {
            if keep[i] {
                fr[k] = fr[i];
                lb[k] = lb[i];
                k += 1;
            }
        }
        fr.truncate(k);
        lb.truncate(k);
    }
}

/// One pose's figure: (clearance, group, part, query row in the group's arrays, copy,
/// triangle, point on it in the tree's frame); group −1 for none within the cap.
#[derive(Clone, Copy)]
struct Hit {
    d: f64,
    g: i64,
    part: i64,
    row: i64,
    copy: i64,
    t: i64,
    w: P3,
}

/// `CollisionScene._chunk` for poses `s..e` of the batch.
#[allow(clippy::too_many_arguments)]
fn chunk(
    trees: &[&Tree],
    parts: &[WalkPart],
    plan: &[Vec<(usize, usize)>],
    queries: &[(&[P3], &[P3], usize)],
    s: usize,
    e: usize,
    cap: f64,
    safety: f64,
) -> Vec<Hit> {
    let mc = e - s;
    let far = safety + FAR_MARGIN;
    let mut ub = vec![cap; mc];
    struct Set {
        part: usize,
        g: usize,
        first: usize,
        row0: usize,
        pairs: Vec<Cand>,
    }
    let mut sets: Vec<Set> = Vec::new();
    let mut scratch = Scratch::default();
    for (j, wp) in parts.iter().enumerate() {
        for &(g, first) in &plan[j] {
            let (tq, aq, nc) = queries[g];
            let row0 = nc * s + first * mc;
            let rows_ = (nc - first) * mc;
            let qs = Queries {
                tq: &tq[row0..row0 + rows_],
                aq: &aq[row0..row0 + rows_],
                mc,
            };
            let pairs = candidates(trees[g], wp, &qs, &mut ub, far, &mut scratch);
            if !pairs.is_empty() {
                sets.push(Set {
                    part: j,
                    g,
                    first,
                    row0,
                    pairs,
                });
            }
        }
    }
    let mut out = vec![
        Hit {
            d: cap,
            g: -1,
            part: -1,
            row: -1,
            copy: -1,
            t: -1,
            w: [f64::NAN; 3]
        };
        mc
    ];
    for set in sets.iter_mut() {
        let tree = trees[set.g];
        let (tq, aq, _) = queries[set.g];
        let wp = &parts[set.part];
        let pose = |c: &Cand| c.q as usize % mc;
        set.pairs.retain(|c| c.lb <= ub[c.q as usize % mc]);
        if set.pairs.is_empty() {
            continue;
        }
        // per pose: the deepest centroids of a penetrating pose, the most promising pairs of
        // a certainly clear one (lexsort by pose, then key; stable)
        let key = |c: &Cand| -> f64 {
            let u = ub[c.q as usize % mc];
            if u < 0.0 {
                c.sdc
            } else if c.sdc <= u + 1e-12 {
                f64::NEG_INFINITY
            } else {
                c.lb
            }
        };
        let mut order: Vec<usize> = (0..set.pairs.len()).collect();
        order.sort_by(|&x, &y| {
            let (cx, cy) = (&set.pairs[x], &set.pairs[y]);
            pose(cx).cmp(&pose(cy)).then_with(|| {
                let (kx, ky) = (key(cx), key(cy));
                // lexsort puts NaN last
                match (kx.is_nan(), ky.is_nan()) {
                    (false, false) => kx.partial_cmp(&ky).unwrap(),
                    (a, b) => a.cmp(&b),
                }
            })
        });
        let mut i = 0;
        while i < order.len() {
            let p = pose(&set.pairs[order[i]]);
            let mut e2 = i + 1;
            while e2 < order.len() && pose(&set.pairs[order[e2]]) == p {
                e2 += 1;
            }
            let run = &order[i..e2];
            let deep = ub[p] < 0.0;
            let lbmin = run
                .iter()
                .map(|&x| set.pairs[x].lb)
                .fold(f64::INFINITY, nanmin);
            let far_p = lbmin >= far;
            let beamed = deep || far_p;
            let take = if deep {
                run.len().min(PENETRATION_PAIRS)
            } else if far_p {
                run.len().min(FAR_PAIRS)
            } else {
                run.len()
            };
            let kept = &run[..take];
            let prs: Vec<Pair> = kept
                .iter()
                .map(|&x| {
                    let c = &set.pairs[x];
                    let (tr, row) = (&tree.tris[c.t as usize], c.q as usize);
                    Pair {
                        a: &tr.a,
                        b: &tr.b,
                        c: &tr.c,
                        n: &tr.nrm,
                        ok: tr.ok,
                        tip: &tq[set.row0 + row],
                        axis: &aq[set.row0 + row],
                    }
                })
                .collect();
            let res = refine_pose(&wp.part, &prs, &mut ub[p]);
            // the pose's least value (the first among equal ones)
            let mut bi: Option<(f64, usize, P3)> = None;
            for (&x, (d, w)) in kept.iter().zip(res) {
                let c = &set.pairs[x];
                let (d, w) = if beamed && c.sdc < d {
                    (c.sdc, tree.tris[c.t as usize].cen)
                } else {
                    (d, w)
                };
                let better = match bi {
                    None => true,
                    Some((bd, _, _)) => d < bd || (bd.is_nan() && !d.is_nan()),
                };
                if better {
                    bi = Some((d, x, w));
                }
            }
            if let Some((d, x, w)) = bi {
                if d < out[p].d {
                    let c = &set.pairs[x];
                    let j = c.q as usize;
                    out[p] = Hit {
                        d,
                        g: set.g as i64,
                        part: set.part as i64,
                        row: (set.row0 + j) as i64,
                        copy: (set.first + j / mc) as i64,
                        t: c.t as i64,
                        w,
                    };
                }
            }
            i = e2;
        }
    }
    out
}

type DetectOut<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<i64>>,
    Bound<'py, PyArray2<f64>>,
);

/// `CollisionScene._chunk` over poses `0..m` in chunks of `chunk` (numpy's), the chunks in
/// parallel on `threads` threads. `trees` one per obstacle group; `parts` per part
/// (`tri_tree._part_spec` floats, rmax); `plan` per part its (group, first copy) list;
/// `queries` per group (tips (c·m, 3), axes (c·m, 3), copies c), each chunk's c·mc rows in a
/// block, copy-major (`_Copies.queries` of the chunk). Returns (clearance (m,), ids (m, 5)
/// = group, part, query row, copy, triangle (−1: none within the cap), point (m, 3) in the
/// tree's frame).
#[pyfunction]
#[pyo3(signature = (trees, parts, plan, queries, m, chunk_size, cap, safety, threads))]
#[allow(clippy::too_many_arguments)]
pub fn collision_detect<'py>(
    py: Python<'py>,
    trees: Vec<PyRef<'py, CollisionTree>>,
    parts: Vec<(Vec<f64>, f64)>,
    plan: Vec<Vec<(usize, usize)>>,
    queries: Vec<(
        PyReadonlyArray2<'py, f64>,
        PyReadonlyArray2<'py, f64>,
        usize,
    )>,
    m: usize,
    chunk_size: usize,
    cap: f64,
    safety: f64,
    threads: usize,
) -> PyResult<DetectOut<'py>> {
    let err = |s: &str| PyValueError::new_err(s.to_string());
    if chunk_size == 0 || plan.len() != parts.len() || queries.len() != trees.len() {
        return Err(err(
            "chunk_size ≥ 1, one plan per part and one query set per tree",
        ));
    }
    let mut wparts = Vec::with_capacity(parts.len());
    for (spec, rmax) in &parts {
        let part = Part::from_slice(spec).ok_or_else(|| err("unknown part description"))?;
        let frustum = if spec[0] == 1.0 {
            Some([spec[1], spec[2], spec[3], spec[4]])
        } else {
            None
        };
        wparts.push(WalkPart {
            part,
            frustum,
            rmax: *rmax,
        });
    }
    let mut qv: Vec<(&[P3], &[P3], usize)> = Vec::with_capacity(queries.len());
    for (tq, aq, nc) in &queries {
        if *nc == 0 {
            return Err(err("each group needs at least one copy"));
        }
        let (t, a) = (
            points_n(tq, "query tips", nc * m)?,
            points_n(aq, "query axes", nc * m)?,
        );
        qv.push((t, a, *nc));
    }
    for pl in &plan {
        if pl
            .iter()
            .any(|&(g, first)| g >= trees.len() || first >= qv[g].2)
        {
            return Err(err("plan names a group or copy that does not exist"));
        }
    }
    let tr: Vec<&Tree> = trees.iter().map(|t| &t.t).collect();
    let spans: Vec<(usize, usize)> = (0..m)
        .step_by(chunk_size)
        .map(|s| (s, (s + chunk_size).min(m)))
        .collect();
    let pool = crate::pool(threads)?;
    let res: Vec<Vec<Hit>> = py.detach(|| {
        pool.install(|| {
            spans
                .par_iter()
                .with_max_len(1)
                .map(|&(s, e)| chunk(&tr, &wparts, &plan, &qv, s, e, cap, safety))
                .collect()
        })
    });
    let hits: Vec<Hit> = res.into_iter().flatten().collect();
    let d: Vec<f64> = hits.iter().map(|h| h.d).collect();
    let ids: Vec<i64> = hits
        .iter()
        .flat_map(|h| [h.g, h.part, h.row, h.copy, h.t])
        .collect();
    let w: Vec<f64> = hits.iter().flat_map(|h| h.w).collect();
    Ok((
        PyArray1::from_vec(py, d),
        PyArray1::from_vec(py, ids).reshape([m, 5])?,
        PyArray1::from_vec(py, w).reshape([m, 3])?,
    ))
}
