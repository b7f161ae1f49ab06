//! The ray type: origin, direction and the parametric interval [t_min, t_max].

use glam::Vec3;

/// A ray `o + t·d` restricted to `t_min < t < t_max`.
///
/// Directions need not be normalised for the intersection kernels, but every generator in
/// rayspace produces unit directions so that `t` is a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub org: Vec3,
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(org: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Self {
        Ray {
            org,
            dir,
            t_min,
            t_max,
        }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.org + self.dir * t
    }
}

/// Move `p` off a surface with geometric normal `n` (pointing to the side the new ray leaves
/// from) by a few float ulps scaled with the magnitude of `p`.
///
/// This is Wächter & Binder, "A Fast and Robust Method for Avoiding Self-Intersection"
/// (Ray Tracing Gems, ch. 6): the offset is proportional to the rounding error of `p` itself,
/// so it works the same for a teapot at the origin and a stadium wall 10^4 units away, unlike
/// a fixed epsilon.
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let of_i = [
        (INT_SCALE * n.x) as i32,
        (INT_SCALE * n.y) as i32,
        (INT_SCALE * n.z) as i32,
    ];
    let pa = p.to_array();
    let na = n.to_array();
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let bits = pa[k].to_bits() as i32;
        let moved = if pa[k] < 0.0 {
            bits - of_i[k]
        } else {
            bits + of_i[k]
        };
        let p_i = f32::from_bits(moved as u32);
        out[k] = if pa[k].abs() < ORIGIN {
            pa[k] + FLOAT_SCALE * na[k]
        } else {
            p_i
        };
    }
    Vec3::from_array(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_along_normal_at_any_scale() {
        for &s in &[1e-3f32, 1.0, 1e3, 1e5] {
            let p = Vec3::new(0.3, -0.7, 0.5) * s;
            let n = Vec3::new(0.0, 1.0, 0.0);
            let q = offset_origin(p, n);
            assert!(q.y > p.y, "scale {s}");
            assert_eq!(q.x, p.x);
            // The move is small relative to the magnitude of p.
            assert!((q.y - p.y).abs() <= p.abs().max_element() * 1e-4 + 1e-4);
        }
    }
}
