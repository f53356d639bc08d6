//! The `kinecal` process's heap: freed blocks kept for reuse instead of returned to the system.
//!
//! glibc's allocator serves a block of more than 128 KiB (at first; the threshold grows as such
//! blocks are freed) by mapping fresh pages, and returns them when it is freed. `diagnose`'s
//! screen builds several such blocks per candidate and fold (the `p × m` blocks of the
//! normal equations, a `p × p` copy), hundreds of thousands in a search: on the UR10 series
//! (2,773 poses) the page faults took 0.6–0.9 s of system time in a 3.4 s run. With blocks under
//! 4 MiB taken from the heap (the screen's blocks are under 1 MiB) and freed memory kept until
//! 32 MiB of it lie unused at the top, the system time is 0.07–0.2 s
//! (`GLIBC_TUNABLES=glibc.malloc.mmap_threshold=4194304:glibc.malloc.trim_threshold=33554432`
//! measures the same). Larger blocks (a million poses' lists) are still mapped and returned:
//! with 64 MiB and 256 MiB the million-pose `identify` of `.ci/run`'s memory guard peaked at
//! 430 MB instead of 343 (budget 400); with these thresholds at 345 MB. Only the command line's
//! process sets this: the Python module leaves its host's allocator alone.

/// Keeps freed heap blocks for reuse (glibc on Linux; elsewhere nothing to do).
pub fn keep_freed_blocks() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets two of the allocator's thresholds, before any thread exists;
    // a value it refuses leaves the default in place.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 4 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 32 << 20);
    }
}
