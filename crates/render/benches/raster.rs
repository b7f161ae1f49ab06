//! Rasterizer time for 512×512 frames of the built-in scenes.

use criterion::{criterion_group, criterion_main, Criterion};
use render::raster::{default_near, rasterize};
use render::View;
use scene::{builtin, Geometry};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("rasterize 512x512");
    for name in ["cornell", "office", "stadium"] {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let view = View::new(&s.camera, 512, 512);
        g.bench_function(name, |b| {
            b.iter(|| rasterize(&geo, &s.materials, &view, default_near(&geo)))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
