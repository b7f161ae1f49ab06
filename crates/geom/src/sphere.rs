//! Spheres: triangle bounding spheres, unions (thesis eqs. 3.14–3.15 and the exact minimal
//! union), and sphere transformation for per-mesh culling (thesis §3.2.2).

use glam::{Mat4, Vec3};

/// A ball `|p - center| <= radius`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (≥ 0).
    pub radius: f32,
}

/// Relative padding applied to computed radii so that rounding can never make a bound
/// exclude a point it must contain.
const PAD: f32 = 8.0 * f32::EPSILON;

/// Grow `r` to absorb the rounding error of a centre whose largest coordinate is `c`.
#[inline]
fn padded(r: f32, c: Vec3) -> f32 {
    r * (1.0 + PAD) + c.abs().max_element() * PAD
}

impl Sphere {
    /// The sphere of `center` and `radius`.
    pub fn new(center: Vec3, radius: f32) -> Self {
        Sphere { center, radius }
    }

    /// Whether `p` lies in the closed ball.
    #[inline]
    pub fn contains(&self, p: Vec3) -> bool {
        (p - self.center).length() <= self.radius
    }

    /// The sphere around a box: its centre and half its diagonal, padded so that it contains
    /// every point of the box despite the rounding of both (the object hierarchy's node
    /// bounds, where the node tests want a sphere).
    pub fn around_box(b: &crate::Aabb) -> Sphere {
        let center = (b.min + b.max) * 0.5;
        let r = (b.max - center).length().max((center - b.min).length());
        Sphere {
            center,
            radius: padded(r, center),
        }
    }

    /// The minimal sphere of a triangle: the circumsphere when the triangle is acute, else the
    /// sphere on its longest edge; padded so that it contains every point of the triangle.
    ///
    /// (The centroid sphere with radius |v₁ − centroid| used in some RAH code does *not*
    /// contain its triangle: a vertex lies outside it in about 2/3 of random triangles.)
    pub fn of_triangle(a: Vec3, b: Vec3, c: Vec3) -> Sphere {
        let (ab, ac, bc) = (b - a, c - a, c - b);
        let (dab, dac) = (ab.length_squared(), ac.length_squared());
        // Obtuse or right at a vertex: the longest edge's midpoint sphere contains the triangle.
        let center = if ab.dot(ac) <= 0.0 {
            (b + c) * 0.5
        } else if (-ab).dot(bc) <= 0.0 {
            (a + c) * 0.5
        } else if ac.dot(bc) <= 0.0 {
            (a + b) * 0.5
        } else {
            let n = ab.cross(ac);
            let n2 = n.length_squared();
            if n2 > 0.0 && n2.is_finite() {
                a + (n.cross(ab) * dac + ac.cross(n) * dab) / (2.0 * n2)
            } else {
                (a + b + c) / 3.0
            }
        };
        // Radius from the actual vertices, so the padding covers the centre's rounding.
        let r = (a - center)
            .length()
            .max((b - center).length())
            .max((c - center).length());
        Sphere {
            center,
            radius: padded(r, center),
        }
    }

    /// Exact minimal sphere enclosing two spheres (see the notes): if one contains the other
    /// keep it, else the sphere on the far points of both along the centre line.
    pub fn union_exact(&self, o: &Sphere) -> Sphere {
        let d = (o.center - self.center).length();
        if d + o.radius <= self.radius {
            return *self;
        }
        if d + self.radius <= o.radius {
            return *o;
        }
        let r = (d + self.radius + o.radius) * 0.5;
        let center = if d > 0.0 {
            self.center + (o.center - self.center) * ((r - self.radius) / d)
        } else {
            self.center
        };
        Sphere {
            center,
            radius: padded(r, center),
        }
    }

    /// The thesis's union (eqs. 3.14–3.15): midpoint centre, half the distance plus the larger
    /// radius. Conservative but looser than [`Sphere::union_exact`].
    pub fn union_thesis(&self, o: &Sphere) -> Sphere {
        let center = (self.center + o.center) * 0.5;
        let r = (o.center - self.center).length() * 0.5 + self.radius.max(o.radius);
        Sphere {
            center,
            radius: padded(r, center),
        }
    }

    /// Bound of this sphere under an affine transform (thesis §3.2.2: the precomputed minimal
    /// sphere is updated, not recomputed): the centre is transformed and the radius scaled by
    /// an upper bound of the largest stretch of the linear part, [`max_axis_scale`].
    pub fn transformed(&self, m: &Mat4) -> Sphere {
        let center = m.transform_point3(self.center);
        let s = max_axis_scale(m);
        Sphere {
            center,
            radius: padded(self.radius * s, center),
        }
    }
}

