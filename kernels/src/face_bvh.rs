//! The bounding-volume tree of [`crate::closest::FaceTree`]: a binary tree over runs of
//! faces consecutive along a Morton curve (split where the runs' codes first differ), each
//! node bounded by its box and, where that is smaller, by an oriented box whose first axis
//! is the normal of its faces (their summed area vectors).
//!
//! Why the oriented boxes: the faces of a node of a surface mesh lie on a thin curved sheet,
//! whose box is as thick as it is wide where the sheet is tilted. A point h mm off the sheet
//! opens every node whose bound is below h; with boxes, that is a ring of nodes whose faces
//! lie within about a box size of h, and on Rotor 37's dense blade (1.29M faces, 0.17 mm
//! edges) the link check's points, 5–21 mm off it, opened ~125 runs of faces and ~540 nodes
//! each (~100 µs a point). An oriented box is as thin as the sheet's sag across it, so its
//! bound is within that sag of the true distance (~30 runs, ~300 nodes). A node's bound is
//! the larger of its two boxes' (the oriented box is not kept where it is no smaller: the
//! root, folds), so the faces compared, and with them the answers, are those of any exact
//! search: only fewer nodes are opened.
//!
//! The oriented boxes are built bottom-up: a leaf's around its vertices (the in-plane axis
//! along its longest extent), a parent's around its children's boxes (exactly: a box of
//! centre c, axes a_i, half extents h_i spans c·e ± Σ h_i |a_i·e| along a unit e), in the
//! smaller of two frames — its normal with the world axis most across it, or the frame of
//! its child with the larger area (a frame turned in the plane by φ grows a child's box by
//! up to |cos φ| + |sin φ|: a frame of each node's own, e.g. along its children's centres,
//! compounded to twice the blade's size at the root) — padded for rounding.

use crate::numpy_ops::einsum_dot as dot;
use crate::numpy_ops::{cross, sub};

pub type P3 = [f64; 3];

/// `kids[0]` of a leaf (its run index is `kids[1]`).
const LEAF: u32 = u32::MAX;

const WORLD: [P3; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// An oriented box: centre, orthonormal axes, half extents.
type Obb = (P3, [P3; 3], P3);

/// A node while the tree is built: its box (lo, hi); its oriented box (centre c, axes a,
/// half extents h; h[0] = ∞: none, the box alone); the sum of its faces' area vectors.
#[derive(Clone, Copy)]
struct Node {
    bx: [f64; 6],
    c: P3,
    a: [P3; 3],
    h: P3,
    area: P3,
}

/// A node as the queries read it (80 bytes, parry's tree took 56 a node): its box rounded
/// outward to f32; its oriented box, holding the built one, in f32 — the centre as an
/// offset from the box's centre, the axes n, u (and n × u, computed), the half extents
/// rounded up (h[0] = ∞: none); its children (or [`LEAF`], run).
#[derive(Clone, Copy)]
struct Packed {
    lo: [f32; 3],
    hi: [f32; 3],
    off: [f32; 3],
    n: [f32; 3],
    u: [f32; 3],
    h: [f32; 3],
    kids: [u32; 2],
}

/// The f32 next to a non-NaN `y` towards +∞ (`up`) or −∞ (f32::next_up / next_down, which
/// need Rust 1.86).
fn step(y: f32, up: bool) -> f32 {
    if y == 0.0 {
        let t = f32::from_bits(1);
        return if up { t } else { -t };
    }
    let b = y.to_bits();
    f32::from_bits(if (y > 0.0) == up { b + 1 } else { b - 1 })
}

/// The f32 at or below x.
fn down(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) > x {
        step(y, false)
    } else {
        y
    }
}

/// The f32 at or above x.
fn up(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < x {
        step(y, true)
    } else {
        y
    }
}

fn wide(x: &[f32; 3]) -> P3 {
    [f64::from(x[0]), f64::from(x[1]), f64::from(x[2])]
}

impl Packed {
    /// The box's centre (the origin of the oriented box's offset).
    #[inline(always)]
    fn box_centre(lo: &P3, hi: &P3) -> P3 {
        [
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ]
    }

