//! Nearest faces of a triangle mesh (`blisk_cam/core/geometry/distance.py::NearestFaces`):
//! for each point, the face at the least squared distance, the lowest face id among equal
//! ones. A bounding-volume tree of boxes and oriented boxes (`face_bvh.rs`) prunes; the
//! distances that decide are those of `closest.py::closest_on_triangles`, ported operation
//! for operation (every three-term dot product summed as numpy's einsum does,
//! `(x0 y0 + x2 y2) + x1 y1`), so the chosen face is the numpy reference's.

use crate::face_bvh::FaceBvh;
use crate::numpy_ops::einsum_dot as dot;
use crate::numpy_ops::nanmax;
use crate::numpy_ops::{cross, sub};
use rayon::prelude::*;

pub type P3 = [f64; 3];

/// `closest._triple`: n · (x × y) summed left to right.
#[inline(always)]
fn triple(n: &P3, x: &P3, y: &P3) -> f64 {
    n[0] * (x[1] * y[2] - x[2] * y[1])
        + n[1] * (x[2] * y[0] - x[0] * y[2])
        + n[2] * (x[0] * y[1] - x[1] * y[0])
}

/// np.clip(t, 0, 1): NaN stays NaN.
#[inline(always)]
pub(crate) fn clip01(t: f64) -> f64 {
    let t = if t < 0.0 { 0.0 } else { t };
    if t > 1.0 {
        1.0
    } else {
        t
    }
}

/// `closest_on_segments` for one point: (t, squared distance).
#[inline(always)]
fn on_segment(p: &P3, a: &P3, b: &P3) -> (f64, f64) {
    let d = sub(b, a);
    let dd = dot(&d, &d);
    let dd = if dd > 0.0 { dd } else { 1.0 };
    let t = clip01(dot(&sub(p, a), &d) / dd);
    let e = [
        p[0] - (a[0] + t * d[0]),
        p[1] - (a[1] + t * d[1]),
        p[2] - (a[2] + t * d[2]),
    ];
    (t, dot(&e, &e))
}

/// The squared distance `closest_on_triangles` returns for one point and one triangle:
/// [`triangle_closest`]'s, whose feature and barycentric work the compiler drops once it is
/// inlined here (the same operations, so the same bits).
#[inline(always)]
pub fn triangle_d2(p: &P3, a: &P3, b: &P3, c: &P3) -> f64 {
    triangle_closest(p, a, b, c).1
}

/// `closest_on_triangles` for one point and one triangle, operation for operation:
/// (closest point, squared distance, feature — 0 interior, 1..3 edge ab/bc/ca, 4..6 vertex
/// a/b/c —, barycentric coordinates).
#[inline(always)]
pub fn triangle_closest(p: &P3, a: &P3, b: &P3, c: &P3) -> (P3, f64, i8, P3) {
    let ab = sub(b, a);
    let bc = sub(c, b);
    let ca = sub(a, c);
    let (lab, lbc, lca) = (dot(&ab, &ab), dot(&bc, &bc), dot(&ca, &ca));
    let c_long = lab >= lbc && lab >= lca;
    let a_long = lbc >= lca;
    let x = if c_long {
        bc
    } else if a_long {
        ca
    } else {
        ab
    };
    let y = if c_long {
        ca
    } else if a_long {
        ab
    } else {
        bc
    };
    let n = cross(&x, &y);
    let nn = dot(&n, &n);
    let m = nanmax(nanmax(lab, lbc), lca);
    let ok = nn > 1e-24 * (m * m);
    let inv = if ok { 1.0 / nn } else { 0.0 };
    let s = dot(&sub(a, p), &n) * inv;
    let q_in = [p[0] + s * n[0], p[1] + s * n[1], p[2] + s * n[2]];
    let (qa, qb, qc) = (sub(a, &q_in), sub(b, &q_in), sub(c, &q_in));
    let u = triple(&n, &qb, &qc) * inv;
    let v = triple(&n, &qc, &qa) * inv;
    let w = triple(&n, &qa, &qb) * inv;
    let inside = ok && u >= 0.0 && v >= 0.0 && w >= 0.0;
    let (q, feature, bary) = if inside {
        let s_uvw = (u + v) + w;
        (q_in, 0i8, [u / s_uvw, v / s_uvw, w / s_uvw])
    } else {
        let mut best = f64::INFINITY;
        let mut bary = [0.0f64; 3];
        let mut feature = 0i8;
        for (s0, e0, i0, i1, fe, fs, fend) in [
            (a, b, 0usize, 1usize, 1i8, 4i8, 5i8),
            (b, c, 1, 2, 2, 5, 6),
            (c, a, 2, 0, 3, 6, 4),
        ] {
            let (t, d2) = on_segment(p, s0, e0);
            if d2 < best {
                best = d2;
                bary = [0.0; 3];
                bary[i0] = 1.0 - t;
                bary[i1] = t;
                feature = if t <= 0.0 {
                    fs
                } else if t >= 1.0 {
                    fend
                } else {
                    fe
                };
            }
        }
        let mut q = [0.0; 3];
        for j in 0..3 {
            q[j] = (bary[0] * a[j] + bary[1] * b[j]) + bary[2] * c[j];
        }
        (q, feature, bary)
    };
    let e = sub(p, &q);
    (q, dot(&e, &e), feature, bary)
}

