//! `x.hypot(y)` as libm computes it, inlined: glibc's algorithm (2.35 and later, without
//! FMA: "An Improved Algorithm for hypot(a, b)", Borges 2019 — one square root and one
//! correction step) for operands well inside its common range, libm's own call elsewhere (NaN,
//! infinities, huge or tiny operands, widely differing magnitudes).
//!
//! numpy's `np.hypot` calls the platform's libm; the compiled kernels must give its very
//! floats. The first call checks the inlined algorithm against the platform's `hypot` on
//! 100 000 operand pairs of widely spread magnitudes and ratios; on a platform whose libm
//! rounds differently anywhere among them (another C library), every call goes to libm.
//! (Checked here, glibc 2.36: the same bits on 2·10⁷ random pairs besides.) The call and its
//! range checks cost as much as the algorithm: collision detection and verify's swept
//! cutter call it in their inner loops.

use std::sync::OnceLock;

/// glibc's `kernel` of `__hypot` (the non-FMA variant) for ax ≥ ay > 0 in range.
#[inline(always)]
fn kernel(ax: f64, ay: f64) -> f64 {
    let h = (ax * ax + ay * ay).sqrt();
    let (t1, t2);
    if h <= 2.0 * ay {
        let delta = h - ay;
        t1 = ax * (2.0 * delta - ax);
        t2 = (delta - 2.0 * (ax - ay)) * delta;
    } else {
        let delta = h - ax;
        t1 = 2.0 * delta * (ax - 2.0 * ay);
        t2 = (4.0 * delta - ay) * ay + delta * delta;
    }
    h - (t1 + t2) / (2.0 * h)
}

/// Whether [`kernel`] gives libm's bits on this platform (checked once).
fn kernel_matches_libm() -> bool {
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    for i in 0..100_000u32 {
        let a = 1.0 + (rnd() >> 11) as f64 / (1u64 << 53) as f64;
        let b = 1.0 + (rnd() >> 11) as f64 / (1u64 << 53) as f64;
        let ea = (rnd() % 60) as i32 - 30;
        let eb = if i % 2 == 0 {
            ea + (rnd() % 9) as i32 - 4
        } else {
            (rnd() % 60) as i32 - 30
        };
        let (x, y) = (a * 2f64.powi(ea), b * 2f64.powi(eb));
        if hypot_in_range(x, y).is_some_and(|h| h.to_bits() != x.hypot(y).to_bits()) {
            return false;
        }
    }
    true
}

/// [`kernel`] where glibc runs it (|x|, |y| between 2⁻⁴⁰⁰ and 2⁴⁰⁰, well inside glibc's
/// unscaled range, the smaller above 2⁻⁵⁴ of the larger), None elsewhere.
#[inline(always)]
fn hypot_in_range(x: f64, y: f64) -> Option<f64> {
    let (x, y) = (x.abs(), y.abs());
    let (ax, ay) = if x < y { (y, x) } else { (x, y) };
    if ax <= f64::from_bits(0x58F0_0000_0000_0000)
        && ay >= f64::from_bits(0x26F0_0000_0000_0000)
        && ay > ax * f64::from_bits(0x3C90_0000_0000_0000)
    {
        Some(kernel(ax, ay))
    } else {
        None
    }
}

/// `x.hypot(y)`, libm's floats (module docstring).
#[inline(always)]
pub fn hypot(x: f64, y: f64) -> f64 {
    static OK: OnceLock<bool> = OnceLock::new();
    if *OK.get_or_init(kernel_matches_libm) {
        if let Some(h) = hypot_in_range(x, y) {
            return h;
        }
    }
    x.hypot(y)
}
