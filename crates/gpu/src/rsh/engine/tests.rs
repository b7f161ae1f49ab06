//! The engine's own tests (device counters that carry into their high words).

use super::*;

/// The traversal's 64-bit device counters carry: with every counter's low word started
/// just below 2³², the counts come back as the plain run's plus the start, high words
/// and all.
#[test]
fn device_counters_carry_into_their_high_words() {
    let Some(g) = testkit::or_skip(Gpu::new(), "gpu") else {
        return;
    };
    let s = scene::builtin::cornell();
    let geo = Geometry::from_scene(&s);
    // The mesh-sphere traversal (the counter bias is its traversal's).
    let cfg = RshConfig {
        objects: ObjectHierarchy::MeshSpheres,
        ..RshConfig::crsh()
    };
    let eng = GpuRsh::new(g, &geo, cfg).unwrap();
    let view = render::View::new(&s.camera, 48, 40);
    let rays = view.primary_rays();
    let run = |bias: u32| {
        eng.counter_bias
            .store(bias, std::sync::atomic::Ordering::Relaxed);
        let mut ex = Exec::new(&eng.s.gpu, &eng.s.kernels);
        let dr = DeviceRays::upload(&eng.s.gpu, &rays);
        let (_, c, _, _) = eng.records(
            &mut ex,
            &dr,
            TraceMode::Closest,
            &mut TraceStats::default(),
            None,
        );
        ex.finish();
        c
    };
    let plain = run(0);
    let bias = u32::MAX - 3;
    let biased = run(bias);
    let b = bias as u64;
    let mut wrapped = 0;
    for (p, q) in plain.tests.iter().zip(&biased.tests) {
        for k in 0..4 {
            assert_eq!(q[k], p[k] + b, "tests");
            wrapped += (p[k] > 3) as u32;
        }
    }
    for (p, q) in plain.hits.iter().zip(&biased.hits) {
        for k in 0..4 {
            assert_eq!(q[k], p[k] + b, "passes");
        }
    }
    for k in 0..4 {
        assert_eq!(
            biased.final_tests[k],
            plain.final_tests[k] + b,
            "final tests"
        );
    }
    assert!(wrapped > 0, "some low word wrapped");
}
