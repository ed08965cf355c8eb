//! Packet searches of a tree: up to [`PACKET`] consecutive queries walk it together
//! (`passes._Generator`'s ball centres on the framed tree of [`PointTree::grouped`], and on
//! plain trees the hints of `PolylineDistance` and the column neighbours of a scallop's
//! levels, come in path order, each near the one before, so they open nearly the same
//! nodes: on Rotor 37 at 1.29M triangles the 8-nearest searches of a packet of 8 found 7.4
//! of its queries live at each split they opened). A node is loaded, its frame's normal
//! made and its children ordered once for the packet, and the queries' lower bounds to both
//! children are made lane by lane with no branch (the loops vectorize); a query takes part
//! in a node only while its own bound leaves the node live. A leaf's points are taken one
//! by one, each point's squared distances to the packet's queries made lane by lane. A
//! child's bound for a query is the larger of its own and its parent's (both bound every
//! point of the child), so a query the parent was pruned for stays pruned below it. The
//! walk asks for a node's records or points as it is pushed (the tree of Rotor 37, 110 MB,
//! is not in cache).
//!
//! The answers are those of [`PointTree::knn_seeded`] and [`PointTree::any_below`] query by
//! query: the (k + 1) smallest (distance, id) pairs below the bound are one set whatever
//! the order the nodes are opened in, the seeds, or the lower bounds (each a lower bound of
//! the squared distances as [`d2`] sums them, which the lanes sum the same way: Rust fuses
//! no multiply-add); every node is popped once, so each point meets each query at most once
//! (a seed met again in its leaf is skipped, as there).

use rayon::prelude::*;

use super::{cross, d2, max0, offer, PointTree, Rec, P3, SEEDED, SPLIT};
use crate::prefetch::{prefetch_all, prefetch_line};

/// Queries a packet holds (the main thread's 8-nearest searches and screens of a Rotor 37
/// plan replayed, CPU s, one query at a time 0.21 / 0.13; packets of 2: 0.16 / 0.08, 4:
/// 0.12 / 0.065, 8: 0.14 / 0.08, 16: 0.16 / 0.12 — the larger the packet, the more of its
/// queries ride along nodes only one of them needs).
pub const PACKET: usize = 4;

/// Per query of a packet: a lower bound of the squared distance to a node's points (+∞ for
/// the slots a short packet leaves empty, and for the queries the node is pruned for).
type Lb = [f64; PACKET];

/// The buffers of [`PointTree::knn_packet`]: per query the best (squared distance, id,
/// position in the tree's order) so far, the walk's stack, and the seeds (positions: the
/// answer of the last query of the packet before).
#[derive(Default)]
pub struct PacketBuffers {
    best: [Vec<(f64, u32, u32)>; PACKET],
    stack: Vec<(u32, Lb)>,
    seeds: Vec<u32>,
}

/// The queries of a packet, coordinate by coordinate (mm), and their frame margins
/// ([`PointTree::frame_margin`]): each query's bounds to a node are made lane by lane.
struct Pk {
    x: [f64; PACKET],
    y: [f64; PACKET],
    z: [f64; PACKET],
    m: [f64; PACKET],
}

