//! The k nearest points of a point cloud within a bound (`passes._Generator._nearest_samples`:
//! the 8 surface samples nearest a ball centre, scipy's `cKDTree.query(k, distance_upper_bound)`).
//!
//! A k-d tree of our own (parry has bounding-volume trees of shapes, not k-nearest queries
//! on points). Squared distances are summed as scipy's k-d tree sums them,
//! `(d0² + d1²) + d2²`, and a point counts when its squared distance is below the bound's
//! square, as in scipy. Among points at equal distance scipy's choice follows its own
//! traversal: the search here keeps the k + 1 nearest by (distance, id) and reports a row
//! whose k-th and (k + 1)-th are at the same distance, so that the caller asks scipy for
//! that row; every other row's set of k is scipy's.
//!
//! The tree over a mesh's samples (`PointTree::grouped`) splits on the vertices first and
//! keeps per node, leaf or split, a box in the frame of the surface patch (`Frame`): a ball
//! centre ρ off the surface is seen ρ away from the nodes around its contact, so fewer are
//! opened at every level (the screens of the 1M-triangle demo: 76 splits a query instead of
//! 160). Each node is one 128-byte record (`Rec`: both boxes and its children), and a split
//! bounds both children at once. Each pruning bound is a lower bound of the squared
//! distances as summed here, so the answers are those of the plain tree over the same
//! points.
//!
//! The framed tree answers many queries in packets of consecutive ones (`packet`: the ball
//! centres of a pass come in path order), the same answers as one at a time.

use crate::numpy_ops::cross;
use rayon::prelude::*;

mod packet;
pub use packet::PACKET;

pub type P3 = [f64; 3];

const LEAF: usize = 16;

/// Points per leaf of a [`PointTree::grouped`] tree: leaves with a [`Frame`] are opened less
/// often, and large ones bound best (the lift's nearest and the screens along 25 levels of
/// the demo and Rotor 37 at 1M: 16 points a leaf 1.4 / -, 32: 1.07 / 1.51, 64: 0.89 / 1.24,
/// 128: 0.84 / 1.26 s of CPU for the build and both searches; with frames on the splits too,
/// the demo's screens and 8-nearest: 32 points 365 / 556, 64: 356 / 558, 128: 376 / 630
/// million instructions).
const FRAME_LEAF: usize = 64;

/// Anchors below which [`PointTree::grouped`] builds a plain subtree over their groups' points
/// (a mesh vertex owns ~6 samples: ~6000 points, 200 kB to sort, in cache).
const GROUP_ANCHORS: usize = 1024;

/// The groups of [`PointTree::grouped`].
struct Groups<'a, F> {
    ptr: &'a [u32],
    members: &'a [u32],
    point: &'a F,
}

/// The tight box (lo (3), hi (3)) of points; empty: +∞ lows and −∞ highs (every query's
/// lower bound to it is +∞).
fn bounds<'a>(pts: impl Iterator<Item = &'a P3>) -> [f64; 6] {
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in pts {
        for j in 0..3 {
            b[j] = b[j].min(p[j]);
            b[j + 3] = b[j + 3].max(p[j]);
        }
    }
    b
}

/// The box (min xyz, max xyz) around the boxes a and b.
fn union(a: &[f64; 6], b: &[f64; 6]) -> [f64; 6] {
    [
        a[0].min(b[0]),
        a[1].min(b[1]),
        a[2].min(b[2]),
        a[3].max(b[3]),
        a[4].max(b[4]),
        a[5].max(b[5]),
    ]
}

/// The nodes of a split over the subtrees `ln` and `rn` (each numbered from 0): the split,
/// then the left subtree (its child 1), then the right, their children renumbered.
fn join(ln: Vec<Node>, rn: Vec<Node>) -> Vec<Node> {
    let nl = ln.len() as u32;
    let shift = |node: Node, by: u32| match node {
        Node::Split { left, right } => Node::Split {
            left: left + by,
            right: right + by,
        },
        leaf => leaf,
    };
    let mut nodes = Vec::with_capacity(1 + ln.len() + rn.len());
    nodes.push(Node::Split {
        left: 1,
        right: 1 + nl,
    });
    nodes.extend(ln.into_iter().map(|x| shift(x, 1)));
    nodes.extend(rn.into_iter().map(|x| shift(x, 1 + nl)));
    nodes
}

/// Queries per run of [`PointTree::knn_many`] (one seeded by the one before).
const SEEDED: usize = 64;

/// The buffers of [`PointTree::knn_seeded`]: the best (squared distance, id, position in
/// the tree's order) so far, and the walk's stack.
#[derive(Default)]
pub struct KnnBuffers {
    best: Vec<(f64, u32, u32)>,
    stack: Vec<(u32, f64)>,
}

/// A node while the tree is built (its [`Rec`] once built).
enum Node {
    /// points `start..end` of the tree order
    Leaf {
        start: u32,
        end: u32,
    },
    Split {
        left: u32,
        right: u32,
    },
}

