//! Eight cones grown ray by ray at once (thesis §3.2.7, eqs. 3.8–3.11: the level-1 cones of a
//! ray-space hierarchy), and the portable elementary functions of [`crate::pmath`] on 8 lanes.
//!
//! Building a hierarchy's level 1 adds every ray's direction to its node's cone
//! ([`Cone::add_dir`]): a few arc tangents, a sine and a cosine per ray, the largest share of
//! the build. Here 8 nodes grow side by side in AVX lanes, one ray of each per step. Every lane
//! performs the scalar code's IEEE operations in its order, without fused multiply-adds, and
//! every branch of the scalar code becomes a lane select, so each lane's cone is
//! [`Cone::add_dir`]'s bit for bit. The one rare branch (a cone growing past a hemisphere,
//! which rotates its axis instead) is left to the scalar code for the lanes that take it.
//! CPUs without AVX take the scalar code for every lane.

use crate::cone::Cone;
use glam::Vec3;

/// Whether this CPU runs the lanes (else every function here falls back to the scalar code).
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `cones[l] = cones[l].add_dir(dirs[l])` for every lane l whose bit is set in `mask`, 8 at a
/// time; bit for bit [`Cone::add_dir`].
pub fn add_dir8(cones: &mut [Cone; 8], dirs: &[Vec3; 8], mask: u8) {
    #[cfg(target_arch = "x86_64")]
    {
        if available() {
            // SAFETY: AVX is present.
            unsafe { avx::add_dir8(cones, dirs, mask) };
            return;
        }
    }
    for l in 0..8 {
        if mask >> l & 1 != 0 {
            cones[l] = cones[l].add_dir(dirs[l]);
        }
    }
}

/// [`crate::pmath::atan2`] lane by lane, bit for bit.
pub fn atan2_8(y: &[f32; 8], x: &[f32; 8]) -> [f32; 8] {
    #[cfg(target_arch = "x86_64")]
    {
        if available() {
            // SAFETY: AVX is present.
            return unsafe { avx::store(avx::atan2(avx::load(y), avx::load(x))) };
        }
    }
    std::array::from_fn(|l| crate::pmath::atan2(y[l], x[l]))
}

/// [`crate::pmath::acos`] lane by lane, bit for bit.
pub fn acos8(x: &[f32; 8]) -> [f32; 8] {
    #[cfg(target_arch = "x86_64")]
    {
        if available() {
            // SAFETY: AVX is present.
            return unsafe { avx::store(avx::acos(avx::load(x))) };
        }
    }
    std::array::from_fn(|l| crate::pmath::acos(x[l]))
}

/// [`crate::pmath::sin_cos`] lane by lane, bit for bit (for |x| < 2³¹, beyond every caller's
/// angles).
pub fn sin_cos8(x: &[f32; 8]) -> ([f32; 8], [f32; 8]) {
    #[cfg(target_arch = "x86_64")]
    {
        if available() {
            // SAFETY: AVX is present.
            return unsafe {
                let (s, c) = avx::sin_cos(avx::load(x));
                (avx::store(s), avx::store(c))
            };
        }
    }
    let sc: [(f32, f32); 8] = std::array::from_fn(|l| crate::pmath::sin_cos(x[l]));
    (sc.map(|p| p.0), sc.map(|p| p.1))
}

#[cfg(target_arch = "x86_64")]
mod avx {
    use crate::cone::Cone;
    use crate::pmath::{AT, CS, DP1, DP2, DP3, SN, T3P8, TP8, TWO_OVER_PI};
    use glam::Vec3;
    use std::arch::x86_64::*;
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

