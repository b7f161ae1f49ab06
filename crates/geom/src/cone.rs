//! Direction cones and the conservative node tests of a ray-space hierarchy.
//!
//! A ray-space node is an origin sphere (centre C, radius r) plus a direction cone (unit axis
//! x, half-angle α): every ray of the node starts in the sphere and points into the cone. The
//! cone operations here implement thesis §3.2.7 (eqs. 3.8–3.13) with these guards and fixes:
//!
//! - Cone of a cone and one ray (eqs. 3.8–3.11), only when the ray is outside the cone:
//!   q = normalize((x·r)x − r) must point *away* from r (the flipped sign never encloses);
//!   e = x cos α + q sin α, x' = normalize(e + r), α' = (θ + α)/2 — the exact minimal cone.
//!   θ + α ≥ π makes the cone wider than a hemisphere: the node is marked *wide* and always
//!   passes; r = −x leaves q undefined; (cos, sin) pairs are kept instead of sin(acos(·))
//!   near 0; angles are padded by a few ulps.
//! - Union of two cones: exact minimal (keep the larger when it contains the other, else
//!   α = (θ + α₁ + α₂)/2 about the great-circle interpolation of the axes), or the thesis's
//!   cheap form (eqs. 3.12–3.13: x = normalize(x₁ + x₂), α = θ/2 + max(α₁, α₂)), conservative
//!   but about 0.13 rad wider on average. Eq. 3.13 is misprinted in the thesis as a cosine;
//!   the angle is meant.
//! - The RAH node test (eq. 3.16) is conservative only for α < 90°: wider nodes always pass.

use crate::sphere::Sphere;
use glam::Vec3;
use std::f32::consts::{FRAC_PI_2, PI};

/// A cone of directions: unit `axis`, half-angle `angle` in radians (0 ..= π).
/// A cone with `angle >= π/2` is *wide*: wider than a hemisphere, it always passes node tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// Unit axis.
    pub axis: Vec3,
    /// Half-angle in radians.
    pub angle: f32,
}

/// Absolute + relative padding of computed angles (radians): atan2 and the f32 unit vectors
/// it is computed from carry errors of a few 1e-7.
#[inline]
fn pad_angle(a: f32) -> f32 {
    (a * (1.0 + 4.0 * f32::EPSILON) + 1e-6).min(PI)
}

/// The angle between two unit vectors, accurate near 0 and π (atan2 of |x×y| and x·y, not acos).
#[inline]
pub fn angle_between(x: Vec3, y: Vec3) -> f32 {
    crate::pmath::atan2(x.cross(y).length(), x.dot(y))
}

/// The half-angle that makes a cone around `axis` contain the cones (x₁, α₁) and (x₂, α₂):
/// by the triangle inequality on the sphere, max(∠(axis, xᵢ) + αᵢ). Measuring it from the
/// rounded axis (instead of trusting the closed-form angle) keeps the bound valid even where
/// the axis formula loses precision, e.g. near a hemisphere where |e + r| is small.
#[inline]
fn enclosing(axis: Vec3, x1: Vec3, a1: f32, x2: Vec3, a2: f32) -> Cone {
    let angle = (angle_between(axis, x1) + a1).max(angle_between(axis, x2) + a2);
    if angle >= PI - 1e-6 {
        return Cone::WIDE;
    }
    Cone {
        axis,
        angle: pad_angle(angle),
    }
}

/// The cone whose axis is `x` rotated by `beta` towards `y` (on the great circle through
/// both), enclosing (x, ax) and (y, ay); `WIDE` when that circle is undefined.
fn rotate_towards(x: Vec3, ax: f32, y: Vec3, ay: f32, beta: f32) -> Cone {
    let w = (y - x * x.dot(y)).normalize_or_zero();
    if w == Vec3::ZERO {
        return Cone::WIDE;
    }
    let (s, c) = crate::pmath::sin_cos(beta);
    enclosing((x * c + w * s).normalize(), x, ax, y, ay)
}

impl Cone {
    /// The cone of every direction (half-angle π).
    pub const WIDE: Cone = Cone {
        axis: Vec3::Z,
        angle: PI,
    };

    /// The cone of a single direction (a leaf of the hierarchy), with the angle padding
    /// every computed cone gets, so the same direction rounded differently (renormalised,
    /// say) still lies inside.
    pub fn from_dir(d: Vec3) -> Cone {
        Cone {
            axis: d,
            angle: pad_angle(0.0),
        }
    }

    /// Wider than a hemisphere (α ≥ π/2): node tests must accept it.
    #[inline]
    pub fn is_wide(&self) -> bool {
        self.angle >= FRAC_PI_2
    }

