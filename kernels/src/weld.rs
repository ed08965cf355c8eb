//! The exact-duplicate pass of the weld (`blisk_cam/core/geometry/weld.py::_first_equal_point`):
//! for each point, the index of the first point with the same coordinate bits. The numpy
//! reference hashes in vectorised rounds; here one pass over an open-addressing table
//! gives the same answer (the answer is defined without the hash: the lowest index of the
//! points equal to it).

#[inline(always)]
fn mix(x: u64, y: u64, z: u64) -> u64 {
    // multiplicative hashing (Knuth TAOCP vol. 3 §6.4) of the coordinate bits, the numpy
    // reference's first round
    let mut h = x.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    h ^= y;
    h = h.wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    h ^= z;
    h = h.wrapping_mul(0x1656_67B1_9E37_79F9);
    h ^ (h >> 29)
}

/// `first[i]`: the lowest j with `(x[j], y[j], z[j])` bit-equal to point i's.
pub fn first_equal_point(x: &[u64], y: &[u64], z: &[u64]) -> Vec<i64> {
    let k = x.len();
    let bits = (usize::BITS - (2 * k.max(1) - 1).leading_zeros()).max(1);
    let size = 1usize << bits; // ≥ 2k slots: load ≤ 0.5
    let mask = size - 1;
    let mut table = vec![u32::MAX; size];
    let mut first = vec![0i64; k];
    let wide = k >= u32::MAX as usize;
    let mut table64 = if wide {
        vec![usize::MAX; size]
    } else {
        Vec::new()
    };
    for i in 0..k {
        let (a, b, c) = (x[i], y[i], z[i]);
        let mut s = (mix(a, b, c) >> (64 - bits)) as usize & mask;
        loop {
            let held = if wide {
                table64[s]
            } else if table[s] == u32::MAX {
                usize::MAX
            } else {
                table[s] as usize
            };
            if held == usize::MAX {
                if wide {
                    table64[s] = i
                } else {
                    table[s] = i as u32
                }
                first[i] = i as i64;
                break;
            }
            if x[held] == a && y[held] == b && z[held] == c {
                first[i] = held as i64;
                break;
            }
            s = (s + 1) & mask;
        }
    }
    first
}

/// `first[i]`: the lowest j with row j of `v` equal to row i, bit for bit after adding 0.0
/// (−0.0 counts as 0.0), as [`first_equal_point`] gives for the columns `v[:, c] + 0.0` — read
/// from the rows, without the columns' copies. `parts` ≥ 1 hash partitions (a power of two
/// is used), one task each: equal rows share a hash, so a partition holds whole groups, and
/// each task inserts its rows in index order into a table of its own, so the answer does
/// not depend on `parts`. None when there are too many rows for 32-bit slots.
pub fn first_equal_rows(v: &[[f64; 3]], parts: usize) -> Option<Vec<i64>> {
    use rayon::prelude::*;
    let k = v.len();
    if k >= u32::MAX as usize {
        return None;
    }
    let key = |p: &[f64; 3]| {
        [
            (p[0] + 0.0).to_bits(),
            (p[1] + 0.0).to_bits(),
            (p[2] + 0.0).to_bits(),
        ]
    };
    let hash: Vec<u64> = v
        .par_chunks(1 << 14)
        .flat_map_iter(|c| {
            c.iter().map(|p| {
                let b = key(p);
                mix(b[0], b[1], b[2])
            })
        })
        .collect();
    // the partition: the hash's top bits; the slot: the bits below them
    let pbits = (usize::BITS - 1 - parts.max(1).leading_zeros()).min(8);
    let lists: Vec<Vec<u32>> = if pbits == 0 {
        vec![(0..k as u32).collect()]
    } else {
        let mut lists = vec![Vec::with_capacity(k >> pbits); 1 << pbits];
        for (i, &h) in hash.iter().enumerate() {
            lists[(h >> (64 - pbits)) as usize].push(i as u32);
        }
        lists
    };
    let mut first = vec![0i64; k];
    struct Out(*mut i64);
    // SAFETY: each task writes only the rows of its own partition (disjoint indices)
    unsafe impl Sync for Out {}
    let out = Out(first.as_mut_ptr());
    let out = &out;
    lists.par_iter().for_each(|rows| {
        let bits = (usize::BITS - (2 * rows.len().max(1) - 1).leading_zeros()).max(1);
        let mask = (1usize << bits) - 1;
        let mut table = vec![u32::MAX; 1usize << bits];
        for &i in rows {
            let b = key(&v[i as usize]);
            let mut s = ((hash[i as usize] << pbits) >> (64 - bits)) as usize & mask;
            let found = loop {
                let held = table[s];
                if held == u32::MAX {
                    table[s] = i;
                    break i;
                }
                if key(&v[held as usize]) == b {
                    break held;
                }
                s = (s + 1) & mask;
            };
            // SAFETY: i < k and no other task writes row i
            unsafe { *out.0.add(i as usize) = found as i64 };
        }
    });
    Some(first)
}
