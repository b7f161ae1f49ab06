//! Refilling a structure-of-arrays batch in parallel, in place: the renderer's ray
//! creation writes each generation's rays straight into buffers that live across bounces
//! and frames (no allocation once they are large enough, no zero fill, no page faults),
//! piece by piece on rayon's threads, every piece at the offset an exclusive scan of the
//! pieces' counts gave it, so the rays come out in the order a serial loop would make them.
//!
//! Every element of a piece is written through a cursor ([`Cursor::put`]); the pieces'
//! cursors are checked to have reached their ends before the arrays' lengths are set, so an
//! element is never read unwritten.

use crate::batch::{RayBatch, RayKind};
use geom::{Ray, Vec3};
use rayon::prelude::*;
use std::mem::MaybeUninit;

/// `v` emptied and given room for `n` elements, its spare room cut at `bounds` (ascending
/// offsets from 0 to `n`) into pieces to be written.
pub fn uninit_pieces<'a, T>(
    v: &'a mut Vec<T>,
    n: usize,
    bounds: &[usize],
) -> Vec<&'a mut [MaybeUninit<T>]> {
    assert!(bounds.first() == Some(&0) && bounds.last() == Some(&n));
    v.clear();
    v.reserve(n);
    let mut rest = &mut v.spare_capacity_mut()[..n];
    let mut out = Vec::with_capacity(bounds.len().saturating_sub(1));
    for w in bounds.windows(2) {
        let (a, b) = rest.split_at_mut(w[1] - w[0]);
        out.push(a);
        rest = b;
    }
    out
}

/// Set `v`'s length to `n` after every element below it was written.
///
/// # Safety
/// Elements `0..n` of `v`'s buffer must have been initialised.
unsafe fn assume_written<T>(v: &mut Vec<T>, n: usize) {
    debug_assert!(n <= v.capacity());
    unsafe { v.set_len(n) };
}

/// One piece of a batch being refilled: the rays are written in order with [`Cursor::put`].
pub struct Cursor<'a> {
    org: &'a mut [MaybeUninit<Vec3>],
    dir: &'a mut [MaybeUninit<Vec3>],
    t_min: &'a mut [MaybeUninit<f32>],
    t_max: &'a mut [MaybeUninit<f32>],
    kind: &'a mut [MaybeUninit<u8>],
    pixel: &'a mut [MaybeUninit<u32>],
    light: &'a mut [MaybeUninit<u32>],
    throughput: &'a mut [MaybeUninit<Vec3>],
    depth: &'a mut [MaybeUninit<u8>],
    at: usize,
}

impl Cursor<'_> {
    /// Write the next ray of the piece (panics past the piece's end).
    #[inline]
    pub fn put(
        &mut self,
        ray: Ray,
        kind: RayKind,
        pixel: u32,
        light: u32,
        throughput: Vec3,
        depth: u8,
    ) {
        let k = self.at;
        self.org[k].write(ray.org);
        self.dir[k].write(ray.dir);
        self.t_min[k].write(ray.t_min);
        self.t_max[k].write(ray.t_max);
        self.kind[k].write(kind as u8);
        self.pixel[k].write(pixel);
        self.light[k].write(light);
        self.throughput[k].write(throughput);
        self.depth[k].write(depth);
        self.at = k + 1;
    }

    /// Whether every ray of the piece was written.
    fn full(&self) -> bool {
        self.at == self.org.len()
    }
}

