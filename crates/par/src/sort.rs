//! Stable LSD radix sort of (key, u32 value) pairs, keys u32 or u64, parallel.
//!
//! Each pass sorts by one 8-bit digit, as on a GPU: per-block digit histograms, a digit-major
//! exclusive scan over (digit, block) so that every block owns a contiguous output range per
//! digit (this is what makes the sort stable), and a per-block scatter (parallel). Only the
//! low `bits` of each key take part, since hash keys rarely use all 32 (thesis §3.2.5 sorts
//! chunk keys). O(n · ⌈bits / 8⌉) work; scratch is caller-owned and reused across calls.
//!
//! The sort is limited by memory traffic, so the passes are arranged to move each byte as
//! few times as possible:
//! - the AND and OR of all keys tell which digits are the same for every key (those passes
//!   are skipped), and one sweep counts the first pass's per-block histograms;
//! - each scatter counts, per destination block, the *next* pass's digits of the items it
//!   writes, so later passes need no histogram sweep (a GPU does the same with one partial
//!   histogram per work-group);
//! - the first pass reads the caller's key and value arrays and the last writes them back,
//!   so packing into (key, value) items costs no extra pass.

use crate::SharedMut;
use rayon::prelude::*;

const RADIX_BITS: u32 = 8;
const BUCKETS: usize = 1 << RADIX_BITS;

/// An unsigned integer key.
pub trait RadixKey: Copy + Send + Sync + Default + 'static {
    /// Width of the key in bits.
    const BITS: u32;
    /// `(self >> shift)` truncated to u32.
    fn shifted(self, shift: u32) -> u32;
    /// The key widened to u64.
    fn wide(self) -> u64;
}

impl RadixKey for u32 {
    const BITS: u32 = 32;
    #[inline]
    fn shifted(self, shift: u32) -> u32 {
        self >> shift
    }
    #[inline]
    fn wide(self) -> u64 {
        self as u64
    }
}

impl RadixKey for u64 {
    const BITS: u32 = 64;
    #[inline]
    fn shifted(self, shift: u32) -> u32 {
        (self >> shift) as u32
    }
    #[inline]
    fn wide(self) -> u64 {
        self
    }
}

/// A key and its value moved together, so each scatter writes one stream per digit.
#[derive(Clone, Copy, Default)]
#[repr(C)]
struct Item<K> {
    key: K,
    val: u32,
}

/// Reusable scratch: two ping-pong item buffers and the histograms.
pub struct SortScratch<K> {
    a: Vec<Item<K>>,
    b: Vec<Item<K>>,
    /// Per-block histograms of the current pass: nb × 256.
    hist: Vec<u32>,
    /// Next-pass counts: nb (source) × nb (destination) × 256.
    partial: Vec<u32>,
}

impl<K: RadixKey> Default for SortScratch<K> {
    fn default() -> Self {
        Self::new()
    }
}

impl<K: RadixKey> SortScratch<K> {
    /// Empty scratch; buffers grow on first use and are reused by later sorts.
    pub fn new() -> Self {
        SortScratch {
            a: Vec::new(),
            b: Vec::new(),
            hist: Vec::new(),
            partial: Vec::new(),
        }
    }
}

/// A digit: shift and mask.
#[derive(Clone, Copy)]
struct Digit {
    shift: u32,
    mask: u32,
}

impl Digit {
    #[inline]
    fn of<K: RadixKey>(self, k: K) -> usize {
        (k.shifted(self.shift) & self.mask) as usize
    }
}

/// Turn per-block histograms (nb × 256) into per-(block, digit) output offsets, digit-major.
fn offsets_in_place(hist: &mut [u32], nb: usize) {
    let mut running = 0u32;
    for d in 0..BUCKETS {
        for b in 0..nb {
            let c = hist[b * BUCKETS + d];
            hist[b * BUCKETS + d] = running;
            running += c;
        }
    }
}

/// Where a pass writes: an item buffer, or the caller's split key and value arrays.
#[derive(Clone, Copy)]
enum Dst<K> {
    Items(SharedMut<Item<K>>),
    Split(SharedMut<K>, SharedMut<u32>),
}

