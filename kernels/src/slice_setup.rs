//! The set-up of `MeshConeSlicer` for a cone pair (`blisk_cam/core/paths/slicing.py`): the
//! vertices' radial vectors, radius and morph ratio `s` (`MorphingCones.ratio`), the faces'
//! least and largest `s`, and the face index of `_index_face_ranges` (the 99.9th percentile
//! of the faces' s spans as `np.quantile` interpolates it, the buckets of the narrow faces'
//! least s, counted and filled in face order as numpy's stable argsort orders them) — in
//! two passes instead of numpy's ~30, with the same arithmetic, so the same bits.
//!
//! `z = (V − o) · d` stays numpy's (`p @ d`: OpenBLAS's dot, whose order of operations
//! depends on the machine); the caller passes it with `p = V − o`.

use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyReadwriteArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::numpy_ops::nanmax;

/// `MorphingCones.ratio`'s constants (numpy's values of its 2-vectors and their crosses).
#[derive(Clone, Copy)]
pub struct Ratio {
    /// cone 1's first point (r, z)
    pub p1: [f64; 2],
    /// cone 1's direction p2 − p1
    pub d1: [f64; 2],
    /// cone 2's direction minus cone 1's
    pub dd: [f64; 2],
    /// cross2(d1, q1 − p1)
    pub d1_da: f64,
    /// −cross2(dd, q1 − p1)
    pub k2: f64,
    /// (α, β, γ) of the LMC at s = 0: the side of a point on no LMC
    pub side: [f64; 3],
}

impl Ratio {
    /// `ratio` of one point (r, z), numpy's operations in numpy's order.
    #[inline(always)]
    pub fn of(&self, r: f64, z: f64) -> f64 {
        let (x0, x1) = (r - self.p1[0], z - self.p1[1]);
        let k0 = self.d1[0] * x1 - self.d1[1] * x0;
        let k1 = (self.dd[0] * x1 - self.dd[1] * x0) - self.d1_da;
        let disc = k1 * k1 - 4.0 * self.k2 * k0;
        let sq = nanmax(disc, 0.0).sqrt();
        let denom = k1 + sq.copysign(k1);
        let s = if denom.abs() > 0.0 {
            -2.0 * k0 / denom
        } else {
            f64::NAN
        };
        if disc < 0.0 || !s.is_finite() {
            let side = (self.side[0] * r + self.side[1] * z) + self.side[2];
            if side > 0.0 {
                f64::INFINITY
            } else {
                f64::NEG_INFINITY
            }
        } else {
            s
        }
    }
}

/// Per vertex: `p` (rows of V − o) becomes the radial vector p − z d; r = |radial| (its
/// three squares added as numpy's einsum adds them: `outer_first` (p0 + p2) + p1, else in
/// order) and s. Returns (r, s).
pub fn vertex_field(
    p: &mut [[f64; 3]],
    z: &[f64],
    d: [f64; 3],
    ratio: &Ratio,
    outer_first: bool,
) -> (Vec<f64>, Vec<f64>) {
    let mut r = vec![0.0f64; p.len()];
    let mut s = vec![0.0f64; p.len()];
    for (((q, &zi), ri), si) in p.iter_mut().zip(z).zip(r.iter_mut()).zip(s.iter_mut()) {
        let v = [q[0] - zi * d[0], q[1] - zi * d[1], q[2] - zi * d[2]];
        *q = v;
        let (a, b, c) = (v[0] * v[0], v[1] * v[1], v[2] * v[2]);
        let rr = if outer_first {
            (a + c) + b
        } else {
            (a + b) + c
        }
        .sqrt();
        *ri = rr;
        *si = ratio.of(rr, zi);
    }
    (r, s)
}

/// `np.minimum(a, b)`: NaN if either is; of two equal values (0.0 and −0.0) the second,
/// as numpy's loops (scalar and SIMD alike) give it.
#[inline(always)]
fn np_minimum(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if a < b {
        a
    } else {
        b
    }
}

/// `np.maximum(a, b)`, as [`np_minimum`].
#[inline(always)]
fn np_maximum(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if a > b {
        a
    } else {
        b
    }
}