pub struct PointTree {
    pts: Vec<P3>,  // in tree order (leaf ranges are contiguous)
    ids: Vec<u32>, // the input id of each
    recs: Vec<Rec>,
    /// whether the nodes have frames ([`PointTree::grouped`])
    framed: bool,
    /// 1.8 max |p_j| over the points (the scale of the frames' rounding)
    reach: f64,
}

/// A node: its [`Frame`] box (axes `u`, `v` and their cross product, as [`axes_of`] makes
/// them; an unbounded box when it has none), its axis-aligned box `bx` (lo (3), hi (3))
/// rounded outward to f32, and its children or points: 128 bytes, one aligned block (the
/// two bounds of a node in one place, where three arrays took three memory accesses).
#[repr(C, align(128))]
struct Rec {
    u: P3,
    v: P3,
    lo: [f64; 3],
    hi: [f64; 3],
    bx: [f32; 6],
    /// [`SPLIT`], or a leaf's first point
    a: u32,
    /// a split's right child (its left is the next node), or a leaf's end
    b: u32,
}

/// [`Rec::a`] of a split.
const SPLIT: u32 = u32::MAX;

/// The largest f32 at most x (x itself when NaN or −∞).
fn f32_down(x: f64) -> f32 {
    let y = x as f32;
    if (y as f64) > x {
        if y == 0.0 {
            -f32::from_bits(1)
        } else if y > 0.0 {
            f32::from_bits(y.to_bits() - 1)
        } else {
            f32::from_bits(y.to_bits() + 1)
        }
    } else {
        y
    }
}

/// The smallest f32 at least x.
fn f32_up(x: f64) -> f32 {
    -f32_down(-x)
}

/// The records of nodes (each split's left child right after it) with their boxes and
/// (when given) frames.
fn records(nodes: &[Node], boxes: &[[f64; 6]], frames: Option<&[Frame]>) -> Vec<Rec> {
    nodes
        .iter()
        .enumerate()
        .map(|(i, node)| {
            let b = &boxes[i];
            let (a, bb) = match *node {
                Node::Leaf { start, end } => (start, end),
                Node::Split { left, right } => {
                    debug_assert_eq!(left as usize, i + 1);
                    (SPLIT, right)
                }
            };
            let mut f = frames.map_or(NAN_FRAME, |f| f[i]);
            if !(f
                .axes
                .iter()
                .flatten()
                .chain(f.lo.iter())
                .chain(f.hi.iter())
                .all(|x| x.is_finite()))
            {
                // no frame: an unbounded box (every query's bound to it is 0)
                f.axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
                f.lo = [f64::NEG_INFINITY; 3];
                f.hi = [f64::INFINITY; 3];
            }
            Rec {
                u: f.axes[0],
                v: f.axes[1],
                lo: f.lo,
                hi: f.hi,
                bx: [
                    f32_down(b[0]),
                    f32_down(b[1]),
                    f32_down(b[2]),
                    f32_up(b[3]),
                    f32_up(b[4]),
                    f32_up(b[5]),
                ],
                a,
                b: bb,
            }
        })
        .collect()
}

/// A box around a node's points in a frame of their own: `axes` (unit, orthogonal within
/// 1e-14), the last the normal of the surface patch the points sample; `lo` ≤ axes[j]·p ≤
/// `hi` for every point p (the computed projection for a leaf's, the exact one for a
/// split's); `reach` = 1.8 max |p_j| (the scale of the projections' rounding). A ball centre
/// ρ off a surface lies ρ from the frame box of the nodes around its contact plus their
/// distance along the surface, which axis-aligned boxes (as thick as the patch is tilted) do
/// not show: the nodes the search must open are fewer.
#[derive(Clone, Copy)]
struct Frame {
    axes: [P3; 3],
    lo: [f64; 3],
    hi: [f64; 3],
    reach: f64,
}

/// A lower bound of the squared distance (as [`d2`] sums it) from `q` to every point in the
/// frame box of `r`: per axis the gap between q's projection and [lo, hi], less `margin`
/// (1e-11 of the projections' scale, [`PointTree::frame_margin`]: their rounding is below
/// 1e-15 of it; the axes are unit and orthogonal within 1e-14), the squares summed, less
/// 1e-9 of the sum (the frame's own rounding and `d2`'s are below 1e-13 of a squared
/// distance); a gap that is not a positive number counts 0 (an unbounded box bounds
/// nothing; a query of NaNs gets 0).
#[inline(always)]
fn frame_d2(q: &P3, r: &Rec, margin: f64) -> f64 {
    let n = cross(&r.u, &r.v);
    let mut sum = 0.0;
    for (j, a) in [&r.u, &r.v, &n].into_iter().enumerate() {
        let t = a[0] * q[0] + a[1] * q[1] + a[2] * q[2];
        let gap = max0(max(r.lo[j] - t, t - r.hi[j]) - margin);
        sum += gap * gap;
    }
    sum * (1.0 - 1e-9)
}

/// The larger of a and b (b when either is NaN: no bound).
#[inline(always)]
fn max(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
    }
}

