//! Memory accounting for per-statement budgets.
//!
//! [`CountingAlloc`] wraps the system allocator and keeps, per thread, the net number of bytes
//! that thread has allocated (allocations minus frees). A Cypher statement runs on one thread,
//! so the growth of that number while it runs is what the statement holds; the engine compares
//! it with the statement's budget ([`crate::cypher::QueryOptions::max_memory_bytes`]) as values
//! are built and stops the statement with [`crate::cypher::ErrorKind::MemoryLimit`] before the
//! process runs out.
//!
//! A binary installs it once:
//! ```
//! #[global_allocator]
//! static ALLOC: graphstore::mem::CountingAlloc = graphstore::mem::CountingAlloc;
//! # fn main() {}
//! ```
//! Without it, [`thread_net_bytes`] stays 0 and the budget counts only the sizes the engine
//! checks before large allocations (`range`, string and list concatenation, `replace`, index
//! procedures' `k`), a lower bound.
//!
//! [`release_free_memory`] hands freed heap pages back to the operating system (glibc's
//! `malloc_trim`), so a server's resident size returns to its baseline after a statement that
//! built and dropped a large intermediate result.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

thread_local! {
    static NET: Cell<i64> = const { Cell::new(0) };
}

#[inline]
fn add(delta: i64) {
    // `try_with`: an allocation while the thread's locals are being torn down is not counted
    let _ = NET.try_with(|n| n.set(n.get().wrapping_add(delta)));
}

/// The system allocator with per-thread net byte counts (see the module docs).
#[derive(Debug, Clone, Copy, Default)]
pub struct CountingAlloc;

#[allow(unsafe_code)]
// SAFETY: every call forwards to `System` with the caller's own arguments and only adds
// bookkeeping in a thread-local `Cell` that never allocates (const-initialised, no destructor).
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded unchanged; the caller upholds `GlobalAlloc::alloc`'s contract
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            add(layout.size() as i64);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as for `alloc`
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            add(layout.size() as i64);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from this allocator (so from `System`) with this layout
        unsafe { System.dealloc(ptr, layout) };
        add(-(layout.size() as i64));
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as for `dealloc`; `new_size` is the caller's
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            add(new_size as i64 - layout.size() as i64);
        }
        p
    }
}

/// Net bytes this thread has allocated since it started (may be negative when it frees what
/// other threads allocated); 0 when [`CountingAlloc`] is not the global allocator. Only
/// differences between two readings on one thread mean anything.
pub fn thread_net_bytes() -> i64 {
    NET.try_with(Cell::get).unwrap_or(0)
}

/// Runs `f` without charging what it allocates (and keeps) to this thread's count: for
/// shared caches built while a statement runs, which outlive the statement.
pub(crate) fn uncounted<T>(f: impl FnOnce() -> T) -> T {
    let before = thread_net_bytes();
    let out = f();
    let _ = NET.try_with(|n| n.set(before));
    out
}

/// Whether [`CountingAlloc`] counts this process's allocations (checked once, by allocating).
pub fn counting() -> bool {
    static COUNTING: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *COUNTING.get_or_init(|| {
        let before = thread_net_bytes();
        let probe: Vec<u8> = Vec::with_capacity(4096);
        let after = thread_net_bytes();
        drop(std::hint::black_box(probe));
        after - before >= 4096
    })
}

/// Returns freed heap memory to the operating system where the C library allows it (glibc's
/// `malloc_trim(0)`); elsewhere does nothing. Takes milliseconds on a large heap, so call it
/// after a statement that used much memory, not after every one.
pub fn release_free_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        #[allow(unsafe_code)]
        // SAFETY: malloc_trim only walks glibc's own arenas and takes no pointers from us
        unsafe {
            libc::malloc_trim(0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_this_threads_allocations() {
        // the test binary installs CountingAlloc (lib.rs)
        assert!(counting());
        let before = thread_net_bytes();
        let v: Vec<u64> = vec![7; 1 << 20];
        let mid = thread_net_bytes();
        assert!(mid - before >= 8 << 20, "counted {}", mid - before);
        drop(v);
        let after = thread_net_bytes();
        assert!((after - before).abs() < 4096, "left {}", after - before);
        // another thread's allocations are not this thread's
        let other = std::thread::spawn(|| {
            let start = thread_net_bytes();
            let v = vec![1u8; 1 << 20];
            std::hint::black_box(&v);
            thread_net_bytes() - start
        })
        .join()
        .unwrap();
        assert!(other >= 1 << 20);
        assert!((thread_net_bytes() - after).abs() < 64 << 10);
        release_free_memory();
    }
}
