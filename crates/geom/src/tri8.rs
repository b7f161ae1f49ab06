//! Eight rays against one triangle at once: the watertight test of [`crate::tri`] (Woop,
//! Benthin & Wald 2013) over 8 lanes of AVX, rejecting misses; every lane it does not
//! reject is decided by [`crate::tri::intersect`], so the results are the scalar kernel's by
//! construction.
//!
//! The ray-space hierarchies' final tests (thesis §3.2.9) test every ray of a level-1 node
//! (b = 8 in the thesis's configurations) against one triangle, so the natural vector is
//! the node's rays, not a list of triangles. Each lane runs the scalar kernel's inside test
//! in the same order: the vertex minus the origin, the shear (a product, then a difference:
//! never fused), the three edge functions, the sign test and det = (u + v) + w. Every step
//! is one IEEE-754 operation, so a lane rejects exactly where the scalar test does. Lanes that
//! pass (or whose edge function is exactly zero, which the scalar kernel decides in f64) come
//! back as "redo", and the caller runs [`crate::tri::intersect`] for them: its distance is
//! computed in f64 ([`crate::tri::exact_hit`]), which is not worth vectorising for the few
//! lanes that get that far. Without AVX (checked at run time, once) every lane is a redo.
//!
//! Rays are kept as [`RayLanes`], structure of arrays in the order the caller tests them
//! (for the hierarchies, leaf order), with the per-ray axis permutation of the shear stored
//! as floats so that a lane's `a[kx]` is two blends of the triangle's broadcast vertex.

use crate::tri::RayPre;
use glam::Vec3;

/// Rays as structure of arrays for [`intersect8`], padded by 8 lanes so that any window of
/// 8 starting at a ray is in bounds.
#[derive(Clone, Debug, Default)]
pub struct RayLanes {
    /// Origin components permuted by the shear: org[kx], org[ky], org[kz].
    ok: [Vec<f32>; 3],
    /// The shear's axes kx, ky, kz as 0.0, 1.0 or 2.0.
    k: [Vec<f32>; 3],
    /// sx, sy.
    s: [Vec<f32>; 2],
    /// The direction (unpermuted), for the scalar kernel's exact distance.
    d: [Vec<f32>; 3],
    t_min: Vec<f32>,
    t_max: Vec<f32>,
    len: usize,
}

impl RayLanes {
    /// Lane p holds ray `order[p]` of `pre`.
    pub fn gather(pre: &[RayPre], order: &[u32]) -> RayLanes {
        RayLanes::build(order.len(), |p| pre[order[p] as usize])
    }

