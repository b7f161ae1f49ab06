//! Data-parallel primitives for the ray-space hierarchies and the irregular grid.
//!
//! The CRSH pipeline is built from GPU primitives (the thesis uses CUB): scans, stream
//! compaction ("trimming", §3.2.3), run-length compression into chunks (§3.2.4), key-value
//! radix sort (§3.2.5) and decompression (§3.2.6). Each primitive here is a plain function
//! over slices with caller-provided outputs (and reusable scratch where it needs any), written
//! block-wise like its GPU counterpart — per-block reduce, a small sequential scan of block
//! totals, per-block apply — so a wgpu backend can mirror it kernel for kernel.
//!
//! Parallelism is over at most [`MAX_BLOCKS`] contiguous blocks of at least [`MIN_BLOCK`]
//! elements; below that the same code runs as one block. Results never depend on the number
//! of threads.

#![warn(missing_docs)]

pub mod compact;
pub mod emit;
pub mod runs;
pub mod scan;
pub mod sort;

pub use compact::{collect_blocks, compact, compact_pairs, compact_with, Flag};
pub use emit::{emit_pairs, emit_streams, Pairs};
pub use runs::{compress_runs, expand_runs, segmented_inclusive_scan};
pub use scan::{exclusive_scan, exclusive_scan_in_place, inclusive_scan, Elem};
pub use sort::{sort_pairs, RadixKey, SortScratch};

/// Smallest block a parallel pass hands to one task.
pub const MIN_BLOCK: usize = 4096;
/// Most blocks a pass is cut into (block totals live in fixed-size stack arrays).
pub const MAX_BLOCKS: usize = 256;

/// (number of blocks, block length) for `n` elements.
#[inline]
pub(crate) fn blocks(n: usize) -> (usize, usize) {
    if n <= MIN_BLOCK {
        return (1, n.max(1));
    }
    let threads = rayon::current_num_threads().max(1);
    let nb = n.div_ceil(MIN_BLOCK).min(threads * 8).min(MAX_BLOCKS);
    (nb, n.div_ceil(nb))
}

/// A raw pointer that may be shared across the tasks of one pass (also used by the engines'
/// count → scan → emit passes).
///
/// Used only where each task writes a set of indices that is disjoint from every other
/// task's by construction (exclusive-scan offsets), which is what makes the writes sound.
#[derive(Clone, Copy)]
pub struct SharedMut<T>(pub *mut T);
unsafe impl<T: Send> Send for SharedMut<T> {}
unsafe impl<T: Send> Sync for SharedMut<T> {}

impl<T> SharedMut<T> {
    /// # Safety
    /// `i` must be in bounds and no other task may access index `i` during the pass.
    #[inline]
    pub unsafe fn write(&self, i: usize, v: T) {
        unsafe { self.0.add(i).write(v) }
    }
}
