//! Minimal enclosing ball of a point set (thesis §3.2.1: the per-mesh culling sphere).
//!
//! Welzl's algorithm in its iterative move-free form (Welzl 1991; the nested-loop formulation
//! as in Gärtner's notes): points in a fixed pseudo-random order, and for each point outside
//! the current ball, the ball is rebuilt with that point on the boundary. Expected O(n).
//! Arithmetic is in f64; the final radius is the exact maximum distance from the centre to
//! the input (plus padding), so containment never depends on the solver's accuracy.

use crate::rng::Pcg32;
use crate::sphere::Sphere;
use glam::{DVec3, Vec3};

#[derive(Clone, Copy, Debug)]
struct Ball {
    c: DVec3,
    r2: f64,
}

impl Ball {
    const EMPTY: Ball = Ball {
        c: DVec3::ZERO,
        r2: -1.0,
    };

    #[inline]
    fn contains(&self, p: DVec3) -> bool {
        // Relative tolerance: a point on the boundary up to rounding counts as inside,
        // otherwise the rebuild loops can flip forever on cospherical input.
        (p - self.c).length_squared() <= self.r2 * (1.0 + 1e-10) + 1e-20
    }
}

fn ball2(a: DVec3, b: DVec3) -> Ball {
    let c = (a + b) * 0.5;
    Ball {
        c,
        r2: (a - c).length_squared(),
    }
}

/// Smallest ball with a, b, c on its boundary: the circumcircle's ball (centre in the plane).
fn ball3(a: DVec3, b: DVec3, c: DVec3) -> Ball {
    let ab = b - a;
    let ac = c - a;
    let n = ab.cross(ac);
    let n2 = n.length_squared();
    if n2 <= 1e-24 * ab.length_squared().max(ac.length_squared()).powi(2) {
        // Collinear: the diametral ball of the farthest pair.
        return [ball2(a, b), ball2(a, c), ball2(b, c)]
            .into_iter()
            .max_by(|x, y| x.r2.total_cmp(&y.r2))
            .unwrap();
    }
    let off = (n.cross(ab) * ac.length_squared() + ac.cross(n) * ab.length_squared()) / (2.0 * n2);
    Ball {
        c: a + off,
        r2: off.length_squared(),
    }
}

