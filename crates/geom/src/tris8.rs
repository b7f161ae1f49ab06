//! One ray against eight triangles at once: the watertight test of [`crate::tri`] (Woop,
//! Benthin & Wald 2013) over 8 lanes of AVX, one triangle per lane, rejecting misses; every
//! lane it does not reject is decided by [`crate::tri::intersect_inlined`], so the results
//! are the scalar kernel's by construction.
//!
//! [`crate::tri8`] is the ray hierarchies' vector (a node's rays against one triangle); this
//! is a single ray's (a wide BVH node's leaf triangles against one ray, as Embree's BVH8
//! tests its leaves' triangles several at a time). The triangles sit as structure of arrays
//! ([`Tris8`]: per vertex, per axis, 8 lanes), so the ray's shear axes pick whole rows: a
//! lane's `a[kx] − org[kx]` is one load and one subtraction, then
//! [`crate::tri8::watertight8`] runs the scalar kernel's inside test in the same IEEE
//! operations (the shear as a product then a difference, never fused; the three edge
//! functions; the sign test; det = (u + v) + w). A lane comes back as "redo" when it may hit
//! (inside with det ≠ 0) or when an edge function is exactly zero (which the scalar kernel
//! decides in f64); the caller runs the scalar kernel on those, whose exact distance
//! ([`crate::tri::exact_hit`]) is computed in f64 for the few lanes that get that far.
//! Without AVX every lane is a redo ([`redo8_scalar`]).
//!
//! Why: a ray's triangle tests one by one are a chain of branches that random rays guess
//! wrong (is each edge function negative, positive, zero?); eight at once are a few vector
//! instructions and one mask. On a dense tangle (`hairball:2k`, random rays, everything in
//! cache) the single-ray walk spent most of its time there.

use crate::tri::RayPre;
use glam::Vec3;

/// Eight triangles as structure of arrays: `v[vertex][axis][lane]`. Unused lanes hold
/// anything (callers mask them off).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct Tris8 {
    /// Vertex a, b, c; axis x, y, z; lane.
    pub v: [[[f32; 8]; 3]; 3],
}

impl Tris8 {
    /// Lane `l`'s triangle, bit for bit as stored.
    #[inline]
    pub fn tri(&self, l: usize) -> [Vec3; 3] {
        let v = &self.v;
        [
            Vec3::new(v[0][0][l], v[0][1][l], v[0][2][l]),
            Vec3::new(v[1][0][l], v[1][1][l], v[1][2][l]),
            Vec3::new(v[2][0][l], v[2][1][l], v[2][2][l]),
        ]
    }

    /// Store `t` in lane `l`.
    #[inline]
    pub fn set(&mut self, l: usize, t: [Vec3; 3]) {
        for (k, p) in t.iter().enumerate() {
            self.v[k][0][l] = p.x;
            self.v[k][1][l] = p.y;
            self.v[k][2][l] = p.z;
        }
    }
}

/// The lanes of `lanes` (bit l for lane l) that the scalar kernel must decide for the ray
/// `pre` against `tris`; every lane left out misses. The portable build: every lane.
#[inline]
pub fn redo8_scalar(_pre: &RayPre, _tris: &Tris8, lanes: u8) -> u8 {
    lanes
}

