//! The `bvh` engine's walk for batches of neighbouring rays: a batch's rays in packets of 16
//! consecutive rays, each packet walking the object tree's collapsed nodes
//! ([`crate::bvh::objects::BoxNode`], 8 children) together, every child's box slab-tested against the 16 rays at once (one AVX-512
//! vector, two AVX2 ones, or the same lane loop scalar): the packet traversal of Wald et al.
//! 2001 ("Interactive rendering with coherent ray tracing") over a wide tree, as Embree's
//! stream mode traces coherent rays.
//!
//! Why: one ray alone through the tree is bound by the latency of each node's loads and of
//! the tests that depend on them (about 100 cycles a node on Sponza's shadow rays,
//! [`crate::bvh::single`]), and neighbouring rays whose segments stay close (rays made pixel
//! by pixel towards a light or a mirror, short ambient-occlusion rays from neighbouring
//! points: [`crate::bvh::locality`]) walk nearly the same nodes. A packet pays each node's
//! loads once for all its rays, and its 16 slab tests fill a vector. A packet is a one-level
//! ray hierarchy in the batch's own order, without cones: nothing is hashed, sorted or built.
//!
//! Per packet: a stack of (node, lanes that entered it). Visiting a node tests all its
//! children against every lane and keeps the lanes that entered the node and are not done
//! (any hit: a lane stops at its first hit). A leaf lane's triangles are tested for each lane
//! whose slab test passed: 16 lanes of the watertight inside test reject the misses (each
//! lane the scalar kernel's operations in its order, so a lane rejects only where the scalar
//! kernel misses), and the shared kernel ([`geom::tri::intersect`]) decides every other lane,
//! so each hit is brute force's bit for bit. An inner child is entered by the lanes whose
//! entry lies before their closest hit so far; the child entered nearest (over its lanes) is
//! visited next and the others are pushed farthest first. A lane's box tests use its own
//! closest hit as the slab's far end, inclusively, and the boxes are the tree's grown boxes
//! with Ize's robust slab test, as for single rays: no triangle a ray reaches is culled, and
//! the closest hit is the smallest (t, triangle) key, whatever order the packet took.
//!
//! Every build (scalar, AVX2, AVX-512) runs the same lane loops, the same IEEE operations
//! per lane, so the hits and the counts are equal (tested).

use crate::bvh::objects::{BoxNode, ObjectTree, LEAF};
use crate::bvh::single::{slab_inverse, SingleCounts};
use geom::aabb::SLAB_ROBUST;
use geom::tri::pack;
use geom::tri::{intersect_inlined, RayPre};
use geom::{intersect, Isa, Vec3};
use rayon::prelude::*;
use trace::{Hit, RayBatch, TraceMode};

/// Rays per packet.
pub const LANES: usize = 16;

/// Packets per parallel task (each task reuses one stack).
const PACKETS_PER_TASK: usize = 16;

/// A value per lane.
type L<T> = [T; LANES];