/// Faces per leaf of the tree: runs of faces consecutive along a Morton curve of their
/// centroids (compact runs), so the tree holds a quarter of the nodes it would hold with one
/// face per leaf (its memory dominated the orient stage's peak).
const RUN: usize = 4;

/// Faces per leaf of a tree with the per-face bounds (verify's: far fewer of its queries, on
/// a mesh of its own): runs of 2 cut the nodes and faces a query opens (Rotor 37: ball
/// centres ~5 %, points on the surface ~13 % less CPU than runs of 4).
const RUN_DISKS: usize = 2;

/// Consecutive points searched one after the other, each from the previous one's nearest
/// face (the unit of work of the threads).
const WARM_RUN: usize = 64;

/// A mesh's faces in a bounding-volume tree ([`FaceBvh`]: one leaf per run of [`RUN`] faces,
/// [`RUN_DISKS`] with the per-face bounds).
pub struct FaceTree {
    v: Vec<P3>,
    f: Vec<[usize; 3]>,
    order: Vec<u32>, // faces in Morton order: leaf i holds order[run i .. run (i + 1)]
    run: usize,
    bvh: FaceBvh,
    /// per face (when asked for): the disk in its plane that holds it (see [`FaceDisk`])
    disks: Option<Vec<FaceDisk>>,
}

/// The disk in a face's plane, around its centroid, that holds the face: a lower bound of
/// the distance from a point to the face — sqrt(z² + max(ρ − r, 0)²) with z the height
/// above the plane and ρ the in-plane distance to the centre — far cheaper than the exact
/// distance, and tight for points far off the surface (a ball centre 6 mm above a face
/// finds ~25 runs within its box reach, but only the faces under it within their disks).
/// Slivers (an angle below ~0.06°, whose normal from rounded edges is off) and zero-area
/// faces get n = 0: the bound is then that of the sphere around the centroid.
///
/// With it, the capsule around the face's longest edge, of radius the opposite vertex's
/// height (the angles at that edge's ends are at most 90°, so the whole face projects onto
/// the edge): tight on long thin faces, whose disk is wide (Rotor 37's blade as stored: the
/// exact distance took 43 % of a ball-centre query with the disks alone).
///
/// And the prism over the face (n ≠ 0): the face lies on the inner side of each edge's line
/// in its plane, so with s_i the signed in-plane distance of the point beyond edge i,
/// sqrt(z² + max(s_0, s_1, s_2, 0)²) bounds the distance too — exact where the point's
/// foot lies inside the face or off one edge's middle. It drops most of the faces whose disk
/// covers a ball centre's foot (~20 exact distances per ball centre on Rotor 37 with the
/// disks and capsules alone: the centres' queries took ~18 % less CPU with it).
#[derive(Clone, Copy)]
struct FaceDisk {
    c: P3,
    n: P3,
    r: f64,
    /// per edge (ab, bc, ca): its outward unit normal in the plane, and the centroid's
    /// distance to its line (n = 0: m = 0 and h = 0, s = 0: no bound)
    m: [P3; 3],
    h: P3,
    /// the longest edge: start, direction (end − start), 1 / |direction|² (0 if degenerate)
    es: P3,
    ed: P3,
    einv: f64,
    /// the capsule's radius: the opposite vertex's distance to that edge, padded
    eh: f64,
}

