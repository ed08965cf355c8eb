//! The volume swept by a ball along centre polylines (`blisk_cam/core/verify/sweep_ball.py`):
//! for each point the least squared distance to the centre segments and the segment giving it.
//! parry3d-f64's bounding-volume tree (one leaf per run of consecutive segments) prunes; the
//! squared distances that decide are those of `SweptBall._d2` (`closest.segment_offsets`
//! with b − a and |b − a|² given per segment, then einsum's three-term dot product
//! `(x0 y0 + x2 y2) + x1 y1`), operation for operation, so the minimum is the numpy
//! reference's float.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use parry3d_f64::bounding_volume::Aabb;
use parry3d_f64::math::Vector;
use parry3d_f64::partitioning::{Bvh, BvhBuildStrategy};
use parry3d_f64::query::PointQuery;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;

use crate::numpy_ops::einsum_dot as dot;
use crate::numpy_ops::nanmax;
use crate::numpy_ops::sub;

pub type P3 = [f64; 3];

/// Consecutive segments per leaf (a pass polyline's moves are short next to the ball).
const RUN: usize = 4;

/// Consecutive points searched one after the other, each from the previous one's nearest
/// segment (the unit of work of the threads).
const WARM_RUN: usize = 64;

pub struct SegTree {
    a: Vec<P3>,
    b: Vec<P3>,
    d: Vec<P3>,
    dd: Vec<f64>,
    bvh: Bvh,
    /// each leaf's capsule (see [`LeafCapsule`]), for the group queries' own tests (tighter
    /// than the leaf's box and as cheap)
    caps: Vec<LeafCapsule>,
}

/// The capsule around a leaf's run of segments: the chord from the run's first start to its
/// last end, and the largest distance of the run's ends from it (padded). The distance to a
/// segment's points is convex along the segment, so every segment of the run lies within
/// `rad` of the chord, and dist(p, chord) − rad is a lower bound of the distance from p to
/// any of them. A ball's surface samples lie on the thin shell ρ from their nearest centre:
/// the neighbouring passes' runs come within a few tenths of a mm of that distance, where an
/// axis-aligned box around a slanted run is loose by up to its length; the chord is not.
#[derive(Clone, Copy)]
pub struct LeafCapsule {
    s: P3,
    d: P3,
    /// 1 / |d|² (0 for a point chord)
    inv: f64,
    rad: f64,
}

impl LeafCapsule {
    fn new(a: &[P3], b: &[P3]) -> Self {
        let s = a[0];
        let e = b[b.len() - 1];
        let d = [e[0] - s[0], e[1] - s[1], e[2] - s[2]];
        let ll = dot(&d, &d);
        let inv = if ll > 0.0 && ll.is_finite() {
            1.0 / ll
        } else {
            0.0
        };
        let mut cap = LeafCapsule {
            s,
            d,
            inv,
            rad: 0.0,
        };
        let mut rad = 0.0f64;
        let mut scale = 1.0f64;
        for p in a.iter().chain(b) {
            rad = nanmax(rad, cap.dist2(p).sqrt());
            scale = nanmax(scale, p[0].abs().max(p[1].abs()).max(p[2].abs()));
        }
        // the chord's and the queries' rounding: far below 1e-9 of the coordinates
        cap.rad = if rad.is_finite() {
            rad * (1.0 + 1e-9) + 1e-9 * scale
        } else {
            f64::INFINITY
        };
        cap
    }

    /// The squared distance from `p` to the chord.
    #[inline(always)]
    fn dist2(&self, p: &P3) -> f64 {
        let w = [p[0] - self.s[0], p[1] - self.s[1], p[2] - self.s[2]];
        let t = (dot(&w, &self.d) * self.inv).clamp(0.0, 1.0);
        let e = [
            w[0] - t * self.d[0],
            w[1] - t * self.d[1],
            w[2] - t * self.d[2],
        ];
        dot(&e, &e)
    }

    /// Whether every segment of the leaf is farther than `r` from `p` (false for NaN).
    #[inline(always)]
    pub fn beyond(&self, p: &P3, r: f64) -> bool {
        let rr = r + self.rad;
        self.dist2(p) > rr * rr
    }
}

/// The segments listed near a point x ([`SegTree::nearest_group_listed`]): every segment
/// within `r` mm of x (NaN `r`: none listed, a full search each time), and x's nearest
/// segment `seg`.
#[derive(Clone, Copy)]
pub struct Listed {
    x: P3,
    r: f64,
    seg: i64,
    /// its leaves: `Lists::leaves[from..to]`
    from: u32,
    to: u32,
}

/// [`Listed`] of many points, their leaves in one vector.
#[derive(Default)]
pub struct Lists {
    pub near: Vec<Listed>,
    leaves: Vec<u32>,
}

impl Lists {
    fn push_none(&mut self, p: &P3, seg: i64) {
        let n = self.leaves.len() as u32;
        self.near.push(Listed {
            x: *p,
            r: f64::NAN,
            seg,
            from: n,
            to: n,
        });
    }
}

/// Whether every coordinate of p is finite (a NaN or infinite point is searched alone and
/// has no segment).
#[inline(always)]
fn finite(p: &P3) -> bool {
    p[0].is_finite() && p[1].is_finite() && p[2].is_finite()
}

/// The points' indices in Morton (Z) order on a 1024³ grid over their box, ties and
/// non-finite points (last) by index: nearby points come together, whatever their order.
pub fn spatial_order(pts: &[P3]) -> Vec<u32> {
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in pts.iter().filter(|p| finite(p)) {
        for j in 0..3 {
            lo[j] = lo[j].min(p[j]);
            hi[j] = hi[j].max(p[j]);
        }
    }
    let scale: Vec<f64> = (0..3)
        .map(|j| {
            let w = hi[j] - lo[j];
            if w > 0.0 && w.is_finite() {
                1023.0 / w
            } else {
                0.0
            }
        })
        .collect();
    // (keys, sort and gather on the caller's pool: serial, they were ~8 ms of verify's
    // material query on Rotor 37's 265k samples (0.104 s on one worker), the other worker
    // idle meanwhile; the keys are distinct, so the order is the same on any thread count)
    let key = |(i, p): (usize, &P3)| {
        let code = if finite(p) {
            let c = |j: usize| ((p[j] - lo[j]) * scale[j]).clamp(0.0, 1023.0) as u64;
            crate::morton::code3(c(0), c(1), c(2))
        } else {
            1 << 30
        };
        (code << 32) | i as u64
    };
    if rayon::current_num_threads() == 1 {
        // (one worker: rayon's sort and collect cost that query ~2.5 % more)
        let mut keys: Vec<u64> = pts.iter().enumerate().map(key).collect();
        keys.sort_unstable();
        return keys.into_iter().map(|k| k as u32).collect();
    }
    let mut keys: Vec<u64> = pts.par_iter().enumerate().map(key).collect();
    keys.par_sort_unstable();
    keys.into_par_iter().map(|k| k as u32).collect()
}

