//! Running out of memory as an error: the binary's global allocator is the system's, and a
//! request it refuses (past `ulimit -v`, a container's limit, a machine without swap)
//! ends the command with one line on stderr and status 1, from whichever thread asked,
//! after removing the command's temporaries, instead of Rust's default abort (a core dump,
//! "memory allocation of N bytes failed") or a panic. The memory models refuse the work
//! that would exceed the limit before allocating; this is what is left when something
//! outside them does.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, Ordering};

/// The system allocator, ending the command cleanly where it refuses a request.
pub struct Guarded;

// SAFETY: every call forwards to `System` with the same arguments; a null result ends the
// process instead of being returned.
unsafe impl GlobalAlloc for Guarded {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        checked(System.alloc(layout), layout.size())
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        checked(System.alloc_zeroed(layout), layout.size())
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        checked(System.realloc(ptr, layout, new_size), new_size)
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
}

/// `p`, or the end of the command when the allocator refused `size` bytes.
#[inline]
fn checked(p: *mut u8, size: usize) -> *mut u8 {
    if p.is_null() {
        out_of_memory(size);
    }
    p
}

/// Set by the first thread that runs out: a second one (or an allocation failing inside
/// the cleanup) ends the process at once.
static ENDING: AtomicBool = AtomicBool::new(false);

#[cold]
fn out_of_memory(size: usize) -> ! {
    if !ENDING.swap(true, Ordering::SeqCst) {
        // The message is made without allocating: the number is written into a buffer on
        // the stack.
        let mut digits = [0u8; 20];
        let mut n = size;
        let mut i = digits.len();
        loop {
            i -= 1;
            digits[i] = b'0' + (n % 10) as u8;
            n /= 10;
            if n == 0 {
                break;
            }
        }
        let parts: [&[u8]; 3] = [
            b"error: out of memory: the system refused ",
            &digits[i..],
            b" bytes; lower the size of the work or raise the memory limit (--max-memory, ulimit -v)\n",
        ];
        for p in parts {
            // SAFETY: writing a valid buffer to stderr.
            unsafe { libc::write(2, p.as_ptr().cast(), p.len()) };
        }
        // Small allocations may still succeed; where one fails, ENDING stops a second round.
        render::output::remove_temporaries();
    }
    // SAFETY: _exit ends the process without running anything that could allocate.
    unsafe { libc::_exit(1) }
}
