//! The ray type: origin, direction and the parametric interval [t_min, t_max].

use glam::Vec3;

/// A ray `o + t·d` restricted to `t_min < t < t_max`.
///
/// Directions need not be normalised for the intersection kernels, but every generator in
/// rayspace produces unit directions so that `t` is a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub org: Vec3,
    /// Direction (unit length for every ray the renderer makes; the kernels do not require it).
    pub dir: Vec3,
    /// Hits at t ≤ t_min are ignored (open interval).
    pub t_min: f32,
    /// Hits at t ≥ t_max are ignored (open interval; a shadow ray ends at its light).
    pub t_max: f32,
}

impl Ray {
    /// A ray with the open parameter interval (t_min, t_max).
    pub fn new(org: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Self {
        Ray {
            org,
            dir,
            t_min,
            t_max,
        }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.org + self.dir * t
    }
}

/// Relative size of the offset in [`offset_point`]: 2^-16 ≈ 128 ε.
pub const OFFSET_REL: f32 = 1.0 / 65536.0;

/// Move the surface point `p` off its surface along the unit normal `n` (pointing to the
/// side the new ray leaves from or ends on) by `OFFSET_REL · max(|p|, magnitude)`, where
/// `magnitude` is the largest absolute coordinate of the triangle's vertices and of the ray's
/// other endpoint (e.g. the light).
///
/// Why this size: the watertight test computes t with an absolute error of a few ε·M
/// (M the magnitude of the coordinates it subtracts), divided by sin θ for a ray at angle θ to
/// the plane. Moving the point h along the normal moves the plane crossing by h / sin θ along
/// the ray, so with h = 128 ε·M the clearance beats the error by a wide margin *at every
/// angle*: the grazing factor cancels. An offset of a few ulps of p itself (Wächter & Binder
/// 2019) is not enough when the triangle's vertices are much larger than p (a point near the
/// origin on a floor 10³ units wide; see the `stadium` scene).
#[inline]
pub fn offset_point(p: Vec3, n: Vec3, magnitude: f32) -> Vec3 {
    let m = p.abs().max_element().max(magnitude).max(1e-30);
    p + n * (m * OFFSET_REL)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tri::{intersect, RayPre};
    use crate::Pcg32;

    /// Rays leaving from or ending at an offset point never hit the triangle the point lies
    /// on, for large and far triangles and grazing directions alike.
    #[test]
    fn offset_points_clear_their_triangle() {
        let mut rng = Pcg32::new(11, 2);
        let mut grazing = 0;
        for case in 0..20_000 {
            let scale = [1e-2f32, 1.0, 1e2, 1e4][case % 4];
            let c = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            ) * scale;
            let tri = [0, 1, 2].map(|_| c + rng.unit_vector() * scale * rng.range(0.5, 2.0));
            let ng = crate::tri::geometric_normal(tri[0], tri[1], tri[2]);
            if ng == Vec3::ZERO
                || crate::tri::double_area(tri[0], tri[1], tri[2]) < 1e-3 * scale * scale
            {
                continue;
            }
            let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let p = tri[0] * (1.0 - u - v) + tri[1] * u + tri[2] * v;
            let mag = tri
                .iter()
                .map(|t| t.abs().max_element())
                .fold(0.0, f32::max);
            // A light on the normal's side, possibly at a grazing angle and far away.
            let mut dir = rng.unit_vector();
            if dir.dot(ng) < 0.0 {
                dir = -dir;
            }
            let dist = scale * rng.range(0.01, 1000.0);
            let light = p + dir * dist;
            if dir.dot(ng) < 0.01 {
                grazing += 1;
            }
            let lm = mag.max(light.abs().max_element());
            let end = offset_point(p, ng, lm);
            let d = end - light;
            let len = d.length();
            let shadow = RayPre::new(&Ray::new(light, d / len, 0.0, len));
            assert!(
                intersect(&shadow, tri[0], tri[1], tri[2]).is_none(),
                "shadow acne at scale {scale}"
            );
            let org = offset_point(p, ng, mag);
            let leave = RayPre::new(&Ray::new(org, dir, 0.0, f32::INFINITY));
            assert!(
                intersect(&leave, tri[0], tri[1], tri[2]).is_none(),
                "self-hit at scale {scale}"
            );
        }
        assert!(grazing > 50, "grazing cases were exercised");
    }
}