/// One block's share of a scatter pass: the digit it scatters by (and the next pass's, to
/// count), its running offsets per digit, its partial counts of the next digit, and where
/// it writes.
struct Block<'a, K> {
    digit: Digit,
    next: Option<Digit>,
    log_bl: u32,
    off: &'a mut [u32],
    part: &'a mut [u32],
    dst: Dst<K>,
}

/// Scatter one block's items (in order) to their offsets, optionally counting the next
/// digit per destination block. A plain loop over an iterator: this is the hot loop.
#[inline(always)]
fn scatter_block<K: RadixKey>(items: impl Iterator<Item = Item<K>>, block: Block<K>) {
    let (digit, next, log_bl) = (block.digit, block.next, block.log_bl);
    let (off, part, dst) = (block.off, block.part, block.dst);
    let off: &mut [u32; BUCKETS] = off.try_into().unwrap();
    match (dst, next) {
        (Dst::Items(out), Some(nd)) => {
            for it in items {
                let d = digit.of(it.key);
                let p = off[d] as usize;
                off[d] += 1;
                // SAFETY: see `scatter`.
                unsafe { out.write(p, it) };
                part[(p >> log_bl) * BUCKETS + nd.of(it.key)] += 1;
            }
        }
        (Dst::Items(out), None) => {
            for it in items {
                let d = digit.of(it.key);
                let p = off[d] as usize;
                off[d] += 1;
                // SAFETY: see `scatter`.
                unsafe { out.write(p, it) };
            }
        }
        (Dst::Split(ko, vo), _) => {
            for it in items {
                let d = digit.of(it.key);
                let p = off[d] as usize;
                off[d] += 1;
                // SAFETY: see `scatter`.
                unsafe {
                    ko.write(p, it.key);
                    vo.write(p, it.val);
                }
            }
        }
    }
}

/// Where a scatter pass reads: an item buffer or the caller's split key and value arrays.
#[derive(Clone, Copy)]
enum Src<'a, K> {
    Items(&'a [Item<K>]),
    Split(&'a [K], &'a [u32]),
}

impl<K> Src<'_, K> {
    fn len(&self) -> usize {
        match self {
            Src::Items(v) => v.len(),
            Src::Split(k, _) => k.len(),
        }
    }
}

/// One scatter pass over all of `src` with per-block offsets in `hist`. When `next` is given, counts the next digit
/// of every written item per destination block into `partial` and leaves the next pass's
/// per-block histograms in `hist`.
///
/// SAFETY of the writes: each (digit, block) destination range comes from the exclusive scan
/// of the histograms, so the ranges are disjoint and cover 0..n once, and every destination
/// buffer has length n.
fn scatter<K: RadixKey>(
    bl: usize,
    digit: Digit,
    next: Option<Digit>,
    hist: &mut [u32],
    partial: &mut [u32],
    src: Src<K>,
    dst: Dst<K>,
) {
    let n = src.len();
    let nb = hist.len() / BUCKETS;
    let stride = nb * BUCKETS;
    debug_assert!(bl.is_power_of_two());
    let log_bl = bl.trailing_zeros();
    hist.par_chunks_mut(BUCKETS)
        .zip(partial.par_chunks_mut(stride))
        .enumerate()
        .for_each(|(b, (off, part))| {
            if next.is_some() {
                part.fill(0);
            }
            let r = b * bl..((b + 1) * bl).min(n);
            let block = Block {
                digit,
                next,
                log_bl,
                off,
                part,
                dst,
            };
            match src {
                Src::Items(items) => scatter_block(items[r].iter().copied(), block),
                Src::Split(ks, vs) => scatter_block(
                    ks[r.clone()]
                        .iter()
                        .zip(&vs[r])
                        .map(|(&key, &val)| Item { key, val }),
                    block,
                ),
            }
        });
    if next.is_some() {
        // hist[dst block][digit] = Σ over source blocks.
        hist.par_chunks_mut(BUCKETS)
            .enumerate()
            .for_each(|(db, h)| {
                h.fill(0);
                for sb in 0..nb {
                    let src =
                        &partial[sb * stride + db * BUCKETS..sb * stride + (db + 1) * BUCKETS];
                    for (x, y) in h.iter_mut().zip(src) {
                        *x += y;
                    }
                }
            });
    }
}