/// The larger of a and b (b when either is NaN), as [`super::max`].
#[inline(always)]
fn mx(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// The smallest finite-or-not entry of `lb` among the slots of `mask`, for ordering
/// children (+∞ when none).
#[inline(always)]
fn least(lb: &Lb, mask: u32) -> f64 {
    let mut m = f64::INFINITY;
    for (i, &x) in lb.iter().enumerate() {
        if mask >> i & 1 == 1 && x < m {
            m = x;
        }
    }
    m
}

impl PointTree {
    /// Asks for what opening node `n` reads (its children's records, or a leaf's points and
    /// ids): the walk is bound by the latency of those loads (the records and samples of
    /// Rotor 37 at 1.29M triangles, 110 MB, are not in cache), and the node is opened after
    /// the packet's work on its sibling or its parent's.
    #[inline(always)]
    fn prefetch_node(&self, n: u32) {
        let r = &self.recs[n as usize];
        if r.a == SPLIT {
            for c in [n as usize + 1, r.b as usize] {
                let p = &self.recs[c] as *const Rec as *const u8;
                prefetch_line(p);
                prefetch_line(p.wrapping_add(64));
            }
        } else {
            let (a, e) = (r.a as usize, r.b as usize);
            prefetch_all(&self.pts[a..e]);
            prefetch_all(&self.ids[a..e]);
        }
    }

    /// Pushes the children of the split `n` (its right child `right`) that hold a live
    /// query, the nearer last (searched first: the one whose least bound over its live
    /// queries is smaller), each with the packet's bounds there. A query not live at `n`
    /// (`mask`) gets +∞ in both children (they inherit it); `live` gives a child's live
    /// queries from its bounds.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn push_children(
        &self,
        pk: &Pk,
        n: u32,
        right: u32,
        lb: &Lb,
        mask: u32,
        live: impl Fn(&Lb) -> u32,
        stack: &mut Vec<(u32, Lb)>,
    ) {
        let mut pl = *lb;
        for (i, x) in pl.iter_mut().enumerate() {
            if mask >> i & 1 == 0 {
                *x = f64::INFINITY;
            }
        }
        let left = n + 1;
        let dl = self.packet_lb(pk, left, &pl);
        let dr = self.packet_lb(pk, right, &pl);
        let (ml, mr) = (live(&dl), live(&dr));
        let (near, far, mn, mf) = if least(&dl, ml) <= least(&dr, mr) {
            ((left, dl), (right, dr), ml, mr)
        } else {
            ((right, dr), (left, dl), mr, ml)
        };
        if mf != 0 {
            self.prefetch_node(far.0);
            stack.push(far);
        }
        if mn != 0 {
            self.prefetch_node(near.0);
            stack.push(near);
        }
    }

    /// Each query's lower bound to node `n`: the largest of its box's ([`super::box_d2`]), its
    /// frame's where the tree has frames ([`super::frame_d2`], the normal made once), and
    /// `parent`'s; each a lower bound of the squared distances to the node's points (see
    /// [`PointTree::lower_d2`]), made lane by lane with no branch.
    #[inline(always)]
    fn packet_lb(&self, p: &Pk, n: u32, parent: &Lb) -> Lb {
        let r = &self.recs[n as usize];
        let bx = r.bx.map(|v| v as f64);
        // lane by lane, one coordinate or axis at a time (the loops vectorize)
        let mut g = [[0.0f64; PACKET]; 3];
        for (j, c) in [&p.x, &p.y, &p.z].into_iter().enumerate() {
            for i in 0..PACKET {
                g[j][i] = max0(mx(bx[j] - c[i], c[i] - bx[j + 3]));
            }
        }
        let mut out = [0.0f64; PACKET];
        for i in 0..PACKET {
            out[i] = (g[0][i] * g[0][i] + g[1][i] * g[1][i]) + g[2][i] * g[2][i];
        }
        if self.framed {
            let nn = cross(&r.u, &r.v);
            let mut sum = [0.0f64; PACKET];
            for (j, a) in [&r.u, &r.v, &nn].into_iter().enumerate() {
                let (lo, hi) = (r.lo[j], r.hi[j]);
                for i in 0..PACKET {
                    let t = a[0] * p.x[i] + a[1] * p.y[i] + a[2] * p.z[i];
                    let gap = max0(mx(lo - t, t - hi) - p.m[i]);
                    sum[i] += gap * gap;
                }
            }
            for i in 0..PACKET {
                out[i] = mx(sum[i] * (1.0 - 1e-9), out[i]);
            }
        }
        for i in 0..PACKET {
            out[i] = mx(out[i], parent[i]);
        }
        out
    }

    /// The queries (q (m, 3), m ≤ [`PACKET`]) padded to a packet (the last repeated), and
    /// the bound +∞ for the empty slots (0 for the others).
    fn packet_of(&self, q: &[P3]) -> ([P3; PACKET], Pk, Lb) {
        debug_assert!(!q.is_empty() && q.len() <= PACKET);
        let mut qq = [q[0]; PACKET];
        let mut pk = Pk {
            x: [0.0; PACKET],
            y: [0.0; PACKET],
            z: [0.0; PACKET],
            m: [0.0; PACKET],
        };
        let mut l0 = [f64::INFINITY; PACKET];
        for i in 0..PACKET {
            let j = i.min(q.len() - 1);
            qq[i] = q[j];
            pk.x[i] = q[j][0];
            pk.y[i] = q[j][1];
            pk.z[i] = q[j][2];
            pk.m[i] = self.frame_margin(&q[j]);
            if i < q.len() {
                l0[i] = 0.0;
            }
        }
        (qq, pk, l0)
    }

    /// The k nearest ids below `ub2` of each of the queries `qs`, handed packet by packet to
    /// `visit(first, ids, tie, a, b)`: the packet's first query (its index in `qs`), its m
    /// queries' ids (m × k, by (distance, id), -1 padded) and tie flags (m), and its rows of
    /// the outputs `a` (`per_a` items a query) and `b` (`per_b`). Runs of [`SEEDED`]
    /// consecutive queries go in parallel, each in packets of [`PACKET`]
    /// ([`PointTree::knn_packet`], each packet seeded by the answers of the one before): the
    /// answers are those of [`PointTree::knn_seeded`] query by query, whatever the runs.
    #[allow(clippy::too_many_arguments)]
    pub fn knn_runs<A: Send, B: Send>(
        &self,
        qs: &[P3],
        k: usize,
        ub2: f64,
        (a, per_a): (&mut [A], usize),
        (b, per_b): (&mut [B], usize),
        visit: impl Fn(usize, &[i64], &[bool], &mut [A], &mut [B]) + Sync,
    ) {
        debug_assert!(k > 0 && a.len() == qs.len() * per_a && b.len() == qs.len() * per_b);
        a.par_chunks_mut(per_a * SEEDED)
            .zip(b.par_chunks_mut(per_b * SEEDED))
            .zip(qs.par_chunks(SEEDED))
            .enumerate()
            .for_each(|(r, ((ar, br), qr))| {
                let mut buf = PacketBuffers::default();
                let (mut ids, mut tie) = (vec![-1i64; k * PACKET], [false; PACKET]);
                for (j, ((ap, bp), q)) in ar
                    .chunks_mut(per_a * PACKET)
                    .zip(br.chunks_mut(per_b * PACKET))
                    .zip(qr.chunks(PACKET))
                    .enumerate()
                {
                    let m = q.len();
                    self.knn_packet(q, k, ub2, &mut ids[..m * k], &mut tie[..m], &mut buf);
                    visit(r * SEEDED + j * PACKET, &ids[..m * k], &tie[..m], ap, bp);
                }
            });
    }

    /// [`PointTree::knn_seeded`] for up to [`PACKET`] queries `q` at once: their k nearest
    /// ids below `ub2` into `out` (q.len() × k, -1 padded) and the ties into `tie`. Seeded by
    /// the answer of the last query of the packet before (`buf`; a fresh one: no seeds), and
    /// leaves this packet's last there: the nearest to the next packet's first queries, and
    /// k + 1 seeds a query to measure and order, where the union of the packet's answers
    /// (~10 for the k = 6 of `PolylineDistance`) cost more than the nodes they spared (its
    /// kernel on a Rotor 37 plan's calls replayed, CPU s: 0.195 with the union, 0.152 with
    /// the last answer; the sample tree's 8-nearest 0.102 / 0.097). The same answers as query
    /// by query (see the module).
    pub fn knn_packet(
        &self,
        q: &[P3],
        k: usize,
        ub2: f64,
        out: &mut [i64],
        tie: &mut [bool],
        buf: &mut PacketBuffers,
    ) {
        let m = q.len();
        let cap = k + 1;
        let (qq, pk, l0) = self.packet_of(q);
        let PacketBuffers { best, stack, seeds } = buf;
        // per query the seeds at their distances from it, the k + 1 smallest kept
        let mut lim = [f64::INFINITY; PACKET];
        for i in 0..m {
            let b = &mut best[i];
            b.clear();
            for &s in seeds.iter() {
                let d = d2(&qq[i], &self.pts[s as usize]);
                if !(d < ub2) {
                    continue;
                }
                offer(b, cap, d, self.ids[s as usize], s);
            }
            if b.len() == cap {
                lim[i] = b[cap - 1].0;
            }
        }
        let walk = Nearest {
            best,
            lim,
            cap,
            ub2,
        };
        let best = self.packet_walk(pk, l0, stack, walk).best;
        seeds.clear();
        for (i, b) in best.iter().enumerate().take(m) {
            let o = &mut out[i * k..(i + 1) * k];
            for (j, x) in o.iter_mut().enumerate() {
                *x = if j < b.len().min(k) {
                    b[j].1 as i64
                } else {
                    -1
                };
            }
            tie[i] = b.len() == cap && b[k - 1].0 == b[k].0;
        }
        seeds.extend(best[m - 1].iter().map(|e| e.2));
    }

    /// The walk of a packet's queries `pk` (their bounds at the root no less than `l0`) down
    /// the tree, on `stack`, returning `walk` after (taken and given back by value: its
    /// state stays in the walk's registers and frame): a node is opened for the queries `walk` finds live at it
    /// ([`PacketWalk::live`], asked again as it is popped: its bounds or answers may have
    /// changed since it was pushed), a leaf's points handed to [`PacketWalk::leaf`] (which
    /// may end the walk), a split's children pushed nearer last. The AVX2 build where the
    /// CPU has it (the bounds and distances four lanes at a time; the same arithmetic, Rust
    /// fuses no multiply-add).
    #[inline(always)]
    fn packet_walk<W: PacketWalk>(&self, pk: Pk, l0: Lb, stack: &mut Vec<(u32, Lb)>, walk: W) -> W {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2
            return unsafe { self.packet_walk_avx2(pk, l0, stack, walk) };
        }
        self.packet_walk_in(pk, l0, stack, walk)
    }

    /// [`PointTree::packet_walk`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn packet_walk_avx2<W: PacketWalk>(
        &self,
        pk: Pk,
        l0: Lb,
        stack: &mut Vec<(u32, Lb)>,
        walk: W,
    ) -> W {
        self.packet_walk_in(pk, l0, stack, walk)
    }

    #[inline(always)]
    fn packet_walk_in<W: PacketWalk>(
        &self,
        pk: Pk,
        l0: Lb,
        stack: &mut Vec<(u32, Lb)>,
        mut walk: W,
    ) -> W {
        if self.recs.is_empty() {
            return walk;
        }
        stack.clear();
        let r0 = self.packet_lb(&pk, 0, &l0);
        if walk.live(&r0) != 0 {
            stack.push((0, r0));
        }
        while let Some((n, lb)) = stack.pop() {
            let mask = walk.live(&lb);
            if mask == 0 {
                continue; // the bounds have come down, or its queries hit, since it was pushed
            }
            let r = &self.recs[n as usize];
            if r.a != SPLIT {
                if walk.leaf(self, &pk, mask, r.a as usize, r.b as usize) {
                    break;
                }
            } else {
                self.push_children(&pk, n, r.b, &lb, mask, |b| walk.live(b), stack);
            }
        }
        walk
    }

    /// The points `a..e` of a leaf into the `best` of the queries in `mask` (the k + 1 =
    /// `cap` smallest (distance, id) below `ub2` so far), as [`PointTree::knn_seeded`] takes
    /// them, point by point (each point's squared distances to the packet's queries made
    /// lane by lane, as [`d2`] sums them); each such query's (k + 1)-th distance after into
    /// `lim` (+∞ while fewer).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn leaf_into(
        &self,
        pk: &Pk,
        mask: u32,
        a: usize,
        e: usize,
        cap: usize,
        ub2: f64,
        best: &mut [Vec<(f64, u32, u32)>; PACKET],
        lim: &mut [f64; PACKET],
    ) {
        // a point farther than a query's cut cannot enter its best: the bound, or the
        // (k + 1)-th's distance once there are k + 1; −∞ for the queries not in mask
        let mut cut = [f64::NEG_INFINITY; PACKET];
        for i in 0..PACKET {
            if mask >> i & 1 == 1 {
                let b = &best[i];
                cut[i] = if b.len() == cap { b[cap - 1].0 } else { ub2 };
            }
        }
        for (j, p) in self.pts[a..e].iter().enumerate() {
            let mut d = [0.0f64; PACKET];
            let mut near = 0u32;
            for l in 0..PACKET {
                let (x, y, z) = (pk.x[l] - p[0], pk.y[l] - p[1], pk.z[l] - p[2]);
                d[l] = (x * x + y * y) + z * z;
                near |= ((d[l] <= cut[l] && d[l] < ub2) as u32) << l;
            }
            while near != 0 {
                let l = near.trailing_zeros() as usize;
                near &= near - 1;
                let b = &mut best[l];
                offer(b, cap, d[l], self.ids[a + j], (a + j) as u32);
                if b.len() == cap {
                    cut[l] = b[cap - 1].0;
                }
            }
        }
        for i in 0..PACKET {
            if mask >> i & 1 == 1 {
                let b = &best[i];
                lim[i] = if b.len() == cap {
                    b[cap - 1].0
                } else {
                    f64::INFINITY
                };
            }
        }
    }

    /// [`PointTree::any_below`] for up to [`PACKET`] queries `q` at once, into `out`.
    pub fn any_below_packet(
        &self,
        q: &[P3],
        ub2: f64,
        out: &mut [bool],
        stack: &mut Vec<(u32, Lb)>,
    ) {
        let m = q.len();
        let (_, pk, l0) = self.packet_of(q);
        let walk = AnyBelow {
            hit: [false; PACKET],
            m,
            ub2,
        };
        let walk = self.packet_walk(pk, l0, stack, walk);
        out[..m].copy_from_slice(&walk.hit[..m]);
    }
}

