//! One trace call of CRSH with the object hierarchy (the dual traversal, its default) on a
//! frame's shadow rays, and the per-frame object-hierarchy build: Dabrovic Sponza at 512² when the shared
//! scenes are present (`RAYSPACE_SCENES`), else the built-in office at 256². The figures of
//! issue 16's "build + trace" come from these two. Throughput is in rays.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use render::raygen::{generate, Kind, Options};
use rsh::{ObjectHierarchy, RshConfig, RshEngine};
use scene::{Geometry, LoadOptions};
use trace::{Hit, TraceMode, TraceStats, Tracer};

fn bench(c: &mut Criterion) {
    let sponza = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../bench/scenes/sponza.toml"
    );
    let (s, side) = match scene::load(sponza, &LoadOptions::default()) {
        Ok(s) => (s, 512),
        Err(e) => {
            eprintln!("SKIPPED: Sponza ({e}); the built-in office instead");
            (scene::builtin::by_name("office").unwrap(), 256)
        }
    };
    let geo = Geometry::from_scene(&s);
    let opts = Options {
        width: side,
        height: side,
        spp: 1,
        seed: 1,
        ao_distance: None,
    };
    let rays = generate(&s, &geo, Kind::Shadow, &opts);
    let cfg = RshConfig {
        objects: ObjectHierarchy::Bvh,
        ..RshConfig::crsh()
    };
    let mut g = c.benchmark_group(format!("CRSH 8/2 + BVH, {} shadow rays", s.name));
    g.sample_size(10);
    g.throughput(Throughput::Elements(rays.len() as u64));
    let engine = RshEngine::new(&geo, cfg.clone()).unwrap();
    g.bench_function("trace (any hit)", |b| {
        let mut hits = vec![Hit::MISS; rays.len()];
        b.iter(|| engine.trace(&rays, TraceMode::Any, &mut hits, &mut TraceStats::default()))
    });
    g.bench_function("object hierarchy build", |b| {
        b.iter(|| RshEngine::new(&geo, cfg.clone()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