    /// Lane p holds the constants `f(p)` for p in `0..n` (filled in parallel: one pass,
    /// each task writing its own range of lanes in all thirteen arrays; no per-ray record is
    /// kept besides the lanes, [`RayLanes::pre`] rebuilds one).
    pub fn build(n: usize, f: impl Fn(usize) -> RayPre + Sync) -> RayLanes {
        use rayon::prelude::*;
        // Uninitialised room, every lane written below (the rays' by the tasks, the padding
        // here): zero-filling thirteen arrays first would be one more pass over all of them,
        // on every trace.
        let zeros = || {
            let mut v = Vec::<f32>::with_capacity(n + 8);
            // SAFETY: the 8 padding lanes sit within the capacity; lanes 0..n follow.
            unsafe {
                std::ptr::write_bytes(v.as_mut_ptr().add(n), 0, 8);
            }
            v
        };
        let mut l = RayLanes {
            ok: std::array::from_fn(|_| zeros()),
            k: std::array::from_fn(|_| zeros()),
            s: std::array::from_fn(|_| zeros()),
            d: std::array::from_fn(|_| zeros()),
            t_min: zeros(),
            t_max: zeros(),
            len: n,
        };
        let [o0, o1, o2] = &mut l.ok;
        let [k0, k1, k2] = &mut l.k;
        let [s0, s1] = &mut l.s;
        let [d0, d1, d2] = &mut l.d;
        let out = Lanes13(
            [
                o0,
                o1,
                o2,
                k0,
                k1,
                k2,
                s0,
                s1,
                d0,
                d1,
                d2,
                &mut l.t_min,
                &mut l.t_max,
            ]
            .map(|v| v.as_mut_ptr()),
        );
        const CHUNK: usize = 4096;
        (0..n.div_ceil(CHUNK)).into_par_iter().for_each(|c| {
            let out = &out;
            for p in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let q = f(p);
                let org = q.org.to_array();
                let v = [
                    org[q.kx as usize],
                    org[q.ky as usize],
                    org[q.kz as usize],
                    q.kx as f32,
                    q.ky as f32,
                    q.kz as f32,
                    q.sx,
                    q.sy,
                    q.dir.x,
                    q.dir.y,
                    q.dir.z,
                    q.t_min,
                    q.t_max,
                ];
                for (i, x) in v.into_iter().enumerate() {
                    // SAFETY: lane p < n is written by this task only, in arrays of n + 8
                    // floats that outlive the loop.
                    unsafe { *out.0[i].add(p) = x };
                }
            }
        });
        for v in
            l.ok.iter_mut()
                .chain(&mut l.k)
                .chain(&mut l.s)
                .chain(&mut l.d)
        {
            // SAFETY: every lane 0..n + 8 is written (above, and the padding in `zeros`).
            unsafe { v.set_len(n + 8) };
        }
        // SAFETY: as above.
        unsafe {
            l.t_min.set_len(n + 8);
            l.t_max.set_len(n + 8);
        }
        l
    }

    /// Lane p's constants as one record, bit for bit those it was built from (the origin
    /// un-permuted by the shear's axes).
    #[inline]
    pub fn pre(&self, p: usize) -> RayPre {
        let k = [self.k[0][p], self.k[1][p], self.k[2][p]];
        let ok = [self.ok[0][p], self.ok[1][p], self.ok[2][p]];
        // The origin's component i is the permuted one whose axis is i (selects, not stores
        // through a computed index).
        let axis = |i: f32| {
            if k[0] == i {
                ok[0]
            } else if k[1] == i {
                ok[1]
            } else {
                ok[2]
            }
        };
        let org = [axis(0.0), axis(1.0), axis(2.0)];
        let (kx, ky, kz) = (k[0] as u8, k[1] as u8, k[2] as u8);
        RayPre {
            org: Vec3::from_array(org),
            dir: Vec3::new(self.d[0][p], self.d[1][p], self.d[2][p]),
            kx,
            ky,
            kz,
            sx: self.s[0][p],
            sy: self.s[1][p],
            t_min: self.t_min[p],
            t_max: self.t_max[p],
        }
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when there are no rays.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// The thirteen lane arrays' pointers, shared by the tasks of [`RayLanes::build`] (each
/// writes a disjoint range of lanes).
struct Lanes13([*mut f32; 13]);
// SAFETY: the tasks write disjoint lanes; the arrays outlive them.
unsafe impl Sync for Lanes13 {}

/// Rays `first..first + n` of `lanes` (n ≤ 8) against triangle (a, b, c): bit l is set
/// when lane l must be tested by the scalar kernel ([`crate::tri::intersect`]); every other
/// lane misses.
#[inline]
pub fn intersect8(lanes: &RayLanes, first: usize, n: usize, a: Vec3, b: Vec3, c: Vec3) -> u8 {
    assert!(n <= 8 && first + n <= lanes.len, "a window of lanes");
    let all = ((1u32 << n) - 1) as u8;
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: AVX is present; the window first..first + 8 is in bounds (padding).
            return unsafe { avx::intersect8(lanes, first, all, [a, b, c]) };
        }
    }
    let _ = (a, b, c, first);
    all
}

