//! The `bvh` engine's single rays: every ray traced alone through the object tree's
//! collapsed nodes ([`BoxNode`], 8 children each), the way a wide BVH traces single rays
//! (Wald et al. 2008, "Getting rid of packets"; Embree's BVH8). Batches whose rays are not
//! neighbours ([`crate::bvh::locality`]) take this path; neighbours go as packets
//! ([`crate::bvh::packet`]).
//!
//! Per ray: the node being visited, and a stack of (collapsed node, entry distance) to
//! come back to; each visited node's 8 boxes are slab-tested at once (AVX2 lanes, or the
//! scalar [`boxes_scalar`] on CPUs without it: the same answers, tested); the triangles of
//! its passing leaf lanes, side by side in the box order's blocks of 8
//! ([`crate::bvh::objects::blocks`]), go through one 8-lane watertight test per block
//! ([`geom::tris8`]) that rejects misses, and every triangle it does not reject gets the
//! shared kernel ([`geom::intersect`], inlined: so every hit is brute force's bit for bit);
//! an any-hit ray stops at the end of the first leaf lane that gives it a hit (lanes in lane
//! order, as the GPU's walk, so both record the same triangle); of its passing inner
//! children entered before the closest hit
//! so far the nearest is visited next and the others are pushed farthest first, so a node
//! with one such child (the common case) touches no stack. A popped node whose entry lies
//! beyond the closest hit so far is skipped untested. The boxes are the tree's grown
//! boxes and the slab test is Ize's robust one, so no triangle a ray reaches is ever
//! culled; ties at equal t are kept (inclusive slabs), so the smallest triangle id wins as
//! in brute force.

use crate::bvh::objects::{BoxNode, ObjectTree, LEAF};
use geom::tri::intersect_inlined;
use geom::tri::pack;
use geom::tri::RayPre;
use geom::tris8::Tris8;
use geom::{intersect, Vec3};
use rayon::prelude::*;
use trace::{Hit, RayBatch, TraceMode};

/// Rays per parallel task (each task reuses one stack).
const CHUNK: usize = 256;

/// What the single-ray path did, per trace call.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SingleCounts {
    /// Ray–triangle tests per ray kind.
    pub final_tests: [u64; 4],
    /// Slab tests of rays against children's boxes (8 per collapsed node visited, less
    /// the unused lanes).
    pub box_tests: u64,
    /// Slab tests that passed.
    pub box_passes: u64,
    /// Rays that hit.
    pub hits: u64,
}

impl SingleCounts {
    /// The sum of two calls' counts.
    pub fn merged(mut self, o: SingleCounts) -> SingleCounts {
        for k in 0..4 {
            self.final_tests[k] += o.final_tests[k];
        }
        self.box_tests += o.box_tests;
        self.box_passes += o.box_passes;
        self.hits += o.hits;
        self
    }
}

/// A ray's reciprocal direction for the slab tests: `1 / d` with an infinite component
/// (a zero direction component) clamped to ±`f32::MAX`, so that `(plane − o) · inv` is
/// never `0 · ∞` and no NaN enters the test. Still conservative: along such an axis the
/// ray stays at its origin's coordinate, and a grown box ([`crate::bvh::objects`]: 8 ulps of the
/// scene's largest coordinate beyond its triangles) whose slab holds that coordinate at a
/// triangle's distance `δ` from a face gives the interval `[−δ·MAX, +δ·MAX]` around it,
/// which holds every parameter a ray can reach a triangle at; an origin outside the slab
/// gives an interval at ±`δ·MAX` or beyond, which no triangle inside needs.
#[inline]
pub fn slab_inverse(d: Vec3) -> Vec3 {
    d.recip()
        .clamp(Vec3::splat(-f32::MAX), Vec3::splat(f32::MAX))
}

