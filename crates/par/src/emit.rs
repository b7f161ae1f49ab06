//! Expansion of items into (key, value) pairs: the GPU's count → exclusive scan → emit.
//!
//! Item i says how many pairs it makes, the counts are scanned into offsets, and every item
//! writes its pairs into its own output range. The output order is the items' order whatever
//! the scheduling. The grid's reference emission (paper §4.1) and the dual traversal's pair
//! expansion (thesis §3.2.8 with an object hierarchy) are this pass.

use crate::{exclusive_scan, SharedMut};
use rayon::prelude::*;

/// Emit (key, value) pairs for items `0..n`: `count(i)` says how many pairs item i makes,
/// `emit(i, out)` pushes them in the same order. `check(total)` sees the total before
/// anything is allocated for it, and its error is returned as is (a caller's memory cap).
pub fn emit_pairs<E>(
    n: usize,
    count: impl Fn(usize) -> u32 + Sync,
    check: impl FnOnce(u64) -> Result<(), E>,
    emit: impl Fn(usize, &mut dyn FnMut(u32, u32)) + Sync,
) -> Result<(Vec<u32>, Vec<u32>), E> {
    let counts: Vec<u32> = (0..n)
        .into_par_iter()
        .with_min_len(1024)
        .map(&count)
        .collect();
    let total: u64 = counts.par_iter().map(|&c| c as u64).sum();
    check(total)?;
    let mut offs = vec![0u32; n];
    let total = exclusive_scan(&counts, &mut offs) as usize;
    let mut keys = vec![0u32; total];
    let mut vals = vec![0u32; total];
    let kp = SharedMut(keys.as_mut_ptr());
    let vp = SharedMut(vals.as_mut_ptr());
    (0..n)
        .into_par_iter()
        .with_min_len(1024)
        .filter(|&i| counts[i] != 0)
        .for_each(|i| {
            let mut k = offs[i] as usize;
            let end = k + counts[i] as usize;
            emit(i, &mut |key, val| {
                assert!(k < end, "emit made more pairs than count");
                // SAFETY: item i owns [offs[i], offs[i] + counts[i]) by the exclusive scan.
                unsafe {
                    kp.write(k, key);
                    vp.write(k, val);
                }
                k += 1;
            });
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
}
