//! numpy's element-wise operations with numpy's own semantics, for kernels whose results must
//! equal the numpy reference bit for bit.

/// `np.einsum("ij,ij->i")` (numpy's row dot) of one pair of 3-vectors, summed as numpy sums
/// three terms: `(a₀b₀ + a₂b₂) + a₁b₁` (its two-lane loop puts terms 0 and 2 in one lane;
/// numpy 1.26 and 2.x alike).
#[inline(always)]
pub fn einsum_dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (a[0] * b[0] + a[2] * b[2]) + a[1] * b[1]
}

/// `a - b` of two 3-vectors (numpy's row subtraction).
#[inline(always)]
pub fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `np.cross(u, v)` of two 3-vectors: `u₁v₂ − u₂v₁, u₂v₀ − u₀v₂, u₀v₁ − u₁v₀`.
#[inline(always)]
pub fn cross(u: &[f64; 3], v: &[f64; 3]) -> [f64; 3] {
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

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