    /// The axes n, u, n × u (orthonormal to ~1e-7: f32 n and u).
    #[inline(always)]
    fn axes(n: &[f32; 3], u: &[f32; 3]) -> [P3; 3] {
        let (n, u) = (wide(n), wide(u));
        [n, u, cross(&n, &u)]
    }

    /// The node `nd` (built) with children `kids`, rounded outward: the oriented box in the
    /// rounded axes is the one around the built box (c·e ± Σ h_i |a_i·e| along each axis e),
    /// grown by the rounding of its centre and by 1e-9 of its extents.
    fn new(nd: &Node, kids: [u32; 2]) -> Self {
        let b = &nd.bx;
        let (lo, hi) = (
            [down(b[0]), down(b[1]), down(b[2])],
            [up(b[3]), up(b[4]), up(b[5])],
        );
        let mut p = Packed {
            lo,
            hi,
            off: [0.0; 3],
            n: [0.0; 3],
            u: [0.0; 3],
            h: [f32::INFINITY; 3],
            kids,
        };
        if nd.h[0] < f64::INFINITY {
            let n = nd.a[0].map(|x| x as f32);
            let u = nd.a[1].map(|x| x as f32);
            let ax = Self::axes(&n, &u);
            let bc = Self::box_centre(&wide(&lo), &wide(&hi));
            let off = sub(&nd.c, &bc).map(|x| x as f32);
            let c2 = [
                bc[0] + f64::from(off[0]),
                bc[1] + f64::from(off[1]),
                bc[2] + f64::from(off[2]),
            ];
            let e = sub(&nd.c, &c2);
            let moved = (e[0].abs() + e[1].abs() + e[2].abs()) * (1.0 + 1e-6);
            let sum = nd.h[0] + nd.h[1] + nd.h[2];
            let h = [0, 1, 2].map(|j| {
                let r = nd.h[0] * dot(&nd.a[0], &ax[j]).abs()
                    + nd.h[1] * dot(&nd.a[1], &ax[j]).abs()
                    + nd.h[2] * dot(&nd.a[2], &ax[j]).abs();
                up(r + moved + 1e-9 * (1.0 + sum))
            });
            if off.iter().chain(&h).all(|x| x.is_finite()) {
                (p.off, p.n, p.u, p.h) = (off, n, u, h);
            }
        }
        p
    }
}

impl Node {
    /// Its oriented box, or its box as one (world axes).
    fn obb(&self) -> Obb {
        if self.h[0] < f64::INFINITY {
            (self.c, self.a, self.h)
        } else {
            let b = &self.bx;
            (
                [
                    0.5 * (b[0] + b[3]),
                    0.5 * (b[1] + b[4]),
                    0.5 * (b[2] + b[5]),
                ],
                WORLD,
                [
                    0.5 * (b[3] - b[0]),
                    0.5 * (b[4] - b[1]),
                    0.5 * (b[5] - b[2]),
                ],
            )
        }
    }
}

/// The squared distance from a point to a box (lo, hi) (0 inside).
#[inline(always)]
fn box_d2(bx: &[f64; 6], p: &P3) -> f64 {
    let mut s = 0.0;
    for j in 0..3 {
        let e = (bx[j] - p[j]).max(p[j] - bx[3 + j]).max(0.0);
        s += e * e;
    }
    s
}

/// The unit vector of `a`, or 0 when it has no length (or is not finite).
fn unit(a: &P3) -> P3 {
    let l = dot(a, a).sqrt();
    if l > 0.0 && l.is_finite() {
        [a[0] / l, a[1] / l, a[2] / l]
    } else {
        [0.0; 3]
    }
}

/// The frame of a sheet of normal `n` (unit or 0): n, the in-plane part of `along` and their
/// cross product; None when n = 0 or `along` has no in-plane part.
fn frame(n: &P3, along: &P3) -> Option<[P3; 3]> {
    if *n == [0.0; 3] {
        return None;
    }
    let t = dot(along, n);
    let u = unit(&[
        along[0] - t * n[0],
        along[1] - t * n[1],
        along[2] - t * n[2],
    ]);
    if u == [0.0; 3] {
        return None;
    }
    let w = unit(&cross(n, &u));
    if w == [0.0; 3] {
        return None;
    }
    Some([*n, u, w])
}