/// x when positive, else 0 (NaN: 0).
#[inline(always)]
fn max0(x: f64) -> f64 {
    if x > 0.0 {
        x
    } else {
        0.0
    }
}

/// No frame (its record gets an unbounded box, see [`records`]).
const NAN_FRAME: Frame = Frame {
    axes: [[f64::NAN; 3]; 3],
    lo: [f64::NAN; 3],
    hi: [f64::NAN; 3],
    reach: f64::NAN,
};

/// Count, centroid (3) and scatter matrix (3, 3: the sum of (p − c)(p − c)ᵀ) of points, mm
/// and mm²; the axes of a split's [`Frame`] come from its children's merged.
#[derive(Clone, Copy, Default)]
struct Moments {
    n: f64,
    c: P3,
    m: [[f64; 3]; 3],
}

impl Moments {
    /// The moments of the union of two point sets.
    fn merge(&self, o: &Moments) -> Moments {
        let n = self.n + o.n;
        if self.n == 0.0 {
            return *o;
        }
        if o.n == 0.0 {
            return *self;
        }
        let wb = o.n / n;
        let d = [o.c[0] - self.c[0], o.c[1] - self.c[1], o.c[2] - self.c[2]];
        let c = [
            self.c[0] + wb * d[0],
            self.c[1] + wb * d[1],
            self.c[2] + wb * d[2],
        ];
        let f = self.n * o.n / n;
        let mut m = [[0.0f64; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] = self.m[a][b] + o.m[a][b] + f * d[a] * d[b];
            }
        }
        Moments { n, c, m }
    }
}

/// The [`Moments`] of points (zeros when none).
fn moments(pts: &[P3]) -> Moments {
    let k = pts.len() as f64;
    let mut c = [0.0f64; 3];
    for p in pts {
        for j in 0..3 {
            c[j] += p[j];
        }
    }
    if pts.is_empty() {
        return Moments::default();
    }
    for cj in c.iter_mut() {
        *cj /= k;
    }
    let mut m = [[0.0f64; 3]; 3];
    for p in pts {
        let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
        for a in 0..3 {
            for b in 0..3 {
                m[a][b] += d[a] * d[b];
            }
        }
    }
    Moments { n: k, c, m }
}

/// Whether axes are unit and orthogonal within `tol`.
fn orthonormal(axes: &[P3; 3], tol: f64) -> bool {
    let dot = |u: &P3, v: &P3| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    (0..3).all(|i| {
        (0..3).all(|j| {
            let e = dot(&axes[i], &axes[j]) - if i == j { 1.0 } else { 0.0 };
            e.abs() <= tol
        })
    })
}

/// The frame of a split, with no pass over its points: axes from its moments (the merged
/// moments of its children), its box around its children's: each child's points lie in its
/// axis-aligned box and, when it has one, in its frame box, so a·p lies in the sum of the
/// intervals a_k [lo_k, hi_k] and in that of (a·b_j) [lo_j, hi_j] (p = Σ (b_j·p) b_j to
/// 1e-12 of |p| for axes orthogonal within 1e-13); the bounds are widened by 4e-12 of the
/// reach, which covers that and their rounding, so lo ≤ a·p ≤ hi holds for the exact
/// projections. NaN when the axes do not come out or a point is not finite (the reach).
fn frame_around(mo: &Moments, bx: &[f64; 6], kids: [(&Frame, &[f64; 6]); 2]) -> Frame {
    let Some(axes) = axes_of(&mo.m) else {
        return NAN_FRAME;
    };
    let pmax = bx.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let reach = 1.8 * pmax;
    let margin = 4e-12 * reach;
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for (f, b) in kids {
        for i in 0..3 {
            let a = &axes[i];
            // over the axis-aligned box: exact bounds of a·p, summed
            let (mut l, mut h) = (0.0f64, 0.0f64);
            for k in 0..3 {
                let (x, y) = (a[k] * b[k], a[k] * b[k + 3]);
                l += x.min(y);
                h += x.max(y);
            }
            // over the child's frame box: p = Σ (b_j·p) b_j within the axes' orthogonality
            if f.reach.is_finite() && orthonormal(&f.axes, 1e-13) {
                let (mut fl, mut fh) = (0.0f64, 0.0f64);
                for j in 0..3 {
                    let cj = a[0] * f.axes[j][0] + a[1] * f.axes[j][1] + a[2] * f.axes[j][2];
                    let (x, y) = (cj * f.lo[j], cj * f.hi[j]);
                    fl += x.min(y);
                    fh += x.max(y);
                }
                l = l.max(fl);
                h = h.min(fh);
            }
            lo[i] = lo[i].min(l - margin);
            hi[i] = hi[i].max(h + margin);
        }
    }
    if !(lo.iter().chain(hi.iter()).all(|x| x.is_finite()) && reach.is_finite()) {
        return NAN_FRAME;
    }
    Frame {
        axes,
        lo,
        hi,
        reach,
    }
}

