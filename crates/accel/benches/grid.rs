//! The irregular grid's traversal kernels on the same grid and rays: the 8-lane AVX2 kernel
//! (`accel::grid::lanes`, what the engine runs on such CPUs) against the scalar stream
//! (`traverse::trace_stream`, the fallback), single-threaded, on built-in scenes (the real
//! scenes' figures are `rayspace bench grid`'s).

use accel::grid::{build_grid, lanes, traverse, GridConfig};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use render::raygen::{generate, Kind, Options};
use render::View;
use scene::{builtin, Geometry};
use trace::{Hit, RayBatch, TraceMode};

fn bench(c: &mut Criterion) {
    for name in ["office", "spheres"] {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let grid = build_grid(&geo.tris, &GridConfig::default()).unwrap();
        let opts = Options {
            width: 256,
            height: 256,
            spp: 1,
            seed: 1,
            ao_distance: None,
        };
        let kinds: [(&str, RayBatch, TraceMode); 3] = [
            (
                "primary",
                View::new(&s.camera, 256, 256).primary_rays(),
                TraceMode::Closest,
            ),
            ("ao", generate(&s, &geo, Kind::Ao, &opts), TraceMode::Any),
            (
                "random",
                generate(&s, &geo, Kind::Random, &opts),
                TraceMode::Closest,
            ),
        ];
        let mut g = c.benchmark_group(format!("grid traversal ({name}, 1 thread)"));
        for (kind, rays, mode) in &kinds {
            g.throughput(Throughput::Elements(rays.len() as u64));
            let mut hits = vec![Hit::MISS; rays.len()];
            g.bench_function(format!("{kind}: scalar stream"), |b| {
                b.iter(|| traverse::trace_stream(&grid, &geo.tris, rays, 0, &mut hits, *mode))
            });
            if lanes::available() {
                g.bench_function(format!("{kind}: 8 lanes"), |b| {
                    b.iter(|| lanes::trace(&grid, &geo.tris, rays, 0, &mut hits, *mode))
                });
            } else {
                eprintln!("SKIPPED: 8 lanes: this CPU has no AVX2");
            }
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