    /// True when the unit direction `d` lies inside the cone.
    #[inline]
    pub fn contains_dir(&self, d: Vec3) -> bool {
        self.angle >= PI || angle_between(self.axis, d) <= self.angle
    }

    /// The minimal cone containing this cone and the unit direction `r` (eqs. 3.8–3.11).
    ///
    /// With θ = angle(x, r) and r outside the cone: q = normalize((x·r)x − r) points away
    /// from r, e = x cos α + q sin α is the far edge, x' = normalize(e + r); the new half
    /// angle is (θ + α)/2 (computed directly, not as acos(x'·r), for accuracy). If θ + α ≥ π
    /// the result is wider than a hemisphere and is marked wide.
    pub fn add_dir(&self, r: Vec3) -> Cone {
        if self.angle >= PI {
            return Cone::WIDE;
        }
        let theta = angle_between(self.axis, r);
        if theta <= self.angle {
            return *self;
        }
        if theta + self.angle >= PI - 1e-6 {
            // Past a hemisphere e + r flips to the wrong bisector; rotate x towards r by
            // (θ − α)/2 instead (the same cone where both are defined). The result is wide.
            return rotate_towards(self.axis, self.angle, r, 0.0, (theta - self.angle) * 0.5);
        }
        let xr = self.axis.dot(r);
        let q = (self.axis * xr - r).normalize_or_zero();
        if q == Vec3::ZERO {
            return Cone::WIDE;
        }
        let (s, c) = crate::pmath::sin_cos(self.angle);
        let e = self.axis * c + q * s;
        let axis = (e + r).normalize_or_zero();
        if axis == Vec3::ZERO {
            return Cone::WIDE;
        }
        // Exactly (θ + α)/2 (eq. 3.11), measured from the rounded axis.
        enclosing(axis, self.axis, self.angle, r, 0.0)
    }

    /// Exact minimal cone containing two cones. If one contains the other it is kept;
    /// otherwise α = (θ + α₁ + α₂)/2 and the axis is x₁ rotated towards x₂ by α − α₁.
    pub fn union_exact(&self, o: &Cone) -> Cone {
        if self.angle >= PI || o.angle >= PI {
            return Cone::WIDE;
        }
        let theta = angle_between(self.axis, o.axis);
        if theta + o.angle <= self.angle {
            return *self;
        }
        if theta + self.angle <= o.angle {
            return *o;
        }
        let alpha = (theta + self.angle + o.angle) * 0.5;
        // α ≥ 90° gives a wide cone; it is still computed exactly so later unions stay valid.
        rotate_towards(self.axis, self.angle, o.axis, o.angle, alpha - self.angle)
    }

    /// The thesis's union (eq. 3.12 and eq. 3.13 as corrected in the notes):
    /// x = normalize(x₁ + x₂), α = θ/2 + max(α₁, α₂). Conservative, ~0.13 rad looser on average.
    pub fn union_thesis(&self, o: &Cone) -> Cone {
        if self.angle >= PI || o.angle >= PI {
            return Cone::WIDE;
        }
        let axis = (self.axis + o.axis).normalize_or_zero();
        if axis == Vec3::ZERO {
            return Cone::WIDE;
        }
        // θ/2 + max(α₁, α₂) up to rounding, measured from the rounded axis.
        enclosing(axis, self.axis, self.angle, o.axis, o.angle)
    }
}

/// A node's cone in the form the tests use: axis, sin α and cos α precomputed once per node
/// (no trigonometry per node–triangle test), and whether it is wide (α ≥ 90°).
#[derive(Clone, Copy, Debug)]
pub struct ConeSc {
    /// Unit axis.
    pub axis: Vec3,
    /// sin α.
    pub sin: f32,
    /// cos α.
    pub cos: f32,
    /// α ≥ 90°: the RAH test is not conservative, the node always passes.
    pub wide: bool,
    /// α ≥ π: every direction.
    pub full: bool,
}

impl From<&Cone> for ConeSc {
    fn from(k: &Cone) -> Self {
        let (sin, cos) = crate::pmath::sin_cos(k.angle);
        ConeSc {
            axis: k.axis,
            sin,
            cos,
            wide: k.is_wide(),
            full: k.angle >= PI,
        }
    }
}