/// The squared distance from a point to a box (lo, hi) (0 inside).
#[inline(always)]
pub fn box_d2(bx: &[f64; 6], p: &P3) -> f64 {
    let mut s = 0.0;
    for j in 0..3 {
        let e = (bx[j] - p[j]).max(p[j] - bx[3 + j]).max(0.0);
        s += e * e;
    }
    s
}

/// The squared distance from a point to a tree node's box (0 inside).
#[inline(always)]
fn node_d2(node: &parry3d_f64::partitioning::BvhNode, p: &P3) -> f64 {
    let a = node.aabb();
    box_d2(
        &[a.mins.x, a.mins.y, a.mins.z, a.maxs.x, a.maxs.y, a.maxs.z],
        p,
    )
}

/// The reach of a least squared distance `d2`: a box farther than it (with room for the
/// boxes' and the distances' rounding) holds nothing as near.
#[inline(always)]
pub fn reach(d2: f64) -> f64 {
    d2.sqrt() * (1.0 + 1e-9) + 1e-9
}

/// Points per group of [`SegTree::nearest_group`] (consecutive samples of a grid or a
/// polyline lie within a few mm of each other).
pub const GROUP: usize = 32;

/// Candidate leaves above which a group is searched point by point (its points are far
/// apart: one walk per point is then cheaper than testing every candidate per point).
pub const GROUP_MAX_LEAVES: usize = 256;

/// Candidate leaves above which a group's list bounded by the previous group's segment is
/// dropped for one bounded by the group's own first point (searched alone).
pub const GUESS_MAX_LEAVES: usize = 128;

