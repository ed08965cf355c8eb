//! Morton (z-order) codes of 10-bit cell coordinates: items sorted by them come in the order
//! of a space-filling curve (the collision tree's build, as `tri_tree._morton`; verify's
//! whole-path material query, `swept_ball`).

/// The 10 low bits of x with two zero bits between each: one coordinate's share of a
/// 30-bit Morton code.
#[inline(always)]
pub fn spread10(x: u64) -> u64 {
    let mut x = x & 0x3FF;
    x = (x | (x << 16)) & 0x30000FF;
    x = (x | (x << 8)) & 0x300F00F;
    x = (x | (x << 4)) & 0x30C30C3;
    x = (x | (x << 2)) & 0x9249249;
    x
}

/// The 30-bit Morton code of the cell (x, y, z), each coordinate's 10 low bits.
#[inline(always)]
pub fn code3(x: u64, y: u64, z: u64) -> u64 {
    spread10(x) | (spread10(y) << 1) | (spread10(z) << 2)
}