/// The world axis most across `n`.
fn steady(n: &P3) -> P3 {
    let m = [n[0].abs(), n[1].abs(), n[2].abs()];
    if m[0] <= m[1] && m[0] <= m[2] {
        WORLD[0]
    } else if m[1] <= m[2] {
        WORLD[1]
    } else {
        WORLD[2]
    }
}

/// The oriented box of frame `a` around the ranges lo..hi along its axes, padded for the
/// rounding of the ranges, of the centre and of the axes' orthonormality (~1e-16 of the
/// coordinates) by 1e-9 of the extents and 1e-12 of the coordinates; None unless finite.
fn boxed(a: [P3; 3], lo: &P3, hi: &P3) -> Option<Obb> {
    let m = [
        0.5 * (lo[0] + hi[0]),
        0.5 * (lo[1] + hi[1]),
        0.5 * (lo[2] + hi[2]),
    ];
    let c = [
        m[0] * a[0][0] + m[1] * a[1][0] + m[2] * a[2][0],
        m[0] * a[0][1] + m[1] * a[1][1] + m[2] * a[2][1],
        m[0] * a[0][2] + m[1] * a[1][2] + m[2] * a[2][2],
    ];
    let scale = lo.iter().chain(hi).fold(0.0f64, |s, x| s.max(x.abs()));
    let ext = (hi[0] - lo[0]) + (hi[1] - lo[1]) + (hi[2] - lo[2]);
    let pad = 1e-9 * (1.0 + ext) + 1e-12 * scale;
    let h = [
        0.5 * (hi[0] - lo[0]) + pad,
        0.5 * (hi[1] - lo[1]) + pad,
        0.5 * (hi[2] - lo[2]) + pad,
    ];
    c.iter()
        .chain(&h)
        .all(|x| x.is_finite())
        .then_some((c, a, h))
}

fn volume(h: &P3) -> f64 {
    h[0] * h[1] * h[2]
}

/// The tree (nodes in depth-first order, the root first).
pub struct FaceBvh {
    nodes: Vec<Packed>,
}

impl FaceBvh {
    /// The tree of the runs of `run` faces of `order` (faces in Morton order, `keys` their
    /// codes, ascending) of the mesh (v, f).
    pub fn new(v: &[P3], f: &[[usize; 3]], order: &[u32], keys: &[u64], run: usize) -> Self {
        let runs = order.len().div_ceil(run);
        let mut b = Builder {
            v,
            f,
            order,
            run,
            keys: (0..runs).map(|i| keys[i * run]).collect(),
            nodes: Vec::with_capacity(2 * runs),
        };
        if runs > 0 {
            b.build(0, runs);
        }
        FaceBvh { nodes: b.nodes }
    }

