//! Allocator settings for the training and benchmark commands.
//!
//! burn allocates and frees a fresh buffer for nearly every tensor operation; under autodiff
//! at HOOD size these are tens of MB each ([64360, 128] f32 is 33 MB). glibc serves blocks
//! above its mmap threshold (at most 32 MB) with `mmap` and returns them with `munmap`, and
//! trims the heap top after every large free, so the same pages are faulted in and zeroed by
//! the kernel again and again: a third of the HOOD-size forward + backward was kernel time.
//! Keeping freed memory in the heap removes most of it (`cargo xtask bench model --sizes
//! hood --quick`, two runs each: forward + backward 11.5 / 11.8 → 8.8 / 7.7 s, forward
//! 5.4 / 5.1 → 3.5 / 3.6 s; reports/bench/model-hood.md). The process keeps its peak heap until it exits, which is what a training
//! or benchmark run wants anyway.

/// Serve every allocation from the heap (no per-block `mmap`) and never trim the heap top.
/// Does nothing off glibc.
pub fn keep_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[allow(unsafe_code)]
    // SAFETY: `mallopt` only changes allocator parameters; it is called before any other
    // thread exists, and an unaccepted value is reported by its return value, not by UB.
    unsafe {
        libc::mallopt(libc::M_MMAP_MAX, 0);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
        libc::mallopt(libc::M_TOP_PAD, 64 << 20);
    }
}

/// Hands the heap's free memory back to the kernel (`malloc_trim`), e.g. before starting
/// another memory-hungry process whose time is being compared with ours. Does nothing off
/// glibc.
pub fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    #[allow(unsafe_code)]
    // SAFETY: `malloc_trim` only returns free heap pages to the kernel; no live allocation
    // is touched.
    unsafe {
        libc::malloc_trim(0);
    }
}