impl SegTree {
    /// Segments a + t d (t ∈ [0, 1]) with |d|² `dd` (0 replaced by 1), and their ends `b`
    /// (for the boxes only).
    pub fn new(a: Vec<P3>, b: &[P3], d: Vec<P3>, dd: Vec<f64>) -> Self {
        let boxes: Vec<Aabb> = (0..a.len())
            .step_by(RUN)
            .map(|s| {
                let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
                for i in s..(s + RUN).min(a.len()) {
                    for p in [&a[i], &b[i]] {
                        for j in 0..3 {
                            lo[j] = lo[j].min(p[j]);
                            hi[j] = hi[j].max(p[j]);
                        }
                    }
                }
                // a + t d rounds a few ulps off the box of a and b
                for j in 0..3 {
                    let pad = 1e-9 * (1.0 + lo[j].abs().max(hi[j].abs()));
                    lo[j] -= pad;
                    hi[j] += pad;
                }
                Aabb::new(
                    Vector::new(lo[0], lo[1], lo[2]),
                    Vector::new(hi[0], hi[1], hi[2]),
                )
            })
            .collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &boxes);
        let caps = (0..a.len())
            .step_by(RUN)
            .map(|s| {
                let e = (s + RUN).min(a.len());
                LeafCapsule::new(&a[s..e], &b[s..e])
            })
            .collect();
        let b = b.to_vec();
        SegTree {
            a,
            b,
            d,
            dd,
            bvh,
            caps,
        }
    }

    /// `SweptBall._d2` of one point and one segment.
    #[inline(always)]
    fn d2(&self, p: &P3, s: usize) -> f64 {
        let (a, d) = (&self.a[s], &self.d[s]);
        let w = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
        let t = dot(&w, d) / self.dd[s];
        // np.clip(t, 0, 1): NaN stays NaN
        let t = if t < 0.0 { 0.0 } else { t };
        let t = if t > 1.0 { 1.0 } else { t };
        let e = [
            p[0] - (a[0] + t * d[0]),
            p[1] - (a[1] + t * d[1]),
            p[2] - (a[2] + t * d[2]),
        ];
        dot(&e, &e)
    }

    fn run(&self, leaf: u32) -> std::ops::Range<usize> {
        let s = leaf as usize * RUN;
        s..(s + RUN).min(self.a.len())
    }

    /// (least squared distance, segment: the highest id among equal ones; inf and −1 for a
    /// non-finite point or no segments), searched from the segment `guess` (an id or −1, e.g. the previous
    /// point's): its distance bounds the search from the start. One best-first walk: a run is
    /// visited while its box is within the least distance found so far (with room for the
    /// boxes' and the distances' rounding), so every segment at the least squared distance is
    /// compared — the same (d2, segment) whatever the guess.
    pub fn nearest_from(&self, p: &P3, guess: i64) -> (f64, i64) {
        if self.a.is_empty() {
            return (f64::INFINITY, -1);
        }
        if !finite(p) {
            return (f64::NAN, -1); // numpy's minimum of NaN distances
        }
        let best = std::cell::Cell::new((f64::INFINITY, -1i64));
        let consider = |s: usize| {
            let d2 = self.d2(p, s);
            let (b, id) = best.get();
            if d2 < b || (d2 == b && s as i64 > id) {
                best.set((d2, s as i64));
            }
        };
        // squared distances in the walk (no square root per box), against the squared reach
        let reach2 = |d2: f64| {
            let r = reach(d2);
            r * r
        };
        let mut start = f64::MAX;
        if guess >= 0 && (guess as usize) < self.a.len() {
            consider(guess as usize);
            let (b, _) = best.get();
            if b.is_finite() {
                start = reach2(b);
            }
        }
        self.bvh.find_best(
            start,
            |node, _| {
                let a = node.aabb();
                box_d2(
                    &[a.mins.x, a.mins.y, a.mins.z, a.maxs.x, a.maxs.y, a.maxs.z],
                    p,
                )
            },
            |leaf, _| {
                let (b, _) = best.get();
                if !(b.is_finite() && self.caps[leaf as usize].beyond(p, reach(b))) {
                    for s in self.run(leaf) {
                        consider(s);
                    }
                }
                let (b, _) = best.get();
                if b.is_finite() {
                    Some(reach2(b))
                } else {
                    None
                }
            },
        );
        best.get()
    }

    /// [`Self::nearest_from`] of every point, by groups of [`GROUP`] consecutive points
    /// ([`Self::nearest_group`]; the figures do not depend on the grouping).
    pub fn nearest_many(&self, pts: &[P3]) -> (Vec<f64>, Vec<i64>) {
        // the points in space-filling-curve order (grid samples come triangle by triangle,
        // in the mesh's face order: a quarter of 32 consecutive ones spread over 2 mm), so
        // that each group is compact; every point's figures are its own
        let order = spatial_order(pts);
        let q: Vec<P3> = if rayon::current_num_threads() == 1 {
            order.iter().map(|&i| pts[i as usize]).collect()
        } else {
            order.par_iter().map(|&i| pts[i as usize]).collect()
        };
        let mut dq = vec![f64::INFINITY; q.len()];
        let mut sq = vec![-1i64; q.len()];
        dq.par_chunks_mut(WARM_RUN)
            .zip(sq.par_chunks_mut(WARM_RUN))
            .zip(q.par_chunks(WARM_RUN))
            .for_each(|((dd, ss), ps)| {
                let mut g = -1i64;
                for ((dg, sg), pg) in dd
                    .chunks_mut(GROUP)
                    .zip(ss.chunks_mut(GROUP))
                    .zip(ps.chunks(GROUP))
                {
                    g = self.nearest_group(pg, dg, sg, g);
                }
            });
        let mut d2 = vec![f64::INFINITY; pts.len()];
        let mut seg = vec![-1i64; pts.len()];
        for (k, &i) in order.iter().enumerate() {
            d2[i as usize] = dq[k];
            seg[i as usize] = sq[k];
        }
        (d2, seg)
    }

    /// [`Self::nearest_from`] of a group of nearby points with one tree walk: a segment s0
    /// bounds every point's least distance (d2 to s0), so every segment that can be nearest
    /// to one of them lies in a leaf whose box comes within max(|p − c| + reach(d2(p, s0)))
    /// of the group's centre c: those leaves are listed once, then each point tests them
    /// (capsule, then segments) against its own best so far. s0 is `guess` (the previous
    /// group's last segment: no walk of its own) when that lists at most
    /// [`GUESS_MAX_LEAVES`] leaves, else the first finite point's nearest, searched alone.
    /// Every segment at a point's least distance is compared, so the (d2, segment) are
    /// [`Self::nearest_from`]'s whatever s0. Returns the last segment found (the next
    /// group's guess).
    pub fn nearest_group(&self, ps: &[P3], dd: &mut [f64], ss: &mut [i64], guess: i64) -> i64 {
        self.group_scan(ps, dd, ss, guess, None, &mut Lists::default())
    }

    /// [`Self::nearest_group`] that also lists, with `margin` (one per point, mm), the
    /// segments near each point ([`Listed`], pushed to `lists` in point order) for later
    /// queries at points that moved a little ([`Self::listed_d2`]); the (d2, segment) are
    /// [`Self::nearest_group`]'s. A point's walk down the group's list goes `margin` further
    /// and keeps the leaves whose capsule comes within its reach + margin: its reach only
    /// shrinks during the walk, so every leaf within its final reach + margin is kept (the
    /// group's list is made `margin` wider for that). A point searched alone lists nothing.
    pub fn nearest_group_listed(
        &self,
        ps: &[P3],
        dd: &mut [f64],
        ss: &mut [i64],
        guess: i64,
        margin: &[f64],
        lists: &mut Lists,
    ) -> i64 {
        self.group_scan(ps, dd, ss, guess, Some(margin), lists)
    }

    fn group_scan(
        &self,
        ps: &[P3],
        dd: &mut [f64],
        ss: &mut [i64],
        guess: i64,
        margin: Option<&[f64]>,
        lists: &mut Lists,
    ) -> i64 {
        let listing = margin.is_some();
        let mg = |i: usize| margin.map_or(0.0, |m| m[i]);
        let n0 = lists.near.len();
        let unlisted = |lists: &mut Lists, ss: &[i64]| {
            if listing {
                lists.near.truncate(n0);
                for (&s, p) in ss.iter().zip(ps) {
                    lists.push_none(p, s);
                }
            }
        };
        let alone = |dd: &mut [f64], ss: &mut [i64], lists: &mut Lists, mut g: i64| -> i64 {
            for ((di, si), p) in dd.iter_mut().zip(ss.iter_mut()).zip(ps) {
                (*di, *si) = self.nearest_from(p, g);
                if *si >= 0 {
                    g = *si;
                }
            }
            unlisted(lists, ss);
            g
        };
        let Some(i0) = ps.iter().position(finite) else {
            return alone(dd, ss, lists, guess);
        };
        if ps.len() < 4 {
            return alone(dd, ss, lists, guess);
        }
        let (mut c, mut m) = ([0.0f64; 3], 0.0f64);
        for p in ps.iter().filter(|p| finite(p)) {
            for j in 0..3 {
                c[j] += p[j];
            }
            m += 1.0;
        }
        let c = [c[0] / m, c[1] / m, c[2] / m];
        // the leaves that can hold a point's nearest segment when segment `s0` bounds every
        // point's least distance (its box within max(|p − c| + reach(d2(p, s0)) + margin) of
        // c), sorted by their capsules' distance from the centre: a point p's distance to a
        // capsule is at least that less |p − c|, so its walk down the list stops at the first
        // capsule beyond its reach by that bound (every later one is too; a NaN key, sorted
        // last, never stops it). None beyond `limit` leaves or for an unbounded reach.
        let cands_for = |s0u: usize, limit: usize| -> Option<Vec<(f64, u32)>> {
            let mut rg = 0.0f64;
            for (i, p) in ps.iter().enumerate().filter(|(_, p)| finite(p)) {
                let e = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
                let u = reach(self.d2(p, s0u));
                // a NaN reach: the group searched alone
                rg = nanmax(rg, dot(&e, &e).sqrt() + u + mg(i));
            }
            let r = rg * (1.0 + 1e-9) + 1e-9;
            if !(r < f64::INFINITY) {
                return None;
            }
            let mut cands: Vec<(f64, u32)> = Vec::new();
            let rr = r * r; // squared: no square root per box (r holds far more than its rounding)
            for leaf in self.bvh.leaves(|node| node_d2(node, &c) <= rr) {
                cands.push((0.0, leaf));
                if cands.len() > limit {
                    return None;
                }
            }
            for cand in cands.iter_mut() {
                let cap = &self.caps[cand.1 as usize];
                cand.0 = cap.dist2(&c).sqrt() - cap.rad;
            }
            cands.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            Some(cands)
        };
        // the bound: the segment `guess` (the previous group's last: nearby groups share
        // their nearest passes) when its list is short, else the first point's nearest
        // segment, searched alone (any segment bounds every least distance: the same figures)
        let mut fixed = None;
        let mut s0 = guess;
        let mut listed = None;
        if guess >= 0 && (guess as usize) < self.a.len() {
            listed = cands_for(guess as usize, GUESS_MAX_LEAVES);
        }
        if listed.is_none() {
            let (d0, g0) = self.nearest_from(&ps[i0], guess);
            if g0 < 0 {
                return alone(dd, ss, lists, guess);
            }
            fixed = Some((d0, g0));
            s0 = g0;
            listed = cands_for(g0 as usize, GROUP_MAX_LEAVES);
        }
        let Some(cands) = listed else {
            return alone(dd, ss, lists, s0);
        };
        let s0u = s0 as usize;
        let unlisted_one = |lists: &mut Lists, p: &P3, s: i64| {
            if listing {
                lists.push_none(p, s);
            }
        };
        let mut last = s0;
        for (i, p) in ps.iter().enumerate() {
            if i == i0 && !listing {
                if let Some(f) = fixed {
                    (dd[i], ss[i]) = f;
                    continue;
                }
            }
            if !finite(p) {
                (dd[i], ss[i]) = self.nearest_from(p, -1);
                unlisted_one(lists, p, ss[i]);
                continue;
            }
            let mi = mg(i);
            let from = lists.leaves.len();
            let (mut b, mut id) = (f64::INFINITY, -1i64);
            let (mut r, mut r2) = (f64::INFINITY, f64::INFINITY);
            let consider = |s: usize, b: &mut f64, id: &mut i64, r: &mut f64, r2: &mut f64| {
                let d2 = self.d2(p, s);
                if d2 < *b || (d2 == *b && s as i64 > *id) {
                    *b = d2;
                    *id = s as i64;
                    *r = reach(d2);
                    *r2 = *r * *r;
                }
            };
            consider(s0u, &mut b, &mut id, &mut r, &mut r2);
            if last >= 0 && last != s0 {
                // the previous point's segment: its neighbour's nearest is likely its own
                consider(last as usize, &mut b, &mut id, &mut r, &mut r2);
            }
            let e = sub(p, &c);
            let pc = dot(&e, &e).sqrt();
            for &(key, leaf) in &cands {
                // (the pads: the keys' and |p − c|'s rounding, ~1e-15 of the lengths)
                if key - pc > (r + mi) * (1.0 + 1e-9) + 1e-9 {
                    break;
                }
                let l = leaf as usize;
                if !self.caps[l].beyond(p, r + mi) {
                    for s in self.run(leaf) {
                        consider(s, &mut b, &mut id, &mut r, &mut r2);
                    }
                    if listing {
                        lists.leaves.push(leaf);
                    }
                }
            }
            if let (true, Some(f)) = (i == i0, fixed) {
                // searched alone first: the very (d2, segment) (the walk lists its leaves)
                (b, id) = f;
            }
            (dd[i], ss[i]) = (b, id);
            if listing {
                // the leaves kept while the reach was larger: those still within the final
                let rf = reach(b) + mi;
                let mut to = from;
                for k in from..lists.leaves.len() {
                    let leaf = lists.leaves[k];
                    if !self.caps[leaf as usize].beyond(p, rf) {
                        lists.leaves[to] = leaf;
                        to += 1;
                    }
                }
                lists.leaves.truncate(to);
                lists.near.push(Listed {
                    x: *p,
                    r: rf,
                    seg: id,
                    from: from as u32,
                    to: to as u32,
                });
            }
            if id >= 0 {
                last = id;
            }
        }
        last
    }

    /// `closest.ray_capsules_first_hit` of one ray (`o` + t `n`, unit n) and capsule `s`
    /// (radius² `r2`), operation for operation: the least valid t of the two end spheres and
    /// the cylinder, ∞ where the ray misses.
    #[inline]
    fn capsule_first_hit(&self, o: &P3, n: &P3, s: usize, r2: f64) -> f64 {
        let mut best = f64::INFINITY;
        for cen in [&self.a[s], &self.b[s]] {
            let oc = [o[0] - cen[0], o[1] - cen[1], o[2] - cen[2]];
            let bq = dot(n, &oc);
            let h = bq * bq - (dot(&oc, &oc) - r2);
            let t = -bq - (if h > 0.0 { h } else { 0.0 }).sqrt();
            if h >= 0.0 && t >= 0.0 && t < best {
                best = t;
            }
        }
        let (a, ba) = (&self.a[s], &self.d[s]);
        let oa = [o[0] - a[0], o[1] - a[1], o[2] - a[2]];
        let baba = dot(ba, ba);
        let bard = dot(ba, n);
        let baoa = dot(ba, &oa);
        let rdoa = dot(n, &oa);
        let oaoa = dot(&oa, &oa);
        let aa = baba - bard * bard;
        let bb = baba * rdoa - baoa * bard;
        let cc = baba * oaoa - baoa * baoa - r2 * baba;
        let h = bb * bb - aa * cc;
        // np.maximum(baba, 1e-300): NaN propagates
        let floor = if baba.is_nan() || baba > 1e-300 {
            baba
        } else {
            1e-300
        };
        let okc = aa > 1e-12 * floor && h >= 0.0;
        if okc {
            let t = (-bb - (if h > 0.0 { h } else { 0.0 }).sqrt()) / aa;
            let y = baoa + t * bard;
            if t >= 0.0 && y >= 0.0 && y <= baba && t < best {
                best = t;
            }
        }
        best
    }

    /// The least [`Self::capsule_first_hit`] of the ray `o` + t `n` over the segments of
    /// `leaf` within `reach` (radius + max height, padded) of `o` (∞ without one): a hit at
    /// t lies on the capsule, within radius + t of `o`, so a segment farther than `reach`
    /// is hit beyond the max height, if at all (it cannot be the least hit within it).
    #[inline]
    fn run_first_hit(&self, o: &P3, n: &P3, leaf: u32, r2: f64, reach: f64) -> f64 {
        let far = {
            let r = reach * (1.0 + 1e-9) + 1e-9; // the squared distance's rounding
            r * r
        };
        let mut best = f64::INFINITY;
        for s in self.run(leaf) {
            if self.d2(o, s) > far {
                continue;
            }
            let t = self.capsule_first_hit(o, n, s, r2);
            if t < best {
                best = t;
            }
        }
        best
    }

    /// `SweptBall.height_along` of one point: the first hit of the ray `o` + t `n` with the
    /// capsules of radius `radius` around the segments, t ≤ `hmax` (∞ otherwise). Only a
    /// segment within `radius` + `hmax` of `o` can be hit that soon: the segments of the
    /// leaves within it (with the reach's rounding room of [`Self::within`]) are tried,
    /// the least t kept (the minimum over the numpy reference's superset is the same).
    pub fn first_hit(&self, o: &P3, n: &P3, radius: f64, hmax: f64) -> f64 {
        let r2 = radius * radius;
        let mut best = f64::INFINITY;
        let reach = radius + hmax;
        let r = reach * (1.0 + 1e-12) + 1e-12;
        if !(r >= 0.0) || !finite(o) {
            return f64::INFINITY;
        }
        let rr = r * r;
        for leaf in self.bvh.leaves(|node| node_d2(node, o) <= rr) {
            if self.caps[leaf as usize].beyond(o, r) {
                continue; // every hit of its capsules is beyond hmax
            }
            best = best.min(self.run_first_hit(o, n, leaf, r2, r));
        }
        if best > hmax {
            f64::INFINITY
        } else {
            best
        }
    }

    /// [`Self::first_hit`] of a group of nearby points (`os`, directions `ns`, max heights
    /// `hs`) into `out`, with one tree walk: the leaves whose box comes within
    /// max(|o − c| + reach) of the group's centre c are listed once, sorted by their capsules'
    /// distance from c, and each point walks the list until that, less |o − c|, is beyond its
    /// reach (its capsule is then beyond it, and every later leaf's): the segments it tries
    /// are a superset of those within its reach, whose hits alone can come within its max
    /// height, so the least hit is [`Self::first_hit`]'s. Points far apart (more than
    /// [`GROUP_MAX_LEAVES`] candidates) or fewer than 4 are searched alone.
    pub fn first_hits_group(&self, os: &[P3], ns: &[P3], radius: f64, hs: &[f64], out: &mut [f64]) {
        let alone = |out: &mut [f64]| {
            for (((o, n), &h), oi) in os.iter().zip(ns).zip(hs).zip(out.iter_mut()) {
                *oi = self.first_hit(o, n, radius, h);
            }
        };
        // each point's reach as first_hit takes it (NaN: not searched, ∞)
        let reach_of = |h: f64| (radius + h) * (1.0 + 1e-12) + 1e-12;
        let (mut c, mut m) = ([0.0f64; 3], 0.0f64);
        for p in os.iter().filter(|p| finite(p)) {
            for j in 0..3 {
                c[j] += p[j];
            }
            m += 1.0;
        }
        if os.len() < 4 || m < 1.0 || self.a.is_empty() {
            return alone(out);
        }
        let c = [c[0] / m, c[1] / m, c[2] / m];
        let mut rg = 0.0f64;
        for (o, &h) in os.iter().zip(hs) {
            if finite(o) {
                let e = sub(o, &c);
                rg = nanmax(rg, dot(&e, &e).sqrt() + reach_of(h));
            }
        }
        let r = rg * (1.0 + 1e-9) + 1e-9;
        if !(r < f64::INFINITY) {
            return alone(out);
        }
        let rr = r * r;
        let mut cands: Vec<(f64, u32)> = Vec::new();
        for leaf in self.bvh.leaves(|node| node_d2(node, &c) <= rr) {
            cands.push((0.0, leaf));
            if cands.len() > GROUP_MAX_LEAVES {
                return alone(out);
            }
        }
        for cand in cands.iter_mut() {
            let cap = &self.caps[cand.1 as usize];
            cand.0 = cap.dist2(&c).sqrt() - cap.rad;
        }
        cands.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let r2 = radius * radius;
        for (((o, n), &hmax), oi) in os.iter().zip(ns).zip(hs).zip(out.iter_mut()) {
            let ro = reach_of(hmax);
            if !(ro >= 0.0) || !finite(o) {
                *oi = f64::INFINITY;
                continue;
            }
            let e = sub(o, &c);
            let pc = dot(&e, &e).sqrt();
            let mut best = f64::INFINITY;
            for &(key, leaf) in &cands {
                if key - pc > ro * (1.0 + 1e-9) + 1e-9 {
                    break;
                }
                if self.caps[leaf as usize].beyond(o, ro) {
                    continue; // every hit of its capsules is beyond hmax
                }
                best = best.min(self.run_first_hit(o, n, leaf, r2, ro));
            }
            *oi = if best > hmax { f64::INFINITY } else { best };
        }
    }

    /// The least squared distance from `y` to the segments, as [`Self::nearest_from`] gives
    /// it, from the list `nl` made at a point x near y: the minimum of the same squared
    /// distances over the listed segments. A segment not listed is farther than
    /// R − |y − x| from y (the distance is 1-Lipschitz), so where that minimum's distance is
    /// within R − |y − x| (less a rounding pad) it is the minimum over every segment, the
    /// very float (a minimum does not depend on which larger values are also compared); a
    /// full search otherwise (`sweep_ball._NearSegments`'s rule).
    pub fn listed_d2(&self, y: &P3, lists: &Lists, k: usize) -> f64 {
        let nl = &lists.near[k];
        if nl.r.is_finite() {
            let mut b = f64::INFINITY;
            for &leaf in &lists.leaves[nl.from as usize..nl.to as usize] {
                for s in self.run(leaf) {
                    let d2 = self.d2(y, s);
                    if d2 < b {
                        b = d2;
                    }
                }
            }
            let e = sub(y, &nl.x);
            let reach = nl.r - dot(&e, &e).sqrt();
            if b.sqrt() <= reach * (1.0 - 1e-12) - 1e-12 * (1.0 + nl.r) {
                return b;
            }
        }
        self.nearest_from(y, nl.seg).0
    }

    /// The segments of the leaves whose box comes within `radius` of the point (a superset
    /// of the segments within it; none for a NaN radius or point).
    pub fn within(&self, p: &P3, radius: f64) -> Vec<i64> {
        let pv = Vector::new(p[0], p[1], p[2]);
        let r = radius * (1.0 + 1e-12) + 1e-12;
        let mut out = Vec::new();
        if !(r >= 0.0) {
            return out;
        }
        for leaf in self
            .bvh
            .leaves(|node| node.aabb().distance_to_local_point(pv, true) <= r)
        {
            out.extend(self.run(leaf).map(|s| s as i64));
        }
        out
    }

    /// (query ids, segment ids): `within` of every point, in point order.
    pub fn within_many(&self, pts: &[P3], radius: &[f64]) -> (Vec<i64>, Vec<i64>) {
        let lists: Vec<Vec<i64>> = pts
            .par_iter()
            .zip(radius.par_iter())
            .with_min_len(64)
            .map(|(p, &r)| self.within(p, r))
            .collect();
        let n: usize = lists.iter().map(|l| l.len()).sum();
        let (mut q, mut s) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for (i, l) in lists.into_iter().enumerate() {
            q.extend(std::iter::repeat(i as i64).take(l.len()));
            s.extend(l);
        }
        (q, s)
    }
}

