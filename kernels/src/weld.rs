//! The exact-duplicate pass of the weld (`blisk_cam/core/geometry/weld.py::_first_equal_point`):
//! for each point, the index of the first point with the same coordinate bits. The numpy
//! reference hashes in vectorised rounds; here one pass over an open-addressing table
//! gives the same answer (the answer is defined without the hash: the lowest index of the
//! points equal to it).
use crate::prefetch::prefetch;

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
///
/// The table's slots are touched at random, so the pass waits on memory: it starts sized for
/// an STL's triangle soup (each vertex ~6 corners: k/6 distinct points, at most half the
/// slots held) and doubles whenever half its slots are held, and the slot of the row
/// [`AHEAD`] rows on is fetched while this one is looked up. Neither changes the answer,
/// which is defined without the table: the lowest index of the rows equal to each.
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
    let hash = |p: &[f64; 3]| {
        let b = key(p);
        mix(b[0], b[1], b[2])
    };
    let slots_for = |distinct: usize| (2 * distinct.max(512)).next_power_of_two();
    let mut bits = slots_for(k / 6 + 1).trailing_zeros();
    let mut table = vec![u32::MAX; 1usize << bits];
    let mut held_count = 0usize;
    let mut first = Vec::with_capacity(k);
    let mut ring = [0u64; AHEAD];
    for (i, r) in ring.iter_mut().enumerate().take(k) {
        *r = hash(&v[i]);
        prefetch(&table, (*r >> (64 - bits)) as usize);
    }
    for i in 0..k {
        let h = ring[i % AHEAD];
        if i + AHEAD / 2 < k {
            // halfway: the slot fetched by now names the row it holds (if any), fetched too
            let held = table[(ring[(i + AHEAD / 2) % AHEAD] >> (64 - bits)) as usize];
            if held != u32::MAX {
                prefetch(v, held as usize);
            }
        }
        if i + AHEAD < k {
            let next = hash(&v[i + AHEAD]);
            ring[i % AHEAD] = next;
            prefetch(&table, (next >> (64 - bits)) as usize);
        }
        let b = key(&v[i]);
        let mask = (1usize << bits) - 1;
        let mut s = (h >> (64 - bits)) as usize & mask;
        let got = loop {
            let held = table[s];
            if held == u32::MAX {
                table[s] = i as u32;
                held_count += 1;
                break i as i64;
            }
            if key(&v[held as usize]) == b {
                break held as i64;
            }
            s = (s + 1) & mask;
        };
        first.push(got);
        if 2 * held_count > table.len() {
            // half the slots held: twice the slots, every held row placed again by its hash
            bits += 1;
            let mask = (1usize << bits) - 1;
            let mut grown = vec![u32::MAX; 1usize << bits];
            for &held in table.iter().filter(|&&x| x != u32::MAX) {
                let mut s = (hash(&v[held as usize]) >> (64 - bits)) as usize & mask;
                while grown[s] != u32::MAX {
                    s = (s + 1) & mask;
                }
                grown[s] = held;
            }
            table = grown;
        }
    }
    Some(first)
}

/// Rows looked ahead by [`first_equal_rows`]: their table slots are fetched meanwhile (and
/// halfway there, the rows those slots hold).
const AHEAD: usize = 64;

/// A binary STL's triangle soup welded exactly as it is read: the distinct corners and the
/// faces over them, the answer `weld._welded`'s exact pass gives for the float64 soup the
/// numpy reader builds (`mesh_io._read_stl`), without building it. `records`: the file's
/// `n` records of 50 bytes (normal, three corners of three little-endian float32, attribute
/// count), read from the file's bytes. Corners are equal when their float32 bits are (−0.0
/// counted as 0.0: float32 → float64 widening is exact and keeps equality); the vertices
/// come in the order of their first corner, with that corner's value widened (a −0.0 kept).
/// Returns (vertices (k × 3, flat) float64, corner → vertex (3n,) int64), or None when a
/// coordinate is NaN or infinite (the numpy reader then names the problem), the records are
/// short, or there are too many corners for 32-bit ids.
pub fn stl_corners_welded(records: &[u8], n: usize) -> Option<(Vec<f64>, Vec<i64>)> {
    let k = n.checked_mul(3)?;
    if k >= u32::MAX as usize || records.len() < n.checked_mul(50)? {
        return None;
    }
    let raw = |i: usize| -> [u32; 3] {
        // corner i: record i / 3, after its 12-byte normal, 12 bytes per corner
        let o = 50 * (i / 3) + 12 + 12 * (i % 3);
        let c: &[u8; 12] = records[o..o + 12].try_into().unwrap(); // one bounds check
        let w = |j: usize| u32::from_le_bytes([c[j], c[j + 1], c[j + 2], c[j + 3]]);
        [w(0), w(4), w(8)]
    };
    let key = |b: [u32; 3]| b.map(|x| if x == 0x8000_0000 { 0 } else { x });
    let hash = |b: [u32; 3]| mix(b[0] as u64, b[1] as u64, b[2] as u64);
    let slots_for = |distinct: usize| (2 * distinct.max(512)).next_power_of_two();
    let mut bits = slots_for(k / 6 + 1).trailing_zeros();
    let mut table = vec![u32::MAX; 1usize << bits];
    let mut keys: Vec<[u32; 3]> = Vec::with_capacity(k / 6 + 1);
    let mut verts: Vec<f64> = Vec::with_capacity(3 * (k / 6 + 1));
    let mut corner = Vec::with_capacity(k);
    // the raw corners and their hashes AHEAD rows on (each corner decoded once)
    let mut ring = [([0u32; 3], 0u64); AHEAD];
    for (i, slot) in ring.iter_mut().enumerate().take(k) {
        let r = raw(i);
        *slot = (r, hash(key(r)));
        prefetch(&table, (slot.1 >> (64 - bits)) as usize);
    }
    for i in 0..k {
        let (r, h) = ring[i % AHEAD];
        if i + AHEAD / 2 < k {
            // halfway: the slot fetched by now names the vertex it holds (if any), fetched too
            let held = table[(ring[(i + AHEAD / 2) % AHEAD].1 >> (64 - bits)) as usize];
            if held != u32::MAX {
                prefetch(&keys, held as usize);
            }
        }
        if i + AHEAD < k {
            let next = raw(i + AHEAD);
            let hn = hash(key(next));
            ring[i % AHEAD] = (next, hn);
            prefetch(&table, (hn >> (64 - bits)) as usize);
        }
        let b = key(r);
        let mask = (1usize << bits) - 1;
        let mut s = (h >> (64 - bits)) as usize & mask;
        let id = loop {
            let held = table[s];
            if held == u32::MAX {
                let f = r.map(f32::from_bits);
                if !f.iter().all(|x| x.is_finite()) {
                    return None;
                }
                let id = keys.len() as u32;
                table[s] = id;
                keys.push(b);
                verts.extend(f.map(f64::from));
                break id;
            }
            if keys[held as usize] == b {
                break held;
            }
            s = (s + 1) & mask;
        };
        corner.push(id as i64);
        if 2 * keys.len() > table.len() {
            // half the slots held: twice the slots, every vertex placed again by its hash
            bits += 1;
            let mask = (1usize << bits) - 1;
            let mut grown = vec![u32::MAX; 1usize << bits];
            for (id, b) in keys.iter().enumerate() {
                let mut s = (hash(*b) >> (64 - bits)) as usize & mask;
                while grown[s] != u32::MAX {
                    s = (s + 1) & mask;
                }
                grown[s] = id as u32;
            }
            table = grown;
        }
    }
    Some((verts, corner))
}