/// The 8-lane watertight core, for other kernels that lay out their lanes differently.
#[cfg(target_arch = "x86_64")]
pub use avx::{watertight8, Watertight8};

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::RayLanes;
    use glam::Vec3;
    use std::arch::x86_64::*;

    /// Lane-wise select of the triangle vertex's component along each lane's axis k.
    #[inline]
    #[target_feature(enable = "avx")]
    fn pick(v: [__m256; 3], k: __m256) -> __m256 {
        let is0 = _mm256_cmp_ps::<_CMP_EQ_OQ>(k, _mm256_setzero_ps());
        let is1 = _mm256_cmp_ps::<_CMP_EQ_OQ>(k, _mm256_set1_ps(1.0));
        _mm256_blendv_ps(_mm256_blendv_ps(v[2], v[1], is1), v[0], is0)
    }

    /// The watertight test's lanes, shared by every 8-lane kernel (this file's rays against
    /// one triangle, the grid's rays against their own triangles).
    #[derive(Clone, Copy)]
    pub struct Watertight8 {
        /// Lanes the scalar kernel decides: an edge function exactly 0 (its f64 path), or
        /// inside the triangle with det ≠ 0 (its exact distance and interval test). Every
        /// other lane misses.
        pub scalar: __m256,
    }

    /// [`crate::tri::intersect`]'s inside test per lane, from each vertex minus the ray's
    /// origin on the shear's axes (kx, ky, kz) and the shear constants (sx, sy): the shear (a
    /// product, then a difference: never fused), the three edge functions, the sign test,
    /// det = (u + v) + w. Each step is one IEEE-754 operation, so a lane rejects exactly
    /// where the scalar kernel does.
    ///
    /// # Safety
    ///
    /// The CPU must have AVX (callers check at run time, or call from a function that
    /// enables AVX or AVX2).
    #[inline]
    #[target_feature(enable = "avx")]
    pub fn watertight8(
        a: [__m256; 3],
        b: [__m256; 3],
        c: [__m256; 3],
        s: [__m256; 2],
    ) -> Watertight8 {
        let [sx, sy] = s;
        // Shear: x − s·z, a product then a difference.
        let sh = |p: [__m256; 3], s: __m256, j: usize| _mm256_sub_ps(p[j], _mm256_mul_ps(s, p[2]));
        let (ax, ay) = (sh(a, sx, 0), sh(a, sy, 1));
        let (bx, by) = (sh(b, sx, 0), sh(b, sy, 1));
        let (cx, cy) = (sh(c, sx, 0), sh(c, sy, 1));
        let cross = |p: __m256, q: __m256, r: __m256, s: __m256| {
            _mm256_sub_ps(_mm256_mul_ps(p, q), _mm256_mul_ps(r, s))
        };
        let u = cross(cx, by, cy, bx);
        let v = cross(ax, cy, ay, cx);
        let w = cross(bx, ay, by, ax);
        let zero = _mm256_setzero_ps();
        let eq0 = |x| _mm256_cmp_ps::<_CMP_EQ_OQ>(x, zero);
        let lt0 = |x| _mm256_cmp_ps::<_CMP_LT_OQ>(x, zero);
        let gt0 = |x| _mm256_cmp_ps::<_CMP_GT_OQ>(x, zero);
        let edge = _mm256_or_ps(_mm256_or_ps(eq0(u), eq0(v)), eq0(w));
        let neg = _mm256_or_ps(_mm256_or_ps(lt0(u), lt0(v)), lt0(w));
        let pos = _mm256_or_ps(_mm256_or_ps(gt0(u), gt0(v)), gt0(w));
        let det = _mm256_add_ps(_mm256_add_ps(u, v), w);
        let miss = _mm256_or_ps(_mm256_and_ps(neg, pos), eq0(det));
        Watertight8 {
            scalar: _mm256_or_ps(
                edge,
                _mm256_andnot_ps(miss, _mm256_castsi256_ps(_mm256_set1_epi32(-1))),
            ),
        }
    }

    #[target_feature(enable = "avx")]
    pub(super) unsafe fn intersect8(l: &RayLanes, first: usize, all: u8, tri: [Vec3; 3]) -> u8 {
        // SAFETY (every load): the arrays hold len + 8 floats and first < len.
        let ld = |v: &Vec<f32>| unsafe { _mm256_loadu_ps(v.as_ptr().add(first)) };
        let k = [ld(&l.k[0]), ld(&l.k[1]), ld(&l.k[2])];
        let ok = [ld(&l.ok[0]), ld(&l.ok[1]), ld(&l.ok[2])];
        // Each vertex minus the origin, in the shear's axes: v[k] − org[k] (tri.rs: `a - r.org`).
        let rel = |p: Vec3| {
            let v = [
                _mm256_set1_ps(p.x),
                _mm256_set1_ps(p.y),
                _mm256_set1_ps(p.z),
            ];
            [
                _mm256_sub_ps(pick(v, k[0]), ok[0]),
                _mm256_sub_ps(pick(v, k[1]), ok[1]),
                _mm256_sub_ps(pick(v, k[2]), ok[2]),
            ]
        };
        let s = [ld(&l.s[0]), ld(&l.s[1])];
        let [a, b, c] = tri.map(rel);
        _mm256_movemask_ps(watertight8(a, b, c, s).scalar) as u8 & all
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::tri::intersect;
    use crate::{Pcg32, Ray};
    use proptest::prelude::*;

    /// Every lane against the scalar kernel: a lane the vector test rejects is a scalar
    /// miss. Returns the scalar hits and the lanes left to the scalar kernel.
    fn check(pre: &[RayPre], order: &[u32], tri: [Vec3; 3]) -> Result<(u32, u32), TestCaseError> {
        let lanes = RayLanes::gather(pre, order);
        let (mut hits, mut redos) = (0, 0);
        for first in (0..order.len()).step_by(8) {
            let n = (order.len() - first).min(8);
            let redo = intersect8(&lanes, first, n, tri[0], tri[1], tri[2]);
            prop_assert_eq!(redo as u32 >> n, 0);
            for l in 0..n {
                let s = intersect(&pre[order[first + l] as usize], tri[0], tri[1], tri[2]);
                hits += s.is_some() as u32;
                if redo >> l & 1 != 0 {
                    redos += 1;
                } else {
                    prop_assert!(s.is_none(), "lane {} rejected a scalar hit", l);
                }
            }
        }
        Ok((hits, redos))
    }

    /// Rays from a small region towards a triangle, with every kind of awkward component:
    /// axis-parallel, ±0, on the triangle's vertices and edges, bounded and unbounded.
    pub(crate) fn case(seed: u64, n: usize, degenerate: u32) -> (Vec<RayPre>, Vec<u32>, [Vec3; 3]) {
        let mut rng = Pcg32::new(seed, 77);
        let v = |rng: &mut Pcg32| {
            Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
        };
        let mut tri = [v(&mut rng), v(&mut rng), v(&mut rng)];
        match degenerate {
            1 => tri[2] = tri[1],                   // a segment
            2 => tri[2] = tri[0] * 2.0 - tri[1],    // collinear
            3 => tri = [Vec3::X, Vec3::Y, Vec3::Z], // on the unit planes
            _ => {}
        }
        let pre: Vec<RayPre> = (0..n)
            .map(|i| {
                let org = v(&mut rng) * 3.0;
                let target = match i % 6 {
                    0 => tri[i % 3],                                       // a vertex
                    1 => (tri[0] + tri[1]) * 0.5,                          // an edge
                    2 => tri[0] + (tri[1] - tri[0]) * rng.range(0.0, 1.0), // on an edge
                    _ => {
                        let (x, y) = (rng.range(0.0, 1.0), rng.range(0.0, 1.0));
                        tri[0] + (tri[1] - tri[0]) * x + (tri[2] - tri[0]) * y
                    }
                };
                let mut dir = target - org;
                if i % 7 == 0 {
                    dir = [Vec3::X, -Vec3::Y, Vec3::Z][i % 3];
                }
                if i % 11 == 0 {
                    dir.x = -0.0;
                }
                let t_max = if i % 5 == 0 {
                    rng.range(0.0, 2.0)
                } else {
                    f32::INFINITY
                };
                RayPre::new(&Ray::new(org, dir, 0.0, t_max))
            })
            .collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        for i in (1..n).rev() {
            order.swap(i, rng.below(i as u32 + 1) as usize);
        }
        (pre, order, tri)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        #[test]
        fn lanes_equal_the_scalar_kernel(seed in 0u64..1_000_000, n in 1usize..40, degenerate in 0u32..4) {
            let (pre, order, tri) = case(seed, n, degenerate);
            check(&pre, &order, tri)?;
        }

        /// A lane's record is the one it was built from, bit for bit (the traversal's scalar
        /// tests read rays back from the lanes).
        #[test]
        fn lanes_give_back_their_records(seed in 0u64..1_000_000, n in 1usize..40, degenerate in 0u32..4) {
            let (pre, order, _) = case(seed, n, degenerate);
            let lanes = RayLanes::gather(&pre, &order);
            for (p, &r) in order.iter().enumerate() {
                let (a, b) = (lanes.pre(p), pre[r as usize]);
                let bits = |q: &RayPre| (q.org.to_array().map(f32::to_bits), q.dir.to_array().map(f32::to_bits), [q.kx, q.ky, q.kz], [q.sx, q.sy, q.t_min, q.t_max].map(f32::to_bits));
                prop_assert_eq!(bits(&a), bits(&b), "lane {}", p);
            }
        }
    }

    #[test]
    fn misses_are_decided_by_the_vector_kernel() {
        // Without AVX the kernel hands every lane back; with it, only the lanes inside the
        // triangle (the hits, and those outside the ray's interval) and those with an edge
        // function exactly zero. The case's rays, aimed at its triangle, against a small
        // triangle far away: the vector test rejects almost all of them.
        let (pre, order, tri) = case(5, 4000, 0);
        let lanes = RayLanes::gather(&pre, &order);
        let far = [
            Vec3::splat(100.0),
            Vec3::new(101.0, 100.0, 100.0),
            Vec3::new(100.0, 101.0, 100.0),
        ];
        let (hits, redos) = check(&pre, &order, tri).unwrap();
        assert!(hits > 1000, "{hits} hits");
        let kept: u32 = (0..order.len())
            .step_by(8)
            .map(|f| {
                intersect8(&lanes, f, (order.len() - f).min(8), far[0], far[1], far[2]).count_ones()
            })
            .sum();
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            assert!(redos < 4000, "{redos} lanes left to the scalar kernel");
            // (Axis-parallel rays, a seventh of the case's, may have an edge function exactly
            // zero against this axis-aligned triangle: those go to the scalar kernel.)
            assert!(
                kept < 4000 / 5,
                "{kept} lanes kept for a triangle they miss"
            );
            return;
        }
        assert_eq!((redos, kept), (4000, 4000));
    }
}
