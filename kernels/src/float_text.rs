//! Float arrays as JSON text, byte for byte what `json.dumps(a.tolist())` writes
//! (`blisk_cam/core/toolpath/paths_io.py`, the paths JSON): each float as Python's `repr`
//! (the shortest digits that read back to the same double; plain notation for decimal
//! exponents −4 … 15, else `d.ddde±XX` with at least two exponent digits), ", " between
//! values, rows of a 2-D array as nested lists. A paths JSON at 1M triangles holds ~150k
//! floats: `json.dumps` took ~0.07 s for them, here a few ms.
//!
//! The digits come from Rust's `{:e}`, which gives the shortest digits that round-trip, the
//! nearest to the double among them — the digits of Python's `repr` (David Gay's shortest
//! mode) except at an exact tie between two such candidates (987947971728212.25: Python
//! writes the even "…212.2", Rust "…212.3"), which [`is_tie`] finds and turns to Python's.

use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::fmt::Write;

/// Append Python's `repr` of the finite `x` to `out` (`scratch`: a buffer for the digits).
pub fn push_repr(out: &mut String, scratch: &mut String, x: f64) {
    scratch.clear();
    write!(scratch, "{:e}", x.abs()).expect("formatting into a String cannot fail");
    let (mant, exp) = scratch.split_once('e').expect("{:e} writes an exponent");
    let e: i32 = exp.parse().expect("{:e} writes an integer exponent");
    // the digits without the point: d[0] is the units digit of d.ddd × 10^e
    let mut digits: Vec<u8> = mant.bytes().filter(|b| b.is_ascii_digit()).collect();
    if digits.last().is_some_and(|d| d % 2 == 1) && is_tie(x.abs(), &digits, e) {
        // exactly halfway between two shortest candidates: Rust took the one above, Python
        // (round-half-even) the even one below
        *digits.last_mut().expect("a digit") -= 1;
    }
    let n = digits.len();
    if x.is_sign_negative() {
        out.push('-');
    }
    let push = |out: &mut String, d: &[u8]| out.push_str(std::str::from_utf8(d).expect("ASCII"));
    if (-4..16).contains(&e) {
        if e < 0 {
            out.push_str("0.");
            for _ in 0..(-e - 1) {
                out.push('0');
            }
            push(out, &digits);
        } else {
            let int_digits = e as usize + 1;
            if int_digits >= n {
                push(out, &digits);
                for _ in n..int_digits {
                    out.push('0');
                }
                out.push_str(".0");
            } else {
                push(out, &digits[..int_digits]);
                out.push('.');
                push(out, &digits[int_digits..]);
            }
        }
    } else {
        push(out, &digits[..1]);
        if n > 1 {
            out.push('.');
            push(out, &digits[1..]);
        }
        write!(
            out,
            "e{}{:02}",
            if e < 0 { '-' } else { '+' },
            e.unsigned_abs()
        )
        .expect("formatting into a String cannot fail");
    }
}

/// Whether `x` (> 0) lies exactly halfway between the shortest digits `d` × 10^(e − n + 1)
/// (n = d.len(), last digit odd) and the candidate one unit below, which also reads back to
/// `x`: then Python's `repr` writes the one below (its round-half-even), Rust's `{:e}` `d`.
fn is_tie(x: f64, d: &[u8], e: i32) -> bool {
    let n = d.len();
    // the halfway decimal ends at 10^(e − n): x must be a multiple of that, so a multiple of
    // 2^min(e − n, 0) (x = m · 2^E, its lowest set bit at 2^(E + trailing zeros of m)).
    // Measured coordinates carry ~50 bits below their units: this test alone settles them
    let bits = x.to_bits();
    let (m, big_e) = match ((bits >> 52) & 0x7ff) as i32 {
        0 => (bits & ((1 << 52) - 1), -1074),
        b => ((bits & ((1 << 52) - 1)) | (1 << 52), b - 1075),
    };
    if m == 0 || big_e + (m.trailing_zeros() as i32) < (e - n as i32).min(0) {
        return false;
    }
    // x to n + 1 significant digits must be "d − 1, then 5" ...
    let near = format!("{:.*e}", n, x);
    let (m, ex) = near.split_once('e').expect("{:e} writes an exponent");
    if ex.parse::<i32>() != Ok(e) {
        return false;
    }
    let got: Vec<u8> = m.bytes().filter(|b| b.is_ascii_digit()).collect();
    let mut mid = d.to_vec();
    *mid.last_mut().expect("a digit") -= 1;
    let low = mid.clone();
    mid.push(b'5');
    if got != mid {
        return false;
    }
    // ... exactly (a double's exact decimal has at most 767 significant digits) ...
    let exact = format!("{:.*e}", 800, x);
    let tail = exact.split_once('e').expect("{:e} writes an exponent").0;
    if !tail
        .bytes()
        .filter(|b| b.is_ascii_digit())
        .skip(n + 1)
        .all(|b| b == b'0')
    {
        return false;
    }
    // ... and the candidate below must read back to x too
    let low_text = format!(
        "{}.{}e{}",
        low[0] as char,
        std::str::from_utf8(&low[1..]).expect("ASCII"),
        e
    );
    low_text.parse::<f64>() == Ok(x)
}

/// The JSON text of a 1-D or 2-D float64 array as `json.dumps(a.tolist())` writes it; None
/// when a value is not finite (JSON has none: the caller's `json.dumps` says so) or the
/// array has another number of dimensions.
#[pyfunction]
pub fn json_float_array(
    py: Python<'_>,
    a: PyReadonlyArrayDyn<'_, f64>,
) -> PyResult<Option<String>> {
    let shape = a.shape().to_vec();
    if shape.is_empty() || shape.len() > 2 {
        return Ok(None);
    }
    let Ok(values) = a.as_slice() else {
        return Ok(None); // not contiguous: the caller's route
    };
    Ok(py.detach(|| {
        if values.iter().any(|x| !x.is_finite()) {
            return None;
        }
        let mut out = String::with_capacity(24 * values.len() + 8);
        let mut scratch = String::with_capacity(32);
        let row = |out: &mut String, scratch: &mut String, r: &[f64]| {
            out.push('[');
            for (i, &x) in r.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                push_repr(out, scratch, x);
            }
            out.push(']');
        };
        if shape.len() == 1 {
            row(&mut out, &mut scratch, values);
        } else {
            let cols = shape[1];
            out.push('[');
            for i in 0..shape[0] {
                if i > 0 {
                    out.push_str(", ");
                }
                row(&mut out, &mut scratch, &values[i * cols..(i + 1) * cols]);
            }
            out.push(']');
        }
        Some(out)
    }))
}