/// Ball with a, b, c, d on its boundary (circumsphere); for (nearly) coplanar points the
/// smallest of the 3-point balls that contains all four.
fn ball4(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> Ball {
    let u = b - a;
    let v = c - a;
    let w = d - a;
    let det = u.dot(v.cross(w));
    let scale = u.length() * v.length() * w.length();
    if det.abs() > 1e-12 * scale {
        let off = (v.cross(w) * u.length_squared()
            + w.cross(u) * v.length_squared()
            + u.cross(v) * w.length_squared())
            / (2.0 * det);
        return Ball {
            c: a + off,
            r2: off.length_squared(),
        };
    }
    let pts = [a, b, c, d];
    let mut best = Ball {
        c: a,
        r2: f64::INFINITY,
    };
    for skip in 0..4 {
        let q: Vec<DVec3> = (0..4).filter(|&i| i != skip).map(|i| pts[i]).collect();
        let ball = ball3(q[0], q[1], q[2]);
        if pts.iter().all(|&p| ball.contains(p)) && ball.r2 < best.r2 {
            best = ball;
        }
    }
    best
}

/// The minimal ball enclosing `points`; `None` for an empty set.
pub fn minimal_ball(points: &[Vec3]) -> Option<Sphere> {
    if points.is_empty() {
        return None;
    }
    // Small sets (a ray node's origins: b ≤ 16 in the thesis's configurations) on the stack:
    // the hierarchy's build calls this once per level-1 node, on every trace.
    const SMALL: usize = 16;
    let mut small = [DVec3::ZERO; SMALL];
    let mut large = Vec::new();
    let p: &mut [DVec3] = if points.len() <= SMALL {
        for (d, v) in small.iter_mut().zip(points) {
            *d = v.as_dvec3();
        }
        &mut small[..points.len()]
    } else {
        large.extend(points.iter().map(|v| v.as_dvec3()));
        &mut large
    };
    // A fixed shuffle: expected linear time without giving up determinism.
    let mut rng = Pcg32::new(0x6d696e69, 0x62616c6c);
    for i in (1..p.len()).rev() {
        let j = rng.below(i as u32 + 1) as usize;
        p.swap(i, j);
    }
    let mut ball = Ball::EMPTY;
    for i in 0..p.len() {
        if ball.contains(p[i]) {
            continue;
        }
        // p[i] on the boundary.
        ball = Ball { c: p[i], r2: 0.0 };
        for j in 0..i {
            if ball.contains(p[j]) {
                continue;
            }
            ball = ball2(p[i], p[j]);
            for k in 0..j {
                if ball.contains(p[k]) {
                    continue;
                }
                ball = ball3(p[i], p[j], p[k]);
                for l in 0..k {
                    if !ball.contains(p[l]) {
                        ball = ball4(p[i], p[j], p[k], p[l]);
                    }
                }
            }
        }
    }
    let c = ball.c;
    let r = p.iter().map(|q| (*q - c).length()).fold(0.0f64, f64::max);
    let center = c.as_vec3();
    // Containment in f32: the radius measured from the rounded centre, then padded.
    let r32 = points
        .iter()
        .map(|q| (*q - center).length())
        .fold(r as f32, f32::max);
    Some(Sphere {
        center,
        radius: r32 * (1.0 + 8.0 * f32::EPSILON) + center.abs().max_element() * 8.0 * f32::EPSILON,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute-force oracle for small sets: the smallest of all balls determined by ≤ 4 points
    /// that contains every point.
    fn oracle(pts: &[Vec3]) -> f64 {
        let p: Vec<DVec3> = pts.iter().map(|v| v.as_dvec3()).collect();
        let n = p.len();
        let mut best = f64::INFINITY;
        let mut consider = |b: Ball| {
            if p.iter()
                .all(|&q| (q - b.c).length_squared() <= b.r2 * (1.0 + 1e-9) + 1e-12)
            {
                best = best.min(b.r2.sqrt());
            }
        };
        for i in 0..n {
            consider(Ball { c: p[i], r2: 0.0 });
            for j in i + 1..n {
                consider(ball2(p[i], p[j]));
                for k in j + 1..n {
                    consider(ball3(p[i], p[j], p[k]));
                    for l in k + 1..n {
                        consider(ball4(p[i], p[j], p[k], p[l]));
                    }
                }
            }
        }
        best
    }

    fn pts(max: usize) -> impl Strategy<Value = Vec<Vec3>> {
        prop::collection::vec(
            (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0)
                .prop_map(|(x, y, z)| Vec3::new(x, y, z)),
            1..max,
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        #[test]
        fn matches_brute_force_oracle(p in pts(9)) {
            let s = minimal_ball(&p).unwrap();
            for q in &p { prop_assert!(s.contains(*q)); }
            let o = oracle(&p);
            prop_assert!((s.radius as f64 - o).abs() <= 1e-4 * (1.0 + o), "ours {} oracle {}", s.radius, o);
        }

        /// Degenerate sets: duplicates, collinear and coplanar points.
        #[test]
        fn degenerate_sets(p in pts(7), kind in 0usize..3) {
            let q: Vec<Vec3> = match kind {
                0 => p.iter().flat_map(|v| [*v, *v]).collect(),
                1 => p.iter().map(|v| Vec3::new(v.x, 2.0 * v.x, -v.x)).collect(),
                _ => p.iter().map(|v| Vec3::new(v.x, v.y, 3.0)).collect(),
            };
            let s = minimal_ball(&q).unwrap();
            for v in &q { prop_assert!(s.contains(*v)); }
            let o = oracle(&q);
            prop_assert!((s.radius as f64 - o).abs() <= 1e-4 * (1.0 + o), "ours {} oracle {}", s.radius, o);
        }

        /// Large sets: contains every point and is no larger than the bounding box's sphere.
        #[test]
        fn large_sets(p in prop::collection::vec((-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0).prop_map(|(x, y, z)| Vec3::new(x, y, z)), 1..400)) {
            let s = minimal_ball(&p).unwrap();
            for q in &p { prop_assert!(s.contains(*q)); }
            let b = crate::Aabb::from_points(p.iter().copied());
            prop_assert!(s.radius <= b.diagonal() * 0.5 * (1.0 + 1e-5) + 1e-5);
        }
    }

    #[test]
    fn empty_and_single() {
        assert!(minimal_ball(&[]).is_none());
        let s = minimal_ball(&[Vec3::new(1.0, 2.0, 3.0)]).unwrap();
        assert!(s.radius < 1e-5);
    }

    #[test]
    fn sphere_points() {
        let mut rng = Pcg32::new(3, 3);
        let p: Vec<Vec3> = (0..20_000)
            .map(|_| Vec3::new(5.0, -2.0, 1.0) + rng.unit_vector() * 3.0)
            .collect();
        let s = minimal_ball(&p).unwrap();
        assert!((s.center - Vec3::new(5.0, -2.0, 1.0)).length() < 0.05);
        assert!((s.radius - 3.0).abs() < 0.01);
    }
}
