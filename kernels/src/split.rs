//! Splitting a pass over the threads of the caller's rayon pool where the answer does not
//! depend on the split: item ranges, disjoint mutable pieces of one array, arrays written
//! once without being filled first, and scattered writes to positions known to be disjoint.
//!
//! The kernels that use it allocate their arrays on the calling thread and hand only the
//! passes to the pool: the arrays come from the calling thread's malloc arena, as they did
//! before the passes were split, not from a pool worker's.

use std::mem::MaybeUninit;
use std::ops::Range;

/// `0..n` cut into `parts` ranges of nearly equal length (the first ones one longer), in
/// order; one empty range when n is 0.
pub fn even_ranges(n: usize, parts: usize) -> Vec<Range<usize>> {
    let parts = parts.max(1).min(n.max(1));
    let (q, r) = (n / parts, n % parts);
    let mut out = Vec::with_capacity(parts);
    let mut s = 0;
    for p in 0..parts {
        let e = s + q + usize::from(p < r);
        out.push(s..e);
        s = e;
    }
    out
}

/// `threads` (a pool's), but at most one a `min_items` items (a small job stays on one).
pub fn parts_for(threads: usize, items: usize, min_items: usize) -> usize {
    threads.max(1).min(items / min_items.max(1)).max(1)
}

/// `s` cut into consecutive pieces of the lengths `lens` (their sum at most `s.len()`).
pub fn pieces<T>(mut s: &mut [T], lens: impl IntoIterator<Item = usize>) -> Vec<&mut [T]> {
    let mut out = Vec::new();
    for l in lens {
        let (a, b) = std::mem::take(&mut s).split_at_mut(l);
        out.push(a);
        s = b;
    }
    out
}

/// `len` uninitialised items, to be written (by pieces, on several threads) before
/// [`assume_written`]: no zeros written first (`vec![0; len]` is free on fresh pages, but
/// a memset where the allocator hands back memory it had).
pub fn uninit<T>(len: usize) -> Vec<MaybeUninit<T>> {
    let mut v = Vec::with_capacity(len);
    // SAFETY: MaybeUninit items need no initialisation
    unsafe { v.set_len(len) };
    v
}

/// The items of `v`, every one of them written.
///
/// # Safety
/// Every item of `v` has been written.
pub unsafe fn assume_written<T>(v: Vec<MaybeUninit<T>>) -> Vec<T> {
    let mut v = std::mem::ManuallyDrop::new(v);
    // SAFETY: MaybeUninit<T> has T's layout; the items are written (the caller's contract)
    unsafe { Vec::from_raw_parts(v.as_mut_ptr() as *mut T, v.len(), v.capacity()) }
}

/// A raw pointer to an array that threads write at positions known to be disjoint (each
/// position by one thread only, none read meanwhile).
#[derive(Clone, Copy)]
pub struct Scatter<T>(*mut T);

// SAFETY: the writers' positions are disjoint (the users' contract), so no data race
unsafe impl<T: Send> Send for Scatter<T> {}
unsafe impl<T: Send> Sync for Scatter<T> {}

impl<T> Scatter<T> {
    pub fn new(s: &mut [T]) -> Self {
        Scatter(s.as_mut_ptr())
    }

    /// Writes `x` at position `i`.
    ///
    /// # Safety
    /// `i` is within the array, and no other thread reads or writes position `i` meanwhile.
    #[inline(always)]
    pub unsafe fn put(self, i: usize, x: T) {
        unsafe { self.0.add(i).write(x) }
    }
}
