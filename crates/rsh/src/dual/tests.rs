//! The dual traversal against brute force and its parts against f64 references.

use super::*;
use geom::{Aabb, Pcg32};
use proptest::prelude::*;

/// Whether the ray meets the box, in f64 (the slab test without rounding to speak of).
fn meets(o: Vec3, d: Vec3, t0: f32, t1: f32, b: &Aabb) -> bool {
    let (mut tn, mut tf) = (t0 as f64, t1 as f64);
    for k in 0..3 {
        let (o, d, lo, hi) = (o[k] as f64, d[k] as f64, b.min[k] as f64, b.max[k] as f64);
        if d == 0.0 {
            if o < lo || o > hi {
                return false;
            }
            continue;
        }
        let (a, c) = ((lo - o) / d, (hi - o) / d);
        tn = tn.max(a.min(c));
        tf = tf.min(a.max(c));
    }
    tn <= tf
}

/// A node of `rays` for the beam test alone (its cone fields are not read).
fn beam_node(rays: &[(Vec3, Vec3, f32, f32)]) -> RayNode {
    let beam = beam_union(
        rays.iter()
            .map(|&(o, d, t0, t1)| (o, o, d.recip(), d.recip(), t0, t1)),
    );
    RayNode {
        center: Vec3::ZERO,
        radius: 0.0,
        cone: ConeSc {
            axis: Vec3::X,
            sin: 1.0,
            cos: 0.0,
            wide: true,
            full: true,
        },
        max_t: rays.iter().map(|r| r.3).fold(0.0, f32::max),
        reach: f32::INFINITY,
        kind: 0,
        omin: beam.0,
        omax: beam.1,
        ilo: beam.2,
        ihi: beam.3,
        tmin: beam.4,
        tmax: beam.5,
    }
}

