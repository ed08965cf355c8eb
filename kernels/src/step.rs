//! The greedy forward step of `blisk_cam/core/paths/sampling.py::forward_step_indices`
//! (paper 001 §3.1.3, Eq. 10): from each kept point, an exponential search then a bisection
//! find the farthest point such that every skipped CC point and every skipped ball centre
//! lies within its tolerance of the straight move.
//!
//! The arithmetic of one test is that of `_span_deviations`, operation for operation, so the
//! chosen points are the numpy reference's to the last bit: every sum of three products is
//! `(x0*y0 + x2*y2) + x1*y1` (numpy's einsum order), a zero-length chord divides by 1, the
//! projection parameter is clamped to [0, 1], and a span passes when the square root of its
//! largest squared distance is `<=` the tolerance (NaN fails, as in numpy). No fused
//! multiply-add: Rust never contracts `a * b + c` on its own.

use crate::numpy_ops::einsum_dot as dot3;

/// One polyline point, mm.
pub type P3 = [f64; 3];

/// Whether every point strictly between `i` and `j` lies within `tol` of the segment from
/// point `i` to point `j` (the test of `_span_deviations` for one end and one polyline).
#[inline]
pub fn span_within(x: &[P3], i: usize, j: usize, tol: f64) -> bool {
    if j <= i + 1 {
        return true; // nothing between: deviation 0
    }
    let a = x[i];
    let b = [x[j][0] - a[0], x[j][1] - a[1], x[j][2] - a[2]];
    let mut l2 = dot3(&b, &b);
    if l2 == 0.0 {
        l2 = 1.0; // numpy: L2 += (L2 == 0)
    }
    let mut worst = 0.0f64;
    for p in &x[i + 1..j] {
        let q = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
        let mut t = dot3(&q, &b) / l2;
        // np.maximum(t, 0) then np.minimum(t, 1): NaN propagates through both
        if t < 0.0 {
            t = 0.0;
        }
        if t > 1.0 {
            t = 1.0;
        }
        let d = [q[0] - b[0] * t, q[1] - b[1] * t, q[2] - b[2] * t];
        let d2 = dot3(&d, &d);
        if d2.is_nan() {
            return false; // np.max propagates NaN, NaN <= tol is False
        }
        if d2 > worst {
            worst = d2;
            if !(worst.sqrt() <= tol) {
                return false; // sqrt is monotone: the max only grows
            }
        }
    }
    worst.sqrt() <= tol
}

/// The result of [`forward_step`]: the kept indices and, per search start, (first step,
/// outcome, farthest end tested), -1 where no search started.
pub struct Stepped {
    pub keep: Vec<i64>,
    pub trace: Vec<[i64; 3]>,
}

/// The greedy forward step over the CC points `p` and centres `c` (same length k ≥ 1).
///
/// `old`: the trace of the last call on the same polyline and `unchanged_to` (k + 1 counts
/// of changed points before each index): a search from `i` with the same first step whose
/// tested points are unchanged is taken from it, as the numpy memo does.
pub fn forward_step(
    p: &[P3],
    c: &[P3],
    tol_p: f64,
    tol_c: f64,
    old: Option<(&[[i64; 3]], &[i64])>,
) -> Stepped {
    let k = p.len();
    let mut keep = vec![0i64];
    let mut trace = vec![[-1i64; 3]; k];
    if k == 0 {
        return Stepped { keep, trace }; // [0], as the numpy reference
    }
    let last = k - 1;
    let test = |i: usize, j: usize| span_within(p, i, j, tol_p) && span_within(c, i, j, tol_c);
    let mut i = 0usize;
    let mut prev = 2usize;
    while i < last {
        let first_step = prev.max(2);
        if let Some((was, unchanged_to)) = old {
            let w = was[i];
            if w[0] >= 0
                && w[0] as usize == first_step
                && unchanged_to[(w[2] + 1) as usize] == unchanged_to[i]
            {
                let good = w[1] as usize;
                trace[i] = w;
                keep.push(good as i64);
                prev = good - i;
                i = good;
                continue;
            }
        }
        let mut step = first_step;
        let mut good = i + 1;
        let mut bad: Option<usize> = None;
        loop {
            let j = (i + step).min(last);
            if !test(i, j) {
                bad = Some(j);
                break;
            }
            good = j;
            if j == last {
                break;
            }
            step *= 2;
        }
        if let Some(b) = bad {
            let (mut lo, mut hi) = (good, b);
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if test(i, mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            good = lo;
        }
        trace[i] = [first_step as i64, good as i64, bad.unwrap_or(last) as i64];
        keep.push(good as i64);
        prev = good - i;
        i = good;
    }
    Stepped { keep, trace }
}