impl RayBatch {
    /// Refill the batch with `n` rays (keeping its buffers: no allocation once they are
    /// large enough), written in parallel: piece `i` holds rays `bounds[i]..bounds[i + 1]`
    /// and `fill(i, cursor)` writes every one of them in order. Panics (before any length
    /// is set) if a piece is not written whole.
    pub fn refill(
        &mut self,
        n: usize,
        width: u32,
        bounds: &[usize],
        fill: impl Fn(usize, &mut Cursor) + Sync,
    ) {
        let mut org = uninit_pieces(&mut self.org, n, bounds).into_iter();
        let mut dir = uninit_pieces(&mut self.dir, n, bounds).into_iter();
        let mut t_min = uninit_pieces(&mut self.t_min, n, bounds).into_iter();
        let mut t_max = uninit_pieces(&mut self.t_max, n, bounds).into_iter();
        let mut kind = uninit_pieces(&mut self.kind, n, bounds).into_iter();
        let mut pixel = uninit_pieces(&mut self.pixel, n, bounds).into_iter();
        let mut light = uninit_pieces(&mut self.light, n, bounds).into_iter();
        let mut throughput = uninit_pieces(&mut self.throughput, n, bounds).into_iter();
        let mut depth = uninit_pieces(&mut self.depth, n, bounds).into_iter();
        let cursors: Vec<Cursor> = (0..bounds.len() - 1)
            .map(|_| Cursor {
                org: org.next().expect("a piece per bound"),
                dir: dir.next().expect("a piece per bound"),
                t_min: t_min.next().expect("a piece per bound"),
                t_max: t_max.next().expect("a piece per bound"),
                kind: kind.next().expect("a piece per bound"),
                pixel: pixel.next().expect("a piece per bound"),
                light: light.next().expect("a piece per bound"),
                throughput: throughput.next().expect("a piece per bound"),
                depth: depth.next().expect("a piece per bound"),
                at: 0,
            })
            .collect();
        let whole = cursors
            .into_par_iter()
            .enumerate()
            .map(|(i, mut c)| {
                fill(i, &mut c);
                c.full()
            })
            .collect::<Vec<bool>>();
        assert!(
            whole.iter().all(|&w| w),
            "RayBatch::refill: a piece was not written whole"
        );
        // SAFETY: every piece's cursor reached its end, so each of the n elements of every
        // array was written.
        unsafe {
            assume_written(&mut self.org, n);
            assume_written(&mut self.dir, n);
            assume_written(&mut self.t_min, n);
            assume_written(&mut self.t_max, n);
            assume_written(&mut self.kind, n);
            assume_written(&mut self.pixel, n);
            assume_written(&mut self.light, n);
            assume_written(&mut self.throughput, n);
            assume_written(&mut self.depth, n);
        }
        self.width = width;
    }
}

/// Pieces of `items` items of about `per` each, as [`RayBatch::refill`]'s bounds when
/// piece `i` makes `count(i)` rays: (bounds over the rays, item ranges of the pieces).
pub fn scan_pieces(
    items: usize,
    per: usize,
    count: impl Fn(std::ops::Range<usize>) -> usize + Sync,
) -> (Vec<usize>, Vec<std::ops::Range<usize>>) {
    let per = per.max(1);
    let ranges: Vec<std::ops::Range<usize>> = (0..items.div_ceil(per))
        .map(|i| i * per..((i + 1) * per).min(items))
        .collect();
    let counts: Vec<usize> = ranges.par_iter().map(|r| count(r.clone())).collect();
    let mut bounds = Vec::with_capacity(counts.len() + 1);
    bounds.push(0);
    for c in counts {
        bounds.push(bounds.last().expect("starts at 0") + c);
    }
    (bounds, ranges)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refill_writes_in_order_and_reuses_buffers() {
        let mut b = RayBatch::default();
        for round in 0..2 {
            let items = 1000 + round;
            // Item i makes i % 3 rays.
            let (bounds, ranges) = scan_pieces(items, 64, |r| r.map(|i| i % 3).sum());
            let n = *bounds.last().unwrap();
            b.refill(n, 7, &bounds, |p, c| {
                for i in ranges[p].clone() {
                    for k in 0..i % 3 {
                        let r = Ray::new(Vec3::splat(i as f32), Vec3::X, 0.0, k as f32);
                        c.put(r, RayKind::Shadow, i as u32, k as u32, Vec3::ONE, 1);
                    }
                }
            });
            let mut want = RayBatch::with_capacity(n);
            for i in 0..items {
                for k in 0..i % 3 {
                    let r = Ray::new(Vec3::splat(i as f32), Vec3::X, 0.0, k as f32);
                    want.push(r, RayKind::Shadow, i as u32, k as u32, Vec3::ONE, 1);
                }
            }
            assert_eq!(b.len(), n);
            assert_eq!(b.org, want.org);
            assert_eq!(b.t_max, want.t_max);
            assert_eq!(b.pixel, want.pixel);
            assert_eq!(b.light, want.light);
            assert_eq!(b.kind, want.kind);
            assert_eq!(b.width, 7);
        }
        // Nothing to make: an empty batch.
        let (bounds, _) = scan_pieces(0, 64, |_| 0);
        b.refill(0, 0, &bounds, |_, _| {});
        assert_eq!(b.len(), 0);
    }

    #[test]
    #[should_panic(expected = "not written whole")]
    fn a_piece_left_short_is_refused() {
        let mut b = RayBatch::default();
        b.refill(4, 0, &[0, 2, 4], |p, c| {
            let n = if p == 0 { 2 } else { 1 };
            for _ in 0..n {
                c.put(
                    Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0),
                    RayKind::Shadow,
                    0,
                    0,
                    Vec3::ONE,
                    0,
                );
            }
        });
    }
}