/// The [`Frame`] of points (≥ 3 not on one line, all finite), else None: the normal of the
/// plane their covariance spans most (the largest cross product of two of its rows), the
/// first axis along the covariance row of largest spread across it.
fn frame_of(pts: &[P3]) -> Option<Frame> {
    if pts.len() < 3 {
        return None;
    }
    let m = moments(pts).m;
    let axes = axes_of(&m)?;
    frame_on(pts, axes)
}

/// The axes of a scatter matrix (see [`frame_of`]): u, v, and their cross product (the
/// records keep u and v and recompute it, the same bits); None unless unit and orthogonal
/// within 1e-14.
fn axes_of(m: &[[f64; 3]; 3]) -> Option<[P3; 3]> {
    let dot = |u: &P3, v: &P3| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let unit = |x: P3| -> Option<P3> {
        let l = dot(&x, &x);
        if !(l > 0.0 && l.is_finite()) {
            return None;
        }
        let l = l.sqrt();
        Some([x[0] / l, x[1] / l, x[2] / l])
    };
    let mut n = [0.0f64; 3];
    let mut best = 0.0f64;
    for (u, v) in [(0, 1), (1, 2), (2, 0)] {
        let x = cross(&m[u], &m[v]);
        let l = dot(&x, &x);
        if l > best {
            best = l;
            n = x;
        }
    }
    let n = unit(n)?;
    let row = (0..3)
        .max_by(|&a, &b| dot(&m[a], &m[a]).total_cmp(&dot(&m[b], &m[b])))
        .unwrap();
    let r = m[row];
    let along = dot(&r, &n);
    let u = unit([
        r[0] - along * n[0],
        r[1] - along * n[1],
        r[2] - along * n[2],
    ])?;
    let v = unit(cross(&n, &u))?;
    let axes = [u, v, cross(&u, &v)];
    orthonormal(&axes, 1e-14).then_some(axes)
}

/// The frame box of points on given axes (None when a projection is not finite).
fn frame_on(pts: &[P3], axes: [P3; 3]) -> Option<Frame> {
    let (mut lo, mut hi, mut pmax) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], 0.0f64);
    for p in pts {
        for j in 0..3 {
            let t = axes[j][0] * p[0] + axes[j][1] * p[1] + axes[j][2] * p[2];
            lo[j] = lo[j].min(t);
            hi[j] = hi[j].max(t);
        }
        pmax = pmax.max(p[0].abs()).max(p[1].abs()).max(p[2].abs());
    }
    let reach = 1.8 * pmax;
    if !(lo.iter().chain(hi.iter()).all(|x| x.is_finite()) && reach.is_finite()) {
        return None;
    }
    Some(Frame {
        axes,
        lo,
        hi,
        reach,
    })
}

/// Squared distance from q to a box, a lower bound of the squared distance (as summed by
/// [`d2`]) to every point in it: each gap rounds below the point's difference.
#[inline(always)]
fn box_d2(q: &P3, b: &[f32; 6]) -> f64 {
    let mut g = [0.0f64; 3];
    for j in 0..3 {
        g[j] = max0(max(b[j] as f64 - q[j], q[j] - b[j + 3] as f64));
    }
    (g[0] * g[0] + g[1] * g[1]) + g[2] * g[2]
}

/// The smallest [`d2`] from q to the points (+∞ when none; NaNs skipped).
#[inline(always)]
fn min_d2(q: &P3, pts: &[P3]) -> f64 {
    let mut m = [f64::INFINITY; 4];
    let mut it = pts.chunks_exact(4);
    for c in &mut it {
        for j in 0..4 {
            let d = d2(q, &c[j]);
            m[j] = if d < m[j] { d } else { m[j] };
        }
    }
    for p in it.remainder() {
        let d = d2(q, p);
        m[0] = if d < m[0] { d } else { m[0] };
    }
    let a = if m[1] < m[0] { m[1] } else { m[0] };
    let b = if m[3] < m[2] { m[3] } else { m[2] };
    if b < a {
        b
    } else {
        a
    }
}

#[inline(always)]
fn d2(a: &P3, b: &P3) -> f64 {
    let (x, y, z) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    (x * x + y * y) + z * z
}

/// (squared distance, id) of a best entry as integers: the distances kept are below a bound
/// (not NaN) and sums of squares (not −0), so their bits order them as the floats.
#[inline(always)]
fn key(d: f64, i: u32) -> (u64, u32) {
    (d.to_bits(), i)
}

/// Puts the point at tree position `s` (id `i`, squared distance `d` below the bound) into
/// `best`, the `cap` smallest (squared distance, id, position) so far in ascending order,
/// when it ranks among them and is not held already (a seed met again in its leaf, at its
/// own (distance, id)). By insertion from the end (the lists are short).
#[inline(always)]
fn offer(best: &mut Vec<(f64, u32, u32)>, cap: usize, d: f64, i: u32, s: u32) {
    let kd = key(d, i);
    let n = best.len();
    if n == cap && kd >= key(best[n - 1].0, best[n - 1].1) {
        return;
    }
    let mut j = n;
    while j > 0 && key(best[j - 1].0, best[j - 1].1) > kd {
        j -= 1;
    }
    if j > 0 && best[j - 1].2 == s {
        return; // the same point: the same (distance, id)
    }
    if n < cap {
        best.push((d, i, s));
    }
    let mut t = best.len() - 1;
    while t > j {
        best[t] = best[t - 1];
        t -= 1;
    }
    best[j] = (d, i, s);
}