/// Sort `(keys[i], vals[i])` stably by the low `bits` bits of the key (1 ≤ bits ≤ key width;
/// higher key bits are carried along but ignored).
pub fn sort_pairs<K: RadixKey>(
    keys: &mut [K],
    vals: &mut [u32],
    bits: u32,
    scratch: &mut SortScratch<K>,
) {
    assert_eq!(
        keys.len(),
        vals.len(),
        "sort_pairs: keys and values differ in length"
    );
    assert!(
        bits <= K::BITS,
        "sort_pairs: {bits} bits requested of a {}-bit key",
        K::BITS
    );
    let n = keys.len();
    if n <= 1 || bits == 0 {
        return;
    }
    assert!(
        n <= u32::MAX as usize,
        "sort_pairs: more than 2^32 elements"
    );
    // Few large blocks: each block costs histograms and its own scatter streams.
    let threads = rayon::current_num_threads().max(1);
    let nb = n
        .div_ceil(crate::MIN_BLOCK)
        .min(threads)
        .clamp(1, crate::MAX_BLOCKS);
    // A power-of-two block length, so the destination block of an index is a shift.
    let bl = n.div_ceil(nb).next_power_of_two();
    let nb = n.div_ceil(bl);
    // At most 8 digits (64-bit keys): fixed arrays, so a warm call allocates nothing.
    let nd = bits.div_ceil(RADIX_BITS) as usize;
    let mut all = [Digit { shift: 0, mask: 0 }; 8];
    for (p, dg) in all.iter_mut().enumerate().take(nd) {
        let shift = p as u32 * RADIX_BITS;
        *dg = Digit {
            shift,
            mask: (1u32 << (bits - shift).min(RADIX_BITS)) - 1,
        };
    }
    let all = &all[..nd];
    // A digit is the same for every key iff its bits agree in the AND and the OR of all keys:
    // such passes would move nothing and are skipped.
    let (and, or) = keys
        .par_chunks(bl)
        .map(|ks| {
            ks.iter()
                .fold((u64::MAX, 0u64), |(a, o), k| (a & k.wide(), o | k.wide()))
        })
        .reduce(|| (u64::MAX, 0), |x, y| (x.0 & y.0, x.1 | y.1));
    let varying = and ^ or;
    let mut live_buf = [0usize; 8];
    let mut nlive = 0;
    for (j, dg) in all.iter().enumerate() {
        if (varying >> dg.shift) & dg.mask as u64 != 0 {
            live_buf[nlive] = j;
            nlive += 1;
        }
    }
    let live = &live_buf[..nlive];
    if live.is_empty() {
        return;
    }
    // Per-block histograms of the first live digit (later passes count theirs while
    // scattering).
    let first = all[live[0]];
    scratch.hist.resize(nb * BUCKETS, 0);
    scratch
        .hist
        .par_chunks_mut(BUCKETS)
        .zip(keys.par_chunks(bl))
        .for_each(|(h, ks)| {
            h.fill(0);
            for &k in ks {
                h[first.of(k)] += 1;
            }
        });
    scratch.a.resize(n, Item::default());
    scratch.b.resize(n, Item::default());
    scratch.partial.resize(nb * nb * BUCKETS, 0);
    let SortScratch {
        a,
        b,
        hist,
        partial,
    } = scratch;
    let (mut cur, mut other) = (&mut a[..n], &mut b[..n]);
    for (idx, &j) in live.iter().enumerate() {
        let digit = all[j];
        let next = live.get(idx + 1).map(|&k| all[k]);
        offsets_in_place(hist, nb);
        let is_first = idx == 0;
        let is_last = idx + 1 == live.len();
        let to_items = Dst::Items(SharedMut(other.as_mut_ptr()));
        if is_first {
            // Reads the caller's arrays; with one live digit the result goes to scratch and
            // is copied back, since a pass cannot write the arrays it is reading.
            scatter(
                bl,
                digit,
                next,
                hist,
                partial,
                Src::Split(&*keys, &*vals),
                to_items,
            );
            if is_last {
                other
                    .par_chunks(bl)
                    .zip(keys.par_chunks_mut(bl))
                    .zip(vals.par_chunks_mut(bl))
                    .for_each(|((s, k), v)| {
                        for ((it, key), val) in s.iter().zip(k.iter_mut()).zip(v.iter_mut()) {
                            *key = it.key;
                            *val = it.val;
                        }
                    });
                return;
            }
        } else if is_last {
            let split = Dst::Split(SharedMut(keys.as_mut_ptr()), SharedMut(vals.as_mut_ptr()));
            scatter(bl, digit, None, hist, partial, Src::Items(&*cur), split);
            return;
        } else {
            scatter(bl, digit, next, hist, partial, Src::Items(&*cur), to_items);
        }
        std::mem::swap(&mut cur, &mut other);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check<K: RadixKey + Into<u64> + std::fmt::Debug + PartialEq>(
        keys: Vec<K>,
        bits: u32,
    ) -> Result<(), TestCaseError> {
        let vals: Vec<u32> = (0..keys.len() as u32).collect();
        let mask = if bits >= 64 {
            u64::MAX
        } else {
            (1u64 << bits) - 1
        };
        let mut expect: Vec<(K, u32)> = keys.iter().copied().zip(vals.iter().copied()).collect();
        expect.sort_by_key(|(k, _)| (*k).into() & mask); // stable
        let (mut k, mut v) = (keys, vals);
        let mut s = SortScratch::new();
        sort_pairs(&mut k, &mut v, bits, &mut s);
        let got: Vec<(K, u32)> = k.into_iter().zip(v).collect();
        prop_assert_eq!(got, expect);
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn u32_pairs(keys in prop::collection::vec(any::<u32>(), 0..40_000), bits in 1u32..=32) {
            check(keys, bits)?;
        }

        #[test]
        fn u32_few_distinct(keys in prop::collection::vec(0u32..4, 0..30_000), bits in 1u32..=32) {
            check(keys, bits)?;
        }

        #[test]
        fn u64_pairs(keys in prop::collection::vec(any::<u64>(), 0..20_000), bits in 1u32..=64) {
            check(keys, bits)?;
        }
    }

    #[test]
    fn special_cases() {
        let mut s = SortScratch::<u32>::new();
        for n in [0usize, 1, 2, 4095, 4096, 4097, 50_000] {
            // All equal keys: every pass is skipped, order unchanged.
            let mut k = vec![0xdead_beefu32; n];
            let mut v: Vec<u32> = (0..n as u32).collect();
            sort_pairs(&mut k, &mut v, 32, &mut s);
            assert!(v.iter().enumerate().all(|(i, &x)| x == i as u32));
            // Keys using all 32 bits, descending.
            let mut k: Vec<u32> = (0..n as u32)
                .map(|i| u32::MAX - i.wrapping_mul(2654435761))
                .collect();
            let mut v: Vec<u32> = (0..n as u32).collect();
            let mut e: Vec<(u32, u32)> = k.iter().copied().zip(v.iter().copied()).collect();
            e.sort_by_key(|p| p.0);
            sort_pairs(&mut k, &mut v, 32, &mut s);
            assert_eq!(k.into_iter().zip(v).collect::<Vec<_>>(), e);
        }
        // u64 keys that differ only in the top bits.
        let mut k: Vec<u64> = (0..10_000u64).rev().map(|i| i << 50).collect();
        let mut v: Vec<u32> = (0..10_000).collect();
        sort_pairs(&mut k, &mut v, 64, &mut SortScratch::new());
        assert!(k.windows(2).all(|w| w[0] <= w[1]));
    }
}