/// The smaller of `a` and `b` as x86's `minps` takes it (`b` when they are equal): the lane
/// loops compile to one vector instruction. No operand is ever NaN here
/// ([`slab_inverse`]).
#[inline(always)]
fn mn(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// The larger of `a` and `b` (`b` when they are equal), as `maxps`.
#[inline(always)]
fn mx(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// A packet's rays as lanes.
struct Packet {
    /// Origins.
    org: [L<f32>; 3],
    /// Reciprocal directions for the slab tests ([`slab_inverse`]).
    inv: [L<f32>; 3],
    /// t_min.
    t0: L<f32>,
    /// How far each lane still looks: its t_max, or its closest hit's t.
    far: L<f32>,
    /// The watertight shear per lane: origin on the axes (kx, ky, kz), the axes as 0.0, 1.0
    /// or 2.0, and (sx, sy).
    ok: [L<f32>; 3],
    k: [L<f32>; 3],
    s: [L<f32>; 2],
    /// Per shear slot j the lanes whose axis is 0 and those whose axis is 1 (the vector
    /// builds' blends).
    axis: [[u16; 2]; 3],
    /// The shared kernel's constants per lane.
    pre: L<RayPre>,
    /// Closest hit so far per lane (`pack(t, triangle)`; `u64::MAX`: none) and its
    /// barycentrics.
    best: L<u64>,
    uv: L<(f32, f32)>,
    /// Ray kinds (the counters), and the lanes of each kind.
    kind: L<u8>,
    kind_lanes: [u16; 4],
}

impl Packet {
    /// Rays `first..first + n` of `rays` (n ≤ 16); lanes `n..` repeat the first ray and are
    /// never active.
    #[inline(always)]
    fn new(rays: &RayBatch, first: usize, n: usize) -> Packet {
        let z = [0f32; LANES];
        let mut p = Packet {
            org: [z; 3],
            inv: [z; 3],
            t0: z,
            far: z,
            ok: [z; 3],
            k: [z; 3],
            s: [z; 2],
            axis: [[0; 2]; 3],
            pre: [shear([0.0; 3], [0.0, 0.0, 1.0], 0.0, 0.0); LANES],
            best: [u64::MAX; LANES],
            uv: [(0.0, 0.0); LANES],
            kind: [0; LANES],
            kind_lanes: [0; 4],
        };
        // Plain loops, the lanes written in place, every per-ray choice a select on local
        // arrays (closures per lane were not inlined, and `Vec3`'s index is a branch).
        for l in 0..LANES {
            let r = first + if l < n { l } else { 0 };
            let (o, d) = (rays.org[r].to_array(), rays.dir[r].to_array());
            let pre = shear(o, d, rays.t_min[r], rays.t_max[r]);
            let inv = slab_inverse(rays.dir[r]).to_array();
            let axes = [pre.kx as usize, pre.ky as usize, pre.kz as usize];
            for k in 0..3 {
                p.org[k][l] = o[k];
                p.inv[k][l] = inv[k];
                p.ok[k][l] = o[axes[k]];
                p.k[k][l] = axes[k] as f32;
                p.axis[k][0] |= ((axes[k] == 0) as u16) << l;
                p.axis[k][1] |= ((axes[k] == 1) as u16) << l;
            }
            p.t0[l] = pre.t_min;
            p.far[l] = pre.t_max;
            p.s[0][l] = pre.sx;
            p.s[1][l] = pre.sy;
            p.kind[l] = rays.kind[r] & 3;
            p.kind_lanes[p.kind[l] as usize] |= 1 << l;
            p.pre[l] = pre;
        }
        p
    }

    /// The lanes the watertight inside test does not reject for triangle `(a, b, c)`: per
    /// lane [`geom::tri::intersect`]'s steps up to its sign test and determinant (each
    /// vertex minus the origin on the shear's axes, the shear as a product then a difference,
    /// the three edge functions, det = (u + v) + w), so a rejected lane is a scalar miss; an
    /// edge function exactly 0 (the scalar kernel's f64 case) is not rejected.
    #[inline(always)]
    fn inside(&self, a: Vec3, b: Vec3, c: Vec3) -> u16 {
        let pick = |v: Vec3, k: f32| {
            if k == 0.0 {
                v.x
            } else if k == 1.0 {
                v.y
            } else {
                v.z
            }
        };
        let mut keep = 0u16;
        for l in 0..LANES {
            let rel = |v: Vec3| {
                [
                    pick(v, self.k[0][l]) - self.ok[0][l],
                    pick(v, self.k[1][l]) - self.ok[1][l],
                    pick(v, self.k[2][l]) - self.ok[2][l],
                ]
            };
            let (pa, pb, pc) = (rel(a), rel(b), rel(c));
            let (sx, sy) = (self.s[0][l], self.s[1][l]);
            let ax = pa[0] - sx * pa[2];
            let ay = pa[1] - sy * pa[2];
            let bx = pb[0] - sx * pb[2];
            let by = pb[1] - sy * pb[2];
            let cx = pc[0] - sx * pc[2];
            let cy = pc[1] - sy * pc[2];
            let u = cx * by - cy * bx;
            let v = ax * cy - ay * cx;
            let w = bx * ay - by * ax;
            let edge = (u == 0.0) | (v == 0.0) | (w == 0.0);
            let neg = (u < 0.0) | (v < 0.0) | (w < 0.0);
            let pos = (u > 0.0) | (v > 0.0) | (w > 0.0);
            let det = (u + v) + w;
            keep |= ((edge | !((neg & pos) | (det == 0.0))) as u16) << l;
        }
        keep
    }
}

/// [`RayPre::new`] for the ray (o, d, t_min, t_max), its choices made on local arrays: the
/// same axes (kz the largest |d| component, ties as there; kx, ky the next ones, swapped for
/// d[kz] < 0) and the same operations, so the same record (tested).
#[inline(always)]
fn shear(o: [f32; 3], d: [f32; 3], t_min: f32, t_max: f32) -> RayPre {
    let ad = [d[0].abs(), d[1].abs(), d[2].abs()];
    let kz = if ad[0] > ad[1] {
        if ad[0] > ad[2] {
            0
        } else {
            2
        }
    } else if ad[1] > ad[2] {
        1
    } else {
        2
    };
    let kx0 = if kz == 2 { 0 } else { kz + 1 };
    let ky0 = if kx0 == 2 { 0 } else { kx0 + 1 };
    let neg = d[kz] < 0.0;
    let (kx, ky) = if neg { (ky0, kx0) } else { (kx0, ky0) };
    let sz = 1.0 / d[kz];
    RayPre {
        org: Vec3::from_array(o),
        dir: Vec3::from_array(d),
        kx: kx as u8,
        ky: ky as u8,
        kz: kz as u8,
        sx: d[kx] * sz,
        sy: d[ky] * sz,
        t_min,
        t_max,
    }
}

/// What one node's test gives: per child the lanes whose slab test passed (of the lanes
/// asked), and per child each lane's entry.
type Tested = ([u16; 8], [L<f32>; 8]);

/// The first `count` children of `node` against the lanes `m` of `p`, in the portable build:
/// per lane the single-ray test's operations ([`crate::bvh::single::boxes_scalar`]): per axis
/// `(min − o) · inv` and `(max − o) · inv` ordered, the entry the largest of t_min and the
/// lower ends, the exit the smallest of the upper ends enlarged by `SLAB_ROBUST` and capped by
/// the lane's reach; a pass when entry ≤ exit. The vector builds ([`x86`]) make the same
/// operations in the same order.
#[inline(always)]
fn children_scalar(p: &Packet, node: &BoxNode, count: usize, m: u16, out: &mut Tested) {
    for i in 0..count {
        let lo = [node.min[0][i], node.min[1][i], node.min[2][i]];
        let hi = [node.max[0][i], node.max[1][i], node.max[2][i]];
        let mut pass = 0u16;
        for l in 0..LANES {
            let (mut n, mut f) = (p.t0[l], f32::INFINITY);
            for k in 0..3 {
                let a = (lo[k] - p.org[k][l]) * p.inv[k][l];
                let b = (hi[k] - p.org[k][l]) * p.inv[k][l];
                n = mx(n, mn(a, b));
                f = mn(f, mx(a, b));
            }
            out.1[i][l] = n;
            pass |= ((n <= mn(p.far[l], f * SLAB_ROBUST)) as u16) << l;
        }
        out.0[i] = pass & m;
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    //! The node test in AVX-512 (the 16 lanes in one vector) and AVX2 (two), and the walk
    //! compiled for each around it.
    use super::*;
    use std::arch::x86_64::*;

    /// [`super::children_scalar`] in one AVX-512 vector: `minps`/`maxps` are the scalar
    /// `mn`/`mx` (the first operand when it is smaller/larger, else the second), the other
    /// steps single IEEE operations.
    ///
    /// # Safety
    /// The CPU must have AVX-512 F.
    #[inline]
    #[target_feature(enable = "avx512f,avx512vl,avx2,popcnt")]
    pub unsafe fn children512(p: &Packet, node: &BoxNode, count: usize, m: u16, out: &mut Tested) {
        let ld = |v: &L<f32>| unsafe { _mm512_loadu_ps(v.as_ptr()) };
        let org = [ld(&p.org[0]), ld(&p.org[1]), ld(&p.org[2])];
        let inv = [ld(&p.inv[0]), ld(&p.inv[1]), ld(&p.inv[2])];
        let (t0, far) = (ld(&p.t0), ld(&p.far));
        let robust = _mm512_set1_ps(SLAB_ROBUST);
        for i in 0..count {
            let (mut n, mut f) = (t0, _mm512_set1_ps(f32::INFINITY));
            for k in 0..3 {
                let lo = _mm512_set1_ps(node.min[k][i]);
                let hi = _mm512_set1_ps(node.max[k][i]);
                let a = _mm512_mul_ps(_mm512_sub_ps(lo, org[k]), inv[k]);
                let b = _mm512_mul_ps(_mm512_sub_ps(hi, org[k]), inv[k]);
                n = _mm512_max_ps(n, _mm512_min_ps(a, b));
                f = _mm512_min_ps(f, _mm512_max_ps(a, b));
            }
            let exit = _mm512_min_ps(far, _mm512_mul_ps(f, robust));
            out.0[i] = _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(m, n, exit);
            _mm512_storeu_ps(out.1[i].as_mut_ptr(), n);
        }
    }

    /// [`Packet::inside`] in one AVX-512 vector: the same operations per lane (each vertex
    /// component picked by the lane's axis with blends, products and differences never
    /// fused, ordered comparisons as the scalar ones).
    ///
    /// # Safety
    /// The CPU must have AVX-512 F.
    #[inline]
    #[target_feature(enable = "avx512f,avx512vl,avx2,popcnt")]
    pub unsafe fn inside512(p: &Packet, a: Vec3, b: Vec3, c: Vec3) -> u16 {
        let ld = |v: &L<f32>| unsafe { _mm512_loadu_ps(v.as_ptr()) };
        let ok = [ld(&p.ok[0]), ld(&p.ok[1]), ld(&p.ok[2])];
        let rel = |v: Vec3| {
            let (x, y, z) = (
                _mm512_set1_ps(v.x),
                _mm512_set1_ps(v.y),
                _mm512_set1_ps(v.z),
            );
            let pick = |j: usize| {
                let [is0, is1] = p.axis[j];
                let v = _mm512_mask_blend_ps(is0, _mm512_mask_blend_ps(is1, z, y), x);
                _mm512_sub_ps(v, ok[j])
            };
            [pick(0), pick(1), pick(2)]
        };
        let (pa, pb, pc) = (rel(a), rel(b), rel(c));
        let (sx, sy) = (ld(&p.s[0]), ld(&p.s[1]));
        let sh = |q: [__m512; 3], s: __m512, j: usize| _mm512_sub_ps(q[j], _mm512_mul_ps(s, q[2]));
        let (ax, ay) = (sh(pa, sx, 0), sh(pa, sy, 1));
        let (bx, by) = (sh(pb, sx, 0), sh(pb, sy, 1));
        let (cx, cy) = (sh(pc, sx, 0), sh(pc, sy, 1));
        let cross = |p: __m512, q: __m512, r: __m512, s: __m512| {
            _mm512_sub_ps(_mm512_mul_ps(p, q), _mm512_mul_ps(r, s))
        };
        let u = cross(cx, by, cy, bx);
        let v = cross(ax, cy, ay, cx);
        let w = cross(bx, ay, by, ax);
        let zero = _mm512_setzero_ps();
        let eq = |x| _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(x, zero);
        let lt = |x| _mm512_cmp_ps_mask::<_CMP_LT_OQ>(x, zero);
        let gt = |x| _mm512_cmp_ps_mask::<_CMP_GT_OQ>(x, zero);
        let edge = eq(u) | eq(v) | eq(w);
        let neg = lt(u) | lt(v) | lt(w);
        let pos = gt(u) | gt(v) | gt(w);
        let det = _mm512_add_ps(_mm512_add_ps(u, v), w);
        edge | !((neg & pos) | eq(det))
    }

    /// [`super::children_scalar`] in two AVX2 vectors (lanes 0–7 and 8–15).
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[inline]
    #[target_feature(enable = "avx2,popcnt")]
    pub unsafe fn children256(p: &Packet, node: &BoxNode, count: usize, m: u16, out: &mut Tested) {
        for h in 0..2 {
            let ld = |v: &L<f32>| unsafe { _mm256_loadu_ps(v.as_ptr().add(8 * h)) };
            let org = [ld(&p.org[0]), ld(&p.org[1]), ld(&p.org[2])];
            let inv = [ld(&p.inv[0]), ld(&p.inv[1]), ld(&p.inv[2])];
            let (t0, far) = (ld(&p.t0), ld(&p.far));
            let robust = _mm256_set1_ps(SLAB_ROBUST);
            for i in 0..count {
                let (mut n, mut f) = (t0, _mm256_set1_ps(f32::INFINITY));
                for k in 0..3 {
                    let lo = _mm256_set1_ps(node.min[k][i]);
                    let hi = _mm256_set1_ps(node.max[k][i]);
                    let a = _mm256_mul_ps(_mm256_sub_ps(lo, org[k]), inv[k]);
                    let b = _mm256_mul_ps(_mm256_sub_ps(hi, org[k]), inv[k]);
                    n = _mm256_max_ps(n, _mm256_min_ps(a, b));
                    f = _mm256_min_ps(f, _mm256_max_ps(a, b));
                }
                let exit = _mm256_min_ps(far, _mm256_mul_ps(f, robust));
                let pass = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(n, exit)) as u16;
                if h == 0 {
                    out.0[i] = pass;
                } else {
                    out.0[i] = (out.0[i] | pass << 8) & m;
                }
                _mm256_storeu_ps(out.1[i].as_mut_ptr().add(8 * h), n);
            }
        }
    }

    /// [`super::walk_packets`] compiled for AVX-512 around [`children512`].
    ///
    /// # Safety
    /// The CPU must have AVX-512 F and VL, AVX2 and POPCNT.
    #[target_feature(enable = "avx512f,avx512vl,avx2,popcnt")]
    pub unsafe fn walk512(a: Args, out: &mut [Hit], stack: &mut Vec<(u32, u16)>) -> SingleCounts {
        walk_packets(
            a,
            out,
            stack,
            |p, n, c, m, o| unsafe { children512(p, n, c, m, o) },
            |p, x, y, z| unsafe { inside512(p, x, y, z) },
        )
    }

    /// [`super::walk_packets`] compiled for AVX2 around [`children256`].
    ///
    /// # Safety
    /// The CPU must have AVX2 and POPCNT.
    #[target_feature(enable = "avx2,popcnt")]
    pub unsafe fn walk256(a: Args, out: &mut [Hit], stack: &mut Vec<(u32, u16)>) -> SingleCounts {
        walk_packets(
            a,
            out,
            stack,
            |p, n, c, m, o| unsafe { children256(p, n, c, m, o) },
            Packet::inside,
        )
    }
}

/// What every task of a trace reads.
#[derive(Clone, Copy)]
struct Args<'a> {
    tree: &'a ObjectTree,
    tris: &'a [[Vec3; 3]],
    rays: &'a RayBatch,
    /// The task's first ray.
    first: usize,
    any: bool,
}

/// Trace every ray of `rays` through `tree` (over `tris`) in packets of [`LANES`]
/// consecutive rays, writing each ray's record into `hits` (closest hit: brute force's;
/// any hit: the first found), with the lane loops built for `isa` (which the CPU must run).
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
    hits.par_chunks_mut(LANES * PACKETS_PER_TASK)
        .enumerate()
        .map_init(
            || Vec::with_capacity(64),
            |stack: &mut Vec<(u32, u16)>, (ci, out)| {
                let a = Args {
                    tree,
                    tris,
                    rays,
                    first: ci * LANES * PACKETS_PER_TASK,
                    any,
                };
                match isa {
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: checked by `available` above.
                    Isa::Avx512 => unsafe { x86::walk512(a, out, stack) },
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: checked by `available` above.
                    Isa::Avx2 => unsafe { x86::walk256(a, out, stack) },
                    _ => walk_packets(a, out, stack, children_scalar, Packet::inside),
                }
            },
        )
        .reduce(SingleCounts::default, SingleCounts::merged)
}

