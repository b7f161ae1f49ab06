//! Portable elementary functions: `atan`, `atan2`, `acos` and `sin_cos` from +, −, ×, ÷ and
//! comparisons only, in a fixed evaluation order.
//!
//! Why not `f32::atan2`: its result depends on the platform's libm, and a GPU's built-ins are
//! different again. Every quantity that decides a ray-space hierarchy's shape (the hash's
//! spherical angles, the cones' angles and their sines and cosines) is computed here, and the
//! WGSL kernels (`gpu` crate, `shaders/common.wgsl`) evaluate the very same operations in the same
//! order. On a device whose f32 +, −, ×, ÷ and sqrt are IEEE round-to-nearest and not fused
//! into FMAs (lavapipe is one; checked by the `gpu` crate's tests), the GPU's nodes, and so
//! its counters, are bit-identical to the CPU's.
//!
//! The approximations are Cephes's single-precision ones (S. Moshier): `atanf` (three-range
//! reduction, degree-4 odd polynomial in x², ≈ 2 ulp) and `sinf`/`cosf` (Cody–Waite reduction
//! by π/2 with a three-part constant, degree-3/4 polynomials, ≈ 1 ulp for |x| ≤ 8192). Their
//! errors are far below the 1e-6 rad padding every computed cone angle gets (see
//! [`crate::cone`]), so the conservative node tests keep their guarantees.

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// tan(3π/8) and tan(π/8): the range-reduction thresholds of Cephes `atanf`.
pub const T3P8: f32 = 2.414_213_5;
/// tan(π/8).
pub const TP8: f32 = 0.414_213_57;
/// Cephes `atanf` polynomial coefficients (magnitudes; signs as written in [`atan`]).
pub const AT: [f32; 4] = [8.053_744_5e-2, 1.387_768_6e-1, 1.997_771_1e-1, 3.333_295e-1];
/// Cephes `sinf` and `cosf` polynomial coefficients (magnitudes; signs as in [`sin_cos`]).
pub const SN: [f32; 3] = [1.951_529_6e-4, 8.332_161e-3, 1.666_665_5e-1];
/// Cephes `cosf` polynomial coefficients (magnitudes; signs as in [`sin_cos`]).
pub const CS: [f32; 3] = [2.443_315_7e-5, 1.388_731_6e-3, 4.166_664_6e-2];

/// Arc tangent (radians, in [−π/2, π/2]).
#[inline]
pub fn atan(x: f32) -> f32 {
    let neg = x < 0.0;
    let mut x = x.abs();
    let y0 = if x > T3P8 {
        x = -(1.0 / x);
        FRAC_PI_2
    } else if x > TP8 {
        x = (x - 1.0) / (x + 1.0);
        FRAC_PI_4
    } else {
        0.0
    };
    let z = x * x;
    let p = (((AT[0] * z - AT[1]) * z + AT[2]) * z - AT[3]) * z;
    let y = y0 + (p * x + x);
    if neg {
        -y
    } else {
        y
    }
}

/// Two-argument arc tangent (radians, in [−π, π]); atan2(0, 0) = 0, atan2(0, x < 0) = π.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    if x == 0.0 {
        return if y > 0.0 {
            FRAC_PI_2
        } else if y < 0.0 {
            -FRAC_PI_2
        } else {
            0.0
        };
    }
    if y == 0.0 {
        return if x > 0.0 { 0.0 } else { PI };
    }
    let a = atan(y / x);
    if x > 0.0 {
        a
    } else if y > 0.0 {
        a + PI
    } else {
        a - PI
    }
}

/// Arc cosine of x ∈ [−1, 1] (clamped), as atan2(√((1 − x)(1 + x)), x).
#[inline]
pub fn acos(x: f32) -> f32 {
    let x = x.clamp(-1.0, 1.0);
    atan2(((1.0 - x) * (1.0 + x)).sqrt(), x)
}

/// π/2 split in three parts (Cody–Waite): q · DP1 is exact for the quadrant counts used here.
pub const DP1: f32 = 1.570_312_5;
/// Second part of the Cody–Waite split of π/2.
pub const DP2: f32 = 4.837_513e-4;
/// Third part of the Cody–Waite split of π/2.
pub const DP3: f32 = 7.549_79e-8;
/// 2/π, the quadrant scale of [`sin_cos`].
pub const TWO_OVER_PI: f32 = std::f32::consts::FRAC_2_PI;

/// (sin x, cos x) for |x| ≤ 8192 (larger arguments lose accuracy; no caller uses them).
#[inline]
pub fn sin_cos(x: f32) -> (f32, f32) {
    // Quadrant q = round(x · 2/π), r = x − q·π/2 ∈ [−π/4, π/4].
    let qf = (x * TWO_OVER_PI + 0.5).floor();
    let r = ((x - qf * DP1) - qf * DP2) - qf * DP3;
    let z = r * r;
    let s = ((-SN[0] * z + SN[1]) * z - SN[2]) * z * r + r;
    let c = ((CS[0] * z - CS[1]) * z + CS[2]) * z * z - 0.5 * z + 1.0;
    let q = (qf as i32) & 3;
    match q {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn atan2_is_accurate(y in -1e3f32..1e3, x in -1e3f32..1e3) {
            let e = (atan2(y, x) as f64 - (y as f64).atan2(x as f64)).abs();
            prop_assert!(e < 4e-7, "atan2({y}, {x}) off by {e}");
        }

        #[test]
        fn atan2_of_unit_pairs(a in -3.2f64..3.2) {
            let (y, x) = (a.sin() as f32, a.cos() as f32);
            let e = (atan2(y, x) as f64 - (y as f64).atan2(x as f64)).abs();
            prop_assert!(e < 4e-7, "angle {a}: off by {e}");
        }

        #[test]
        fn sin_cos_is_accurate(x in -20.0f32..20.0) {
            let (s, c) = sin_cos(x);
            prop_assert!((s as f64 - (x as f64).sin()).abs() < 2.5e-7);
            prop_assert!((c as f64 - (x as f64).cos()).abs() < 2.5e-7);
        }

        #[test]
        fn acos_is_accurate(x in -1.0f32..=1.0) {
            prop_assert!((acos(x) as f64 - (x as f64).acos()).abs() < 5e-7);
        }
    }

    #[test]
    fn special_values() {
        assert_eq!(atan2(0.0, 0.0), 0.0);
        assert_eq!(atan2(0.0, -1.0), PI);
        assert_eq!(atan2(1.0, 0.0), FRAC_PI_2);
        assert_eq!(atan2(-1.0, 0.0), -FRAC_PI_2);
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert!((atan(f32::INFINITY) - FRAC_PI_2).abs() < 1e-7);
        assert_eq!(acos(1.0), 0.0);
        assert!((acos(-1.0) - PI).abs() < 1e-7);
    }
}