/// A random ray node: a bundle of up to 8 rays (some axis-parallel, some unbounded) with
/// a random cone, sometimes wide.
fn random_node(rng: &mut Pcg32, scale: f32) -> RayNode {
    let c = Vec3::new(
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
    ) * scale;
    let axis = rng.unit_vector();
    let spread = rng.range(0.0, 1.0);
    let n = 1 + (rng.next_f32() * 8.0) as usize;
    let flat = (rng.next_f32() * 5.0) as usize;
    let rays: Vec<_> = (0..n)
        .map(|i| {
            let o = c + rng.unit_vector() * spread * scale * 0.1;
            let mut d = (axis + rng.unit_vector() * spread).normalize_or(Vec3::X);
            if i % 2 == 0 && flat < 3 {
                d[flat] = 0.0;
                d = d.normalize_or(Vec3::Y);
            }
            let t1 = if rng.next_f32() < 0.3 {
                f32::INFINITY
            } else {
                rng.range(0.1, 4.0) * scale
            };
            (o, d, rng.range(0.0, 0.01) * scale, t1)
        })
        .collect();
    let mut node = beam_node(&rays);
    let angle = rng.range(0.0, 2.0);
    node.center = c;
    node.radius = spread * scale * 0.1;
    node.cone = ConeSc {
        axis,
        sin: angle.sin(),
        cos: angle.cos(),
        wide: angle >= std::f32::consts::FRAC_PI_2,
        full: false,
    };
    if rng.next_f32() < 0.2 {
        node.max_t = f32::INFINITY;
    }
    if rng.next_f32() < 0.2 {
        node.tmax = f32::INFINITY;
    }
    node
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2048))]

    /// Eight nodes in lanes give the scalar tests' answers bit for bit (RAH's cone test and
    /// the beam test), whatever the nodes and the object.
    #[test]
    fn lanes_equal_the_scalar_node_test(seed in 0u64..1_000_000, scale in 0.01f32..1000.0) {
        if !node8::available() {
            testkit::skip("avx2", "this CPU has no AVX: the dual traversal tests nodes one at a time");
            return Ok(());
        }
        let mut rng = Pcg32::new(seed, 11);
        let nodes: Vec<RayNode> = (0..13).map(|_| random_node(&mut rng, scale)).collect();
        let lanes = NodeLanes::new(nodes.len(), |i| nodes[i].fields());
        for _ in 0..16 {
            let lo = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)) * scale;
            let ext = Vec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0)) * scale * rng.range(0.0, 1.0);
            let b = Aabb::new(lo, lo + ext);
            let (p, d) = (b.center(), ext.length() * 0.5);
            // Besides the object's own radius, radii right at each node's cone boundary
            // (where one rounding decides), a few ulps either side.
            let at_boundary = |x: &RayNode| {
                let cp = p - x.center;
                let along = cp.dot(x.cone.axis);
                let radial = (cp - x.cone.axis * along).length();
                radial * x.cone.cos - along.abs() * x.cone.sin - x.radius - 1e-5 * cp.length()
            };
            let mut radii = vec![d];
            for x in &nodes[..3] {
                let d0 = at_boundary(x).max(0.0);
                radii.extend((0..7u32).map(|k| f32::from_bits((d0.to_bits() + k).saturating_sub(3))));
            }
            for d in radii {
                for first in [0usize, 5] {
                    let m = node8::test8(&lanes, first, p, d, &b);
                    for i in 0..8.min(nodes.len() - first) {
                        let x = &nodes[first + i];
                        let scalar = x.beam_test(&b) && x.cone_test(NodeTest::Rah, p, d);
                        prop_assert_eq!(m >> i & 1 != 0, scalar, "node {} radius {}", first + i, d);
                    }
                }
            }
        }
    }

    /// One node against a collapsed node's children in lanes gives the scalar tests'
    /// answers bit for bit, lanes past the children masked off: objects near and far,
    /// radii at the node's cone boundary, nodes of every kind.
    #[test]
    fn object_lanes_equal_the_scalar_node_test(seed in 0u64..1_000_000, scale in 0.01f32..1000.0, count in 1usize..9) {
        if !node8::available() {
            testkit::skip("avx2", "this CPU has no AVX: the dual traversal tests nodes one at a time");
            return Ok(());
        }
        let mut rng = Pcg32::new(seed, 13);
        for _ in 0..8 {
            let x = random_node(&mut rng, scale);
            let mut w = accel::bvh::objects::WideNode {
                center: [[0.0; 8]; 3],
                radius: [0.0; 8],
                min: [[0.0; 8]; 3],
                max: [[0.0; 8]; 3],
                child: [0; 8],
                count: count as u32,
            };
            let mut objects = Vec::new();
            for i in 0..8 {
                let lo = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)) * scale;
                let ext = Vec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0)) * scale * rng.range(0.0, 1.0);
                let b = Aabb::new(lo, lo + ext);
                let p = b.center();
                // Half the lanes right at the node's cone boundary (one rounding decides).
                let d = if i % 2 == 0 {
                    ext.length() * 0.5
                } else {
                    let cp = p - x.center;
                    let along = cp.dot(x.cone.axis);
                    let radial = (cp - x.cone.axis * along).length();
                    let d0 = (radial * x.cone.cos - along.abs() * x.cone.sin - x.radius - 1e-5 * cp.length()).max(0.0);
                    f32::from_bits((d0.to_bits() + rng.below(7)).saturating_sub(3))
                };
                for k in 0..3 {
                    w.center[k][i] = p[k];
                    w.min[k][i] = b.min[k];
                    w.max[k][i] = b.max[k];
                }
                w.radius[i] = d;
                objects.push((b, p, d));
            }
            let m = node8::test8_objects(&x.fields(), &w);
            for (i, (b, p, d)) in objects.iter().enumerate() {
                let scalar = i < count && x.beam_test(b) && x.cone_test(NodeTest::Rah, *p, *d);
                prop_assert_eq!(m >> i & 1 != 0, scalar, "lane {} of {}", i, count);
            }
        }
    }

    /// The beam test never culls a box that one of the node's rays meets: coherent
    /// and incoherent bundles, axis-parallel directions, boxes thin and far.
    #[test]
    fn beam_test_is_conservative(seed in 0u64..1_000_000, n in 1usize..9, spread in 0.0f32..1.0, scale in 0.01f32..1000.0, flat in 0usize..4) {
        let mut rng = Pcg32::new(seed, 7);
        let c = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * scale;
        let axis = rng.unit_vector();
        let rays: Vec<_> = (0..n).map(|i| {
            let o = c + Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * spread * scale * 0.1;
            let mut d = (axis + rng.unit_vector() * spread).normalize_or(Vec3::X);
            if i % 3 == 0 && flat < 3 {
                d[flat] = 0.0;
                d = d.normalize_or(Vec3::Y);
            }
            let t1 = if rng.next_f32() < 0.3 { f32::INFINITY } else { rng.range(0.1, 4.0) * scale };
            (o, d, rng.range(0.0, 0.01) * scale, t1)
        }).collect();
        let node = beam_node(&rays);
        for _ in 0..16 {
            let lo = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0)) * scale;
            let mut ext = Vec3::new(rng.range(0.0, 1.0), rng.range(0.0, 1.0), rng.range(0.0, 1.0)) * scale;
            if flat < 3 {
                ext[flat] = 0.0;
            }
            let b = Aabb::new(lo, lo + ext);
            if rays.iter().any(|&(o, d, t0, t1)| meets(o, d, t0, t1, &b)) {
                prop_assert!(node.beam_test(&b), "{b:?} culled for {rays:?}");
            }
        }
    }
}