/// The centre segments of a swept ball in a tree (see `sweep_ball.SweptBall`).
#[pyclass(frozen)]
pub struct SweptBallTree {
    tree: SegTree,
}

#[pymethods]
impl SweptBallTree {
    /// a, b, d = b − a (S, 3) float64 mm; dd (S,) |d|² with 0 replaced by 1.
    #[new]
    fn new(
        py: Python<'_>,
        a: PyReadonlyArray2<'_, f64>,
        b: PyReadonlyArray2<'_, f64>,
        d: PyReadonlyArray2<'_, f64>,
        dd: PyReadonlyArray1<'_, f64>,
    ) -> PyResult<Self> {
        let (aa, bb, d3) = (
            crate::points(&a, "a")?,
            crate::points(&b, "b")?,
            crate::points(&d, "d")?,
        );
        let dd = crate::slice1(&dd, "dd")?;
        if bb.len() != aa.len() || d3.len() != aa.len() || dd.len() != aa.len() {
            return Err(PyValueError::new_err(
                "a, b, d and dd must describe the same segments",
            ));
        }
        let (aa, d3, dd) = (aa.to_vec(), d3.to_vec(), dd.to_vec());
        let tree = py.detach(|| SegTree::new(aa, bb, d3, dd));
        Ok(SweptBallTree { tree })
    }