    /// A lower bound of the squared distance from `p` to the faces of node `i`, exact enough
    /// to decide against `r2`: the box's when it is not below `r2`, else the larger of the
    /// box's and the oriented box's. The latter's axes are orthonormal to ~1e-7 (f32), so
    /// its sum s of squared overshoots along them is within a factor 1 + 1e-6 of a squared
    /// distance; less a rounding pad of 1e-9 of the lengths (the pad of `closest.rs`' face
    /// disks), as s − 2 pad max(s, 1) ≤ (√s − pad)².
    #[inline(always)]
    fn lower_d2(&self, i: u32, p: &P3, r2: f64) -> f64 {
        let nd = &self.nodes[i as usize];
        let (lo, hi) = (wide(&nd.lo), wide(&nd.hi));
        let b = box_d2(&[lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]], p);
        if !(b < r2 && nd.h[0] < f32::INFINITY) {
            return b;
        }
        let bc = Packed::box_centre(&lo, &hi);
        let d = [
            p[0] - (bc[0] + f64::from(nd.off[0])),
            p[1] - (bc[1] + f64::from(nd.off[1])),
            p[2] - (bc[2] + f64::from(nd.off[2])),
        ];
        let a = Packed::axes(&nd.n, &nd.u);
        let h = wide(&nd.h);
        let mut s = 0.0;
        for j in 0..3 {
            let e = dot(&d, &a[j]).abs() - h[j];
            if e > 0.0 {
                s += e * e;
            }
        }
        let s = s * (1.0 - 1e-6);
        let dd = dot(&d, &d);
        let pad = 1e-9 * (1.0 + dd.max(1.0) + (h[0] + h[1] + h[2]));
        let lb = s - 2.0 * pad * s.max(1.0);
        if lb > b {
            lb
        } else {
            b // (and for a NaN)
        }
    }

    /// Visit the leaves (runs) that may hold a face within the reach whose square is `r2`
    /// (f64::MAX: any): depth first, the nearer child first; `leaf(run)` compares its faces
    /// and returns the new squared reach (None: unchanged). A node is skipped when its bound
    /// is not below the squared reach of the moment (a NaN bound is opened).
    pub fn walk(&self, p: &P3, mut r2: f64, mut leaf: impl FnMut(u32) -> Option<f64>) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
        stack.push((0, self.lower_d2(0, p, r2)));
        while let Some((i, lb)) = stack.pop() {
            if lb >= r2 {
                continue;
            }
            let nd = &self.nodes[i as usize];
            if nd.kids[0] == LEAF {
                if let Some(x) = leaf(nd.kids[1]) {
                    r2 = r2.min(x);
                }
                continue;
            }
            let (a, b) = (nd.kids[0], nd.kids[1]);
            let (la, lb) = (self.lower_d2(a, p, r2), self.lower_d2(b, p, r2));
            // the nearer child on top
            let ((n0, l0), (n1, l1)) = if la <= lb {
                ((a, la), (b, lb))
            } else {
                ((b, lb), (a, la))
            };
            if l1 < r2 || l1.is_nan() {
                stack.push((n1, l1));
            }
            if l0 < r2 || l0.is_nan() {
                stack.push((n0, l0));
            }
        }
    }
}

struct Builder<'a> {
    v: &'a [P3],
    f: &'a [[usize; 3]],
    order: &'a [u32],
    run: usize,
    keys: Vec<u64>, // per run: its first face's Morton code
    nodes: Vec<Packed>,
}