/// What a packet walk ([`PointTree::packet_walk`]) does: which queries a node is live for,
/// and what a leaf's points do to the answers.
trait PacketWalk {
    /// The queries (bit i: query i) live at a node with the bounds `lb`.
    fn live(&self, lb: &Lb) -> u32;
    /// The points `a..e` of a leaf for the queries of `mask`; true: the walk is done.
    fn leaf(&mut self, tree: &PointTree, pk: &Pk, mask: u32, a: usize, e: usize) -> bool;
}

/// The walk of [`PointTree::knn_packet`]: per query its k + 1 = `cap` smallest (squared
/// distance, id, position) below `ub2` so far (`best`) and the (k + 1)-th's distance (`lim`,
/// +∞ while fewer).
struct Nearest<'b> {
    best: &'b mut [Vec<(f64, u32, u32)>; PACKET],
    lim: [f64; PACKET],
    cap: usize,
    ub2: f64,
}

impl PacketWalk for Nearest<'_> {
    /// A query is live at a node while its bound there is below ub2 and not above its
    /// (k + 1)-th so far.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // lane by lane (the loop vectorizes)
    fn live(&self, lb: &Lb) -> u32 {
        let mut mask = 0u32;
        for i in 0..PACKET {
            mask |= ((lb[i] < self.ub2 && !(lb[i] > self.lim[i])) as u32) << i;
        }
        mask
    }

    #[inline(always)]
    fn leaf(&mut self, tree: &PointTree, pk: &Pk, mask: u32, a: usize, e: usize) -> bool {
        tree.leaf_into(pk, mask, a, e, self.cap, self.ub2, self.best, &mut self.lim);
        false
    }
}