    /// (d2 (k,) the least squared distance of each point (k, 3) to the segments, seg (k,)
    /// int64 the segment: the highest id of equal ones), on `threads` threads.
    fn nearest<'py>(
        &self,
        py: Python<'py>,
        p: PyReadonlyArray2<'py, f64>,
        threads: usize,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>)> {
        let pp = crate::points(&p, "points")?;
        let pl = crate::pool(threads)?;
        let (d2, seg) = py.detach(|| pl.install(|| self.tree.nearest_many(pp)));
        Ok((PyArray1::from_vec(py, d2), PyArray1::from_vec(py, seg)))
    }

    /// (k,) mm: the first hit of each ray `p` + t `n` (points and unit directions (k, 3)) with
    /// the capsules of `radius` around the segments, ∞ beyond `hmax` (k,) mm or without one
    /// (`SweptBall.height_along`), on `threads` threads.
    fn first_hits<'py>(
        &self,
        py: Python<'py>,
        p: PyReadonlyArray2<'py, f64>,
        n: PyReadonlyArray2<'py, f64>,
        radius: f64,
        hmax: PyReadonlyArray1<'py, f64>,
        threads: usize,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let pp = crate::points(&p, "points")?;
        let nn = crate::points(&n, "directions")?;
        let hh = crate::slice1(&hmax, "max_height")?;
        if nn.len() != pp.len() || hh.len() != pp.len() {
            return Err(PyValueError::new_err(
                "points, directions and max_height must be one per point",
            ));
        }
        let pl = crate::pool(threads)?;
        let out: Vec<f64> = py.detach(|| {
            pl.install(|| {
                pp.par_iter()
                    .zip(nn.par_iter())
                    .zip(hh.par_iter())
                    .with_min_len(64)
                    .map(|((o, d), &h)| self.tree.first_hit(o, d, radius, h))
                    .collect()
            })
        });
        Ok(PyArray1::from_vec(py, out))
    }

    /// (query (p,), segment (p,)) int64: a superset of the segments within `radius` (k,) mm
    /// of each point (k, 3) (every segment truly within is listed), by point.
    fn within<'py>(
        &self,
        py: Python<'py>,
        p: PyReadonlyArray2<'py, f64>,
        radius: PyReadonlyArray1<'py, f64>,
        threads: usize,
    ) -> PyResult<(Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>)> {
        let pp = crate::points(&p, "points")?;
        let rr = crate::slice1(&radius, "radius")?;
        if rr.len() != pp.len() {
            return Err(PyValueError::new_err(
                "radius must give one value per point",
            ));
        }
        let pl = crate::pool(threads)?;
        let (q, s) = py.detach(|| pl.install(|| self.tree.within_many(pp, rr)));
        Ok((PyArray1::from_vec(py, q), PyArray1::from_vec(py, s)))
    }
}

