//! Ray hashing (thesis §3.2.3) and the screen-space keys of RAH.
//!
//! ## 32-bit thesis hash ([`HashKind::Thesis`]); bit 31 is the most significant
//! ```text
//! all rays      [31:30] ray kind (0 primary, 1 shadow, 2 reflection, 3 refraction)
//! shadow        [29 : 30-L] light index (L = light_bits, wraps modulo 2^L)
//!               [low 2·S bits] direction from the light: quantised spherical (θ, φ),
//!                              S bits each, interleaved (2-D Morton)
//! other rays    [29 : 30-3·O] origin: 3-D Morton of the origin quantised to 2^O cells per
//!                              axis of the scene box
//!               [low 2·D bits] direction: quantised (θ, φ), D bits each, interleaved
//! ```
//! The thesis keeps light index above direction for shadows (so rays sort by light first)
//! and origin plus direction for the other rays; it does not fix how θ and φ share their
//! bits, so they are interleaved here to keep both angles coherent in a node.
//!
//! ## 64-bit 5-D Morton hash ([`HashKind::Morton64`])
//! `[63:62]` kind, then 60 bits interleaving origin x, y, z and direction θ, φ at 12 bits each
//! (the thesis's future work: one code that weighs origin and direction alike). A shadow ray's
//! origin is its light, so shadows still group by light.
//!
//! ## RAH screen key
//! `[31:30]` kind, `[29:26]` light, `[25:0]` Z-order (Morton) of the pixel (x, y): the layout
//! of RAH's ray textures, whose 2×2 pyramid is exactly consecutive runs of this order.

use geom::{pmath, Aabb, Vec3};
use trace::{RayBatch, RayKind};

/// Which key orders CRSH's leaves (thesis §3.2.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HashKind {
    /// The thesis's typed 32-bit hash.
    Thesis,
    /// A 64-bit 5-D Morton code of origin and direction.
    Morton64,
}

impl HashKind {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, HashKind); 2] = [
        ("thesis", HashKind::Thesis),
        ("morton64", HashKind::Morton64),
    ];
}

/// Bit budgets of the 32-bit hash (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HashBits {
    /// Bits of the light index for shadow rays.
    pub light: u32,
    /// Bits per angle for shadow rays.
    pub shadow_dir: u32,
    /// Bits per axis of the origin for reflection/refraction rays.
    pub origin: u32,
    /// Bits per angle for reflection/refraction rays.
    pub dir: u32,
}

impl Default for HashBits {
    fn default() -> Self {
        HashBits {
            light: 4,
            shadow_dir: 13,
            origin: 5,
            dir: 7,
        }
    }
}

/// `LIGHT,SHADOW_DIR,ORIGIN,DIR`, as `--hash-bits` takes them.
impl std::fmt::Display for HashBits {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{},{},{},{}",
            self.light, self.shadow_dir, self.origin, self.dir
        )
    }
}

/// Why a hash bit budget is refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum HashBitsError {
    /// A budget is not a number.
    #[error("'{0}' is not a number")]
    NotANumber(String),
    /// Not four budgets.
    #[error("expected 4 comma-separated numbers, got {0}")]
    Count(usize),
    /// The budgets leave no room in 30 bits below the kind.
    #[error("hash bit budgets exceed 30 bits (shadow uses {shadow}, other rays {other})")]
    Over30 {
        /// Bits the shadow rays' fields take.
        shadow: u32,
        /// Bits the other rays' fields take.
        other: u32,
    },
    /// A direction budget of 0.
    #[error("hash direction bits must be at least 1")]
    NoDirectionBits,
}

impl std::str::FromStr for HashBits {
    type Err = HashBitsError;
    /// Parse `LIGHT,SHADOW_DIR,ORIGIN,DIR` (the budgets are checked by `validate`).
    fn from_str(s: &str) -> Result<Self, HashBitsError> {
        let v: Vec<u32> = s
            .split(',')
            .map(|x| {
                x.trim()
                    .parse::<u32>()
                    .map_err(|_| HashBitsError::NotANumber(x.to_string()))
            })
            .collect::<Result<_, _>>()?;
        let [light, shadow_dir, origin, dir] = v[..] else {
            return Err(HashBitsError::Count(v.len()));
        };
        Ok(HashBits {
            light,
            shadow_dir,
            origin,
            dir,
        })
    }
}