/// The task's rays (`a.first..a.first + out.len()`) in packets of [`LANES`], each node
/// tested by `children`.
#[inline(always)]
fn walk_packets(
    a: Args,
    out: &mut [Hit],
    stack: &mut Vec<(u32, u16)>,
    children: impl Fn(&Packet, &BoxNode, usize, u16, &mut Tested),
    inside: impl Fn(&Packet, Vec3, Vec3, Vec3) -> u16,
) -> SingleCounts {
    let Args {
        tree,
        tris,
        rays,
        first,
        any,
    } = a;
    let mut c = SingleCounts::default();
    for (pi, out) in out.chunks_mut(LANES).enumerate() {
        let n = out.len();
        let mut p = Packet::new(rays, first + pi * LANES, n);
        let active = ((1u32 << n) - 1) as u16;
        if tree.root & LEAF != 0 {
            // One triangle, no inner node (and no leaf order).
            if let Some(&[a, b, cc]) = tris.first() {
                for l in 0..n {
                    c.final_tests[p.kind[l] as usize] += 1;
                    if let Some(hit) = intersect(&p.pre[l], a, b, cc) {
                        p.best[l] = pack(hit.t, 0);
                        p.uv[l] = (hit.u, hit.v);
                    }
                }
            }
        } else {
            walk(tree, &mut p, active, any, stack, &mut c, &children, &inside);
        }
        for (l, h) in out.iter_mut().enumerate() {
            let best = p.best[l];
            *h = if best == u64::MAX {
                Hit::MISS
            } else {
                c.hits += 1;
                Hit {
                    tri: best as u32,
                    t: f32::from_bits((best >> 32) as u32),
                    u: p.uv[l].0,
                    v: p.uv[l].1,
                }
            };
        }
    }
    c
}