/// The RAH node test (Roger et al. 2007; thesis eq. 3.16): does the node (origin sphere `s`,
/// cone `k`) possibly reach the ball `(p, d)`? With H the projection of P on the axis:
/// accept iff |C − H|·tan α + (d + r)/cos α ≥ |P − H|.
///
/// Conservative only for α < 90° (then also for P behind the apex, where it is merely loose);
/// wide cones always pass. `max_len` is the longest ray of the node (∞ when unbounded): a
/// ball farther than r + L + d from the centre cannot be reached.
#[inline]
pub fn node_hits_sphere_rah(s: &Sphere, k: &Cone, p: Vec3, d: f32, max_len: f32) -> bool {
    rah_test(s.center, s.radius, &ConeSc::from(k), p, d, max_len)
}

/// [`node_hits_sphere_rah`] with the cone's sine and cosine precomputed.
#[inline]
pub fn rah_test(c: Vec3, r: f32, k: &ConeSc, p: Vec3, d: f32, max_len: f32) -> bool {
    if k.wide {
        return true;
    }
    let cp = p - c;
    let len = cp.length();
    if len > (r + max_len + d) * (1.0 + 1e-5) {
        return false;
    }
    let along = cp.dot(k.axis);
    let radial = (cp - k.axis * along).length();
    // |C − H|·tan α + (d + r)/cos α ≥ |P − H|, multiplied through by cos α > 0; the slack of
    // 1e-5 of the distance absorbs the rounding of this f32 evaluation, so a ball touching
    // the cone's boundary is never rejected by rounding.
    along.abs() * k.sin + (d + r) + 1e-5 * len >= radial * k.cos
}

/// Exact variant: distance from P to the infinite solid cone with apex C ≤ d + r (the node's
/// reachable set is inside the Minkowski sum of that cone and the origin ball). Also valid
/// for wide cones up to α < π.
#[inline]
pub fn node_hits_sphere_exact(s: &Sphere, k: &Cone, p: Vec3, d: f32, max_len: f32) -> bool {
    exact_test(s.center, s.radius, &ConeSc::from(k), p, d, max_len)
}