/// The k-d split of `idx` (each item's point first) across the widest side of `region`: the
/// median position `m` (items partially sorted about it) and the two halves' regions.
fn median_split(idx: &mut [(P3, u32)], region: [f64; 6]) -> (usize, [f64; 6], [f64; 6]) {
    let ext = |j: usize| region[j + 3] - region[j];
    let dim = (0..3).max_by(|&a, &b| ext(a).total_cmp(&ext(b))).unwrap();
    let m = idx.len() / 2;
    idx.select_nth_unstable_by(m, |a, b| a.0[dim].total_cmp(&b.0[dim]));
    let val = idx[m].0[dim];
    let (mut lr, mut rr) = (region, region);
    lr[dim + 3] = val;
    rr[dim] = val;
    (m, lr, rr)
}

impl PointTree {
    pub fn new(pts: Vec<P3>) -> Self {
        // the points move with their ids (contiguous, not gathered through an index)
        let mut items: Vec<(P3, u32)> = pts
            .iter()
            .enumerate()
            .map(|(i, p)| (*p, i as u32))
            .collect();
        drop(pts);
        let (nodes, boxes) = if items.is_empty() {
            (Vec::new(), Vec::new())
        } else {
            let region = bounds(items.iter().map(|x| &x.0));
            Self::build(&mut items, 0, region, LEAF)
        };
        let ids = items.iter().map(|x| x.1).collect();
        let sorted = items.into_iter().map(|x| x.0).collect();
        PointTree {
            pts: sorted,
            ids,
            recs: records(&nodes, &boxes, None),
            framed: false,
            reach: 0.0,
        }
    }

    /// The subtree of the points `idx` (at `offset` in the tree order) inside `region`:
    /// split at the median along the region's longest side (the two halves built in
    /// parallel when large); each node's box is the tight box of its points (bottom-up).
    fn build(
        idx: &mut [(P3, u32)],
        offset: usize,
        region: [f64; 6],
        leaf: usize,
    ) -> (Vec<Node>, Vec<[f64; 6]>) {
        if idx.len() <= leaf {
            let b = bounds(idx.iter().map(|x| &x.0));
            let leaf = Node::Leaf {
                start: offset as u32,
                end: (offset + idx.len()) as u32,
            };
            return (vec![leaf], vec![b]);
        }
        let (m, lr, rr) = median_split(idx, region);
        let n = idx.len();
        let (l, r) = idx.split_at_mut(m);
        let ((ln, lb), (rn, rb)) = if n > 50_000 {
            rayon::join(
                || Self::build(l, offset, lr, leaf),
                || Self::build(r, offset + m, rr, leaf),
            )
        } else {
            (
                Self::build(l, offset, lr, leaf),
                Self::build(r, offset + m, rr, leaf),
            )
        };
        let mut boxes = Vec::with_capacity(1 + lb.len() + rb.len());
        boxes.push(union(&lb[0], &rb[0]));
        boxes.extend(lb);
        boxes.extend(rb);
        let nodes = join(ln, rn);
        (nodes, boxes)
    }

