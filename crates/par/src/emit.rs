//! Expansion of items into (key, value) pairs: the GPU's count → exclusive scan → emit.
//!
//! Item i says how many pairs it makes, the counts are scanned into offsets, and every item
//! writes its pairs into its own output range. The output order is the items' order whatever
//! the scheduling. The grid's reference emission (paper §4.1) and the dual traversal's pair
//! expansion (thesis §3.2.8 with an object hierarchy) are this pass.

use crate::SharedMut;
use rayon::prelude::*;

/// Emitted pairs: (keys, values).
pub type Pairs = (Vec<u32>, Vec<u32>);

/// Items per block: the unit of the count and emit passes (a GPU workgroup's share). An
/// item's offset is its block's (scanned over blocks) plus what the block's earlier items
/// wrote, so no per-item count or offset array is stored.
const BLOCK: usize = 2048;

/// Emit (key, value) pairs for items `0..n`: `count(i)` says how many pairs item i makes,
/// `emit(i, out)` pushes exactly that many, in the same order (it is not called for items
/// that make none). `check(total)` sees the total before anything is allocated for it, and
/// its error is returned as is (a caller's memory cap).
///
/// Two passes over blocks of `BLOCK` (2048) items (count; emit at the block's scanned offset),
/// `count` is called twice per item and nothing per item is stored: on the 2-core VM a
/// per-item count and offset array cost more in fresh memory than the counting itself.
pub fn emit_pairs<E>(
    n: usize,
    count: impl Fn(usize) -> u32 + Sync,
    check: impl FnOnce(u64) -> Result<(), E>,
    emit: impl Fn(usize, &mut dyn FnMut(u32, u32)) + Sync,
) -> Result<Pairs, E> {
    let [out] = emit_streams(
        n,
        |i| [count(i)],
        |[total]| check(total),
        |i, out| emit(i, &mut |k, v| out(0, k, v)),
    )?;
    Ok(out)
}

/// [`emit_pairs`] into `K` output streams at once: `count(i)` says how many pairs item i
/// makes in each, `emit(i, out)` pushes them as `out(stream, key, value)`, each stream's in
/// item order. One count pass and one emit pass serve all the streams (a traversal step's
/// final, ray-side and object-side pairs, say), instead of two passes per stream.
pub fn emit_streams<E, const K: usize>(
    n: usize,
    count: impl Fn(usize) -> [u32; K] + Sync,
    check: impl FnOnce([u64; K]) -> Result<(), E>,
    emit: impl Fn(usize, &mut dyn FnMut(usize, u32, u32)) + Sync,
) -> Result<[Pairs; K], E> {
    let blocks = n.div_ceil(BLOCK);
    let items = |b: usize| b * BLOCK..((b + 1) * BLOCK).min(n);
    let per_block: Vec<[u64; K]> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            items(b).fold([0u64; K], |mut acc, i| {
                let c = count(i);
                for s in 0..K {
                    acc[s] += c[s] as u64;
                }
                acc
            })
        })
        .collect();
    let mut total = [0u64; K];
    // The blocks' offsets per stream: an exclusive scan over a few thousand entries at most.
    let first: Vec<[usize; K]> = per_block
        .iter()
        .map(|c| {
            let at = total.map(|t| t as usize);
            for s in 0..K {
                total[s] += c[s];
            }
            at
        })
        .collect();
    check(total)?;
    let mut out: [Pairs; K] =
        std::array::from_fn(|s| (vec![0u32; total[s] as usize], vec![0u32; total[s] as usize]));
    let ptr: [(SharedMut<u32>, SharedMut<u32>); K] = std::array::from_fn(|s| {
        (
            SharedMut(out[s].0.as_mut_ptr()),
            SharedMut(out[s].1.as_mut_ptr()),
        )
    });
    (0..blocks).into_par_iter().for_each(|b| {
        let mut at = first[b];
        for i in items(b) {
            let c = count(i);
            if c.iter().all(|&c| c == 0) {
                continue;
            }
            let end: [usize; K] = std::array::from_fn(|s| at[s] + c[s] as usize);
            emit(i, &mut |s, key, val| {
                assert!(at[s] < end[s], "emit made more pairs than count");
                // SAFETY: item i owns [at[s], end[s]) of stream s: its block's scanned
                // offset plus the counts of the block's earlier items, which equal what
                // they wrote (checked).
                unsafe {
                    ptr[s].0.write(at[s], key);
                    ptr[s].1.write(at[s], val);
                }
                at[s] += 1;
            });
            assert_eq!(at, end, "emit made fewer pairs than count");
        }
    });
    Ok(out)
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
            _ if (BLOCK..2 * BLOCK + 5).contains(&i) || i.is_multiple_of(3) => 0,
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
    fn streams_each_in_item_order() {
        let n = 3 * BLOCK + 11;
        let count = |i: usize| [(i % 3) as u32, i.is_multiple_of(7) as u32, 0];
        let [a, b, c] = emit_streams(
            n,
            count,
            |t| if t[2] == 0 { Ok(()) } else { Err(t) },
            |i, out| {
                // Interleaved writes to both streams.
                for j in 0..(i % 3) as u32 {
                    out(0, i as u32, j);
                    if j == 0 && i % 7 == 0 {
                        out(1, i as u32, 99);
                    }
                }
                if i % 3 == 0 && i % 7 == 0 {
                    out(1, i as u32, 99);
                }
            },
        )
        .unwrap();
        let want_a: Vec<(u32, u32)> = (0..n as u32)
            .flat_map(|i| (0..i % 3).map(move |j| (i, j)))
            .collect();
        let want_b: Vec<(u32, u32)> = (0..n as u32)
            .filter(|i| i % 7 == 0)
            .map(|i| (i, 99))
            .collect();
        assert_eq!(a.0.into_iter().zip(a.1).collect::<Vec<_>>(), want_a);
        assert_eq!(b.0.into_iter().zip(b.1).collect::<Vec<_>>(), want_b);
        assert!(c.0.is_empty() && c.1.is_empty());
    }

    #[test]
    #[should_panic(expected = "fewer pairs than count")]
    fn an_emit_short_of_its_count_is_caught() {
        let _ = emit_pairs(10, |_| 2, |_| Ok::<(), ()>(()), |i, out| out(i as u32, 0));
    }
}
