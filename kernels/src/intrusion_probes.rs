//! The probes of `passes._Generator.intrusion_lift` (paper 001 §3: a part of the mesh away
//! from the contact point reaching into the ball): the ball centres `C = p + (ρ + λ) n`, their
//! arc length along the centre path, and the points where that arc crosses every `spacing`
//! mm (plus the last point). The numpy reference's floats and indices: the centres as numpy
//! broadcasts them, `np.linalg.norm(np.diff(C))` as ((x0² + x1²) + x2²), `np.cumsum`
//! in order, `np.arange(0, arc[-1], spacing)` as numpy fills it (`start + i · delta`) and
//! `np.searchsorted(side="left")` with numpy's order (NaN last).

use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// numpy's `DOUBLE_LT`: `a < b`, NaN sorting last.
#[inline(always)]
fn lt(a: f64, b: f64) -> bool {
    a < b || (b.is_nan() && !a.is_nan())
}

/// (probe (p,) int64 ascending, their centres (p, 3)) of the points `d` (q, 3) with unit
/// normals `dn` and lifts `lam` (q,) for a ball of radius `rho` (mm), probes `spacing` mm
/// apart along the centres' arc; None when the arc length is not finite (numpy's `arange`
/// raises) or q = 0.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn intrusion_probes<'py>(
    py: Python<'py>,
    d: PyReadonlyArray2<'py, f64>,
    dn: PyReadonlyArray2<'py, f64>,
    lam: PyReadonlyArray1<'py, f64>,
    rho: f64,
    spacing: f64,
) -> PyResult<Option<(Bound<'py, PyArray1<i64>>, Bound<'py, numpy::PyArray2<f64>>)>> {
    let pp = crate::points(&d, "D")?;
    let q = pp.len();
    let nn = crate::arrays::points_n(&dn, "DN", q)?;
    let ll = crate::arrays::values_n(&lam, "lam", q)?;
    let got = py.detach(|| {
        if q == 0 {
            return None;
        }
        let c: Vec<[f64; 3]> = (0..q)
            .map(|i| {
                let s = rho + ll[i];
                let (p, n) = (&pp[i], &nn[i]);
                [p[0] + s * n[0], p[1] + s * n[1], p[2] + s * n[2]]
            })
            .collect();
        let mut arc = Vec::with_capacity(q);
        arc.push(0.0f64);
        let mut run = 0.0f64;
        for i in 1..q {
            let (a, b) = (&c[i - 1], &c[i]);
            let x = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let len = ((x[0] * x[0] + x[1] * x[1]) + x[2] * x[2]).sqrt();
            run = if i == 1 { len } else { run + len };
            arc.push(run);
        }
        let last = arc[q - 1];
        let count = (last / spacing).ceil();
        if !count.is_finite() {
            return None;
        }
        let count = if count > 0.0 { count as usize } else { 0 };
        let mut probe: Vec<i64> = Vec::with_capacity(count + 1);
        let mut lo = 0usize;
        for i in 0..count {
            // np.arange: buffer[0] = start, buffer[1] = start + delta, then start + i·delta
            let at = if i == 0 {
                0.0
            } else {
                0.0 + (i as f64) * ((0.0 + spacing) - 0.0)
            };
            // side="left": the first index whose arc is not below `at` (keys ascending)
            let mut hi = q;
            while lo < hi {
                let mid = (lo + hi) / 2;
                if lt(arc[mid], at) {
                    lo = mid + 1;
                } else {
                    hi = mid;
                }
            }
            if probe.last() != Some(&(lo as i64)) && lo < q {
                probe.push(lo as i64);
            }
        }
        if probe.last() != Some(&((q - 1) as i64)) {
            probe.push((q - 1) as i64);
        }
        let cp: Vec<f64> = probe.iter().flat_map(|&i| c[i as usize]).collect();
        Some((probe, cp))
    });
    match got {
        None => Ok(None),
        Some((probe, cp)) => {
            let n = probe.len();
            Ok(Some((
                PyArray1::from_vec(py, probe),
                PyArray1::from_vec(py, cp).reshape([n, 3])?,
            )))
        }
    }
}