    /// A tree over points that come in groups, each near its anchor (a mesh vertex with the
    /// edge midpoints and face centroids it owns, `mesh_samples::sample_point_tree`): the
    /// upper splits are made on the anchors alone (a sixth of a mesh's samples: the passes
    /// over the whole data that make a k-d tree's build slow sort a sixth of it), down to
    /// [`GROUP_ANCHORS`] anchors; below, the points of those anchors' groups get the
    /// subtree of [`PointTree::new`] (small enough to stay in cache), so the leaves and
    /// their boxes are as tight as a plain tree's. The group of anchor `a` is
    /// `members[ptr[a]..ptr[a + 1]]`, point ids whose coordinates are `point(id)`. The points
    /// and ids are those [`PointTree::new`] is given for the same samples, and a query's
    /// answer is a property of the point set, not of the tree's shape (see
    /// [`PointTree::knn_seeded`] and [`PointTree::any_below`]): the same answers, from less
    /// work and less memory (no (point, id) copy of every sample at once, no subtree's nodes
    /// and boxes copied into its parent's). Every node gets a [`Frame`]: a leaf's from its
    /// points, a split's from its children's ([`frame_around`]: O(1) a split, no pass over
    /// its points).
    pub fn grouped(
        anchors: &[P3],
        ptr: Vec<u32>,
        members: Vec<u32>,
        point: &(impl Fn(u32) -> P3 + Sync),
    ) -> Self {
        let total = ptr[anchors.len()] as usize;
        let mut items: Vec<(P3, u32)> = anchors
            .iter()
            .enumerate()
            .map(|(i, p)| (*p, i as u32))
            .collect();
        let mut pts = vec![[0.0f64; 3]; total];
        let mut ids = vec![0u32; total];
        let nodes = if total == 0 {
            Vec::new()
        } else {
            let region = bounds(items.iter().map(|x| &x.0));
            let g = Groups {
                ptr: &ptr,
                members: &members,
                point,
            };
            Self::split_groups(&mut items, &mut pts, &mut ids, 0, region, &g)
        };
        // freed before the boxes are made (the build's peak memory); the tight boxes go
        // bottom-up (a node's children come after it) into one array, no subtree's boxes
        // copied into its parent's
        drop((items, ptr, members));
        // the leaves' boxes and frames in parallel (each of its own points), then the splits'
        // boxes bottom-up; a leaf whose points span no plane gets a frame of NaNs (no bound)
        let mut boxes = vec![[0.0f64; 6]; nodes.len()];
        boxes
            .par_iter_mut()
            .zip(nodes.par_iter())
            .with_min_len(1024)
            .for_each(|(b, node)| {
                if let Node::Leaf { start, end, .. } = node {
                    *b = bounds(pts[*start as usize..*end as usize].iter());
                }
            });
        for i in (0..nodes.len()).rev() {
            if let Node::Split { left, right, .. } = nodes[i] {
                boxes[i] = union(&boxes[left as usize], &boxes[right as usize]);
            }
        }
        // every node gets a frame: each leaf's of its points (with their moments, in
        // parallel), each split's axes from its children's merged moments and its box around
        // its children's boxes (the frame boxes, else the axis-aligned ones), bottom-up
        let mut leaf_ranges: Vec<(u32, u32)> = Vec::new();
        for node in nodes.iter() {
            if let Node::Leaf { start, end } = node {
                leaf_ranges.push((*start, *end));
            }
        }
        let leaf_frames: Vec<(Moments, Frame)> = leaf_ranges
            .par_iter()
            .with_min_len(256)
            .map(|&(a, b)| {
                let sub = &pts[a as usize..b as usize];
                (moments(sub), frame_of(sub).unwrap_or(NAN_FRAME))
            })
            .collect();
        let mut mom: Vec<Moments> = Vec::with_capacity(nodes.len());
        let mut frames: Vec<Frame> = Vec::with_capacity(nodes.len());
        let mut li = 0;
        for node in nodes.iter() {
            if let Node::Leaf { .. } = node {
                let (m, f) = &leaf_frames[li];
                mom.push(*m);
                frames.push(*f);
                li += 1;
            } else {
                mom.push(Moments::default());
                frames.push(NAN_FRAME);
            }
        }
        drop(leaf_frames);
        for i in (0..nodes.len()).rev() {
            if let Node::Split { left, right, .. } = nodes[i] {
                let (l, r) = (left as usize, right as usize);
                mom[i] = mom[l].merge(&mom[r]);
                let (fl, fr) = (frames[l], frames[r]);
                frames[i] = frame_around(&mom[i], &boxes[i], [(&fl, &boxes[l]), (&fr, &boxes[r])]);
            }
        }
        drop(mom);
        let recs = records(&nodes, &boxes, Some(&frames));
        let reach = boxes.first().map_or(0.0, |b| {
            1.8 * b.iter().fold(
                0.0f64,
                |a, x| if x.is_finite() { a.max(x.abs()) } else { a },
            )
        });
        PointTree {
            pts,
            ids,
            recs,
            framed: true,
            reach,
        }
    }

    /// The subtree of the groups of anchors `idx` inside `region`, their points written to
    /// `pts`, `ids` (at `offset` in the tree order): see [`PointTree::grouped`].
    fn split_groups<F: Fn(u32) -> P3 + Sync>(
        idx: &mut [(P3, u32)],
        pts: &mut [P3],
        ids: &mut [u32],
        offset: usize,
        region: [f64; 6],
        g: &Groups<'_, F>,
    ) -> Vec<Node> {
        let size = |a: u32| (g.ptr[a as usize + 1] - g.ptr[a as usize]) as usize;
        if idx.len() <= GROUP_ANCHORS {
            let mut items: Vec<(P3, u32)> = Vec::with_capacity(pts.len());
            for (_, a) in idx.iter() {
                for &m in &g.members[g.ptr[*a as usize] as usize..g.ptr[*a as usize + 1] as usize] {
                    items.push(((g.point)(m), m));
                }
            }
            if items.is_empty() {
                // anchors without points: an empty leaf no query enters (its box is empty)
                return vec![Node::Leaf {
                    start: offset as u32,
                    end: offset as u32,
                }];
            }
            let tight = bounds(items.iter().map(|x| &x.0));
            let (sub, _) = Self::build(&mut items, offset, tight, FRAME_LEAF);
            for ((p, i), (q, m)) in pts.iter_mut().zip(ids.iter_mut()).zip(items) {
                *p = q;
                *i = m;
            }
            return sub;
        }
        let (m, lr, rr) = median_split(idx, region);
        let n = idx.len();
        let (l, r) = idx.split_at_mut(m);
        let nl_pts: usize = l.iter().map(|x| size(x.1)).sum();
        let (lp, rp) = pts.split_at_mut(nl_pts);
        let (li, ri) = ids.split_at_mut(nl_pts);
        let (ln, rn) = if n > 8_192 {
            rayon::join(
                || Self::split_groups(l, lp, li, offset, lr, g),
                || Self::split_groups(r, rp, ri, offset + nl_pts, rr, g),
            )
        } else {
            (
                Self::split_groups(l, lp, li, offset, lr, g),
                Self::split_groups(r, rp, ri, offset + nl_pts, rr, g),
            )
        };
        join(ln, rn)
    }