impl HashBits {
    /// Check the budgets fit 30 bits below the kind.
    pub fn validate(&self) -> Result<(), HashBitsError> {
        let s = self.light + 2 * self.shadow_dir;
        let o = 3 * self.origin + 2 * self.dir;
        if s > 30 || o > 30 {
            return Err(HashBitsError::Over30 {
                shadow: s,
                other: o,
            });
        }
        if self.shadow_dir == 0 || self.dir == 0 {
            return Err(HashBitsError::NoDirectionBits);
        }
        Ok(())
    }
}

/// Spread the low 16 bits of `v` to even bit positions.
#[inline]
pub fn part1by1(v: u32) -> u32 {
    let mut x = v & 0xffff;
    x = (x | (x << 8)) & 0x00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333;
    x = (x | (x << 1)) & 0x5555_5555;
    x
}

/// Spread the low 10 bits of `v` to every third bit.
#[inline]
pub fn part1by2(v: u32) -> u32 {
    let mut x = v & 0x3ff;
    x = (x | (x << 16)) & 0x0300_00ff;
    x = (x | (x << 8)) & 0x0300_f00f;
    x = (x | (x << 4)) & 0x030c_30c3;
    x = (x | (x << 2)) & 0x0924_9249;
    x
}

/// Interleave 5 coordinates of up to 12 bits each into a 60-bit Morton code.
#[inline]
pub fn morton5(c: [u32; 5]) -> u64 {
    let mut out = 0u64;
    for bit in 0..12 {
        for (k, v) in c.iter().enumerate() {
            out |= (((v >> bit) & 1) as u64) << (bit * 5 + k as u32);
        }
    }
    out
}

/// Quantise `x ∈ [0, 1]` to `bits` bits.
#[inline]
fn quant(x: f32, bits: u32) -> u32 {
    let n = (1u32 << bits) as f32;
    ((x * n) as u32).min((1u32 << bits) - 1)
}

/// Spherical coordinates of a unit direction, each normalised to [0, 1]:
/// θ = acos(z) / π, φ = (atan2(y, x) + π) / 2π, with the portable [`geom::pmath`] functions
/// so that the GPU backend computes the same keys.
#[inline]
pub fn spherical01(d: Vec3) -> (f32, f32) {
    normalise01(pmath::acos(d.z), pmath::atan2(d.y, d.x))
}

/// θ and φ of [`spherical01`] from acos(z) and atan2(y, x).
#[inline]
fn normalise01(acos_z: f32, atan2_yx: f32) -> (f32, f32) {
    let theta = acos_z * std::f32::consts::FRAC_1_PI;
    let phi = (atan2_yx + std::f32::consts::PI) * (0.5 * std::f32::consts::FRAC_1_PI);
    (theta.clamp(0.0, 1.0), phi.clamp(0.0, 1.0))
}

/// [`spherical01`] of rays `first .. first + 8` (fewer at the batch's end), the elementary
/// functions 8 lanes at a time ([`geom::cone8`]), bit for bit.
#[inline]
pub fn spherical01_8(rays: &RayBatch, first: usize) -> [(f32, f32); 8] {
    let n = rays.len().saturating_sub(first).min(8);
    let d = |l: usize| rays.dir[first + l.min(n.max(1) - 1)];
    let z: [f32; 8] = std::array::from_fn(|l| d(l).z);
    let y: [f32; 8] = std::array::from_fn(|l| d(l).y);
    let x: [f32; 8] = std::array::from_fn(|l| d(l).x);
    let (a, b) = (geom::cone8::acos8(&z), geom::cone8::atan2_8(&y, &x));
    std::array::from_fn(|l| normalise01(a[l], b[l]))
}

#[inline]
fn unit_in_box(p: Vec3, b: &Aabb) -> Vec3 {
    let e = b.extent().max(Vec3::splat(1e-30));
    ((p - b.min) / e).clamp(Vec3::ZERO, Vec3::ONE)
}

/// The 32-bit thesis hash of ray `i`.
#[inline]
pub fn thesis_key(rays: &RayBatch, i: usize, scene: &Aabb, bits: &HashBits) -> u32 {
    thesis_key_at(rays, i, spherical01(rays.dir[i]), scene, bits)
}