/// Per lane of `node` (its first `count` children): whether the ray (origin `org`,
/// reciprocal direction `inv` from [`slab_inverse`], interval `[t0, t1]`) meets the
/// child's box, and its entry: per axis `(min − o) · inv` and `(max − o) · inv` ordered,
/// the entry the largest of `t0` and the lower ends, the exit the smallest of the upper
/// ends enlarged by `SLAB_ROBUST` (Ize 2013) and capped by `t1`; a hit when entry ≤ exit.
/// The scalar twin of [`avx2::boxes8`] (the same operations in the same order).
pub fn boxes_scalar(node: &BoxNode, org: Vec3, inv: Vec3, t0: f32, t1: f32) -> (u8, [f32; 8]) {
    let mut mask = 0u8;
    let mut tn = [f32::INFINITY; 8];
    for (i, t) in tn.iter_mut().enumerate().take(node.count as usize) {
        let (mut near, mut far) = (t0, f32::INFINITY);
        for k in 0..3 {
            let a = (node.min[k][i] - org[k]) * inv[k];
            let b = (node.max[k][i] - org[k]) * inv[k];
            near = near.max(a.min(b));
            far = far.min(a.max(b));
        }
        if near <= t1.min(far * geom::aabb::SLAB_ROBUST) {
            mask |= 1 << i;
            *t = near;
        }
    }
    (mask, tn)
}

#[cfg(target_arch = "x86_64")]
pub mod avx2 {
    //! The 8-lane slab test, and the walk compiled for AVX2 around it.
    use super::{BoxNode, ObjectTree, SingleCounts};
    use geom::aabb::SLAB_ROBUST;
    use geom::Vec3;
    use std::arch::x86_64::*;
    use trace::{Hit, RayBatch};

