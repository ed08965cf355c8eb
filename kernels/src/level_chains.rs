//! The chaining of a level curve's links, equal to its numpy reference:
//! `chain_directed` (`geometry/mesh.py`, `_chain_directed`): directed links forming
//!   disjoint paths and cycles ordered into chains — each path from its head to its tail,
//!   each cycle from its lowest node, the chains by their tail's id (numpy's list ranking by
//!   pointer jumping gives that order).
//!
//! None where the numpy reference takes another route (links not of the directed form: the
//! general graph route).

use numpy::{PyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// (order (p,) int64, starts (c + 1,) int64, closed (c,) bool): the chains of the directed
/// links (k, 2) over `n` nodes, chain i being `order[starts[i]:starts[i + 1]]` (see
/// `_chain_directed`); None when a link is a loop, a node has two links out or in, two nodes
/// link both ways, or an id is outside [0, n).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn chain_directed<'py>(
    py: Python<'py>,
    links: PyReadonlyArray2<'py, i64>,
    n: usize,
) -> PyResult<
    Option<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<bool>>,
    )>,
> {
    if links.shape()[1] != 2 {
        return Err(PyValueError::new_err(
            "links must be (k, 2): one (from, to) pair a row",
        ));
    }
    let ll = crate::arrays::flat(&links, "links")?;
    if ll.iter().any(|&v| v < 0 || v as usize >= n) {
        return Ok(None);
    }
    let out = py.detach(|| {
        let mut succ = vec![-1i64; n];
        let mut pred = vec![-1i64; n];
        for l in ll.chunks_exact(2) {
            let (a, b) = (l[0], l[1]);
            if a == b || succ[a as usize] >= 0 || pred[b as usize] >= 0 {
                return None;
            }
            succ[a as usize] = b;
            pred[b as usize] = a;
        }
        for l in ll.chunks_exact(2) {
            if succ[l[1] as usize] == l[0] {
                return None;
            }
        }
        let mut seen = vec![false; n];
        let mut chains: Vec<(i64, Vec<i64>, bool)> = Vec::new(); // (tail, nodes, closed)
        for v in 0..n {
            if pred[v] < 0 && succ[v] >= 0 {
                let mut c = vec![v as i64];
                seen[v] = true;
                let mut x = v;
                while succ[x] >= 0 {
                    x = succ[x] as usize;
                    seen[x] = true;
                    c.push(x as i64);
                }
                chains.push((x as i64, c, false));
            }
        }
        for v in 0..n {
            if !seen[v] && succ[v] >= 0 {
                // on a cycle (every path node is seen), and the lowest of it
                let mut c = vec![v as i64];
                seen[v] = true;
                let mut x = succ[v] as usize;
                while x != v {
                    seen[x] = true;
                    c.push(x as i64);
                    x = succ[x] as usize;
                }
                chains.push((*c.last().unwrap(), c, true));
            }
        }
        chains.sort_unstable_by_key(|c| c.0);
        let mut order = Vec::with_capacity(n);
        let mut starts = Vec::with_capacity(chains.len() + 1);
        let mut closed = Vec::with_capacity(chains.len());
        starts.push(0i64);
        for (_, c, cl) in chains {
            order.extend_from_slice(&c);
            starts.push(order.len() as i64);
            closed.push(cl);
        }
        Some((order, starts, closed))
    });
    Ok(out.map(|(o, s, c)| {
        (
            PyArray1::from_vec(py, o),
            PyArray1::from_vec(py, s),
            PyArray1::from_vec(py, c),
        )
    }))
}
