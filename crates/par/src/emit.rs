//! Expansion of items into (key, value) pairs: the GPU's count → exclusive scan → emit.
//!
//! Item i says how many pairs it makes, the counts are scanned into offsets, and every item
//! writes its pairs into its own output range. The output order is the items' order whatever
//! the scheduling. The grid's reference emission (paper §4.1) and the dual traversal's pair
//! expansion (thesis §3.2.8 with an object hierarchy) are this pass.

use crate::SharedMut;
use rayon::prelude::*;

/// Items per block: the unit of the count and emit passes (a GPU workgroup's share). An
/// item's offset is its block's (scanned over blocks) plus what the block's earlier items
/// wrote, so no per-item count or offset array is stored.
const BLOCK: usize = 2048;

/// Emit (key, value) pairs for items `0..n`: `count(i)` says how many pairs item i makes,
/// `emit(i, out)` pushes exactly that many, in the same order (it is not called for items
/// that make none). `check(total)` sees the total before anything is allocated for it, and
/// its error is returned as is (a caller's memory cap).
///
/// Two passes over blocks of [`BLOCK`] items (count; emit at the block's scanned offset),
/// `count` is called twice per item and nothing per item is stored: on the 2-core VM a
/// per-item count and offset array cost more in fresh memory than the counting itself.
pub fn emit_pairs<E>(
    n: usize,
    count: impl Fn(usize) -> u32 + Sync,
    check: impl FnOnce(u64) -> Result<(), E>,
    emit: impl Fn(usize, &mut dyn FnMut(u32, u32)) + Sync,
) -> Result<(Vec<u32>, Vec<u32>), E> {
    let blocks = n.div_ceil(BLOCK);
    let items = |b: usize| b * BLOCK..((b + 1) * BLOCK).min(n);
    let per_block: Vec<u64> = (0..blocks)
        .into_par_iter()
        .map(|b| items(b).map(|i| count(i) as u64).sum())
        .collect();
    let total: u64 = per_block.iter().sum();
    check(total)?;
    // The blocks' offsets: an exclusive scan over a few thousand entries at most.
    let first: Vec<usize> = per_block
        .iter()
        .scan(0usize, |acc, &c| {
            let at = *acc;
            *acc += c as usize;
            Some(at)
        })
        .collect();
    let total = total as usize;
    let mut keys = vec![0u32; total];
    let mut vals = vec![0u32; total];
    let kp = SharedMut(keys.as_mut_ptr());
    let vp = SharedMut(vals.as_mut_ptr());
    (0..blocks).into_par_iter().for_each(|b| {
        let mut k = first[b];
        for i in items(b) {
            let c = count(i) as usize;
            if c == 0 {
                continue;
            }
            let end = k + c;
            emit(i, &mut |key, val| {
                assert!(k < end, "emit made more pairs than count");
                // SAFETY: item i owns [k, end): its block's scanned offset plus the counts
                // of the block's earlier items, which equal what they wrote (checked).
                unsafe {
                    kp.write(k, key);
                    vp.write(k, val);
                }
                k += 1;
            });
            assert_eq!(k, end, "emit made fewer pairs than count");
        }
    });
    Ok((keys, vals))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_in_item_order_and_the_check_sees_the_total() {
        let n = 10_000;
        let (k, v) = emit_pairs(
            n,
            |i| (i % 4) as u32,
            |t| if t == 15_000 { Ok(()) } else { Err(t) },
            |i, out| {
                for j in 0..(i % 4) as u32 {
                    out(i as u32, j)
                }
            },
        )
        .unwrap();
        let want: Vec<(u32, u32)> = (0..n as u32)
            .flat_map(|i| (0..i % 4).map(move |j| (i, j)))
            .collect();
        assert_eq!(k.into_iter().zip(v).collect::<Vec<_>>(), want);
        let refused = emit_pairs(
            n,
            |_| 3,
            |t| if t > 100 { Err(t) } else { Ok(()) },
            |_, _| {},
        );
        assert_eq!(refused, Err(3 * n as u64));
    }

    #[test]
    fn items_making_nothing_are_not_emitted_and_blocks_join_in_order() {
        // Runs of empty items across block boundaries, and one item bigger than a block.
        let n = 5 * BLOCK + 7;
        let count = |i: usize| match i {
            _ if i == 3 * BLOCK - 1 => 3 * BLOCK as u32,
            _ if (BLOCK..2 * BLOCK + 5).contains(&i) || i % 3 == 0 => 0,
            _ => (i % 5) as u32,
        };
        let (k, v) = emit_pairs(
            n,
            count,
            |_| Ok::<(), ()>(()),
            |i, out| {
                assert_ne!(count(i), 0, "item {i} makes no pairs");
                for j in 0..count(i) {
                    out(i as u32, j)
                }
            },
        )
        .unwrap();
        let want: Vec<(u32, u32)> = (0..n)
            .flat_map(|i| (0..count(i)).map(move |j| (i as u32, j)))
            .collect();
        assert_eq!(k.into_iter().zip(v).collect::<Vec<_>>(), want);
    }

    #[test]
    #[should_panic(expected = "fewer pairs than count")]
    fn an_emit_short_of_its_count_is_caught() {
        let _ = emit_pairs(10, |_| 2, |_| Ok::<(), ()>(()), |i, out| out(i as u32, 0));
    }
}