/// [`thesis_key`] with the ray's [`spherical01`] angles `(t, p)` given.
#[inline]
pub fn thesis_key_at(
    rays: &RayBatch,
    i: usize,
    (t, p): (f32, f32),
    scene: &Aabb,
    bits: &HashBits,
) -> u32 {
    let kind = rays.kind[i] as u32 & 3;
    let payload = if kind == RayKind::Shadow as u32 {
        let light = rays.light[i] & ((1u32 << bits.light) - 1);
        let dir = part1by1(quant(t, bits.shadow_dir)) << 1 | part1by1(quant(p, bits.shadow_dir));
        light << (2 * bits.shadow_dir) | dir
    } else {
        let u = unit_in_box(rays.org[i], scene);
        let o = bits.origin;
        let org =
            part1by2(quant(u.x, o)) << 2 | part1by2(quant(u.y, o)) << 1 | part1by2(quant(u.z, o));
        let dir = part1by1(quant(t, bits.dir)) << 1 | part1by1(quant(p, bits.dir));
        org << (2 * bits.dir) | dir
    };
    kind << 30 | payload
}

/// [`thesis_key_at`] of rays `first .. first + out.len()` (at most 8) into `out`, from their
/// [`spherical01_8`] angles `tp`: with AVX2, the 8 keys side by side in integer lanes (the
/// same float operations and truncations, so the same bits); else one by one.
#[inline]
pub fn thesis_keys8(
    rays: &RayBatch,
    first: usize,
    tp: &[(f32, f32); 8],
    scene: &Aabb,
    bits: &HashBits,
    out: &mut [u32],
) {
    assert!(
        !out.is_empty() && out.len() <= 8 && first + out.len() <= rays.len(),
        "a window of at most 8 rays"
    );
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: AVX2 is present; the window is in bounds (checked above).
            let k = unsafe { avx2::keys8(rays, first, out.len(), tp, scene, bits) };
            out.copy_from_slice(&k[..out.len()]);
            return;
        }
    }
    for (l, k) in out.iter_mut().enumerate() {
        *k = thesis_key_at(rays, first + l, tp[l], scene, bits);
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::{HashBits, RayKind};
    use geom::{Aabb, Vec3};
    use std::arch::x86_64::*;
    use trace::RayBatch;

    /// [`super::part1by1`] per lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn part1by1(v: __m256i) -> __m256i {
        let m = _mm256_set1_epi32;
        let mut x = _mm256_and_si256(v, m(0xffff));
        x = _mm256_and_si256(
            _mm256_or_si256(x, _mm256_slli_epi32::<8>(x)),
            m(0x00ff_00ff),
        );
        x = _mm256_and_si256(
            _mm256_or_si256(x, _mm256_slli_epi32::<4>(x)),
            m(0x0f0f_0f0f),
        );
        x = _mm256_and_si256(
            _mm256_or_si256(x, _mm256_slli_epi32::<2>(x)),
            m(0x3333_3333),
        );
        _mm256_and_si256(
            _mm256_or_si256(x, _mm256_slli_epi32::<1>(x)),
            m(0x5555_5555),
        )
    }

    /// [`super::part1by2`] per lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn part1by2(v: __m256i) -> __m256i {
        let m = _mm256_set1_epi32;
        let mut x = _mm256_and_si256(v, m(0x3ff));
        x = _mm256_and_si256(
            _mm256_or_si256(x, _mm256_slli_epi32::<16>(x)),
            m(0x0300_00ff),
        );
        x = _mm256_and_si256(
            _mm256_or_si256(x, _mm256_slli_epi32::<8>(x)),
            m(0x0300_f00f),
        );
        x = _mm256_and_si256(
            _mm256_or_si256(x, _mm256_slli_epi32::<4>(x)),
            m(0x030c_30c3),
        );
        _mm256_and_si256(
            _mm256_or_si256(x, _mm256_slli_epi32::<2>(x)),
            m(0x0924_9249),
        )
    }

    /// [`super::quant`] per lane for `x` in [0, 1] or NaN: x · 2^bits (one product, as the
    /// scalar code) is then in [0, 2^bits], so truncating to i32 is the scalar `as u32`;
    /// a NaN product becomes 0 (`as u32` of NaN is 0) by the max with 0, which returns its
    /// second operand for NaN.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn quant(x: __m256, bits: u32) -> __m256i {
        let n = (1u32 << bits) as f32;
        let q = _mm256_max_ps(_mm256_mul_ps(x, _mm256_set1_ps(n)), _mm256_setzero_ps());
        _mm256_min_epu32(
            _mm256_cvttps_epi32(q),
            _mm256_set1_epi32(((1u32 << bits) - 1) as i32),
        )
    }

    /// `v << k` per lane (k < 32: the budgets are validated to 30 bits).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn shl(v: __m256i, k: u32) -> __m256i {
        _mm256_sll_epi32(v, _mm_cvtsi32_si128(k as i32))
    }

    /// The keys of rays `first .. first + n` (lanes past `n` repeat the last ray).
    #[target_feature(enable = "avx2")]
    pub(super) fn keys8(
        rays: &RayBatch,
        first: usize,
        n: usize,
        tp: &[(f32, f32); 8],
        scene: &Aabb,
        bits: &HashBits,
    ) -> [u32; 8] {
        let at = |l: usize| first + l.min(n - 1);
        let f = |g: &dyn Fn(usize) -> f32| {
            let a: [f32; 8] = std::array::from_fn(g);
            // SAFETY: `a` holds 8 floats.
            unsafe { _mm256_loadu_ps(a.as_ptr()) }
        };
        let i = |g: &dyn Fn(usize) -> u32| {
            let a: [u32; 8] = std::array::from_fn(g);
            // SAFETY: `a` holds 8 words.
            unsafe { _mm256_loadu_si256(a.as_ptr().cast()) }
        };
        let t = f(&|l| tp[l].0);
        let p = f(&|l| tp[l].1);
        let kind = i(&|l| rays.kind[at(l)] as u32 & 3);
        // Shadow rays: light index, then direction.
        let s = bits.shadow_dir;
        let sdir = _mm256_or_si256(shl(part1by1(quant(t, s)), 1), part1by1(quant(p, s)));
        let light = i(&|l| rays.light[at(l)] & ((1u32 << bits.light) - 1));
        let shadow = _mm256_or_si256(shl(light, 2 * s), sdir);
        // Other rays: origin in the scene box (unit_in_box: difference, quotient, clamp),
        // then direction.
        let e = scene.extent().max(Vec3::splat(1e-30));
        let unit = |k: usize| {
            let x = f(&|l| rays.org[at(l)][k]);
            let q = _mm256_div_ps(
                _mm256_sub_ps(x, _mm256_set1_ps(scene.min[k])),
                _mm256_set1_ps(e[k]),
            );
            // clamp(0, 1); a NaN quotient becomes 0 here, as quant makes it 0 anyway.
            _mm256_min_ps(_mm256_max_ps(q, _mm256_setzero_ps()), _mm256_set1_ps(1.0))
        };
        let o = bits.origin;
        let org = _mm256_or_si256(
            _mm256_or_si256(
                shl(part1by2(quant(unit(0), o)), 2),
                shl(part1by2(quant(unit(1), o)), 1),
            ),
            part1by2(quant(unit(2), o)),
        );
        let d = bits.dir;
        let dir = _mm256_or_si256(shl(part1by1(quant(t, d)), 1), part1by1(quant(p, d)));
        let other = _mm256_or_si256(shl(org, 2 * d), dir);
        let is_shadow = _mm256_cmpeq_epi32(kind, _mm256_set1_epi32(RayKind::Shadow as i32));
        let payload = _mm256_blendv_epi8(other, shadow, is_shadow);
        let key = _mm256_or_si256(_mm256_slli_epi32::<30>(kind), payload);
        let mut out = [0u32; 8];
        // SAFETY: `out` holds 8 words.
        unsafe { _mm256_storeu_si256(out.as_mut_ptr().cast(), key) };
        out
    }
}