impl FaceDisk {
    fn new(a: &P3, b: &P3, c: &P3) -> Self {
        let cen = [
            (a[0] + b[0] + c[0]) / 3.0,
            (a[1] + b[1] + c[1]) / 3.0,
            (a[2] + b[2] + c[2]) / 3.0,
        ];
        let n = cross(&sub(b, a), &sub(c, a));
        let nl = dot(&n, &n).sqrt();
        // the squared edges; the longest one and the opposite vertex make the capsule below
        let (lab, lbc, lca) = (
            dot(&sub(b, a), &sub(b, a)),
            dot(&sub(c, b), &sub(c, b)),
            dot(&sub(a, c), &sub(a, c)),
        );
        let longest = lab.max(lbc).max(lca);
        let n = if nl > 1e-3 * longest && nl.is_finite() {
            [n[0] / nl, n[1] / nl, n[2] / nl]
        } else {
            [0.0; 3]
        };
        let r = [a, b, c]
            .iter()
            .map(|v| dot(&sub(v, &cen), &sub(v, &cen)).sqrt())
            .fold(0.0f64, f64::max);
        // the vertices' own distance to the plane (rounding of n) and the radius' rounding
        let r = r * (1.0 + 1e-9) + 1e-12;
        // the longest edge and the opposite vertex
        let (es, ee, opp) = if lab >= lbc && lab >= lca {
            (*a, *b, *c)
        } else if lbc >= lca {
            (*b, *c, *a)
        } else {
            (*c, *a, *b)
        };
        let ed = sub(&ee, &es);
        let ll = dot(&ed, &ed);
        let (einv, eh) = if ll > 0.0 && ll.is_finite() {
            let einv = 1.0 / ll;
            let w = sub(&opp, &es);
            let t = dot(&w, &ed) * einv;
            let e = [w[0] - t * ed[0], w[1] - t * ed[1], w[2] - t * ed[2]];
            (
                einv,
                dot(&e, &e).sqrt() * (1.0 + 1e-9) + 1e-9 * (1.0 + ll.sqrt()),
            )
        } else {
            (0.0, 0.0) // a point face: its disk bound alone (the capsule is not used)
        };
        // the edges' outward normals in the plane (away from the opposite vertex)
        let (mut m, mut h) = ([[0.0; 3]; 3], [0.0; 3]);
        if n != [0.0; 3] {
            for (i, (s0, e0, o)) in [(a, b, c), (b, c, a), (c, a, b)].into_iter().enumerate() {
                let mi = cross(&sub(e0, s0), &n);
                let ml = dot(&mi, &mi).sqrt();
                if !(ml > 0.0 && ml.is_finite()) {
                    (m, h) = ([[0.0; 3]; 3], [0.0; 3]); // (a zero edge: no prism)
                    break;
                }
                let mut mi = [mi[0] / ml, mi[1] / ml, mi[2] / ml];
                if dot(&sub(o, s0), &mi) > 0.0 {
                    mi = [-mi[0], -mi[1], -mi[2]];
                }
                m[i] = mi;
                h[i] = dot(&sub(s0, &cen), &mi);
            }
        }
        FaceDisk {
            c: cen,
            n,
            r,
            m,
            h,
            es,
            ed,
            einv,
            eh,
        }
    }

    /// Whether the face is farther than `r` from `p` by its lower bounds, less a rounding
    /// pad (1e-9 of the lengths: far above the exact kernel's own rounding): the disk's,
    /// sqrt(z² + max(ρ − r_disk, 0)²), the prism's, sqrt(z² + max(s_i, 0)²), and the
    /// longest-edge capsule's, its distance less its radius — compared squared with the squared reach (one square root, where the
    /// point lies beyond the disk's rim), the pads taken with |d| ≤ max(1, |d|²). False for
    /// a NaN (such a face is compared).
    #[inline(always)]
    fn beyond(&self, p: &P3, r: f64) -> bool {
        let d = sub(p, &self.c);
        let dd = dot(&d, &d);
        let z = dot(&d, &self.n);
        let rin2 = (dd - z * z).max(0.0);
        let e = if rin2 > self.r * self.r {
            rin2.sqrt() - self.r
        } else {
            0.0
        };
        let rr = r + 1e-9 * (1.0 + dd.max(1.0) + self.r);
        if z * z + e * e > rr * rr {
            return true;
        }
        // the prism: the in-plane distance beyond the farthest edge line (the pads as the
        // disk's: m is orthogonal to n, and the vertices lie inside each line, to ~1e-16 of
        // the lengths)
        let s = (dot(&d, &self.m[0]) - self.h[0])
            .max(dot(&d, &self.m[1]) - self.h[1])
            .max(dot(&d, &self.m[2]) - self.h[2])
            .max(0.0);
        if z * z + s * s > rr * rr {
            return true;
        }
        if self.einv > 0.0 {
            let w = sub(p, &self.es);
            let t = (dot(&w, &self.ed) * self.einv).clamp(0.0, 1.0);
            let q = [
                w[0] - t * self.ed[0],
                w[1] - t * self.ed[1],
                w[2] - t * self.ed[2],
            ];
            let dq2 = dot(&q, &q);
            let rq = r + self.eh + 1e-9 * (1.0 + dq2.max(1.0) + self.eh);
            return dq2 > rq * rq;
        }
        false
    }
}