/// Per face the least and largest s of its corners: `np.minimum(np.minimum(s0, s1), s2)`
/// (and the maximum), as the reference folds them.
pub fn face_extent(s: &[f64], f: &[[i64; 3]]) -> (Vec<f64>, Vec<f64>) {
    let mut lo = Vec::with_capacity(f.len());
    let mut hi = Vec::with_capacity(f.len());
    for t in f {
        let (a, b, c) = (s[t[0] as usize], s[t[1] as usize], s[t[2] as usize]);
        lo.push(np_minimum(np_minimum(a, b), c));
        hi.push(np_maximum(np_maximum(a, b), c));
    }
    (lo, hi)
}

/// `np.quantile(x, q)` (method "linear") of finite values `x` (reordered), as numpy computes
/// it: the virtual index (n − 1) q, the two order statistics around it and numpy's `_lerp`.
pub fn quantile_linear(x: &mut [f64], q: f64) -> f64 {
    let n = x.len();
    let v = (n - 1) as f64 * q;
    if v >= (n - 1) as f64 {
        return x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    }
    let prev = v.floor() as usize;
    let cmp = |a: &f64, b: &f64| a.partial_cmp(b).unwrap();
    let (_, &mut a, right) = x.select_nth_unstable_by(prev, cmp);
    let b = right.iter().copied().fold(f64::INFINITY, f64::min);
    let t = v - prev as f64;
    let diff = b - a;
    if t >= 0.5 {
        b - diff * (1.0 - t)
    } else {
        a + diff * t
    }
}

/// `_index_face_ranges` of the faces' least and largest s.
pub struct FaceIndex {
    pub cut: f64,
    pub bucket_lo: f64,
    pub bucket_scale: f64,
    pub narrow: Vec<i64>,
    pub bucket_start: Vec<i64>,
    pub wide: Vec<i64>,
}

/// The face index: faces whose span `hi − lo` is finite and at most its `q` quantile are
/// narrow, bucketed by `lo` into `nb` buckets over [min, max] of their `lo` clamped to
/// `range` (a monotone key, `floor(clip((lo − bucket_lo) · scale, 0, nb − 1))`) and listed
/// by bucket, then face id; the others with no NaN end are wide.
pub fn face_index(lo: &[f64], hi: &[f64], q: f64, nb: usize, range: (f64, f64)) -> FaceIndex {
    let m = lo.len();
    let mut widths: Vec<f64> = lo
        .iter()
        .zip(hi)
        .map(|(&a, &b)| b - a)
        .filter(|w| w.is_finite())
        .collect();
    let cut = if widths.is_empty() {
        0.0
    } else {
        quantile_linear(&mut widths, q)
    };
    drop(widths);
    let is_narrow = |i: usize| {
        let w = hi[i] - lo[i];
        w.is_finite() && w <= cut
    };
    let (mut a, mut b) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut any = false;
    for i in (0..m).filter(|&i| is_narrow(i)) {
        a = a.min(lo[i]);
        b = b.max(lo[i]);
        any = true;
    }
    if any {
        let (ra, rb) = (a.max(range.0), b.min(range.1));
        if ra < rb {
            (a, b) = (ra, rb);
        }
    } else {
        (a, b) = (0.0, 0.0);
    }
    let scale = if b > a {
        (nb - 1) as f64 / (b - a)
    } else {
        0.0
    };
    let top = (nb - 1) as f64;
    // the floor of a value clamped to [0, nb − 1] (`max`/`min` take 0.0 for a NaN) is its
    // truncation: the cast, without a call of libm's `floor` per face (x86-64's baseline has
    // no SSE4.1 rounding instruction)
    let key = |x: f64| ((x - a) * scale).max(0.0).min(top) as usize;
    let mut start = vec![0i64; nb + 1];
    let mut n_wide = 0usize;
    for i in 0..m {
        if is_narrow(i) {
            start[key(lo[i]) + 1] += 1;
        } else if !lo[i].is_nan() && !hi[i].is_nan() {
            n_wide += 1;
        }
    }
    for k in 0..nb {
        start[k + 1] += start[k];
    }
    let mut fill: Vec<i64> = start[..nb].to_vec();
    let mut narrow = vec![0i64; start[nb] as usize];
    let mut wide = Vec::with_capacity(n_wide);
    for i in 0..m {
        if is_narrow(i) {
            let p = &mut fill[key(lo[i])];
            narrow[*p as usize] = i as i64;
            *p += 1;
        } else if !lo[i].is_nan() && !hi[i].is_nan() {
            wide.push(i as i64);
        }
    }
    FaceIndex {
        cut,
        bucket_lo: a,
        bucket_scale: scale,
        narrow,
        bucket_start: start,
        wide,
    }
}

