//! The object tree by binned SAH (Wald 2007, "On fast construction of SAH-based bounding
//! volume hierarchies"; MacDonald & Booth 1990's surface area cost): top down, each node's
//! triangles binned by centroid into up to [`BINS`] slabs per axis, split where
//! `A(left)·N(left) + A(right)·N(right)` is least, down to one triangle per leaf (the dual
//! traversal's leaves are triangles). Large nodes bin in parallel; the two halves of a node
//! build in parallel. The result is deterministic: bin counts and box unions (min, max) do
//! not depend on how the work was split.
//!
//! The tree comes out in the layout the LBVH's radix tree has, so everything
//! downstream (spheres, collapse, both traversals) is shared: triangles in leaf order, every
//! inner node's leaves a contiguous range `[lo, hi]` of it, and inner nodes numbered as
//! Karras numbers a radix tree — the root 0, a left child by its range's right end and a
//! right child by its left end. That numbering needs no radix tree: each split position
//! between two neighbouring leaves belongs to exactly one inner node, and a left child
//! `[lo, s]` is named by its parent's split `s`, a right child `[s + 1, hi]` by `s + 1`,
//! so no two nodes share a name and names run over `0..n − 1`.

use super::RadixTree;
use geom::Aabb;
use geom::Vec3A;
use par::SharedMut;
use rayon::prelude::*;

/// Centroid bins per axis.
pub const BINS: usize = 32;

/// Nodes with more triangles than this bin and partition in parallel (chunks of it).
const PAR_BIN: usize = 1 << 15;

/// Nodes with more triangles than this build their two halves in parallel.
const PAR_SPLIT: usize = 1 << 11;

/// A triangle's box as the build moves it: SIMD minimum and maximum (their sum is twice
/// the centroid, which is all the binning needs), with its id beside it.
#[derive(Clone, Copy)]
struct Prim {
    min: Vec3A,
    max: Vec3A,
}

/// Where the build writes (shared by the parallel halves: every node is written once).
struct Out {
    child: SharedMut<[u32; 2]>,
    range: SharedMut<[u32; 2]>,
    nbox: SharedMut<Aabb>,
}

/// The binned-SAH tree over `n ≥ 2` triangles with boxes `boxes`: (tree, the triangles in
/// leaf order).
pub(super) fn build(boxes: &[Aabb]) -> (RadixTree, Vec<u32>) {
    let n = boxes.len();
    debug_assert!(n >= 2);
    let ni = n - 1;
    let mut child = vec![[0u32; 2]; ni];
    let mut range = vec![[0u32; 2]; ni];
    let mut nbox = vec![Aabb::default(); ni];
    let mut prims: Vec<Prim> = boxes
        .par_iter()
        .with_min_len(4096)
        .map(|b| Prim {
            min: b.min.into(),
            max: b.max.into(),
        })
        .collect();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let cb = prims
        .par_iter()
        .with_min_len(4096)
        .map(|p| Cb::of(p.min + p.max))
        .reduce(Cb::empty, Cb::union);
    let out = Out {
        child: SharedMut(child.as_mut_ptr()),
        range: SharedMut(range.as_mut_ptr()),
        nbox: SharedMut(nbox.as_mut_ptr()),
    };
    let mut scratch = Box::new([[EMPTY_BIN; BINS]; 3]);
    let (_, depth) = node(&mut prims, &mut order, cb, 0, 0, &out, &mut scratch);
    (
        RadixTree {
            child,
            range,
            nbox,
            depth,
        },
        order,
    )
}

/// Bounds of doubled centroids.
#[derive(Clone, Copy)]
struct Cb {
    min: Vec3A,
    max: Vec3A,
}

impl Cb {
    fn empty() -> Cb {
        Cb {
            min: Vec3A::INFINITY,
            max: Vec3A::NEG_INFINITY,
        }
    }
    fn of(c: Vec3A) -> Cb {
        Cb { min: c, max: c }
    }
    fn union(self, o: Cb) -> Cb {
        Cb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }
    fn grow(&mut self, c: Vec3A) {
        self.min = self.min.min(c);
        self.max = self.max.max(c);
    }
}

/// Per bin: triangles and the union of their boxes.
#[derive(Clone, Copy)]
struct Bin {
    min: Vec3A,
    max: Vec3A,
    n: u32,
}

const EMPTY_BIN: Bin = Bin {
    min: Vec3A::INFINITY,
    max: Vec3A::NEG_INFINITY,
    n: 0,
};

/// Half the surface area of the box `[min, max]` (0 for an empty one).
#[inline]
fn half_area(min: Vec3A, max: Vec3A) -> f32 {
    let e = (max - min).max(Vec3A::ZERO);
    // (x·y + y·z) + z·x, its three products in one vector multiply (the same roundings
    // in the same order as the scalar sum: the sweeps evaluate this for every bin).
    let p = e * Vec3A::new(e.y, e.z, e.x);
    (p.x + p.y) + p.z
}

