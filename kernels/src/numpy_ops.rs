//! numpy's element-wise operations with numpy's own semantics, for kernels whose results must
//! equal the numpy reference bit for bit.

/// np.maximum: NaN if either is NaN.
#[inline(always)]
pub fn nanmax(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if a >= b {
        a
    } else {
        b
    }
}

/// np.minimum: NaN if either is NaN.
#[inline(always)]
pub fn nanmin(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else if a <= b {
        a
    } else {
        b
    }
}