/// One packet's walk (see the module doc) over the lanes `active`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn walk(
    tree: &ObjectTree,
    p: &mut Packet,
    active: u16,
    any: bool,
    stack: &mut Vec<(u32, u16)>,
    c: &mut SingleCounts,
    children: &impl Fn(&Packet, &BoxNode, usize, u16, &mut Tested),
    inside: &impl Fn(&Packet, Vec3, Vec3, Vec3) -> u16,
) {
    stack.clear();
    // Any hit: the lanes that hit (and stop).
    let mut done = 0u16;
    let (mut box_tests, mut box_passes) = (0u64, 0u64);
    let mut tested: Tested = ([0; 8], [[0.0; LANES]; 8]);
    let (mut w, mut m) = (0u32, active);
    'walk: loop {
        let node = &tree.boxes[w as usize];
        let count = node.count as usize;
        children(p, node, count, m, &mut tested);
        let (pass, near) = (&tested.0, &tested.1);
        box_tests += (count as u32 * m.count_ones()) as u64;
        box_passes += pass[..count]
            .iter()
            .map(|x| x.count_ones() as u64)
            .sum::<u64>();
        // Triangles first (they shorten the lanes for the inner children).
        let mut shortened = false;
        let mut lm = node.leaves & ((1u32 << count) - 1);
        while lm != 0 {
            let i = lm.trailing_zeros() as usize;
            lm &= lm - 1;
            if pass[i] & !done == 0 {
                continue;
            }
            let at = (node.child[i] & !LEAF) as usize;
            for j in 0..node.ntri[i] as usize {
                let [a, b, cc] = tree.leaf_tri(at + j);
                let tested = pass[i] & !done;
                // One count per lane tested, by kind (a packet's rays are mostly of one).
                for (k, &lanes) in p.kind_lanes.iter().enumerate() {
                    c.final_tests[k] += (tested & lanes).count_ones() as u64;
                }
                let mut redo = tested & inside(p, a, b, cc);
                while redo != 0 {
                    let l = redo.trailing_zeros() as usize;
                    redo &= redo - 1;
                    if let Some(hit) = intersect_inlined(&p.pre[l], a, b, cc) {
                        let key = pack(hit.t, tree.leaf_ids[at + j]);
                        if key < p.best[l] {
                            p.best[l] = key;
                            p.uv[l] = (hit.u, hit.v);
                            p.far[l] = hit.t;
                            shortened = true;
                        }
                        if any {
                            done |= 1 << l;
                        }
                    }
                }
            }
            if any && m & !done == 0 {
                break;
            }
        }
        m &= !done;
        // The inner children, each with the lanes that enter it before their reach, and its
        // nearest entry over them.
        let mut inner = [(0u32, 0u16, 0f32); 8];
        let mut ni = 0;
        if m != 0 {
            let mut im = !node.leaves & ((1u32 << count) - 1);
            while im != 0 {
                let i = im.trailing_zeros() as usize;
                im &= im - 1;
                if pass[i] & m == 0 {
                    continue;
                }
                // A lane that passed entered before its reach; only a hit in this node's
                // leaves can have shortened it since.
                let mut lanes = pass[i] & m;
                if shortened {
                    let mut ok = 0u16;
                    for (l, (&n, &f)) in near[i].iter().zip(&p.far).enumerate() {
                        ok |= ((n <= f) as u16) << l;
                    }
                    lanes &= ok;
                }
                if lanes != 0 {
                    // Ordered by the entry of its first lane (one load; the packet's rays
                    // are neighbours, so one of them stands for all).
                    let first = near[i][lanes.trailing_zeros() as usize];
                    inner[ni] = (node.child[i], lanes, first);
                    ni += 1;
                }
            }
        }
        let next = match ni {
            0 => None,
            1 => Some((inner[0].0, inner[0].1)),
            _ => {
                // Insertion sort by entry, farthest first (stable: equal entries keep lane
                // order), all but the nearest pushed.
                let inner = &mut inner[..ni];
                for i in 1..inner.len() {
                    let mut j = i;
                    while j > 0 && inner[j - 1].2 < inner[j].2 {
                        inner.swap(j - 1, j);
                        j -= 1;
                    }
                }
                for &(x, lanes, _) in &inner[..ni - 1] {
                    stack.push((x, lanes));
                }
                Some((inner[ni - 1].0, inner[ni - 1].1))
            }
        };
        (w, m) = match next {
            Some(x) => x,
            None => loop {
                let Some((x, lanes)) = stack.pop() else {
                    break 'walk;
                };
                let lanes = lanes & !done;
                if lanes != 0 {
                    break (x, lanes);
                }
            },
        };
    }
    c.box_tests += box_tests;
    c.box_passes += box_passes;
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::Ray;
    use proptest::prelude::*;

    /// A direction component: ordinary values, zeros of both signs, ties and extremes.
    fn component() -> impl Strategy<Value = f32> {
        prop_oneof![
            -4.0f32..4.0,
            Just(0.0),
            Just(-0.0),
            Just(1.0),
            Just(-1.0),
            Just(f32::MIN_POSITIVE),
            Just(1e-30),
        ]
    }

    proptest! {
        /// The packets' shear is [`RayPre::new`]'s record, bit for bit (so the scalar
        /// kernel sees the same constants on either path).
        #[test]
        fn shear_is_raypre_new(o in prop::array::uniform3(-100.0f32..100.0), d in prop::array::uniform3(component()), t0 in 0.0f32..1.0, t1 in 1.0f32..1e6) {
            let a = shear(o, d, t0, t1);
            let b = RayPre::new(&Ray { org: Vec3::from_array(o), dir: Vec3::from_array(d), t_min: t0, t_max: t1 });
            prop_assert_eq!((a.kx, a.ky, a.kz), (b.kx, b.ky, b.kz));
            prop_assert_eq!((a.sx.to_bits(), a.sy.to_bits()), (b.sx.to_bits(), b.sy.to_bits()));
            prop_assert_eq!(a.org.to_array().map(f32::to_bits), b.org.to_array().map(f32::to_bits));
            prop_assert_eq!(a.dir.to_array().map(f32::to_bits), b.dir.to_array().map(f32::to_bits));
            prop_assert_eq!((a.t_min, a.t_max), (b.t_min, b.t_max));
        }

        /// The vector builds' node and triangle tests give the portable lane loops' masks and
        /// entries, bit for bit, on random packets (some lanes parallel to an axis, some
        /// with a shortened reach) against random boxes and triangles.
        #[test]
        fn vector_tests_are_the_lane_loops(seed in 0u64..1_000_000, n in 1usize..=LANES, m in any::<u16>()) {
            let mut rng = geom::Pcg32::new(seed, 7);
            let mut f = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
            let mut rays = RayBatch::with_capacity(n);
            for l in 0..n {
                let o = Vec3::new(f(-2.0, 2.0), f(-2.0, 2.0), f(-2.0, 2.0));
                let mut d = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0));
                if l % 5 == 0 {
                    d.x = 0.0;
                }
                rays.push(Ray::new(o, d, 0.0, f(0.5, 10.0)), trace::RayKind::Shadow, l as u32, 0, Vec3::ONE, 0);
            }
            let p = Packet::new(&rays, 0, n);
            let mut node = BoxNode { min: [[0.0; 8]; 3], max: [[0.0; 8]; 3], child: [0; 8], count: 8, leaves: 0, ntri: [0; 8] };
            for i in 0..8 {
                for k in 0..3 {
                    let (a, b) = (f(-3.0, 3.0), f(-3.0, 3.0));
                    node.min[k][i] = a.min(b);
                    node.max[k][i] = a.max(b);
                }
            }
            let tri = [0; 3].map(|_| Vec3::new(f(-3.0, 3.0), f(-3.0, 3.0), f(-3.0, 3.0)));
            let mut want: Tested = ([0; 8], [[0.0; LANES]; 8]);
            children_scalar(&p, &node, 8, m, &mut want);
            let inside = p.inside(tri[0], tri[1], tri[2]);
            for isa in geom::isa::builds_for_tests("packet node and triangle tests") {
                let mut got: Tested = ([0; 8], [[0.0; LANES]; 8]);
                #[cfg(target_arch = "x86_64")]
                // SAFETY: `builds_for_tests` lists only builds this CPU runs.
                let ins = unsafe {
                    match isa {
                        Isa::Avx512 => {
                            x86::children512(&p, &node, 8, m, &mut got);
                            x86::inside512(&p, tri[0], tri[1], tri[2])
                        }
                        Isa::Avx2 => {
                            x86::children256(&p, &node, 8, m, &mut got);
                            p.inside(tri[0], tri[1], tri[2])
                        }
                        Isa::Scalar => {
                            children_scalar(&p, &node, 8, m, &mut got);
                            p.inside(tri[0], tri[1], tri[2])
                        }
                    }
                };
                #[cfg(not(target_arch = "x86_64"))]
                let ins = {
                    children_scalar(&p, &node, 8, m, &mut got);
                    p.inside(tri[0], tri[1], tri[2])
                };
                prop_assert_eq!(got.0, want.0, "{:?} masks", isa);
                prop_assert_eq!(got.1.map(|v| v.map(f32::to_bits)), want.1.map(|v| v.map(f32::to_bits)), "{:?} entries", isa);
                prop_assert_eq!(ins, inside, "{:?} inside", isa);
            }
        }
    }
}