/// The work units of a forest query: (member, first, end) runs of at most [`WARM_RUN`] of
/// the points of each member (`start` (members + 1,): the points sorted by member).
fn forest_units(start: &[i64], members: usize) -> PyResult<Vec<(usize, usize, usize)>> {
    if start.len() != members + 1 {
        return Err(PyValueError::new_err(
            "start must give one offset per tree and the end",
        ));
    }
    let mut units = Vec::new();
    for j in 0..members {
        let (s, e) = (start[j], start[j + 1]);
        if s < 0 || e < s {
            return Err(PyValueError::new_err(
                "start must be non-decreasing offsets",
            ));
        }
        let (s, e) = (s as usize, e as usize);
        let mut a = s;
        while a < e {
            let b = (a + WARM_RUN).min(e);
            units.push((j, a, b));
            a = b;
        }
    }
    Ok(units)
}

/// Several swept balls' trees queried in one call (verify's per-level volumes): the points
/// (k, 3) sorted by member, member j's being `start[j]..start[j + 1]`; each point's
/// (d2, segment) in its member is [`SweptBallTree::nearest`]'s (the grouping does not change
/// them). Runs of the members' points share the `threads` threads (one call instead of one
/// per member: no per-call overhead, no thread idle at a small member's end).
#[pyfunction]
pub fn forest_nearest<'py>(
    py: Python<'py>,
    trees: Vec<Bound<'py, SweptBallTree>>,
    p: PyReadonlyArray2<'py, f64>,
    start: PyReadonlyArray1<'py, i64>,
    threads: usize,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i64>>)> {
    let pp = crate::points(&p, "points")?;
    let st = crate::slice1(&start, "start")?;
    let units = forest_units(st, trees.len())?;
    if st[trees.len()] as usize != pp.len() {
        return Err(PyValueError::new_err(
            "start must end at the number of points",
        ));
    }
    let ts: Vec<&SegTree> = trees.iter().map(|t| &t.get().tree).collect();
    let pl = crate::pool(threads)?;
    let (d2, seg) = py.detach(|| {
        pl.install(|| {
            let parts: Vec<(usize, Vec<f64>, Vec<i64>)> = units
                .par_iter()
                .map(|&(j, a, b)| {
                    let (mut dd, mut ss) = (vec![f64::INFINITY; b - a], vec![-1i64; b - a]);
                    let mut g = -1i64;
                    for ((dg, sg), pg) in dd
                        .chunks_mut(GROUP)
                        .zip(ss.chunks_mut(GROUP))
                        .zip(pp[a..b].chunks(GROUP))
                    {
                        g = ts[j].nearest_group(pg, dg, sg, g);
                    }
                    (a, dd, ss)
                })
                .collect();
            let mut d2 = vec![f64::INFINITY; pp.len()];
            let mut seg = vec![-1i64; pp.len()];
            for (a, dd, ss) in parts {
                d2[a..a + dd.len()].copy_from_slice(&dd);
                seg[a..a + ss.len()].copy_from_slice(&ss);
            }
            (d2, seg)
        })
    });
    Ok((PyArray1::from_vec(py, d2), PyArray1::from_vec(py, seg)))
}