#[cfg(target_arch = "x86_64")]
pub use avx::redo8;

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::Tris8;
    use crate::tri::RayPre;
    use crate::tri8::watertight8;
    use std::arch::x86_64::*;

    /// [`super::redo8_scalar`] in AVX lanes: the lanes of `lanes` that are not a miss of
    /// the scalar kernel's inside test (see the module doc).
    ///
    /// # Safety
    /// The CPU must have AVX (callers check at run time, or call from a function that
    /// enables AVX, AVX2 or AVX-512).
    #[inline]
    #[target_feature(enable = "avx")]
    pub unsafe fn redo8(pre: &RayPre, tris: &Tris8, lanes: u8) -> u8 {
        // Each vertex minus the origin on the shear's axes (tri.rs: `a - r.org`, then
        // `a[kx]`): a row per axis. (Written out: closures and array maps here are not
        // inlined into the callers' target features.)
        let (kx, ky, kz) = (pre.kx as usize, pre.ky as usize, pre.kz as usize);
        let (ox, oy, oz) = (
            _mm256_set1_ps(pre.org[kx]),
            _mm256_set1_ps(pre.org[ky]),
            _mm256_set1_ps(pre.org[kz]),
        );
        let v = &tris.v;
        // SAFETY: the rows are 8 floats, 32-byte aligned (`Tris8`'s alignment).
        let (a, b, c) = unsafe {
            (
                [
                    _mm256_sub_ps(_mm256_load_ps(v[0][kx].as_ptr()), ox),
                    _mm256_sub_ps(_mm256_load_ps(v[0][ky].as_ptr()), oy),
                    _mm256_sub_ps(_mm256_load_ps(v[0][kz].as_ptr()), oz),
                ],
                [
                    _mm256_sub_ps(_mm256_load_ps(v[1][kx].as_ptr()), ox),
                    _mm256_sub_ps(_mm256_load_ps(v[1][ky].as_ptr()), oy),
                    _mm256_sub_ps(_mm256_load_ps(v[1][kz].as_ptr()), oz),
                ],
                [
                    _mm256_sub_ps(_mm256_load_ps(v[2][kx].as_ptr()), ox),
                    _mm256_sub_ps(_mm256_load_ps(v[2][ky].as_ptr()), oy),
                    _mm256_sub_ps(_mm256_load_ps(v[2][kz].as_ptr()), oz),
                ],
            )
        };
        let s = [_mm256_set1_ps(pre.sx), _mm256_set1_ps(pre.sy)];
        let w = watertight8(a, b, c, s);
        _mm256_movemask_ps(w.scalar) as u8 & lanes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tri::intersect_inlined;
    use crate::{Pcg32, Ray};
    use proptest::prelude::*;

    /// Eight triangles, each with rays aimed at it: [`crate::tri8`]'s cases (triangles
    /// in the unit cube, some degenerate or on the unit planes; rays aimed at their
    /// vertices, edges and insides, axis-parallel, with ±0 components, bounded and not),
    /// one per lane.
    fn case(seed: u64) -> (Tris8, Vec<RayPre>) {
        let mut t = Tris8::default();
        let mut rays = Vec::new();
        for l in 0..8u64 {
            let (pre, _, tri) = crate::tri8::tests::case(seed * 8 + l, 8, (l % 4) as u32);
            t.set(l as usize, tri);
            rays.extend(pre);
        }
        (t, rays)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// A lane the vector test leaves out is a miss of the scalar kernel, for every
        /// subset of lanes asked for; lanes not asked for never come back.
        #[test]
        fn left_out_lanes_are_scalar_misses(seed in 0u64..1_000_000, lanes in 0u32..256) {
            let (t, rays) = case(seed);
            let lanes = lanes as u8;
            for (r, pre) in rays.iter().enumerate() {
                prop_assert_eq!(redo8_scalar(pre, &t, lanes), lanes);
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx") {
                    // SAFETY: AVX is present.
                    let redo = unsafe { redo8(pre, &t, lanes) };
                    prop_assert_eq!(redo & !lanes, 0);
                    for l in 0..8 {
                        let [a, b, c] = t.tri(l);
                        if lanes >> l & 1 != 0 && redo >> l & 1 == 0 {
                            prop_assert!(intersect_inlined(pre, a, b, c).is_none(), "ray {} lane {}", r, l);
                        }
                    }
                }
            }
        }
    }

    /// The vector test does its job: of rays aimed at one lane's triangle, the other lanes
    /// (small triangles far away) are all left out. Without AVX every lane goes to the
    /// scalar kernel.
    #[test]
    fn far_triangles_are_left_out() {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            let mut t = Tris8::default();
            t.set(0, [Vec3::ZERO, Vec3::X, Vec3::Y]);
            for l in 1..8 {
                let o = Vec3::splat(10.0 * l as f32);
                t.set(
                    l,
                    [
                        o,
                        o + Vec3::new(0.5, 0.0, 0.0),
                        o + Vec3::new(0.0, 0.5, 0.0),
                    ],
                );
            }
            let mut rng = Pcg32::new(3, 4);
            let mut kept = [0u32; 8];
            for _ in 0..1000 {
                let target = Vec3::new(rng.range(0.05, 0.45), rng.range(0.05, 0.45), 0.0);
                let org = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 2.0);
                let pre = RayPre::new(&Ray::new(org, target - org, 0.0, f32::INFINITY));
                // SAFETY: AVX is present.
                let redo = unsafe { redo8(&pre, &t, 0xff) };
                for (l, k) in kept.iter_mut().enumerate() {
                    *k += (redo >> l & 1) as u32;
                }
            }
            assert_eq!(kept[0], 1000, "every ray hits lane 0's triangle");
            assert!(kept[1..].iter().all(|&k| k == 0), "{kept:?}");
            return;
        }
        let t = Tris8::default();
        let pre = RayPre::new(&Ray::new(Vec3::ZERO, Vec3::Z, 0.0, 1.0));
        assert_eq!(redo8_scalar(&pre, &t, 0xa5), 0xa5);
    }
}
