//! Segmented scan and run-length chunks: the compression (thesis §3.2.4) and decompression
//! (§3.2.6) halves of CRSH's compress–sort–decompress ray sorting.

use crate::compact::{compact_with, Flag};
use crate::scan::{exclusive_scan, Elem};
use crate::{blocks, SharedMut};
use rayon::prelude::*;

/// Segmented inclusive scan: a set head flag at i starts a new segment
/// (`output[i] = input[i]`), otherwise `output[i] = output[i-1] + input[i]`.
///
/// Block-wise with the segmented operator (f₁, v₁) ⊕ (f₂, v₂) = (f₁ ∨ f₂, f₂ ? v₂ : v₁ + v₂):
/// per-block aggregates, a sequential carry scan, per-block apply. O(n).
pub fn segmented_inclusive_scan<T: Elem, F: Flag>(input: &[T], heads: &[F], output: &mut [T]) {
    assert!(
        input.len() == heads.len() && input.len() == output.len(),
        "segmented scan: lengths differ"
    );
    let n = input.len();
    let (nb, bl) = blocks(n);
    let mut agg = [(false, T::default()); crate::MAX_BLOCKS];
    let agg = &mut agg[..nb];
    agg.par_iter_mut().enumerate().for_each(|(b, a)| {
        let mut acc = T::default();
        let mut any = false;
        for i in b * bl..((b + 1) * bl).min(n) {
            if heads[i].is_set() {
                any = true;
                acc = input[i];
            } else {
                acc = acc.add(input[i]);
            }
        }
        *a = (any, acc);
    });
    // carry[b]: the running value entering block b.
    let mut carry = [T::default(); crate::MAX_BLOCKS];
    for b in 1..nb {
        let (any, tail) = agg[b - 1];
        carry[b] = if any { tail } else { carry[b - 1].add(tail) };
    }
    output.par_chunks_mut(bl).enumerate().for_each(|(b, o)| {
        let mut acc = carry[b];
        for (k, y) in o.iter_mut().enumerate() {
            let i = b * bl + k;
            acc = if heads[i].is_set() {
                input[i]
            } else {
                acc.add(input[i])
            };
            *y = acc;
        }
    });
}

/// Run-length compression of equal consecutive keys into chunks (key, base, size):
/// head flags where the key changes → compaction of the head positions → sizes from
/// consecutive bases. Returns the number of chunks. Outputs need room for `keys.len()` chunks.
pub fn compress_runs<K: Copy + PartialEq + Send + Sync>(
    keys: &[K],
    out_keys: &mut [K],
    out_base: &mut [u32],
    out_size: &mut [u32],
) -> usize {
    let n = keys.len();
    assert!(n <= u32::MAX as usize, "compress_runs: more than 2^32 keys");
    let m = compact_with(
        n,
        |i| i == 0 || keys[i] != keys[i - 1],
        |i| i as u32,
        out_base,
    );
    let base = &out_base[..m];
    out_keys[..m]
        .par_iter_mut()
        .zip(out_size[..m].par_iter_mut())
        .enumerate()
        .for_each(|(j, (k, s))| {
            let b = base[j] as usize;
            *k = keys[b];
            let end = if j + 1 < m { base[j + 1] as usize } else { n };
            *s = (end - b) as u32;
        });
    m
}

/// Decompression: chunks visited in `order` (the sorted chunk values), each expanding to
/// `base[c], base[c] + 1, …, base[c] + size[c] − 1`, concatenated into `out`.
///
/// The exclusive scan of the sizes in sorted order gives each chunk its output range (the
/// thesis's "skeleton" and "scan" arrays); the ranges are then filled in parallel. (A GPU
/// may instead scatter bases at the offsets and run [`segmented_inclusive_scan`] over ones; the
/// tests check both give the same.) `offsets` is scratch of `order.len()`. Returns the total.
pub fn expand_runs(
    order: &[u32],
    base: &[u32],
    size: &[u32],
    offsets: &mut [u32],
    out: &mut [u32],
) -> usize {
    let m = order.len();
    assert!(offsets.len() >= m, "expand_runs: offsets scratch too short");
    offsets[..m]
        .par_iter_mut()
        .zip(order.par_iter())
        .for_each(|(o, &c)| *o = size[c as usize]);
    let sizes: &mut [u32] = &mut offsets[..m];
    // In-place exclusive scan of the sorted sizes.
    let total = crate::scan::exclusive_scan_in_place(sizes) as usize;
    assert!(
        out.len() >= total,
        "expand_runs: output holds {} elements, {} needed",
        out.len(),
        total
    );
    let dst = SharedMut(out.as_mut_ptr());
    let offs = &offsets[..m];
    (0..m).into_par_iter().with_min_len(256).for_each(|j| {
        let c = order[j] as usize;
        let o = offs[j] as usize;
        for k in 0..size[c] as usize {
            // SAFETY: chunk j owns [offs[j], offs[j] + size), disjoint by the exclusive scan.
            unsafe { dst.write(o + k, base[c] + k as u32) };
        }
    });
    total
}