type F1<'py> = Bound<'py, PyArray1<f64>>;
type I1<'py> = Bound<'py, PyArray1<i64>>;

/// The set-up of a cone pair's slicer: `p` (n, 3) = V − o is made the radial vectors in
/// place; from z (n,) = p @ d, the axis direction d, the ratio's constants `consts` = (p1r,
/// p1z, d1r, d1z, ddr, ddz, cross2(d1, da), −cross2(dd, da), α, β, γ of s = 0) and the faces
/// F (m, 3): (r (n,), s (n,), face smin (m,), face smax (m,)) float64.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn cone_slicer_field<'py>(
    py: Python<'py>,
    mut p: PyReadwriteArray2<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
    d: [f64; 3],
    consts: [f64; 11],
    f: PyReadonlyArray2<'py, i64>,
    outer_first: bool,
) -> PyResult<(F1<'py>, F1<'py>, F1<'py>, F1<'py>)> {
    let tri = crate::arrays::triangles(&f, "F")?;
    let flat = p
        .as_slice_mut()
        .map_err(|_| PyValueError::new_err("p must be C-contiguous"))?;
    if flat.len() % 3 != 0 {
        return Err(PyValueError::new_err("p must be (n, 3)"));
    }
    // SAFETY: (n, 3) C-contiguous float64 rows are [f64; 3]s (same layout and alignment)
    let rows: &mut [[f64; 3]] =
        unsafe { std::slice::from_raw_parts_mut(flat.as_mut_ptr().cast(), flat.len() / 3) };
    let n = rows.len();
    let zz = crate::arrays::values_n(&z, "z", n)?;
    if tri.iter().flatten().any(|&i| i < 0 || i as usize >= n) {
        return Err(PyValueError::new_err("F holds vertex ids out of range"));
    }
    let c = consts;
    let ratio = Ratio {
        p1: [c[0], c[1]],
        d1: [c[2], c[3]],
        dd: [c[4], c[5]],
        d1_da: c[6],
        k2: c[7],
        side: [c[8], c[9], c[10]],
    };
    let (r, s, lo, hi) = py.detach(|| {
        let (r, s) = vertex_field(rows, zz, d, &ratio, outer_first);
        let (lo, hi) = face_extent(&s, tri);
        (r, s, lo, hi)
    });
    Ok((
        PyArray1::from_vec(py, r),
        PyArray1::from_vec(py, s),
        PyArray1::from_vec(py, lo),
        PyArray1::from_vec(py, hi),
    ))
}

/// `_index_face_ranges` of the faces' least and largest s (m,) float64 with the quantile
/// `q`, `nb` buckets and the buckets' range (lo, hi): (cut, bucket_lo, bucket_scale,
/// narrow faces (k,), bucket starts (nb + 1,), wide faces (w,)).
#[pyfunction]
pub fn slicer_face_index<'py>(
    py: Python<'py>,
    smin: PyReadonlyArray1<'py, f64>,
    smax: PyReadonlyArray1<'py, f64>,
    q: f64,
    nb: usize,
    range: (f64, f64),
) -> PyResult<(f64, f64, f64, I1<'py>, I1<'py>, I1<'py>)> {
    let lo = crate::slice1(&smin, "smin")?;
    let hi = crate::arrays::values_n(&smax, "smax", lo.len())?;
    if nb == 0 || !(0.0..=1.0).contains(&q) {
        return Err(PyValueError::new_err("nb must be positive and q in [0, 1]"));
    }
    let t = py.detach(|| face_index(lo, hi, q, nb, range));
    Ok((
        t.cut,
        t.bucket_lo,
        t.bucket_scale,
        PyArray1::from_vec(py, t.narrow),
        PyArray1::from_vec(py, t.bucket_start),
        PyArray1::from_vec(py, t.wide),
    ))
}