/// The 64-bit 5-D Morton hash of ray `i`.
#[inline]
pub fn morton64_key(rays: &RayBatch, i: usize, scene: &Aabb) -> u64 {
    let kind = rays.kind[i] as u64 & 3;
    let u = unit_in_box(rays.org[i], scene);
    let (t, p) = spherical01(rays.dir[i]);
    let c = [
        quant(u.x, 12),
        quant(u.y, 12),
        quant(u.z, 12),
        quant(t, 12),
        quant(p, 12),
    ];
    kind << 62 | morton5(c)
}

/// RAH's key: kind, light, pixel Z-order (identity order within a kind when the batch has no
/// screen layout).
#[inline]
pub fn screen_key(rays: &RayBatch, i: usize) -> u32 {
    let kind = rays.kind[i] as u32 & 3;
    let light = rays.light[i] & 15;
    let z = if rays.width > 0 {
        let (x, y) = (rays.pixel[i] % rays.width, rays.pixel[i] / rays.width);
        (part1by1(y & 0x1fff) << 1 | part1by1(x & 0x1fff)) & 0x03ff_ffff
    } else {
        0
    };
    kind << 30 | light << 26 | z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_spreads() {
        assert_eq!(part1by1(0b1011), 0b1000101);
        assert_eq!(part1by2(0b11), 0b1001);
        assert_eq!(morton5([1, 0, 0, 0, 0]), 1);
        assert_eq!(morton5([0, 0, 0, 0, 1]), 1 << 4);
        assert_eq!(morton5([2, 0, 0, 0, 0]), 1 << 5);
        assert_eq!(morton5([0xfff; 5]), (1u64 << 60) - 1);
    }

    #[test]
    fn keys_keep_kinds_apart_and_lights_ordered() {
        let mut b = RayBatch::default();
        let r = geom::Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0);
        b.push(r, RayKind::Shadow, 0, 3, Vec3::ONE, 0);
        b.push(r, RayKind::Shadow, 0, 1, Vec3::ONE, 0);
        b.push(r, RayKind::Reflection, 0, 0, Vec3::ONE, 0);
        let bx = Aabb::new(Vec3::splat(-1.0), Vec3::ONE);
        let bits = HashBits::default();
        let k: Vec<u32> = (0..3).map(|i| thesis_key(&b, i, &bx, &bits)).collect();
        assert!(k[1] < k[0], "light 1 sorts before light 3");
        assert!(k[0] < k[2], "shadow rays before reflection rays");
        assert_eq!(k[2] >> 30, 2);
        let m: Vec<u64> = (0..3).map(|i| morton64_key(&b, i, &bx)).collect();
        assert_eq!(m[2] >> 62, 2);
        assert!(HashBits::default().validate().is_ok());
        assert!(HashBits {
            origin: 8,
            ..Default::default()
        }
        .validate()
        .is_err());
    }

    /// The 8-lane keys equal the scalar ones, for every kind, light, bit budget and window
    /// length, origins inside and outside the scene box, and axis directions.
    #[test]
    fn lane_keys_equal_the_scalar_ones() {
        let mut rng = geom::Pcg32::new(11, 5);
        let scene = Aabb::new(Vec3::new(-3.0, 0.0, -1.0), Vec3::new(5.0, 2.0, 1e-3));
        let budgets = [
            HashBits::default(),
            HashBits {
                light: 0,
                shadow_dir: 15,
                origin: 6,
                dir: 6,
            },
            HashBits {
                light: 4,
                shadow_dir: 1,
                origin: 1,
                dir: 1,
            },
        ];
        for bits in budgets {
            assert!(bits.validate().is_ok(), "{bits:?}");
            for n in [1usize, 7, 8, 9, 203] {
                let mut b = RayBatch::default();
                for i in 0..n {
                    let o = Vec3::new(
                        rng.range(-6.0, 8.0),
                        rng.range(-1.0, 3.0),
                        rng.range(-0.01, 0.01),
                    );
                    let d = match i % 7 {
                        0 => Vec3::X,
                        1 => -Vec3::Z,
                        _ => rng.unit_vector(),
                    };
                    let kind = [
                        RayKind::Primary,
                        RayKind::Shadow,
                        RayKind::Reflection,
                        RayKind::Refraction,
                    ][i % 4];
                    let light = rng.next_u32() % 40;
                    b.push(geom::Ray::new(o, d, 0.0, 1.0), kind, 0, light, Vec3::ONE, 0);
                }
                for first in (0..n).step_by(8) {
                    let len = (n - first).min(8);
                    let tp = spherical01_8(&b, first);
                    let mut got = [0u32; 8];
                    thesis_keys8(&b, first, &tp, &scene, &bits, &mut got[..len]);
                    for (l, &k) in got[..len].iter().enumerate() {
                        let want = thesis_key(&b, first + l, &scene, &bits);
                        assert_eq!(k, want, "{bits:?} ray {}", first + l);
                    }
                }
            }
        }
    }

    /// The 8-lane angles equal the scalar ones bit for bit, up to the batch's last ray (axis
    /// directions, poles and random ones).
    #[test]
    fn lane_angles_equal_the_scalar_ones() {
        let mut rng = geom::Pcg32::new(3, 4);
        let mut b = RayBatch::default();
        let fixed = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
        for i in 0..203 {
            let d = if i < fixed.len() {
                fixed[i]
            } else {
                rng.unit_vector()
            };
            b.push(
                geom::Ray::new(Vec3::ZERO, d, 0.0, 1.0),
                RayKind::Shadow,
                0,
                0,
                Vec3::ONE,
                0,
            );
        }
        for first in (0..b.len()).step_by(8) {
            let lanes = spherical01_8(&b, first);
            for (l, &(t, p)) in lanes.iter().enumerate().take(b.len() - first) {
                let (t1, p1) = spherical01(b.dir[first + l]);
                assert_eq!(
                    (t.to_bits(), p.to_bits()),
                    (t1.to_bits(), p1.to_bits()),
                    "ray {}",
                    first + l
                );
            }
        }
    }
}
