//! Test support shared by the cnc402 crates' tests (a dev-dependency only).
//! [`CountingAlloc`] is the proof behind every "this per-cycle path allocates nothing" test:
//! a test binary installs it as its global allocator and counts what one thread allocates
//! while armed, so the harness's other test threads never disturb the count.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The system allocator, counting allocations, reallocations and frees made on an armed
/// thread. Install it in a test binary with
/// `#[global_allocator] static GLOBAL: cnc402_testkit::CountingAlloc = cnc402_testkit::CountingAlloc;`.
pub struct CountingAlloc;

thread_local! {
    static ARMED: Cell<bool> = const { Cell::new(false) };
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
}

fn note() {
    // `try_with`: the thread-locals may already be gone while a thread shuts down, and an
    // allocator must not panic.
    let _ = ARMED.try_with(|a| {
        if a.get() {
            let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
        }
    });
}

// SAFETY: every call is forwarded unchanged to `System`; counting touches only
// const-initialised thread-locals, which never allocate.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note();
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Arms (or disarms) counting on the current thread.
pub fn arm(on: bool) {
    ARMED.with(|a| a.set(on));
}

/// Allocator calls counted on the current thread so far.
pub fn allocs() -> u64 {
    ALLOCS.with(|c| c.get())
}

/// Runs `f` armed and returns its result with the allocator calls it made on this thread.
/// Only meaningful in a binary that installed [`CountingAlloc`].
///
/// ```
/// # use cnc402_testkit::count_allocs;
/// let (sum, _) = count_allocs(|| (1..=10).sum::<u32>());
/// assert_eq!(sum, 55);
/// ```
pub fn count_allocs<R>(f: impl FnOnce() -> R) -> (R, u64) {
    let before = allocs();
    arm(true);
    let r = f();
    arm(false);
    (r, allocs() - before)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[global_allocator]
    static GLOBAL: CountingAlloc = CountingAlloc;

    #[test]
    fn counts_what_the_armed_thread_allocates_and_nothing_else() {
        let (v, n) = count_allocs(|| vec![1u8; 100]);
        assert_eq!(v.len(), 100);
        assert_eq!(n, 1);
        let (_, n) = count_allocs(|| drop(v));
        assert_eq!(n, 1, "a free counts too");
        let (_, n) = count_allocs(|| {
            let mut s = String::new();
            s.push_str("grows");
            s.push_str(&"x".repeat(100));
        });
        assert!(n >= 3, "{n}");
        // Another thread's allocations while this one is armed are not counted.
        let (_, n) = count_allocs(|| {
            let h = std::thread::spawn(|| vec![0u64; 1000].len());
            h.join().unwrap()
        });
        // Spawning itself allocates on this thread; the child's vector does not count here.
        let (_, spawn_only) = count_allocs(|| std::thread::spawn(|| 0).join().unwrap());
        assert!(n <= spawn_only + 2, "{n} vs {spawn_only}");
        let (_, n) = count_allocs(|| 2 + 2);
        assert_eq!(n, 0);
    }
}
