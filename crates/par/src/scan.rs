//! Prefix sums (work-efficient reduce-then-scan over blocks).
//!
//! Three passes like the GPU version: per-block totals (parallel), an exclusive scan of the
//! ≤ [`MAX_BLOCKS`](crate::MAX_BLOCKS) totals (sequential), and a per-block scan seeded with
//! its offset (parallel). O(n) work, O(n / p + blocks) time; reads the input twice.

use crate::blocks;
use rayon::prelude::*;

/// An element that can be prefix-summed. u32 sums wrap modulo 2^32 (as on a GPU); use u64
/// where counts can exceed u32.
pub trait Elem: Copy + Send + Sync + Default + PartialEq + std::fmt::Debug + 'static {
    /// The sum (wrapping for u32).
    fn add(self, o: Self) -> Self;
}

impl Elem for u32 {
    #[inline]
    fn add(self, o: Self) -> Self {
        self.wrapping_add(o)
    }
}

impl Elem for u64 {
    #[inline]
    fn add(self, o: Self) -> Self {
        self.wrapping_add(o)
    }
}

/// Block totals turned into block offsets in place; returns the grand total.
fn offsets<T: Elem>(sums: &mut [T]) -> T {
    let mut acc = T::default();
    for s in sums.iter_mut() {
        let v = *s;
        *s = acc;
        acc = acc.add(v);
    }
    acc
}

/// Sequential scan of one block starting from `init`; returns the running total.
///
/// Unrolled by 4 so the loop-carried dependency is one add per 4 elements (the in-group
/// prefix sums are independent across groups and pipeline well).
#[inline]
fn scan_block<T: Elem>(input: &[T], output: &mut [T], init: T, inclusive: bool) -> T {
    let mut a = init;
    let mut ic = input.chunks_exact(4);
    let mut oc = output.chunks_exact_mut(4);
    for (i, o) in (&mut ic).zip(&mut oc) {
        let s0 = i[0];
        let s1 = s0.add(i[1]);
        let s2 = s1.add(i[2]);
        let s3 = s2.add(i[3]);
        if inclusive {
            o[0] = a.add(s0);
            o[1] = a.add(s1);
            o[2] = a.add(s2);
            o[3] = a.add(s3);
        } else {
            o[0] = a;
            o[1] = a.add(s0);
            o[2] = a.add(s1);
            o[3] = a.add(s2);
        }
        a = a.add(s3);
    }
    for (x, y) in ic.remainder().iter().zip(oc.into_remainder().iter_mut()) {
        if inclusive {
            a = a.add(*x);
            *y = a;
        } else {
            *y = a;
            a = a.add(*x);
        }
    }
    a
}

fn scan_impl<T: Elem>(input: &[T], output: &mut [T], inclusive: bool) -> T {
    assert_eq!(
        input.len(),
        output.len(),
        "scan: input and output lengths differ"
    );
    let (nb, bl) = blocks(input.len());
    let mut sums = [T::default(); crate::MAX_BLOCKS];
    let sums = &mut sums[..nb];
    input
        .par_chunks(bl)
        .zip(sums.par_iter_mut())
        .for_each(|(c, s)| *s = c.iter().fold(T::default(), |a, &x| a.add(x)));
    let total = offsets(sums);
    input
        .par_chunks(bl)
        .zip(output.par_chunks_mut(bl))
        .zip(sums.par_iter())
        .for_each(|((i, o), &off)| {
            if inclusive {
                scan_block(i, o, off, true);
            } else {
                scan_block(i, o, off, false);
            }
        });
    total
}

/// `output[i] = Σ input[..i]`; returns the total. O(n).
pub fn exclusive_scan<T: Elem>(input: &[T], output: &mut [T]) -> T {
    scan_impl(input, output, false)
}

/// `output[i] = Σ input[..=i]`; returns the total. O(n).
pub fn inclusive_scan<T: Elem>(input: &[T], output: &mut [T]) -> T {
    scan_impl(input, output, true)
}

/// Exclusive scan in place; returns the total. O(n).
pub fn exclusive_scan_in_place<T: Elem>(data: &mut [T]) -> T {
    let (nb, bl) = blocks(data.len());
    let mut sums = [T::default(); crate::MAX_BLOCKS];
    let sums = &mut sums[..nb];
    data.par_chunks(bl)
        .zip(sums.par_iter_mut())
        .for_each(|(c, s)| *s = c.iter().fold(T::default(), |a, &x| a.add(x)));
    let total = offsets(sums);
    data.par_chunks_mut(bl)
        .zip(sums.par_iter())
        .for_each(|(c, &off)| {
            let mut a = off;
            for y in c.iter_mut() {
                let x = *y;
                *y = a;
                a = a.add(x);
            }
        });
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn reference<T: Elem>(v: &[T], inclusive: bool) -> (Vec<T>, T) {
        let mut out = Vec::with_capacity(v.len());
        let mut a = T::default();
        for &x in v {
            if inclusive {
                a = a.add(x);
                out.push(a);
            } else {
                out.push(a);
                a = a.add(x);
            }
        }
        (out, a)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn u32_scans(v in prop::collection::vec(any::<u32>(), 0..40_000)) {
            let mut o = vec![0; v.len()];
            let t = exclusive_scan(&v, &mut o);
            prop_assert_eq!((o.clone(), t), reference(&v, false));
            let t = inclusive_scan(&v, &mut o);
            prop_assert_eq!((o, t), reference(&v, true));
            let mut w = v.clone();
            let t = exclusive_scan_in_place(&mut w);
            prop_assert_eq!((w, t), reference(&v, false));
        }

        #[test]
        fn u64_scans(v in prop::collection::vec(any::<u64>(), 0..20_000), small in prop::collection::vec(0u64..10, 0..9000)) {
            for v in [v, small] {
                let mut o = vec![0; v.len()];
                let t = exclusive_scan(&v, &mut o);
                prop_assert_eq!((o.clone(), t), reference(&v, false));
                let t = inclusive_scan(&v, &mut o);
                prop_assert_eq!((o, t), reference(&v, true));
            }
        }
    }

    #[test]
    fn edge_lengths() {
        for n in [0usize, 1, 2, 4095, 4096, 4097, 8191, 8192 * 3 + 1] {
            let v: Vec<u32> = (0..n as u32).map(|i| i % 7).collect();
            let mut o = vec![0; n];
            assert_eq!(
                (exclusive_scan(&v, &mut o), o.clone()),
                (reference(&v, false).1, reference(&v, false).0),
                "n = {n}"
            );
        }
    }
}
