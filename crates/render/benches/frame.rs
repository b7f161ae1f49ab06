//! The frame around the trace, phase by phase, on Kitchen-sized inputs: BART Kitchen
//! (110,520 triangles, six lights; read from the shared scenes when present, else left out
//! with a note), then the built-in `office` (reflection and refraction rays) and `spheres`,
//! at 512², each phase with its buffers kept from the last iteration as a frame sequence
//! keeps them:
//! - `update`: the scene at a new time into the kept geometry (`Geometry::refill_at`);
//! - `raster`: the G-buffer (`rasterize_into` with its scratch);
//! - `ray creation`: the G-buffer's surfaces, their shadow rays and bounce rays;
//! - `shading`: eq. 3.19 for every surface under every light (`local_shading`).

use criterion::{criterion_group, criterion_main, Criterion};
use render::raster::{default_near, rasterize_into, GBuffer, RasterScratch};
use render::secondary::{bounce_rays_into, shadow_rays_into, Surfaces};
use render::View;
use scene::{Geometry, LoadOptions};
use trace::RayBatch;

fn kitchen() -> Option<scene::Scene> {
    let aff = scene::scenes_dir().map(|d| d.join("bart-kitchen/aff/kitchen.aff"));
    match aff.filter(|p| p.exists()) {
        Some(p) => Some(
            scene::load(p.to_str().expect("a UTF-8 path"), &LoadOptions::default())
                .expect("BART Kitchen loads"),
        ),
        None => {
            eprintln!("note: no shared scenes: the frame benchmark leaves BART Kitchen out");
            None
        }
    }
}

fn bench(c: &mut Criterion) {
    let builtin = |n: &str| scene::builtin::by_name(n).expect("built in");
    for base in kitchen()
        .into_iter()
        .chain([builtin("office"), builtin("spheres")])
    {
        phases(c, &base);
    }
}

fn phases(c: &mut Criterion, base: &scene::Scene) {
    let t = base
        .animation
        .as_ref()
        .map_or(0.0, |a| 0.5 * (a.start + a.end));
    let scene = base.frame_at(t);
    let mut geo = Geometry::default();
    geo.refill_at(base, t);
    let view = View::new(&scene.camera, 512, 512);
    let near = default_near(&geo);
    let mut g = c.benchmark_group(format!("frame phases, {} 512x512", scene.name));
    g.sample_size(20);
    let mut times = [t, t + 0.01];
    g.bench_function("update", |b| {
        b.iter(|| {
            times.swap(0, 1);
            geo.refill_at(base, times[0]);
        })
    });
    geo.refill_at(base, t);
    // Every phase's input is made here, so that a filtered run (`-- shading`) measures it
    // on the same data.
    let (mut gb, mut scratch) = (GBuffer::default(), RasterScratch::default());
    rasterize_into(&geo, &scene.materials, &view, near, &mut gb, &mut scratch);
    g.bench_function("raster", |b| {
        b.iter(|| rasterize_into(&geo, &scene.materials, &view, near, &mut gb, &mut scratch))
    });
    let (mut s, mut shadows, mut bounces) = (
        Surfaces::default(),
        RayBatch::default(),
        RayBatch::default(),
    );
    g.bench_function("ray creation", |b| {
        b.iter(|| {
            s.fill_from_gbuffer(&gb, &geo, view.eye);
            shadow_rays_into(&s, &scene.lights, &mut shadows);
            bounce_rays_into(&s, &scene.materials, &mut bounces);
        })
    });
    s.fill_from_gbuffer(&gb, &geo, view.eye);
    let occluded = vec![false; s.len() * scene.lights.len()];
    g.bench_function("shading", |b| {
        b.iter(|| render::cpu::local_shading(&s, &scene, &occluded))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