/// Decompression the way a GPU without per-chunk loops does it (used to cross-check
/// [`expand_runs`]): scatter heads and bases, then a segmented scan over ones.
pub fn expand_runs_segmented(order: &[u32], base: &[u32], size: &[u32]) -> Vec<u32> {
    let sizes: Vec<u32> = order.iter().map(|&c| size[c as usize]).collect();
    let mut offs = vec![0u32; sizes.len()];
    let total = exclusive_scan(&sizes, &mut offs) as usize;
    let mut vals = vec![1u32; total];
    let mut heads = vec![0u8; total];
    for (j, &c) in order.iter().enumerate() {
        if size[c as usize] > 0 {
            vals[offs[j] as usize] = base[c as usize];
            heads[offs[j] as usize] = 1;
        }
    }
    let mut out = vec![0u32; total];
    segmented_inclusive_scan(&vals, &heads, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn segmented_scan_matches_loop(v in prop::collection::vec(0u32..1000, 0..30_000), every in 1u32..50) {
            let heads: Vec<bool> = v.iter().enumerate().map(|(i, x)| i == 0 || x % every == 0).collect();
            let mut out = vec![0; v.len()];
            segmented_inclusive_scan(&v, &heads, &mut out);
            let mut acc = 0u32;
            for i in 0..v.len() {
                acc = if heads[i] { v[i] } else { acc.wrapping_add(v[i]) };
                prop_assert_eq!(out[i], acc);
            }
        }

        /// compress → reorder chunks → expand is the stable permutation by chunk order.
        #[test]
        fn compress_expand_roundtrip(keys in prop::collection::vec(0u32..6, 0..20_000), seed in any::<u64>()) {
            // Runs of equal keys (sort a copy into runs, then shuffle blocks of it).
            let mut k = keys.clone();
            k.sort_unstable();
            let n = k.len();
            let (mut ck, mut cb, mut cs) = (vec![0u32; n], vec![0u32; n], vec![0u32; n]);
            let m = compress_runs(&k, &mut ck, &mut cb, &mut cs);
            // Every run is maximal and covers the input.
            prop_assert_eq!(cs[..m].iter().map(|&s| s as usize).sum::<usize>(), n);
            for j in 0..m {
                prop_assert!(k[cb[j] as usize..(cb[j] + cs[j]) as usize].iter().all(|&x| x == ck[j]));
                if j + 1 < m { prop_assert_ne!(ck[j], ck[j + 1]); }
            }
            // A permutation of the chunks.
            let mut order: Vec<u32> = (0..m as u32).collect();
            let mut s = seed;
            for i in (1..m).rev() {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                order.swap(i, (s >> 33) as usize % (i + 1));
            }
            let mut offs = vec![0u32; m];
            let mut out = vec![0u32; n];
            let total = expand_runs(&order, &cb[..m], &cs[..m], &mut offs, &mut out);
            prop_assert_eq!(total, n);
            let expect: Vec<u32> = order.iter().flat_map(|&c| cb[c as usize]..cb[c as usize] + cs[c as usize]).collect();
            prop_assert_eq!(&out, &expect);
            prop_assert_eq!(expand_runs_segmented(&order, &cb[..m], &cs[..m]), expect);
        }
    }

    #[test]
    fn all_equal_and_empty() {
        let k = vec![7u64; 10_000];
        let (mut ck, mut cb, mut cs) = (vec![0u64; 10_000], vec![0u32; 10_000], vec![0u32; 10_000]);
        assert_eq!(compress_runs(&k, &mut ck, &mut cb, &mut cs), 1);
        assert_eq!((ck[0], cb[0], cs[0]), (7, 0, 10_000));
        assert_eq!(compress_runs::<u32>(&[], &mut [], &mut [], &mut []), 0);
    }
}
