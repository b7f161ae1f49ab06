//! The fuzzer's global allocator: the system allocator, counting what the loaders ask for.
//!
//! Two limits make "no allocation over a stated cap" a checked property instead of a hope:
//! every request larger than [`SOFT_CAP`] made on a fuzzing thread is a finding (the input
//! is saved and the run fails), and a request larger than [`HARD_CAP`] on any thread is
//! refused before the system sees it (the input in flight is saved by the breach hook, then
//! the allocation-error handler aborts), so a loader that trusts a count in a file cannot
//! take the machine down with it.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use std::sync::OnceLock;

/// The stated cap: no loader may ask for more in one allocation on any input the fuzzer
/// makes (its seeds are under 64 KiB; the real scenes need at most tens of MiB at once).
pub const SOFT_CAP: usize = 256 << 20;
/// Requests above this are refused outright.
pub const HARD_CAP: usize = 2 << 30;

/// The counting allocator (installed by this crate for every binary that links it).
pub struct Counting;

static LARGEST: AtomicUsize = AtomicUsize::new(0);
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static ON_BREACH: OnceLock<fn(usize)> = OnceLock::new();

thread_local! {
    /// The largest request made on this thread since [`take_thread_largest`].
    static THREAD_LARGEST: Cell<usize> = const { Cell::new(0) };
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn admit(size: usize) -> bool {
    LARGEST.fetch_max(size, Relaxed);
    // try_with: a thread being torn down has no locals left, and that is fine.
    let _ = THREAD_LARGEST.try_with(|c| c.set(c.get().max(size)));
    if size > HARD_CAP {
        if let Some(f) = ON_BREACH.get() {
            f(size);
        }
        return false;
    }
    true
}

fn grew(size: usize) {
    let now = LIVE.fetch_add(size, Relaxed) + size;
    PEAK.fetch_max(now, Relaxed);
}

// SAFETY: every call forwards to the system allocator with the caller's layout; the
// bookkeeping only reads sizes and never touches the memory.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        if !admit(l.size()) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc(l) };
        if !p.is_null() {
            grew(l.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        if !admit(l.size()) {
            return std::ptr::null_mut();
        }
        let p = unsafe { System.alloc_zeroed(l) };
        if !p.is_null() {
            grew(l.size());
        }
        p
    }

    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) };
        LIVE.fetch_sub(l.size(), Relaxed);
    }

    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        if !admit(new) {
            return std::ptr::null_mut();
        }
        let q = unsafe { System.realloc(p, l, new) };
        if !q.is_null() {
            LIVE.fetch_sub(l.size(), Relaxed);
            grew(new);
        }
        q
    }
}

/// Set what runs (once) when a request above [`HARD_CAP`] is refused: save the inputs in
/// flight. It may allocate (small amounts).
pub fn on_breach(f: fn(usize)) {
    let _ = ON_BREACH.set(f);
}

/// The largest request made on this thread since the last call, and reset.
pub fn take_thread_largest() -> usize {
    THREAD_LARGEST.with(|c| c.replace(0))
}

/// The largest request on any thread since the last call, and reset.
pub fn take_largest() -> usize {
    LARGEST.swap(0, Relaxed)
}

/// The peak of live bytes since the last call (reset to what is live now).
pub fn take_peak() -> usize {
    PEAK.swap(LIVE.load(Relaxed), Relaxed)
}