    /// The (up to) k nearest ids of `q` with squared distance below `ub2`, by (distance,
    /// id), into `out`; and whether the k-th and the (k + 1)-th are at the same distance.
    /// Seeded with the points `buf` holds from the query before (a query near the one before
    /// starts with their distances as its bound, and so opens fewer nodes; a fresh `buf`: no
    /// seeds).
    /// The answer is the same whatever the seeds: the k + 1 smallest (distance, id) pairs
    /// below `ub2` are one set, each point enters it once (a seed met again in its leaf is
    /// skipped), and a node is skipped only when its lower bound ([`PointTree::lower_d2`])
    /// is above the (k + 1)-th smallest pair so far, which no point in it can then beat.
    /// Leaves in `buf` the answer's points, for the next query's seeds.
    pub fn knn_seeded(
        &self,
        q: &P3,
        k: usize,
        ub2: f64,
        out: &mut [i64],
        buf: &mut KnnBuffers,
    ) -> bool {
        let cap = k + 1;
        let KnnBuffers { best, stack } = buf;
        // the seeds: the previous answer's points at their distances from q
        for e in best.iter_mut() {
            e.0 = d2(q, &self.pts[e.2 as usize]);
        }
        best.retain(|e| e.0 < ub2);
        // in order by insertion (a query near the one before: nearly in order already)
        for j in 1..best.len() {
            let e = best[j];
            let mut t = j;
            while t > 0 && key(best[t - 1].0, best[t - 1].1) > key(e.0, e.1) {
                best[t] = best[t - 1];
                t -= 1;
            }
            best[t] = e;
        }
        best.truncate(cap);
        if !self.recs.is_empty() {
            let qs = self.frame_margin(q);
            // a node is kept while its lower bound can hold a point of the answer
            let live = |l2: f64, best: &Vec<(f64, u32, u32)>| {
                l2 < ub2 && !(best.len() == cap && l2 > best[cap - 1].0)
            };
            stack.clear();
            let l0 = self.lower_d2(q, 0, qs, |l2| live(l2, best));
            if live(l0, best) {
                stack.push((0, l0));
            }
            while let Some((n, l2)) = stack.pop() {
                if !live(l2, best) {
                    continue; // the bound has come down since it was pushed
                }
                let r = &self.recs[n as usize];
                // Ok: a leaf's points; Err: a split's right child (its left is n + 1)
                match (r.a != SPLIT).then_some((r.a, r.b)).ok_or(r.b) {
                    Ok((start, end)) => {
                        let (a, b) = (start as usize, end as usize);
                        // a point farther than `cut` cannot enter: the bound, or the
                        // (k + 1)-th's distance once there are k + 1
                        let mut cut = if best.len() == cap {
                            best[cap - 1].0
                        } else {
                            ub2
                        };
                        for (j, (p, &i)) in self.pts[a..b].iter().zip(&self.ids[a..b]).enumerate() {
                            let d = d2(q, p);
                            if !(d <= cut && d < ub2) {
                                continue;
                            }
                            offer(best, cap, d, i, (a + j) as u32);
                            if best.len() == cap {
                                cut = best[cap - 1].0;
                            }
                        }
                    }
                    Err(right) => {
                        let left = n + 1;
                        // both children's bounds at once (their loads overlap); the nearer
                        // is searched first
                        let dl = self.lower_d2(q, left, qs, |l2| live(l2, best));
                        let dr = self.lower_d2(q, right, qs, |l2| live(l2, best));
                        let (near, far) = if dl <= dr {
                            ((left, dl), (right, dr))
                        } else {
                            ((right, dr), (left, dl))
                        };
                        if live(far.1, best) {
                            stack.push(far);
                        }
                        if live(near.1, best) {
                            stack.push(near);
                        }
                    }
                }
            }
        }
        for (j, o) in out.iter_mut().enumerate() {
            *o = if j < best.len().min(k) {
                best[j].1 as i64
            } else {
                -1
            };
        }
        best.len() == cap && best[k - 1].0 == best[k].0
    }

    /// [`frame_d2`]'s margin for the query q: 1e-11 of the projections' scale, the tree's
    /// reach (≥ every frame's, see [`Frame`]) plus 1.8 max |q_j|.
    #[inline(always)]
    fn frame_margin(&self, q: &P3) -> f64 {
        1e-11 * (self.reach + 1.8 * q[0].abs().max(q[1].abs()).max(q[2].abs()))
    }