/// An upper bound of the largest singular value (the largest stretch) of the linear part of `m`.
///
/// For rotation × axis scale the singular values are the column lengths, so this is the
/// largest axis scale. With shear the columns are not orthogonal; then we take
/// `min(‖A‖_F, sqrt(‖A‖₁·‖A‖_∞))`, both of which bound the spectral norm from above.
pub fn max_axis_scale(m: &Mat4) -> f32 {
    let c = [
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    ];
    let cols = c.map(|v| v.length());
    let orthogonal = c[0].dot(c[1]).abs() <= 1e-6 * cols[0] * cols[1]
        && c[1].dot(c[2]).abs() <= 1e-6 * cols[1] * cols[2]
        && c[0].dot(c[2]).abs() <= 1e-6 * cols[0] * cols[2];
    if orthogonal {
        // Rotation × axis scale: the singular values are the column lengths.
        cols[0].max(cols[1]).max(cols[2]) * (1.0 + 1e-6)
    } else {
        let frob = (cols[0] * cols[0] + cols[1] * cols[1] + cols[2] * cols[2]).sqrt();
        let abs = [c[0].abs(), c[1].abs(), c[2].abs()];
        let max_col_sum = abs.iter().map(|v| v.x + v.y + v.z).fold(0.0f32, f32::max);
        let max_row_sum = (0..3)
            .map(|i| abs[0][i] + abs[1][i] + abs[2][i])
            .fold(0.0f32, f32::max);
        frob.min((max_col_sum * max_row_sum).sqrt()) * (1.0 + 1e-6)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use glam::Quat;
    use proptest::prelude::*;

    use testkit::v3;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1024))]

        /// The triangle sphere contains every vertex and every sampled point of the triangle,
        /// and is no larger than the centroid sphere that does contain it.
        #[test]
        fn triangle_sphere_contains_triangle(a in v3(100.0), b in v3(100.0), c in v3(100.0), seed in 0u64..1000) {
            let s = Sphere::of_triangle(a, b, c);
            prop_assert!(s.contains(a) && s.contains(b) && s.contains(c));
            let mut rng = Pcg32::new(seed, 3);
            for _ in 0..32 {
                let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
                if u + v > 1.0 { u = 1.0 - u; v = 1.0 - v; }
                let p = a * (1.0 - u - v) + b * u + c * v;
                prop_assert!(s.contains(p));
            }
            let g = (a + b + c) / 3.0;
            let rg = (a - g).length().max((b - g).length()).max((c - g).length());
            prop_assert!(s.radius <= rg * (1.0 + 1e-4) + 1e-4);
        }

        /// The sphere around a box contains its corners and sampled points inside it.
        #[test]
        fn box_sphere_contains_box(a in v3(1000.0), b in v3(1000.0), seed in 0u64..1000) {
            let bx = crate::Aabb::new(a.min(b), a.max(b));
            let s = Sphere::around_box(&bx);
            let mut rng = Pcg32::new(seed, 5);
            for k in 0..8 {
                let pick = |bit: usize, lo: f32, hi: f32| if k >> bit & 1 == 0 { lo } else { hi };
                let c = Vec3::new(pick(0, bx.min.x, bx.max.x), pick(1, bx.min.y, bx.max.y), pick(2, bx.min.z, bx.max.z));
                prop_assert!(s.contains(c), "{s:?} misses corner {c:?} of {bx:?}");
            }
            for _ in 0..32 {
                let p = bx.min + (bx.max - bx.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                prop_assert!(s.contains(p.clamp(bx.min, bx.max)));
            }
        }

        #[test]
        fn unions_contain_both(c1 in v3(50.0), r1 in 0.0f32..20.0, c2 in v3(50.0), r2 in 0.0f32..20.0, seed in 0u64..1000) {
            let s1 = Sphere::new(c1, r1);
            let s2 = Sphere::new(c2, r2);
            let e = s1.union_exact(&s2);
            let t = s1.union_thesis(&s2);
            prop_assert!(e.radius <= t.radius * (1.0 + 1e-5) + 1e-5, "exact union is never looser");
            let mut rng = Pcg32::new(seed, 4);
            for s in [s1, s2] {
                for _ in 0..16 {
                    let p = s.center + rng.unit_vector() * s.radius;
                    // p itself carries rounding error of order |p|·ε.
                    let tol = 1e-6 * (1.0 + p.abs().max_element());
                    prop_assert!((p - e.center).length() <= e.radius + tol, "exact {e:?} misses {p:?} of {s:?}");
                    prop_assert!((p - t.center).length() <= t.radius + tol);
                }
            }
        }

        /// A transformed sphere contains every transformed point of the original sphere,
        /// including under non-uniform scale and shear.
        #[test]
        fn transformed_sphere_contains_transformed_points(
            c in v3(10.0), r in 0.0f32..5.0, axis in v3(1.0), angle in 0.0f32..6.3,
            sc in (0.01f32..10.0, 0.01f32..10.0, 0.01f32..10.0), t in v3(100.0), shear in -2.0f32..2.0, seed in 0u64..1000,
        ) {
            prop_assume!(axis.length() > 1e-3);
            let mut m = Mat4::from_scale_rotation_translation(Vec3::new(sc.0, sc.1, sc.2), Quat::from_axis_angle(axis.normalize(), angle), t);
            if seed % 2 == 0 {
                m *= Mat4::from_cols_array(&[1.0, shear, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
            }
            let s = Sphere::new(c, r);
            let ts = s.transformed(&m);
            let mut rng = Pcg32::new(seed, 5);
            for _ in 0..32 {
                let p = c + rng.unit_vector() * r * rng.next_f32().sqrt();
                let q = m.transform_point3(p);
                prop_assert!((q - ts.center).length() <= ts.radius * (1.0 + 1e-5) + 1e-4);
            }
        }
    }

    #[test]
    fn acute_triangle_gets_circumsphere() {
        let s = Sphere::of_triangle(
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(-0.5, 0.866, 0.0),
            Vec3::new(-0.5, -0.866, 0.0),
        );
        assert!(s.center.length() < 1e-3);
        assert!((s.radius - 1.0).abs() < 1e-3);
        // Obtuse: midpoint of the longest edge.
        let s = Sphere::of_triangle(
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.1, 0.0),
        );
        assert!(s.center.length() < 1e-6 && (s.radius - 1.0).abs() < 1e-5);
    }
}