impl Builder<'_> {
    /// The node of runs lo..hi: its id (its subtree follows it) and its bounds as built.
    fn build(&mut self, lo: usize, hi: usize) -> (u32, Node) {
        let id = self.nodes.len() as u32;
        self.nodes.push(Packed {
            lo: [0.0; 3],
            hi: [0.0; 3],
            off: [0.0; 3],
            n: [0.0; 3],
            u: [0.0; 3],
            h: [f32::INFINITY; 3],
            kids: [LEAF, lo as u32],
        }); // (a place for the node, filled below)
        let (nd, kids) = if hi - lo == 1 {
            (self.leaf(lo), [LEAF, lo as u32])
        } else {
            let mid = self.split(lo, hi);
            let (a, na) = self.build(lo, mid);
            let (b, nb) = self.build(mid, hi);
            (Self::parent(&na, &nb), [a, b])
        };
        self.nodes[id as usize] = Packed::new(&nd, kids);
        (id, nd)
    }

    /// Where runs lo..hi split: at the highest bit where their codes differ (the middle
    /// when all are equal).
    fn split(&self, lo: usize, hi: usize) -> usize {
        let (a, b) = (self.keys[lo], self.keys[hi - 1]);
        if a == b {
            return (lo + hi) / 2;
        }
        let mask = 1u64 << (63 - (a ^ b).leading_zeros());
        lo + self.keys[lo..hi].partition_point(|k| k & mask == 0)
    }

    /// Keep the oriented box `o` where it is smaller than the node's box.
    fn keep(nd: &mut Node, o: Option<Obb>) {
        let b = &nd.bx;
        let hb = [b[3] - b[0], b[4] - b[1], b[5] - b[2]];
        if let Some((c, a, h)) = o {
            if 8.0 * volume(&h) < volume(&hb) {
                (nd.c, nd.a, nd.h) = (c, a, h);
            }
        }
    }

    fn leaf(&self, r: usize) -> Node {
        let s = r * self.run;
        let faces = &self.order[s..(s + self.run).min(self.order.len())];
        let mut area = [0.0; 3];
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        let first = self.v[self.f[faces[0] as usize][0]];
        let mut far = [0.0; 3];
        let mut far2 = 0.0;
        for &fi in faces {
            let t = self.f[fi as usize];
            let (a, b, c) = (&self.v[t[0]], &self.v[t[1]], &self.v[t[2]]);
            let n = cross(&sub(b, a), &sub(c, a));
            for j in 0..3 {
                area[j] += n[j];
            }
            for x in [a, b, c] {
                for j in 0..3 {
                    lo[j] = lo[j].min(x[j]);
                    hi[j] = hi[j].max(x[j]);
                }
                let d = sub(x, &first);
                let dd = dot(&d, &d);
                if dd > far2 {
                    (far, far2) = (d, dd);
                }
            }
        }
        let mut nd = Node {
            bx: [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]],
            c: [0.0; 3],
            a: WORLD,
            h: [f64::INFINITY; 3],
            area,
        };
        if !(lo.iter().chain(&hi).all(|x| x.is_finite())) {
            return nd; // (a vertex not finite: the box alone, as for its parents)
        }
        // in-plane: along the longest extent from the first vertex
        let o = frame(&unit(&area), &far).and_then(|a| {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for &fi in faces {
                for &vi in &self.f[fi as usize] {
                    let x = &self.v[vi];
                    for j in 0..3 {
                        let t = dot(x, &a[j]);
                        lo[j] = lo[j].min(t);
                        hi[j] = hi[j].max(t);
                    }
                }
            }
            boxed(a, &lo, &hi)
        });
        Self::keep(&mut nd, o);
        nd
    }

    fn parent(na: &Node, nb: &Node) -> Node {
        let (aa, ab) = (na.area, nb.area);
        let area = [aa[0] + ab[0], aa[1] + ab[1], aa[2] + ab[2]];
        let mut nd = Node {
            bx: [0.0; 6],
            c: [0.0; 3],
            a: WORLD,
            h: [f64::INFINITY; 3],
            area,
        };
        for j in 0..3 {
            nd.bx[j] = na.bx[j].min(nb.bx[j]);
            nd.bx[3 + j] = na.bx[3 + j].max(nb.bx[3 + j]);
        }
        let (oa, ob) = (na.obb(), nb.obb());
        let finite = |o: &Obb| o.0.iter().chain(&o.2).all(|x| x.is_finite());
        if !(finite(&oa) && finite(&ob)) {
            return nd; // (a vertex not finite: the box alone)
        }
        // each child's box projected onto the axes e of a frame: c·e ± Σ h_i |a_i·e|
        let fit = |f: [P3; 3]| {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for (c, ax, h) in [&oa, &ob] {
                for j in 0..3 {
                    let m = dot(c, &f[j]);
                    let r = h[0] * dot(&ax[0], &f[j]).abs()
                        + h[1] * dot(&ax[1], &f[j]).abs()
                        + h[2] * dot(&ax[2], &f[j]).abs();
                    lo[j] = lo[j].min(m - r);
                    hi[j] = hi[j].max(m + r);
                }
            }
            boxed(f, &lo, &hi)
        };
        let n = unit(&area);
        let mut best: Option<Obb> = frame(&n, &steady(&n)).and_then(fit);
        // (and the frame of the child with the larger area: both children's cost ~8 % more
        // to build, and opened as many nodes on Rotor 37's link points)
        let k = if dot(&na.area, &na.area) >= dot(&nb.area, &nb.area) {
            na
        } else {
            nb
        };
        {
            if k.h[0] < f64::INFINITY {
                if let Some(o) = fit(k.a) {
                    if best.is_none_or(|x| volume(&o.2) < volume(&x.2)) {
                        best = Some(o);
                    }
                }
            }
        }
        Self::keep(&mut nd, best);
        nd
    }
}