    /// A lower bound of the squared distance (as [`d2`] sums it) from `q` to every point of
    /// node `n`: its box's, or its frame's where larger (`qs`: [`PointTree::frame_margin`]);
    /// the frame's only when the box's leaves the node `live` (else the node is skipped
    /// either way).
    #[inline(always)]
    fn lower_d2(&self, q: &P3, n: u32, qs: f64, live: impl Fn(f64) -> bool) -> f64 {
        let r = &self.recs[n as usize];
        let b = box_d2(q, &r.bx);
        if self.framed && live(b) {
            b.max(frame_d2(q, r, qs))
        } else {
            b
        }
    }

    /// Whether some point lies at a squared distance (summed as in [`d2`]) below `ub2` from
    /// `q`: scipy's `isfinite(query(q, k=1, distance_upper_bound=sqrt(ub2))[0])`.
    pub fn any_below(&self, q: &P3, ub2: f64, stack: &mut Vec<u32>) -> bool {
        if self.recs.is_empty() {
            return false;
        }
        let qs = self.frame_margin(q);
        // every node on the stack has a lower bound below ub2 (see lower_d2)
        let live = |l2: f64| l2 < ub2;
        if !live(self.lower_d2(q, 0, qs, live)) {
            return false;
        }
        stack.clear();
        stack.push(0);
        while let Some(n) = stack.pop() {
            let r = &self.recs[n as usize];
            // Ok: a leaf's points; Err: a split's right child (its left is n + 1)
            match (r.a != SPLIT).then_some((r.a, r.b)).ok_or(r.b) {
                Ok((start, end)) => {
                    if min_d2(q, &self.pts[start as usize..end as usize]) < ub2 {
                        return true;
                    }
                }
                Err(right) => {
                    let left = n + 1;
                    // both children's bounds at once (their loads overlap); the nearer is
                    // searched first (a hit ends the search)
                    let dl = self.lower_d2(q, left, qs, live);
                    let dr = self.lower_d2(q, right, qs, live);
                    let (near, far) = if dl <= dr {
                        ((left, dl), (right, dr))
                    } else {
                        ((right, dr), (left, dl))
                    };
                    if far.1 < ub2 {
                        stack.push(far.0);
                    }
                    if near.1 < ub2 {
                        stack.push(near.0);
                    }
                }
            }
        }
        false
    }

    /// (ids (q × k), tie (q)): [`PointTree::knn_seeded`] of each query, in packets of
    /// consecutive ones ([`PointTree::knn_runs`]) when the tree has frames or `packets` is
    /// asked (queries in path order: on a plain tree over ~800 level points, the column
    /// neighbours of a Rotor 37 plan, 0.054 s of CPU one by one, 0.034 in packets), else
    /// one by one; the same answers either way.
    pub fn knn_many(&self, qs: &[P3], k: usize, ub2: f64, packets: bool) -> (Vec<i64>, Vec<bool>) {
        let mut ids = vec![-1i64; qs.len() * k];
        let mut tie = vec![false; qs.len()];
        if k == 0 {
            return (ids, tie);
        }
        if self.framed || packets {
            // each packet seeded by the answers of the one before
            self.knn_runs(
                qs,
                k,
                ub2,
                (&mut ids, k),
                (&mut tie, 1),
                |_, i, t, oi, ti| {
                    oi.copy_from_slice(i);
                    ti.copy_from_slice(t);
                },
            );
            return (ids, tie);
        }
        // runs of SEEDED queries in order, each seeded by the one before (queries come
        // along paths: neighbours), the runs in parallel; the answers do not depend on it
        ids.par_chunks_mut(k * SEEDED)
            .zip(tie.par_chunks_mut(SEEDED))
            .zip(qs.par_chunks(SEEDED))
            .for_each(|((o, t), q)| {
                let mut buf = KnnBuffers::default();
                for ((oi, ti), qi) in o.chunks_mut(k).zip(t.iter_mut()).zip(q.iter()) {
                    *ti = self.knn_seeded(qi, k, ub2, oi, &mut buf);
                }
            });
        (ids, tie)
    }

    /// [`PointTree::any_below`] of each query (in packets of consecutive queries when the
    /// tree has frames: see [`PointTree::any_below_packet`]), in parallel.
    pub fn any_below_many(&self, qs: &[P3], ub2: f64) -> Vec<bool> {
        let mut out = vec![false; qs.len()];
        if self.framed {
            out.par_chunks_mut(SEEDED)
                .zip(qs.par_chunks(SEEDED))
                .for_each(|(o, q)| {
                    let mut stack = Vec::new();
                    for (oi, qi) in o.chunks_mut(PACKET).zip(q.chunks(PACKET)) {
                        self.any_below_packet(qi, ub2, oi, &mut stack);
                    }
                });
        } else {
            out.par_iter_mut()
                .zip(qs.par_iter())
                .with_min_len(64)
                .for_each_init(Vec::new, |stack, (o, c)| *o = self.any_below(c, ub2, stack));
        }
        out
    }
}