/// Maps doubled centroids to `nb` bins per axis.
#[derive(Clone, Copy)]
struct Binner {
    min: Vec3A,
    scale: Vec3A,
    /// The last bin, as a float (indices are clamped before the conversion).
    top: Vec3A,
    nb: usize,
}

impl Binner {
    /// `nb` bins over the (doubled) centroid bounds `cb` (a flat axis: one bin).
    fn new(cb: &Cb, nb: usize) -> Binner {
        let e = cb.max - cb.min;
        let s = |e: f32| if e > 0.0 { nb as f32 / e } else { 0.0 };
        Binner {
            min: cb.min,
            scale: Vec3A::new(s(e.x), s(e.y), s(e.z)),
            top: Vec3A::splat((nb - 1) as f32),
            nb,
        }
    }
    /// The bins of doubled centroid `c` (clamped to `[0, nb − 1]`: the top edge falls in
    /// the last bin), truncated as `as` truncates, in one SIMD conversion.
    #[inline]
    fn bins(&self, c: Vec3A) -> [usize; 3] {
        let f = ((c - self.min) * self.scale).max(Vec3A::ZERO).min(self.top);
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE2 is part of x86_64; the lanes are in [0, nb − 1] (no overflow).
            let i: [i32; 4] = unsafe { std::mem::transmute(_mm_cvttps_epi32(f.into())) };
            [i[0] as usize, i[1] as usize, i[2] as usize]
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            [f.x as usize, f.y as usize, f.z as usize]
        }
    }
}

/// Three axes of bins (the first `nb` of each in use).
type Bins = [[Bin; BINS]; 3];

/// Add `prims` to `bins`.
fn fold(bins: &mut Bins, prims: &[Prim], by: &Binner) {
    for p in prims {
        let i = by.bins(p.min + p.max);
        for k in 0..3 {
            // `bins` clamps to nb − 1 < BINS: the mask changes nothing and spares the
            // bounds check.
            let b = &mut bins[k][i[k] & (BINS - 1)];
            b.n += 1;
            b.min = b.min.min(p.min);
            b.max = b.max.max(p.max);
        }
    }
}

/// The bins of `prims` into `bins` (cleared first).
fn bin(bins: &mut Bins, prims: &[Prim], by: &Binner) {
    for axis in bins.iter_mut() {
        axis[..by.nb].fill(EMPTY_BIN);
    }
    if prims.len() <= PAR_BIN {
        return fold(bins, prims, by);
    }
    let parts: Vec<Box<Bins>> = prims
        .par_chunks(PAR_BIN)
        .map(|c| {
            let mut b = Box::new([[EMPTY_BIN; BINS]; 3]);
            fold(&mut b, c, by);
            b
        })
        .collect();
    // Merged in chunk order (counts add, boxes unite: the same whatever the chunks).
    for b in &parts {
        for k in 0..3 {
            for i in 0..by.nb {
                let a = &mut bins[k][i];
                a.n += b[k][i].n;
                a.min = a.min.min(b[k][i].min);
                a.max = a.max.max(b[k][i].max);
            }
        }
    }
}

/// Build the node over `prims` (with their ids `ids`, positions `lo..lo + prims.len()`
/// of the leaf order; doubled centroids within `cb`) named `name`, binning into `bins`;
/// returns its box and the depth of its deepest leaf below it (1: both children leaves).
fn node(
    prims: &mut [Prim],
    ids: &mut [u32],
    cb: Cb,
    lo: usize,
    name: usize,
    out: &Out,
    bins: &mut Bins,
) -> (Aabb, u32) {
    let m = prims.len();
    debug_assert!(m >= 2);
    // 4 bins, one more per 40 triangles, up to BINS (Embree's binner grows its bins with
    // the node the same way, at one per 20). Most nodes are small, and their cost was the
    // bins' clearing and sweeps: with as many bins as triangles (4..=32) the trees' SAH
    // metric is the same to within 0.6 % (nodes per ray: Sponza 15.45 → 15.43, Kitchen
    // 3.41 → 3.39, Conference 8.66 → 8.67; triangles per ray unchanged) for 0.66–0.95 of
    // the build time (one thread, `examples/object_trees`).
    let by = Binner::new(&cb, (4 + m / 40).min(BINS));
    let split = if m == 2 {
        None
    } else {
        bin(bins, prims, &by);
        best_split(bins, by.nb)
    };
    let (mid, lcb, rcb) = match split {
        Some((axis, split)) => partition(prims, ids, |c| by.bins(c)[axis] < split),
        // Two triangles (one tree either way), or centroids all in one bin on every
        // axis: halve by position.
        None => {
            let half = m / 2;
            let fold = |p: &[Prim]| {
                p.iter()
                    .fold(Cb::empty(), |a, p| a.union(Cb::of(p.min + p.max)))
            };
            (half, fold(&prims[..half]), fold(&prims[half..]))
        }
    };
    debug_assert!(mid > 0 && mid < m);
    let (lp, rp) = prims.split_at_mut(mid);
    let (li, ri) = ids.split_at_mut(mid);
    // Split position s: left covers [lo, s], right [s + 1, hi].
    let s = lo + mid - 1;
    let side =
        |p: &mut [Prim], ids: &mut [u32], cb: Cb, first: usize, name: usize, bins: &mut Bins| {
            if p.len() == 1 {
                let b = Aabb::new(p[0].min.into(), p[0].max.into());
                (super::LEAF | ids[0], b, 0)
            } else {
                let (b, d) = node(p, ids, cb, first, name, out, bins);
                (name as u32, b, d)
            }
        };
    let ((lr, lb, ld), (rr, rb, rd)) = if m > PAR_SPLIT {
        rayon::join(
            || side(lp, li, lcb, lo, s, bins),
            || {
                let mut own = Box::new([[EMPTY_BIN; BINS]; 3]);
                side(rp, ri, rcb, s + 1, s + 1, &mut own)
            },
        )
    } else {
        let l = side(lp, li, lcb, lo, s, bins);
        (l, side(rp, ri, rcb, s + 1, s + 1, bins))
    };
    let b = lb.union(&rb);
    // SAFETY: node `name` is written once (see the module doc), inside the vectors
    // `build` made (names < n − 1).
    unsafe {
        out.child.write(name, [lr, rr]);
        out.range.write(name, [lo as u32, (lo + m - 1) as u32]);
        out.nbox.write(name, b);
    }
    (b, 1 + ld.max(rd))
}