    /// [`super::boxes_scalar`] in AVX2 lanes, the same IEEE operations in the same order
    /// (no NaN can arise: [`super::slab_inverse`]), so the masks are the scalar test's and
    /// the entries differ at most in the sign of a zero, which no comparison sees.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn boxes8(node: &BoxNode, org: Vec3, inv: Vec3, t0: f32, t1: f32) -> (u8, [f32; 8]) {
        let mut near = _mm256_set1_ps(t0);
        let mut far = _mm256_set1_ps(f32::INFINITY);
        for k in 0..3 {
            let o = _mm256_set1_ps(org[k]);
            let i = _mm256_set1_ps(inv[k]);
            let a = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(node.min[k].as_ptr()), o), i);
            let b = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(node.max[k].as_ptr()), o), i);
            near = _mm256_max_ps(near, _mm256_min_ps(a, b));
            far = _mm256_min_ps(far, _mm256_max_ps(a, b));
        }
        let exit = _mm256_min_ps(
            _mm256_set1_ps(t1),
            _mm256_mul_ps(far, _mm256_set1_ps(SLAB_ROBUST)),
        );
        let pass = _mm256_cmp_ps::<_CMP_LE_OQ>(near, exit);
        let used = (1u32 << node.count) - 1;
        let mask = (_mm256_movemask_ps(pass) as u32 & used) as u8;
        let mut out = [0f32; 8];
        _mm256_storeu_ps(out.as_mut_ptr(), near);
        (mask, out)
    }

    /// Ask for the `lines` cache lines from `p` ahead of their use.
    ///
    /// # Safety
    /// The CPU must have AVX2 (a prefetch never faults, whatever the address).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn prefetch(p: *const u8, lines: usize) {
        for line in 0..lines {
            _mm_prefetch::<_MM_HINT_T0>(p.add(64 * line) as *const i8);
        }
    }

    /// The walk (`walk_rays`) with the slab test inlined, compiled for the CPU features
    /// `$features`. The scalar triangle kernel compiles to the same IEEE operations under
    /// any of them: Rust never fuses a product and a sum.
    macro_rules! walk_for {
        ($(#[$doc:meta])* $name:ident, $features:literal) => {
            $(#[$doc])*
            #[target_feature(enable = $features)]
            pub unsafe fn $name(
                tree: &ObjectTree,
                tris: &[[Vec3; 3]],
                rays: &RayBatch,
                first: usize,
                out: &mut [Hit],
                any: bool,
                stack: &mut Vec<(u32, f32)>,
            ) -> SingleCounts {
                super::walk_rays(
                    tree,
                    tris,
                    rays,
                    first,
                    out,
                    any,
                    stack,
                    |n, o, i, t0, t1| unsafe { boxes8(n, o, i, t0, t1) },
                    |r, t, m| unsafe { geom::tris8::redo8(r, t, m) },
                    |p, lines| unsafe { prefetch(p, lines) },
                )
            }
        };
    }

    walk_for!(
        /// Rays `first..first + out.len()` compiled for AVX2 and POPCNT.
        ///
        /// # Safety
        /// The CPU must have AVX2 and POPCNT.
        walk,
        "avx2,popcnt"
    );

    walk_for!(
        /// [`walk`] compiled for AVX-512 (F, VL): the same source and intrinsics, with 32
        /// vector registers.
        ///
        /// # Safety
        /// The CPU must have AVX-512 F and VL, AVX2 and POPCNT.
        walk512,
        "avx512f,avx512vl,avx2,popcnt"
    );
}

/// Which build of the walk runs ([`geom::Isa`]): scalar slab tests lane by lane, or AVX2
/// slab tests compiled for AVX2 or AVX-512 (the same IEEE operations, so the same hits and
/// counts: tested).
pub use geom::Isa;

/// Trace every ray of `rays` through `tree` (over `tris`) one by one, writing its record
/// into `hits` (closest hit: brute force's; any hit: the first found), with the walk built
/// for `isa` (which the CPU must run: [`Isa::available`]).
pub fn trace(
    tree: &ObjectTree,
    tris: &[[Vec3; 3]],
    rays: &RayBatch,
    mode: TraceMode,
    hits: &mut [Hit],
    isa: Isa,
) -> SingleCounts {
    assert_eq!(hits.len(), rays.len(), "one hit record per ray");
    assert!(isa.available(), "{isa:?} on this CPU");
    let any = mode == TraceMode::Any;
    hits.par_chunks_mut(CHUNK)
        .enumerate()
        .map_init(
            || Vec::with_capacity(64),
            |stack: &mut Vec<(u32, f32)>, (ci, out)| {
                let first = ci * CHUNK;
                match isa {
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: checked by `available` above.
                    Isa::Avx512 => unsafe {
                        avx2::walk512(tree, tris, rays, first, out, any, stack)
                    },
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: checked by `available` above.
                    Isa::Avx2 => unsafe { avx2::walk(tree, tris, rays, first, out, any, stack) },
                    _ => walk_rays(
                        tree,
                        tris,
                        rays,
                        first,
                        out,
                        any,
                        stack,
                        boxes_scalar,
                        geom::tris8::redo8_scalar,
                        |_, _| {},
                    ),
                }
            },
        )
        .reduce(SingleCounts::default, SingleCounts::merged)
}

/// Rays `first..first + out.len()` one by one (see the module doc), each node's boxes
/// tested by `boxes` and each pushed node announced to `prefetch`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn walk_rays(
    tree: &ObjectTree,
    tris: &[[Vec3; 3]],
    rays: &RayBatch,
    first: usize,
    out: &mut [Hit],
    any: bool,
    stack: &mut Vec<(u32, f32)>,
    boxes: impl Fn(&BoxNode, Vec3, Vec3, f32, f32) -> (u8, [f32; 8]),
    tris8: impl Fn(&RayPre, &Tris8, u8) -> u8,
    prefetch: impl Fn(*const u8, usize),
) -> SingleCounts {
    let mut c = SingleCounts::default();
    for (j, h) in out.iter_mut().enumerate() {
        *h = walk_ray(
            tree,
            tris,
            rays,
            first + j,
            any,
            stack,
            &mut c,
            &boxes,
            &tris8,
            &prefetch,
        );
        c.hits += h.is_hit() as u64;
    }
    c
}

