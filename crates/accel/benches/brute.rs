//! Ray–triangle tests per second of the brute-force engine (throughput in tests, not rays).

use accel::BruteForce;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use geom::{Pcg32, Ray};
use scene::{builtin, Geometry};
use trace::{Hit, RayBatch, RayKind, TraceMode, TraceStats, Tracer};

fn bench(c: &mut Criterion) {
    let s = builtin::cornell();
    let geo = Geometry::from_scene(&s);
    let bf = BruteForce::new(&geo);
    let mut rng = Pcg32::new(1, 1);
    let rays: Vec<Ray> = (0..4096)
        .map(|_| {
            Ray::new(
                rng.unit_vector() * 0.8,
                rng.unit_vector(),
                0.0,
                f32::INFINITY,
            )
        })
        .collect();
    let batch = RayBatch::from_rays(&rays, RayKind::Reflection);
    let mut g = c.benchmark_group("brute force (cornell, 4096 rays)");
    g.throughput(Throughput::Elements((rays.len() * geo.len()) as u64));
    g.bench_function("closest hit: ray-triangle tests", |b| {
        let mut hits = vec![Hit::MISS; rays.len()];
        b.iter(|| {
            bf.trace(
                &batch,
                TraceMode::Closest,
                &mut hits,
                &mut TraceStats::default(),
            )
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
