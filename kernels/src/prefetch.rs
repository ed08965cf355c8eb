//! Cache hints: ask the CPU to fetch memory a walk will read soon (nothing the program sees
//! changes; no effect off x86_64).

/// The cache line at `p` (any address: a prefetch reads nothing and never faults).
#[inline(always)]
pub(crate) fn prefetch_line<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing the program sees and faults never, whatever the address
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(p as *const i8);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// Item `i` of `items` (nothing when `i` is out of range).
#[inline(always)]
pub(crate) fn prefetch<T>(items: &[T], i: usize) {
    if let Some(x) = items.get(i) {
        prefetch_line(x as *const T);
    }
}

/// Every cache line of `items` (64-byte steps from its start).
#[inline(always)]
pub(crate) fn prefetch_all<T>(items: &[T]) {
    let p = items.as_ptr() as *const u8;
    let bytes = std::mem::size_of_val(items);
    let mut o = 0;
    while o < bytes {
        prefetch_line(p.wrapping_add(o));
        o += 64;
    }
}