/// One ray's walk (see the module doc).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn walk_ray(
    tree: &ObjectTree,
    tris: &[[Vec3; 3]],
    rays: &RayBatch,
    r: usize,
    any: bool,
    stack: &mut Vec<(u32, f32)>,
    c: &mut SingleCounts,
    boxes: &impl Fn(&BoxNode, Vec3, Vec3, f32, f32) -> (u8, [f32; 8]),
    tris8: &impl Fn(&RayPre, &Tris8, u8) -> u8,
    prefetch: &impl Fn(*const u8, usize),
) -> Hit {
    let pre = RayPre::new(&rays.ray(r));
    let kind = rays.kind[r] as usize & 3;
    let mut best = u64::MAX;
    let mut uv = (0.0f32, 0.0f32);
    if tree.root & LEAF != 0 {
        if let Some(&[a, b, cc]) = tris.first() {
            // One triangle, no inner node (and no leaf order).
            c.final_tests[kind] += 1;
            if let Some(hit) = intersect(&pre, a, b, cc) {
                best = pack(hit.t, 0);
                uv = (hit.u, hit.v);
            }
        }
    } else {
        // How far the ray still looks: its t_max, or the closest hit so far.
        let reach = |best: u64| pre.t_max.min(f32::from_bits((best >> 32) as u32));
        let inv = slab_inverse(rays.dir[r]);
        // Counted in registers, added once per ray.
        let (mut box_tests, mut box_passes) = (0u64, 0u64);
        stack.clear();
        // The node being visited stays out of the stack: a node with one passing inner
        // child goes straight on to it, one with several pushes all but the nearest
        // (Embree's BVH8 single-ray loop does the same), so most steps touch no stack.
        let mut w = 0u32;
        'walk: loop {
            let far = reach(best);
            let node = &tree.boxes[w as usize];
            let (mask, tn) = boxes(node, pre.org, inv, pre.t_min, far);
            box_tests += node.count as u64;
            box_passes += mask.count_ones() as u64;
            // Triangles first (they shorten the ray for the inner children), then the
            // inner children. The passing leaf lanes' triangles block by block of
            // `leaf_tris`: a node's leaf lanes follow each other in the box order, so they
            // share a block or two.
            let m = mask & node.leaves as u8;
            if m != 0 {
                // The node's leaf lanes hold consecutive positions from `base`, lane after
                // lane ([`crate::bvh::objects::number_level`]): a lane's first position is `base`
                // plus the triangles of the leaf lanes before it, a byte-wise prefix sum
                // of `ntri` (at most 8 × `LANE_TRIS` in all: no byte carries). Per position from `base`:
                // whether it is tested and whether it ends its lane: an any-hit walk stops
                // at the end of the first lane with a hit, as a walk testing lane by lane
                // in lane order does (the GPU's), so the same triangle is recorded.
                let leaf_lanes = node.leaves as u8;
                let base = node.child[leaf_lanes.trailing_zeros() as usize] & !LEAF;
                let counts = u64::from_le_bytes(node.ntri) & lane_bytes(leaf_lanes);
                let before = counts.wrapping_mul(0x0101_0101_0101_0101) - counts;
                let (mut tested, mut ends) = (0u32, 0u32);
                let mut mm = m;
                while mm != 0 {
                    let l = mm.trailing_zeros();
                    mm &= mm - 1;
                    let off = (before >> (8 * l)) as u8 as u32;
                    let k = node.ntri[l as usize] as u32;
                    tested |= ((1u32 << k) - 1) << off;
                    ends |= 1 << (off + k - 1);
                }
                // The tested positions by block of `leaf_tris` (at most three), in position
                // order; the lanes the vector test cannot rule out are decided by the
                // scalar kernel in position order (a lone triangle goes to it straight
                // away). Any hit: `stop`, the last position tested (from `base`).
                let first = base / 8;
                let mut bits = (tested as u64) << (base % 8);
                let mut stop = u32::MAX;
                'runs: while bits != 0 {
                    let byte = bits.trailing_zeros() / 8;
                    let lanes = (bits >> (8 * byte)) as u8;
                    bits &= !(0xffu64 << (8 * byte));
                    let b = first + byte;
                    let blk = &tree.leaf_tris[b as usize];
                    let mut redo = if lanes & (lanes - 1) == 0 {
                        lanes
                    } else {
                        tris8(&pre, blk, lanes)
                    };
                    while redo != 0 {
                        let j = redo.trailing_zeros();
                        redo &= redo - 1;
                        let q = 8 * b + j;
                        let r = q - base;
                        if r > stop {
                            break 'runs;
                        }
                        let [a, b2, cc] = blk.tri(j as usize);
                        if let Some(hit) = intersect_inlined(&pre, a, b2, cc) {
                            let key = pack(hit.t, tree.leaf_ids[q as usize]);
                            if key < best {
                                best = key;
                                uv = (hit.u, hit.v);
                            }
                            if any && stop == u32::MAX {
                                stop = r + (ends >> r).trailing_zeros();
                            }
                        }
                    }
                    if stop != u32::MAX && 8 * b + 7 >= base + stop {
                        break;
                    }
                }
                if stop != u32::MAX {
                    // The lanes up to the one that hit were tested.
                    let upto = (2u64 << stop) - 1;
                    c.final_tests[kind] += (tested as u64 & upto).count_ones() as u64;
                    break 'walk;
                }
                c.final_tests[kind] += tested.count_ones() as u64;
            }
            let far = reach(best);
            // The inner children the ray enters before its closest hit so far.
            let mut m = mask & !node.leaves as u8;
            let mut inner = [(0u32, 0f32); 8];
            let mut ni = 0;
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                inner[ni] = (node.child[l], tn[l]);
                ni += (tn[l] <= far) as usize;
            }
            let next = match ni {
                0 => None,
                1 => Some(inner[0].0),
                _ => {
                    // Insertion sort by entry, farthest first (at most 8; stable, so equal
                    // entries keep lane order), all but the nearest pushed.
                    let inner = &mut inner[..ni];
                    for i in 1..inner.len() {
                        let mut j = i;
                        while j > 0 && inner[j - 1].1 < inner[j].1 {
                            inner.swap(j - 1, j);
                            j -= 1;
                        }
                    }
                    for &(x, t) in &inner[..ni - 1] {
                        prefetch(&tree.boxes[x as usize] as *const BoxNode as *const u8, 4);
                        stack.push((x, t));
                    }
                    Some(inner[ni - 1].0)
                }
            };
            w = match next {
                Some(x) => x,
                None => loop {
                    let Some((x, entry)) = stack.pop() else {
                        break 'walk;
                    };
                    // Entered beyond the closest hit found since it was pushed: skipped.
                    if entry <= reach(best) {
                        break x;
                    }
                },
            };
        }
        c.box_tests += box_tests;
        c.box_passes += box_passes;
    }
    if best == u64::MAX {
        Hit::MISS
    } else {
        Hit {
            tri: best as u32,
            t: f32::from_bits((best >> 32) as u32),
            u: uv.0,
            v: uv.1,
        }
    }
}

// The walk's per-node position masks are u32, shifted by up to 7 into a u64 and summed
// byte-wise (`walk_ray`): a node's leaf triangles must fit them.
const _: () = assert!(8 * crate::bvh::objects::LANE_TRIS <= 32);

/// Byte `i` all ones where bit `i` of `m` is set, else zero.
#[inline(always)]
fn lane_bytes(m: u8) -> u64 {
    // Byte i keeps bit i of m (at bit i of the byte); adding 0x7f carries it to the byte's
    // top bit without reaching the next byte.
    let spread = (m as u64).wrapping_mul(0x0101_0101_0101_0101) & 0x8040_2010_0804_0201;
    (((spread + 0x7f7f_7f7f_7f7f_7f7f) >> 7) & 0x0101_0101_0101_0101) * 0xff
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every lane mask spreads to its bytes.
    #[test]
    fn lane_bytes_spreads_each_bit_to_its_byte() {
        for m in 0..=255u8 {
            let want =
                u64::from_le_bytes(std::array::from_fn(
                    |i| {
                        if m >> i & 1 != 0 {
                            0xff
                        } else {
                            0
                        }
                    },
                ));
            assert_eq!(lane_bytes(m), want, "{m:08b}");
        }
    }
}