/// [`SweptBallTree::first_hits`] of points sorted by member (as [`forest_nearest`]) against
/// their member's capsules of `radius`, in one call: (k,) mm.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn forest_first_hits<'py>(
    py: Python<'py>,
    trees: Vec<Bound<'py, SweptBallTree>>,
    p: PyReadonlyArray2<'py, f64>,
    n: PyReadonlyArray2<'py, f64>,
    radius: f64,
    hmax: PyReadonlyArray1<'py, f64>,
    start: PyReadonlyArray1<'py, i64>,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let pp = crate::points(&p, "points")?;
    let nn = crate::points(&n, "directions")?;
    let hh = crate::slice1(&hmax, "max_height")?;
    let st = crate::slice1(&start, "start")?;
    if nn.len() != pp.len() || hh.len() != pp.len() {
        return Err(PyValueError::new_err(
            "points, directions and max_height must be one per point",
        ));
    }
    let units = forest_units(st, trees.len())?;
    if st[trees.len()] as usize != pp.len() {
        return Err(PyValueError::new_err(
            "start must end at the number of points",
        ));
    }
    let ts: Vec<&SegTree> = trees.iter().map(|t| &t.get().tree).collect();
    let pl = crate::pool(threads)?;
    let out = py.detach(|| {
        pl.install(|| {
            let parts: Vec<(usize, Vec<f64>)> = units
                .par_iter()
                .map(|&(j, a, b)| {
                    let t = ts[j];
                    let mut h = vec![f64::INFINITY; b - a];
                    if !t.a.is_empty() {
                        // by groups of nearby points (the same hits as one by one)
                        for (k, hg) in h.chunks_mut(GROUP).enumerate() {
                            let (s, e) = (a + k * GROUP, a + k * GROUP + hg.len());
                            t.first_hits_group(&pp[s..e], &nn[s..e], radius, &hh[s..e], hg);
                        }
                    }
                    (a, h)
                })
                .collect();
            let mut out = vec![f64::INFINITY; pp.len()];
            for (a, h) in parts {
                out[a..a + h.len()].copy_from_slice(&h);
            }
            out
        })
    });
    Ok(PyArray1::from_vec(py, out))
}

/// np.sign: −1, 0 or 1, NaN for NaN.
#[inline(always)]
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else if x == 0.0 {
        0.0
    } else {
        f64::NAN
    }
}

