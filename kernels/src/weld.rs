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
/// from the rows, without the columns' copies (the table and the answer are all the memory).
/// One pass, one thread: the insertions into one table are sequential by nature (splitting
/// the rows by hash over two threads, each with a table of its own, was no faster on this
/// 2-core machine and held the hashes or the row lists besides). None when there are too
/// many rows for 32-bit slots.
pub fn first_equal_rows(v: &[[f64; 3]]) -> Option<Vec<i64>> {
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
    let bits = (usize::BITS - (2 * k.max(1) - 1).leading_zeros()).max(1);
    let mask = (1usize << bits) - 1;
    let mut table = vec![u32::MAX; 1usize << bits];
    let mut first = vec![0i64; k];
    for (i, p) in v.iter().enumerate() {
        let b = key(p);
        let mut s = (mix(b[0], b[1], b[2]) >> (64 - bits)) as usize & mask;
        first[i] = loop {
            let held = table[s];
            if held == u32::MAX {
                table[s] = i as u32;
                break i as i64;
            }
            if key(&v[held as usize]) == b {
                break held as i64;
            }
            s = (s + 1) & mask;
        };
    }
    Some(first)
}