/// The 21 low bits of x spread to every third bit.
fn spread(mut x: u64) -> u64 {
    x &= 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

impl FaceTree {
    /// `disks`: keep each face's [`FaceDisk`] (15 floats a face) to skip faces far off a
    /// query (points far off the surface, e.g. ball centres); the answers are the same.
    pub fn new(v: Vec<P3>, f: Vec<[usize; 3]>, disks: bool) -> Self {
        let cen: Vec<P3> = f
            .iter()
            .map(|t| {
                let (a, b, c) = (v[t[0]], v[t[1]], v[t[2]]);
                [
                    (a[0] + b[0] + c[0]) / 3.0,
                    (a[1] + b[1] + c[1]) / 3.0,
                    (a[2] + b[2] + c[2]) / 3.0,
                ]
            })
            .collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for c in &cen {
            for j in 0..3 {
                if c[j].is_finite() {
                    lo[j] = lo[j].min(c[j]);
                    hi[j] = hi[j].max(c[j]);
                }
            }
        }
        let code = |c: &P3| -> u64 {
            let mut k = 0u64;
            for j in 0..3 {
                let span = if hi[j] > lo[j] { hi[j] - lo[j] } else { 1.0 };
                let q = ((c[j] - lo[j]) / span * 2_097_151.0).clamp(0.0, 2_097_151.0) as u64;
                k |= spread(q) << j;
            }
            k
        };
        let mut keyed: Vec<(u64, u32)> = cen
            .iter()
            .enumerate()
            .map(|(i, c)| (code(c), i as u32))
            .collect();
        drop(cen);
        keyed.sort_unstable();
        let (keys, order): (Vec<u64>, Vec<u32>) = keyed.into_iter().unzip();
        let run = if disks { RUN_DISKS } else { RUN };
        let bvh = FaceBvh::new(&v, &f, &order, &keys, run);
        drop(keys);
        let disks = disks.then(|| {
            f.iter()
                .map(|t| FaceDisk::new(&v[t[0]], &v[t[1]], &v[t[2]]))
                .collect()
        });
        FaceTree {
            v,
            f,
            order,
            run,
            bvh,
            disks,
        }
    }

    #[inline]
    fn d2(&self, p: &P3, face: u32) -> f64 {
        let t = self.f[face as usize];
        triangle_d2(p, &self.v[t[0]], &self.v[t[1]], &self.v[t[2]])
    }

    /// [`Self::d2`], or +∞ when the face's plane alone is farther from `p` than `r` (then so
    /// is every point of the face, so it cannot reach or tie a least distance whose reach is
    /// `r`): the plane's distance |(a − p) · n| / |n|, n = ab × ac, compared squared, with a
    /// pad of 1e-9 of the lengths (as [`FaceDisk::beyond`]) for the rounding of n and of
    /// a − p. Only where the angle at a is not a sliver's (sin > 1e-3: n's direction is then
    /// good to ~1e-13 rad); the exact distance otherwise. Most faces a query opens lie
    /// around it but off its reach — a ball centre's under the ball, a surface point's
    /// neighbours — and the plane test is a third of the exact distance's work.
    #[inline]
    fn d2_within(&self, p: &P3, face: u32, r: f64) -> f64 {
        let t = self.f[face as usize];
        let (a, b, c) = (&self.v[t[0]], &self.v[t[1]], &self.v[t[2]]);
        let (ab, ac) = (sub(b, a), sub(c, a));
        let n = cross(&ab, &ac);
        let nn = dot(&n, &n);
        if nn > 1e-6 * (dot(&ab, &ab) * dot(&ac, &ac)) {
            let w = sub(a, p);
            let z = dot(&w, &n);
            let rr = r + 1e-9 * (1.0 + dot(&w, &w).max(1.0));
            if z * z > rr * rr * nn {
                return f64::INFINITY;
            }
        }
        triangle_d2(p, a, b, c)
    }

    fn run(&self, leaf: u32) -> &[u32] {
        let s = leaf as usize * self.run;
        &self.order[s..(s + self.run).min(self.order.len())]
    }

    /// The nearest face of one point (-1 for a non-finite point or an empty mesh), searched
    /// from the face `guess` (a face id or −1: e.g. the previous
    /// point's along a polyline): its distance bounds the search from the start. One
    /// depth-first walk, the nearer child first: a run is visited while its bound (box and
    /// oriented box) is within the least distance found so far (with room for the bounds' and
    /// the distances' rounding), so every face at the least squared distance is compared —
    /// the least d2, then the lowest id, whatever the guess.
    pub fn nearest_from(&self, p: &P3, guess: i64) -> i64 {
        if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) || self.f.is_empty() {
            return -1;
        }
        let best = std::cell::Cell::new((f64::INFINITY, u32::MAX));
        // `plane`: skip the face when its plane is beyond the reach of the best (it cannot
        // reach or tie it; the trees with per-face bounds have tested tighter ones already)
        let consider = |face: u32, plane: bool| {
            let (b, id) = best.get();
            let d2 = if plane && b.is_finite() {
                self.d2_within(p, face, crate::swept_ball::reach(b))
            } else {
                self.d2(p, face)
            };
            if d2 < b || (d2 == b && face < id) {
                best.set((d2, face));
            }
        };
        // the reach of a least squared distance d2 (a box farther cannot hold a face as near)
        // the walk compares squared distances (no square root per box): a box is visited
        // while its squared distance is below the squared reach, as its distance below it
        let reach = crate::swept_ball::reach;
        let reach2 = |d2: f64| {
            let r = reach(d2);
            r * r
        };
        let mut start = f64::MAX;
        if guess >= 0 && (guess as usize) < self.f.len() {
            consider(guess as u32, false);
            let (b, _) = best.get();
            if b.is_finite() {
                start = reach2(b);
            }
        }
        self.bvh.walk(p, start, |leaf| {
            match &self.disks {
                Some(disks) => {
                    for &face in self.run(leaf) {
                        // a face whose disk is beyond the reach of the best cannot
                        // reach or tie it
                        let (b, _) = best.get();
                        if !disks[face as usize].beyond(p, reach(b)) {
                            consider(face, false);
                        }
                    }
                }
                None => {
                    for &face in self.run(leaf) {
                        consider(face, true);
                    }
                }
            }
            let (b, _) = best.get();
            if b.is_finite() {
                Some(reach2(b))
            } else {
                None
            }
        });
        let (_, id) = best.get();
        if id == u32::MAX {
            -1
        } else {
            id as i64
        }
    }

    /// `closest_on_triangles` of each point and its face (`face` −1: numpy's index −1, the
    /// last face, as `MeshDistance.query` indexes it), (q, d2, feature, bary) per point.
    pub fn closest_many(&self, pts: &[P3], faces: &[i64]) -> Vec<(P3, f64, i8, P3)> {
        let m = self.f.len() as i64;
        pts.par_iter()
            .zip(faces.par_iter())
            .with_min_len(256)
            .map(|(p, &f)| {
                let fi = if f < 0 { f + m } else { f } as usize;
                let t = self.f[fi];
                triangle_closest(p, &self.v[t[0]], &self.v[t[1]], &self.v[t[2]])
            })
            .collect()
    }

    /// [`Self::nearest_from`] of every point; in runs of consecutive points each searched from the
    /// previous one's face (neighbouring points of a polyline or a grid share their nearest
    /// faces; the faces found do not depend on it).
    pub fn nearest_many(&self, pts: &[P3]) -> Vec<i64> {
        let mut out = vec![-1i64; pts.len()];
        out.par_chunks_mut(WARM_RUN)
            .zip(pts.par_chunks(WARM_RUN))
            .for_each(|(o, ps)| {
                let mut g = -1i64;
                for (oi, p) in o.iter_mut().zip(ps) {
                    *oi = self.nearest_from(p, g);
                    if *oi >= 0 {
                        g = *oi;
                    }
                }
            });
        out
    }
}