/// The walk of [`PointTree::any_below_packet`]: per query whether a point below `ub2` has
/// been met (`hit`), for the packet's `m` queries.
struct AnyBelow {
    hit: [bool; PACKET],
    m: usize,
    ub2: f64,
}

impl PacketWalk for AnyBelow {
    /// A query is live at a node while its bound there is below ub2 and it has not hit.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // lane by lane (the loop vectorizes)
    fn live(&self, lb: &Lb) -> u32 {
        let mut mask = 0u32;
        for i in 0..PACKET {
            mask |= ((lb[i] < self.ub2 && !self.hit[i]) as u32) << i;
        }
        mask
    }

    /// Each point's squared distances to the packet's queries, lane by lane (as d2 sums
    /// them), the least per query; done when all the packet's queries have hit.
    #[inline(always)]
    fn leaf(&mut self, tree: &PointTree, pk: &Pk, mask: u32, a: usize, e: usize) -> bool {
        let mut least = [f64::INFINITY; PACKET];
        for p in &tree.pts[a..e] {
            for l in 0..PACKET {
                let (x, y, z) = (pk.x[l] - p[0], pk.y[l] - p[1], pk.z[l] - p[2]);
                let d = (x * x + y * y) + z * z;
                least[l] = if d < least[l] { d } else { least[l] };
            }
        }
        let m = self.m;
        for (i, h) in self.hit.iter_mut().enumerate().take(m) {
            if mask >> i & 1 == 1 && least[i] < self.ub2 {
                *h = true;
            }
        }
        self.hit[..m].iter().all(|&h| h)
    }
}