/// The SAH's best (axis, first bin of the right side), or `None` when every centroid falls
/// in one bin on every axis. Costs compare as `A(left)·N(left) + A(right)·N(right)`; ties
/// keep the lower axis, then the lower bin.
fn best_split(bins: &Bins, nb: usize) -> Option<(usize, usize)> {
    // The three axes' sweeps are independent chains of min/max: run side by side (bin by
    // bin, axis by axis within), they overlap instead of waiting on each other; each axis
    // still sees the same operations in the same order.
    // Right-to-left: the right side's area times count for every split.
    let mut right_cost = [[f32::INFINITY; BINS]; 3];
    let mut rmin = [Vec3A::INFINITY; 3];
    let mut rmax = [Vec3A::NEG_INFINITY; 3];
    let mut rn = [0u32; 3];
    for i in (1..nb).rev() {
        for k in 0..3 {
            let b = &bins[k][i];
            rmin[k] = rmin[k].min(b.min);
            rmax[k] = rmax[k].max(b.max);
            rn[k] += b.n;
            if rn[k] > 0 {
                right_cost[k][i] = half_area(rmin[k], rmax[k]) * rn[k] as f32;
            }
        }
    }
    // Left-to-right: each split's cost, the least per axis (ties: the lower bin).
    let mut lmin = [Vec3A::INFINITY; 3];
    let mut lmax = [Vec3A::NEG_INFINITY; 3];
    let mut ln = [0u32; 3];
    let mut best = [(f32::INFINITY, usize::MAX); 3];
    for i in 1..nb {
        for k in 0..3 {
            let b = &bins[k][i - 1];
            lmin[k] = lmin[k].min(b.min);
            lmax[k] = lmax[k].max(b.max);
            ln[k] += b.n;
            if ln[k] == 0 || right_cost[k][i].is_infinite() {
                continue;
            }
            let cost = half_area(lmin[k], lmax[k]) * ln[k] as f32 + right_cost[k][i];
            if best[k].1 == usize::MAX || cost < best[k].0 {
                best[k] = (cost, i);
            }
        }
    }
    // Across axes: ties keep the lower axis.
    let mut out: Option<(f32, usize, usize)> = None;
    for (k, &(cost, i)) in best.iter().enumerate() {
        if i != usize::MAX && out.is_none_or(|(c, _, _)| cost < c) {
            out = Some((cost, k, i));
        }
    }
    out.map(|(_, k, i)| (k, i))
}

/// Move the prims (and their ids) whose doubled centroid `left` accepts to the front, in a
/// deterministic order; returns how many there are and both sides' centroid bounds.
fn partition(prims: &mut [Prim], ids: &mut [u32], left: impl Fn(Vec3A) -> bool) -> (usize, Cb, Cb) {
    let (mut lcb, mut rcb) = (Cb::empty(), Cb::empty());
    let (mut i, mut j) = (0usize, prims.len());
    while i < j {
        let c = prims[i].min + prims[i].max;
        if left(c) {
            lcb.grow(c);
            i += 1;
        } else {
            rcb.grow(c);
            j -= 1;
            prims.swap(i, j);
            ids.swap(i, j);
        }
    }
    (i, lcb, rcb)
}