/// [`node_hits_sphere_exact`] with the cone's sine and cosine precomputed (no trigonometry:
/// the angle comparisons are done on cosines).
#[inline]
pub fn exact_test(c: Vec3, r: f32, k: &ConeSc, p: Vec3, d: f32, max_len: f32) -> bool {
    let v = p - c;
    let len = v.length();
    let reach = d + r;
    if len > (r + max_len + d) * (1.0 + 1e-5) {
        return false;
    }
    if k.full || len <= reach {
        return true;
    }
    let a = v.dot(k.axis);
    // Inside the cone: angle(v, axis) ≤ α ⟺ a ≥ |v| cos α (slack for rounding).
    if a >= len * k.cos - 1e-5 * len {
        return true;
    }
    let dist = if !k.wide && a <= -len * k.sin {
        // Angle ≥ α + 90°: the apex is the closest point.
        len
    } else {
        let b = (v - k.axis * a).length();
        b * k.cos - a * k.sin // Distance to the cone's surface line.
    };
    dist <= reach * (1.0 + 4.0 * f32::EPSILON) + 1e-5 * len
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use proptest::prelude::*;

    fn unit() -> impl Strategy<Value = Vec3> {
        (0.0f32..1.0, 0.0f32..1.0).prop_map(|(a, b)| {
            let z = 2.0 * a - 1.0;
            let phi = b * std::f32::consts::TAU;
            let s = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(s * phi.cos(), s * phi.sin(), z)
        })
    }

    /// Directions clustered around an axis with a given spread.
    fn dirs_near(axis: Vec3, spread: f32, n: usize, rng: &mut Pcg32) -> Vec<Vec3> {
        (0..n)
            .map(|_| (axis + rng.unit_vector() * spread).normalize_or(axis))
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        /// Adding directions one by one (the level-1 construction) yields a cone containing
        /// every one of them, and its angle matches the exact 2-direction optimum.
        #[test]
        fn add_dir_contains_all(axis in unit(), spread in 0.0f32..2.0, seed in 0u64..10_000, n in 1usize..16) {
            let mut rng = Pcg32::new(seed, 9);
            let ds = dirs_near(axis, spread, n, &mut rng);
            let mut k = Cone::from_dir(ds[0]);
            for &d in &ds[1..] { k = k.add_dir(d); }
            for &d in &ds { prop_assert!(k.contains_dir(d), "{k:?} misses {d:?}"); }
            if n == 2 && !k.is_wide() {
                let half = angle_between(ds[0], ds[1]) * 0.5;
                prop_assert!((k.angle - half).abs() < 1e-4);
            }
        }

        /// Both unions contain every direction of both inputs; the exact one is never wider.
        #[test]
        fn unions_contain_inputs(a1 in unit(), a2 in unit(), s1 in 0.0f32..1.0, s2 in 0.0f32..1.0, seed in 0u64..10_000) {
            let mut rng = Pcg32::new(seed, 10);
            let d1 = dirs_near(a1, s1, 6, &mut rng);
            let d2 = dirs_near(a2, s2, 6, &mut rng);
            let build = |ds: &[Vec3]| ds[1..].iter().fold(Cone::from_dir(ds[0]), |k, &d| k.add_dir(d));
            let (k1, k2) = (build(&d1), build(&d2));
            let e = k1.union_exact(&k2);
            let t = k1.union_thesis(&k2);
            prop_assert!(e.angle <= t.angle + 1e-5);
            for &d in d1.iter().chain(&d2) {
                prop_assert!(e.contains_dir(d), "exact {e:?} misses {d:?}");
                prop_assert!(t.contains_dir(d), "thesis {t:?} misses {d:?}");
            }
        }

        /// Neither node test rejects a ball that one of the node's rays actually reaches.
        #[test]
        fn node_tests_are_conservative(
            axis in unit(), spread in 0.0f32..1.2, c in (-5.0f32..5.0, -5.0f32..5.0, -5.0f32..5.0),
            r in 0.0f32..2.0, seed in 0u64..100_000, ball_r in 0.0f32..1.0, t in 0.0f32..20.0,
        ) {
            let mut rng = Pcg32::new(seed, 11);
            let center = Vec3::new(c.0, c.1, c.2);
            let n = 8;
            let orgs: Vec<Vec3> = (0..n).map(|_| center + rng.unit_vector() * r * rng.next_f32()).collect();
            let ds = dirs_near(axis, spread, n, &mut rng);
            let k = ds[1..].iter().fold(Cone::from_dir(ds[0]), |k, &d| k.add_dir(d));
            let s = Sphere::new(center, r);
            let max_len = 20.0;
            // A ball touched by ray i at distance t (so the ray reaches it).
            let i = (seed as usize) % n;
            let p = orgs[i] + ds[i] * t + rng.unit_vector() * ball_r * rng.next_f32();
            prop_assert!(node_hits_sphere_exact(&s, &k, p, ball_r, max_len), "exact rejects: node {s:?} {k:?} ball {p:?} {ball_r}");
            prop_assert!(node_hits_sphere_rah(&s, &k, p, ball_r, max_len), "RAH rejects: node {s:?} {k:?} ball {p:?} {ball_r}");
        }
    }

    #[test]
    fn wide_guards() {
        let k = Cone::from_dir(Vec3::X).add_dir(-Vec3::X);
        assert!(k.is_wide());
        let k = Cone::from_dir(Vec3::X).add_dir(Vec3::Y).add_dir(-Vec3::Y);
        assert!(k.is_wide());
        let u = Cone {
            axis: Vec3::X,
            angle: 0.3,
        }
        .union_exact(&Cone {
            axis: -Vec3::X,
            angle: 0.3,
        });
        assert!(u.is_wide());
        assert!(Cone::from_dir(Vec3::X)
            .union_thesis(&Cone::from_dir(-Vec3::X))
            .is_wide());
        // RAH's formula is wrong for α ≥ 90°; the wide flag makes the node pass.
        let s = Sphere::new(Vec3::ZERO, 0.0);
        assert!(node_hits_sphere_rah(
            &s,
            &Cone {
                axis: Vec3::X,
                angle: 2.0
            },
            Vec3::new(-10.0, 0.5, 0.0),
            0.1,
            f32::INFINITY
        ));
    }

    #[test]
    fn tests_reject_far_balls() {
        let s = Sphere::new(Vec3::ZERO, 0.1);
        let k = Cone {
            axis: Vec3::Z,
            angle: 0.1,
        };
        // Off to the side of a narrow cone.
        assert!(!node_hits_sphere_exact(
            &s,
            &k,
            Vec3::new(5.0, 0.0, 5.0),
            0.5,
            f32::INFINITY
        ));
        assert!(!node_hits_sphere_rah(
            &s,
            &k,
            Vec3::new(5.0, 0.0, 5.0),
            0.5,
            f32::INFINITY
        ));
        // Along the axis but beyond the rays' length.
        assert!(!node_hits_sphere_exact(
            &s,
            &k,
            Vec3::new(0.0, 0.0, 50.0),
            0.5,
            10.0
        ));
        assert!(node_hits_sphere_exact(
            &s,
            &k,
            Vec3::new(0.0, 0.0, 5.0),
            0.5,
            10.0
        ));
    }
}