    type V = __m256;

    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn load(a: &[f32; 8]) -> V {
        _mm256_loadu_ps(a.as_ptr())
    }

    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn store(v: V) -> [f32; 8] {
        let mut a = [0.0f32; 8];
        _mm256_storeu_ps(a.as_mut_ptr(), v);
        a
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn s(x: f32) -> V {
        _mm256_set1_ps(x)
    }

    /// b where m is set, else a.
    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn sel(m: V, b: V, a: V) -> V {
        _mm256_blendv_ps(a, b, m)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn neg(x: V) -> V {
        _mm256_xor_ps(x, s(-0.0))
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn add(a: V, b: V) -> V {
        _mm256_add_ps(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn sub(a: V, b: V) -> V {
        _mm256_sub_ps(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn mul(a: V, b: V) -> V {
        _mm256_mul_ps(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn div(a: V, b: V) -> V {
        _mm256_div_ps(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn gt(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_GT_OQ>(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn lt(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_LT_OQ>(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn ge(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_GE_OQ>(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn le(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_LE_OQ>(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn eq(a: V, b: V) -> V {
        _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b)
    }

    /// pmath::atan.
    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn atan(x: V) -> V {
        let negative = lt(x, _mm256_setzero_ps());
        let ax = _mm256_andnot_ps(s(-0.0), x);
        let big = gt(ax, s(T3P8));
        let mid = gt(ax, s(TP8));
        let xb = neg(div(s(1.0), ax));
        let xm = div(sub(ax, s(1.0)), add(ax, s(1.0)));
        let xx = sel(big, xb, sel(mid, xm, ax));
        let y0 = sel(
            big,
            s(FRAC_PI_2),
            sel(mid, s(FRAC_PI_4), _mm256_setzero_ps()),
        );
        let z = mul(xx, xx);
        let p = mul(
            sub(
                mul(add(mul(sub(mul(s(AT[0]), z), s(AT[1])), z), s(AT[2])), z),
                s(AT[3]),
            ),
            z,
        );
        let y = add(y0, add(mul(p, xx), xx));
        sel(negative, neg(y), y)
    }

    /// pmath::atan2.
    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn atan2(y: V, x: V) -> V {
        let zero = _mm256_setzero_ps();
        let on_y = sel(
            gt(y, zero),
            s(FRAC_PI_2),
            sel(lt(y, zero), s(-FRAC_PI_2), zero),
        );
        let on_x = sel(gt(x, zero), zero, s(PI));
        let a = atan(div(y, x));
        let general = sel(
            gt(x, zero),
            a,
            sel(gt(y, zero), add(a, s(PI)), sub(a, s(PI))),
        );
        sel(eq(x, zero), on_y, sel(eq(y, zero), on_x, general))
    }

    /// pmath::acos.
    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn acos(x: V) -> V {
        // f32::clamp: a NaN stays NaN.
        let x = sel(lt(x, s(-1.0)), s(-1.0), x);
        let x = sel(gt(x, s(1.0)), s(1.0), x);
        atan2(_mm256_sqrt_ps(mul(sub(s(1.0), x), add(s(1.0), x))), x)
    }

    /// pmath::sin_cos.
    #[inline]
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn sin_cos(x: V) -> (V, V) {
        let qf = _mm256_floor_ps(add(mul(x, s(TWO_OVER_PI)), s(0.5)));
        let r = sub(
            sub(sub(x, mul(qf, s(DP1))), mul(qf, s(DP2))),
            mul(qf, s(DP3)),
        );
        let z = mul(r, r);
        let sn = add(
            mul(
                mul(sub(mul(add(mul(s(-SN[0]), z), s(SN[1])), z), s(SN[2])), z),
                r,
            ),
            r,
        );
        let cs = add(
            sub(
                mul(
                    mul(add(mul(sub(mul(s(CS[0]), z), s(CS[1])), z), s(CS[2])), z),
                    z,
                ),
                mul(s(0.5), z),
            ),
            s(1.0),
        );
        // (qf as i32) & 3 as a float, exactly, for |qf| < 2^31: qf − 4⌊qf/4⌋ (a NaN compares
        // unequal to every quadrant and keeps quadrant 0, as its integer 0 does).
        let q = sub(qf, mul(s(4.0), _mm256_floor_ps(mul(qf, s(0.25)))));
        let (q1, q2, q3) = (eq(q, s(1.0)), eq(q, s(2.0)), eq(q, s(3.0)));
        let so = sel(q1, cs, sel(q2, neg(sn), sel(q3, neg(cs), sn)));
        let co = sel(q1, neg(sn), sel(q2, neg(cs), sel(q3, sn, cs)));
        (so, co)
    }

    /// Three lanes of vectors.
    #[derive(Clone, Copy)]
    struct V3 {
        x: V,
        y: V,
        z: V,
    }

    impl V3 {
        #[inline]
        #[target_feature(enable = "avx")]
        unsafe fn dot(self, o: V3) -> V {
            add(add(mul(self.x, o.x), mul(self.y, o.y)), mul(self.z, o.z))
        }

        #[inline]
        #[target_feature(enable = "avx")]
        unsafe fn cross(self, o: V3) -> V3 {
            V3 {
                x: sub(mul(self.y, o.z), mul(o.y, self.z)),
                y: sub(mul(self.z, o.x), mul(o.z, self.x)),
                z: sub(mul(self.x, o.y), mul(o.x, self.y)),
            }
        }

        #[inline]
        #[target_feature(enable = "avx")]
        unsafe fn length(self) -> V {
            _mm256_sqrt_ps(self.dot(self))
        }

        #[inline]
        #[target_feature(enable = "avx")]
        unsafe fn scale(self, k: V) -> V3 {
            V3 {
                x: mul(self.x, k),
                y: mul(self.y, k),
                z: mul(self.z, k),
            }
        }

        #[inline]
        #[target_feature(enable = "avx")]
        unsafe fn plus(self, o: V3) -> V3 {
            V3 {
                x: add(self.x, o.x),
                y: add(self.y, o.y),
                z: add(self.z, o.z),
            }
        }

        #[inline]
        #[target_feature(enable = "avx")]
        unsafe fn minus(self, o: V3) -> V3 {
            V3 {
                x: sub(self.x, o.x),
                y: sub(self.y, o.y),
                z: sub(self.z, o.z),
            }
        }

        /// glam's normalize_or_zero: self · (1/|self|) when that reciprocal is finite and
        /// positive, else zero.
        #[inline]
        #[target_feature(enable = "avx")]
        unsafe fn normalize_or_zero(self) -> V3 {
            let rcp = div(s(1.0), self.length());
            let ok = _mm256_and_ps(lt(rcp, s(f32::INFINITY)), gt(rcp, _mm256_setzero_ps()));
            let n = self.scale(rcp);
            let z = _mm256_setzero_ps();
            V3 {
                x: sel(ok, n.x, z),
                y: sel(ok, n.y, z),
                z: sel(ok, n.z, z),
            }
        }

        /// All three components zero (glam's `== Vec3::ZERO`).
        #[inline]
        #[target_feature(enable = "avx")]
        unsafe fn is_zero(self) -> V {
            let z = _mm256_setzero_ps();
            _mm256_and_ps(_mm256_and_ps(eq(self.x, z), eq(self.y, z)), eq(self.z, z))
        }
    }

    /// cone::angle_between.
    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn angle_between(a: V3, b: V3) -> V {
        atan2(a.cross(b).length(), a.dot(b))
    }

    /// cone::pad_angle.
    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn pad_angle(a: V) -> V {
        let p = add(mul(a, s(1.0 + 4.0 * f32::EPSILON)), s(1e-6));
        // f32::min(p, π): π unless p is smaller (a NaN p gives π).
        sel(lt(p, s(PI)), p, s(PI))
    }

    #[target_feature(enable = "avx")]
    pub(super) unsafe fn add_dir8(cones: &mut [Cone; 8], dirs: &[Vec3; 8], mask: u8) {
        let lanes = |f: &dyn Fn(usize) -> f32| -> V {
            let a: [f32; 8] = std::array::from_fn(f);
            load(&a)
        };
        let x = V3 {
            x: lanes(&|l| cones[l].axis.x),
            y: lanes(&|l| cones[l].axis.y),
            z: lanes(&|l| cones[l].axis.z),
        };
        let angle = lanes(&|l| cones[l].angle);
        let r = V3 {
            x: lanes(&|l| dirs[l].x),
            y: lanes(&|l| dirs[l].y),
            z: lanes(&|l| dirs[l].z),
        };
        let wide_in = ge(angle, s(PI));
        let theta = angle_between(x, r);
        let inside = le(theta, angle);
        let hemi = ge(add(theta, angle), s(PI - 1e-6));
        let xr = x.dot(r);
        let q = x.scale(xr).minus(r).normalize_or_zero();
        let (sn, cs) = sin_cos(angle);
        let e = x.scale(cs).plus(q.scale(sn));
        let axis = e.plus(r).normalize_or_zero();
        // enclosing(axis, x, α, r, 0): f32::max of the two bounds (the other one where one
        // is NaN).
        let a1 = add(angle_between(axis, x), angle);
        let a2 = add(angle_between(axis, r), _mm256_setzero_ps());
        let a1_nan = _mm256_cmp_ps::<_CMP_UNORD_Q>(a1, a1);
        let grown = sel(_mm256_or_ps(gt(a2, a1), a1_nan), a2, a1);
        // Every way the scalar code answers WIDE on this path.
        let wide = _mm256_or_ps(
            _mm256_or_ps(q.is_zero(), axis.is_zero()),
            ge(grown, s(PI - 1e-6)),
        );
        let out_angle = store(pad_angle(grown));
        let (ox, oy, oz) = (store(axis.x), store(axis.y), store(axis.z));
        let wide_in = _mm256_movemask_ps(wide_in) as u8;
        let inside = _mm256_movemask_ps(inside) as u8;
        let hemi = _mm256_movemask_ps(hemi) as u8;
        let wide = _mm256_movemask_ps(wide) as u8;
        for l in 0..8 {
            let bit = 1u8 << l;
            if mask & bit == 0 {
                continue;
            }
            cones[l] = if wide_in & bit != 0 {
                Cone::WIDE
            } else if inside & bit != 0 {
                cones[l]
            } else if hemi & bit != 0 {
                // Past a hemisphere the axis rotates instead: the scalar code (rare).
                cones[l].add_dir(dirs[l])
            } else if wide & bit != 0 {
                Cone::WIDE
            } else {
                Cone {
                    axis: Vec3::new(ox[l], oy[l], oz[l]),
                    angle: out_angle[l],
                }
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use proptest::prelude::*;

    fn bits(c: &Cone) -> ([u32; 3], u32) {
        (c.axis.to_array().map(f32::to_bits), c.angle.to_bits())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        /// Eight cones grown in lanes equal the scalar cones bit for bit: coherent and wide
        /// bundles, repeated and opposite directions, cones near a hemisphere.
        #[test]
        fn lanes_equal_add_dir(seed in 0u64..1_000_000, spread in 0.0f32..2.5, steps in 1usize..12) {
            let mut rng = Pcg32::new(seed, 5);
            let axis = rng.unit_vector();
            let dir = |rng: &mut Pcg32| -> Vec3 {
                match rng.below(8) {
                    0 => axis,
                    1 => -axis,
                    _ => (axis + rng.unit_vector() * spread).normalize_or(axis),
                }
            };
            let mut lanes: [Cone; 8] = std::array::from_fn(|_| Cone::from_dir(dir(&mut rng)));
            let mut scalar = lanes;
            for _ in 0..steps {
                let d: [Vec3; 8] = std::array::from_fn(|_| dir(&mut rng));
                let mask = rng.below(256) as u8 | 1;
                add_dir8(&mut lanes, &d, mask);
                for l in 0..8 {
                    if mask >> l & 1 != 0 {
                        scalar[l] = scalar[l].add_dir(d[l]);
                    }
                    prop_assert_eq!(bits(&lanes[l]), bits(&scalar[l]), "lane {}", l);
                }
            }
        }

        /// The lanes' elementary functions are pmath's, bit for bit.
        #[test]
        fn lanes_equal_pmath(seed in 0u64..1_000_000, scale in 0.001f32..1000.0) {
            let mut rng = Pcg32::new(seed, 6);
            let special = [0.0f32, -0.0, 1.0, -1.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 1e-30];
            let mut v = || if rng.below(4) == 0 { special[rng.below(8) as usize] } else { rng.range(-1.0, 1.0) * scale };
            let y: [f32; 8] = std::array::from_fn(|_| v());
            let x: [f32; 8] = std::array::from_fn(|_| v());
            let a = atan2_8(&y, &x);
            let c = acos8(&x);
            let (sn, cs) = sin_cos8(&std::array::from_fn(|l| x[l].clamp(-8192.0, 8192.0)));
            // Bits, or NaN for NaN (a NaN's payload is not specified).
            let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
            for l in 0..8 {
                prop_assert!(same(a[l], crate::pmath::atan2(y[l], x[l])), "atan2({}, {})", y[l], x[l]);
                prop_assert!(same(c[l], crate::pmath::acos(x[l])), "acos({})", x[l]);
                let (s1, c1) = crate::pmath::sin_cos(x[l].clamp(-8192.0, 8192.0));
                prop_assert!(same(sn[l], s1) && same(cs[l], c1), "sin_cos({})", x[l]);
            }
        }
    }
}