/// The regula falsi (Illinois) of verify's scallop ridges (`measure._ridge_points`), every
/// step of every edge here: edge i runs from `xa` to `xb` (k, 3) with g = d_lo − d_hi
/// `ga`, `gb` at its ends, its levels `lo[i]` and `lo[i] + 1` (trees, None for a level
/// without segments: distance ∞); each step takes t = (ta gb − tb ga) / (gb − ga), the
/// point xa + t (xb − xa) and its distances sqrt(d2) − `radius` to the two levels
/// ([`SegTree::nearest_from`]'s d2), then the numpy code's updates, operation for operation.
/// Returns the last iterates and their two distances (x (k, 3), d_lo (k,), d_hi (k,)).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn ridge_steps<'py>(
    py: Python<'py>,
    trees: Vec<Option<Bound<'py, SweptBallTree>>>,
    xa: PyReadonlyArray2<'py, f64>,
    xb: PyReadonlyArray2<'py, f64>,
    ga: PyReadonlyArray1<'py, f64>,
    gb: PyReadonlyArray1<'py, f64>,
    lo: PyReadonlyArray1<'py, i64>,
    radius: f64,
    steps: usize,
    threads: usize,
) -> PyResult<(
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
)> {
    let (pa, pb) = (crate::points(&xa, "xa")?, crate::points(&xb, "xb")?);
    let (g0, g1) = (crate::slice1(&ga, "ga")?, crate::slice1(&gb, "gb")?);
    let lv = crate::slice1(&lo, "lo")?;
    let k = pa.len();
    if pb.len() != k || g0.len() != k || g1.len() != k || lv.len() != k {
        return Err(PyValueError::new_err(
            "xa, xb, ga, gb and lo must be one per edge",
        ));
    }
    if lv.iter().any(|&l| l < 0 || (l as usize) + 1 >= trees.len()) {
        return Err(PyValueError::new_err(
            "lo must name a level whose next level is in trees",
        ));
    }
    let ts: Vec<Option<&SegTree>> = trees
        .iter()
        .map(|t| t.as_ref().map(|t| &t.get().tree))
        .collect();
    let steps = steps.max(1);
    let pl = crate::pool(threads)?;
    let rows: Vec<(P3, f64, f64)> = py.detach(|| {
        pl.install(|| {
            // the edges by level (stable), in runs of one level: each step's points of a run
            // are searched by groups ([`SegTree::nearest_group`]: the same (d2, segment) as
            // alone). (Sorted here, the GIL released and on the pool: the verify's side
            // threads run Python meanwhile; a stable sort gives one order on any count.)
            let mut order: Vec<usize> = (0..k).collect();
            if rayon::current_num_threads() == 1 {
                order.sort_by_key(|&i| lv[i]);
            } else {
                order.par_sort_by_key(|&i| lv[i]);
            }
            let mut units = Vec::new();
            let mut a = 0;
            while a < k {
                let l = lv[order[a]];
                let mut b = a + 1;
                while b < k && b - a < WARM_RUN && lv[order[b]] == l {
                    b += 1;
                }
                units.push((a, b));
                a = b;
            }
            let parts: Vec<Vec<(P3, f64, f64)>> = units
                .par_iter()
                .map(|&(u0, u1)| {
                    let idx = &order[u0..u1];
                    let n = idx.len();
                    let l = lv[idx[0]] as usize;
                    // the first step: every iterate searched by groups, the segments near
                    // it listed (the later iterates move far less than a tenth of the edge)
                    let margin: Vec<f64> = idx
                        .iter()
                        .map(|&i| {
                            let w = sub(&pb[i], &pa[i]);
                            0.1 * dot(&w, &w).sqrt()
                        })
                        .collect();
                    let dist = |xs: &[P3], tree: Option<&SegTree>, out: &mut [f64]| {
                        let Some(t) = tree else {
                            out.fill(f64::INFINITY);
                            return Lists::default();
                        };
                        let mut d2 = vec![f64::INFINITY; xs.len()];
                        let mut sg = vec![-1i64; xs.len()];
                        let mut lists = Lists::default();
                        let mut g = -1i64;
                        for (((dg, sgg), pg), mg) in d2
                            .chunks_mut(GROUP)
                            .zip(sg.chunks_mut(GROUP))
                            .zip(xs.chunks(GROUP))
                            .zip(margin.chunks(GROUP))
                        {
                            g = t.nearest_group_listed(pg, dg, sgg, g, mg, &mut lists);
                        }
                        for (o, v) in out.iter_mut().zip(&d2) {
                            *o = v.sqrt() - radius;
                        }
                        lists
                    };
                    // the later steps: the iterate's distance over its first iterate's list
                    // (the same float where the list decides, a full search elsewhere)
                    let again =
                        |xs: &[P3], tree: Option<&SegTree>, near: &Lists, out: &mut [f64]| {
                            let Some(t) = tree else {
                                out.fill(f64::INFINITY);
                                return;
                            };
                            for (k, (o, x)) in out.iter_mut().zip(xs).enumerate() {
                                *o = t.listed_d2(x, near, k).sqrt() - radius;
                            }
                        };
                    let mut ta = vec![0.0f64; n];
                    let mut tb = vec![1.0f64; n];
                    let mut ga: Vec<f64> = idx.iter().map(|&i| g0[i]).collect();
                    let mut gb: Vec<f64> = idx.iter().map(|&i| g1[i]).collect();
                    let mut last = vec![0u8; n];
                    let mut xs = vec![[0.0f64; 3]; n];
                    let mut la = vec![f64::NAN; n];
                    let mut lb = vec![f64::NAN; n];
                    let mut t = vec![0.0f64; n];
                    let (mut near_a, mut near_b) = (Lists::default(), Lists::default());
                    for step in 0..steps {
                        for e in 0..n {
                            let (a, b) = (&pa[idx[e]], &pb[idx[e]]);
                            t[e] = (ta[e] * gb[e] - tb[e] * ga[e]) / (gb[e] - ga[e]);
                            xs[e] = [
                                a[0] + t[e] * (b[0] - a[0]),
                                a[1] + t[e] * (b[1] - a[1]),
                                a[2] + t[e] * (b[2] - a[2]),
                            ];
                        }
                        if step == 0 {
                            near_a = dist(&xs, ts[l], &mut la);
                            near_b = dist(&xs, ts[l + 1], &mut lb);
                        } else {
                            again(&xs, ts[l], &near_a, &mut la);
                            again(&xs, ts[l + 1], &near_b, &mut lb);
                        }
                        for e in 0..n {
                            let gx = la[e] - lb[e];
                            let repl_a = sign(gx) == sign(ga[e]);
                            if !repl_a && last[e] == 2 {
                                ga[e] *= 0.5;
                            }
                            if repl_a && last[e] == 1 {
                                gb[e] *= 0.5;
                            }
                            if repl_a {
                                (ta[e], ga[e]) = (t[e], gx);
                            } else {
                                (tb[e], gb[e]) = (t[e], gx);
                            }
                            last[e] = if repl_a { 1 } else { 2 };
                        }
                    }
                    (0..n).map(|e| (xs[e], la[e], lb[e])).collect()
                })
                .collect();
            let mut rows = vec![([0.0f64; 3], f64::NAN, f64::NAN); k];
            for (&(u0, _), part) in units.iter().zip(parts) {
                for (e, r) in part.into_iter().enumerate() {
                    rows[order[u0 + e]] = r;
                }
            }
            rows
        })
    });
    let mut xs = Vec::with_capacity(3 * k);
    let (mut dl, mut dh) = (Vec::with_capacity(k), Vec::with_capacity(k));
    for (x, a, b) in rows {
        xs.extend_from_slice(&x);
        dl.push(a);
        dh.push(b);
    }
    Ok((
        PyArray1::from_vec(py, xs).reshape([k, 3])?,
        PyArray1::from_vec(py, dl),
        PyArray1::from_vec(py, dh),
    ))
}
