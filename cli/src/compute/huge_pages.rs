//! Large lists filled once (a million parsed rows, their observations) backed by the
//! processor's 2 MB pages where Linux offers them on request (transparent huge pages in
//! `madvise` mode): the first write to each 4 KB page otherwise costs a page fault, ~150,000
//! of them for a million poses, a tenth of the CPU time of `identify` outside its passes.

/// A list with room for `n` items whose memory Linux is asked to back with huge pages (a
/// hint: ignored where not offered, and for lists under a few megabytes).
pub fn with_capacity<T>(n: usize) -> Vec<T> {
    let v = Vec::with_capacity(n);
    advise(&v);
    v
}

/// Asks for huge pages for the whole 2 MB pages inside `v`'s capacity, before anything is
/// written there.
fn advise<T>(v: &Vec<T>) {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let bytes = v.capacity().saturating_mul(std::mem::size_of::<T>());
        if bytes < 2 * HUGE {
            return;
        }
        let start = v.as_ptr() as usize;
        let first = start.next_multiple_of(HUGE);
        let end = (start + bytes) / HUGE * HUGE;
        if end > first {
            // SAFETY: `first..end` lies inside the list's own allocation (its capacity), which
            // stays allocated and is not moved while this runs; MADV_HUGEPAGE changes how the
            // kernel backs those pages, never their contents or the mapping's permissions, and
            // its failure (a kernel without it) is harmless.
            unsafe {
                libc::madvise(first as *mut libc::c_void, end - first, libc::MADV_HUGEPAGE);
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = v;
}
