//! The device-resident frame (`gpu::frame`) against the host-sequenced GPU frame (the same
//! raster, kernels and engine, with the surfaces and the image on the host between passes):
//! the same counters exactly, image bytes within one (the device encodes sRGB with its own
//! `pow`), and at most the image's bytes + 1 MiB moved between host and device. Also the
//! device traces in parts against the CPU engine.
//!
//! The host-sequenced frame's own tolerance against the CPU renderer is checked in
//! `raster.rs`; together they bound the device frame against the CPU.

use crate::common;

use accel::{GridConfig, GridEngine};
use gpu::{Gpu, GpuEngine, GpuGrid, GpuRaster, GpuRsh, GpuStages};
use render::whitted::{render_with, RenderOptions};
use rsh::RshConfig;
use scene::{builtin, Geometry};
use trace::{Hit, RayKind, TraceMode, TraceStats, Tracer};

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

fn srgb(p: &[geom::Vec3]) -> Vec<u8> {
    p.iter()
        .flat_map(|c| [c.x, c.y, c.z].map(render::output::srgb_encode))
        .collect()
}

fn engines(g: &Gpu, geo: &Geometry) -> Vec<Box<dyn GpuEngine>> {
    vec![
        Box::new(GpuRsh::new(g.clone(), geo, RshConfig::crsh()).unwrap()),
        Box::new(GpuRsh::new(g.clone(), geo, RshConfig::rah()).unwrap()),
        Box::new(GpuGrid::new(g.clone(), geo, &GridConfig::default()).unwrap()),
    ]
}

#[test]
fn device_frames_equal_host_sequenced_frames() {
    let Some(g) = gpu() else { return };
    let kernels = g.kernels();
    for (name, w, h, bounces) in [
        ("cornell", 96, 72, 3),
        ("spheres", 80, 64, 3),
        ("office", 64, 48, 2),
        ("stadium", 48, 40, 1),
        ("soup", 40, 32, 0),
    ] {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let opts = RenderOptions {
            width: w,
            height: h,
            bounces,
        };
        let raster = GpuRaster::new(&g, &geo, &s.materials).unwrap();
        for e in engines(&g, &geo) {
            let what = format!("{name} {}", e.name());
            let stages = GpuStages::new(e.gpu(), &kernels);
            let host = render_with(
                &s,
                &geo,
                e.as_ref(),
                &opts,
                &(),
                &|v, n| raster.rasterize(v, n),
                &stages,
            );
            let moved = e.gpu().bytes_moved();
            let dev = gpu::frame::render(e.as_ref(), &raster, &s, &geo, &opts, &()).unwrap();
            let bytes = e.gpu().bytes_moved() - moved;
            let image = (w * h * 3) as u64;
            eprintln!("{what}: {bytes} bytes moved, image {image}");
            assert!(
                bytes <= image + (1 << 20),
                "{what}: {bytes} bytes moved for a {image}-byte image"
            );
            let (a, b) = (srgb(&host.pixels), dev.srgb8);
            assert_eq!(a.len(), b.len(), "{what}: image size");
            let off = a.iter().zip(&b).filter(|(x, y)| x != y).count();
            let far = a
                .iter()
                .zip(&b)
                .filter(|(x, y)| x.abs_diff(**y) > 1)
                .count();
            eprintln!("{what}: {off} of {} bytes differ by one", a.len());
            assert_eq!(far, 0, "{what}: bytes differ by more than one");
            let (hs, ds) = (&host.stats, &dev.stats);
            assert_eq!(ds.covered_pixels, hs.covered_pixels, "{what}: covered");
            assert_eq!(
                (ds.rays_shadow, ds.rays_reflection, ds.rays_refraction),
                (hs.rays_shadow, hs.rays_reflection, hs.rays_refraction),
                "{what}: rays by kind"
            );
            assert_eq!(ds.trace.rays, hs.trace.rays, "{what}: traced");
            assert_eq!(ds.trace.hits, hs.trace.hits, "{what}: hits");
            assert_eq!(ds.total_tests, hs.total_tests, "{what}: tests");
            assert_eq!(ds.brute_force_tests, hs.brute_force_tests);
            assert!(
                ds.phases.iter().any(|p| p.0 == render::FramePhase::Trace),
                "{what}: phases"
            );
            // Deterministic: the same frame again gives the same bytes and counts.
            let again = gpu::frame::render(e.as_ref(), &raster, &s, &geo, &opts, &()).unwrap();
            assert_eq!(again.srgb8, b, "{what}: a second frame");
            assert_eq!(again.stats.total_tests, ds.total_tests);
        }
    }
}

#[test]
fn device_traces_in_parts_equal_the_cpu() {
    // A grid uploaded as if a binding held just its largest array: a sixteenth of that in
    // rays per part, so the device trace copies parts out and records back on the device.
    let Some(mut g) = gpu() else { return };
    let s = builtin::by_name("cornell").unwrap();
    let geo = Geometry::from_scene(&s);
    let cpu = GridEngine::new(&geo, &GridConfig::default()).unwrap();
    let gr = &cpu.grid;
    let limit = common::tight_binding(&cpu, &geo);
    let full = g.clone();
    g.limits.max_storage_buffer_binding_size = limit;
    let dev = GpuGrid::upload(g, gr, &geo.tris, "grid-gpu").unwrap();
    assert_eq!(dev.max_rays() as u64, limit / 16);
    let side = ((3 * limit / 16) as f64).sqrt() as u32 + 1;
    let view = render::View::new(&s.camera, side, side);
    let mut rays = view.primary_rays();
    for k in rays.kind.iter_mut().skip(3).step_by(7) {
        *k = RayKind::Reflection as u8;
    }
    let n = rays.len();
    assert!(n > 2 * dev.max_rays(), "more than two parts");
    let v4 = |a: &[geom::Vec3], w: &[f32]| -> Vec<[f32; 4]> {
        a.iter().zip(w).map(|(v, &w)| [v.x, v.y, v.z, w]).collect()
    };
    let kl: Vec<u32> = rays.kind.iter().map(|&k| k as u32).collect();
    let dr = gpu::rays::DeviceRays {
        org: full.upload("org", &v4(&rays.org, &rays.t_min)),
        dir: full.upload("dir", &v4(&rays.dir, &rays.t_max)),
        kl: full.upload("kl", &kl),
        pix: full.upload("pix", &rays.pixel),
        pre: full.storage("pre", n as u64 * 16),
        len: n as u64,
        width: 0,
    };
    for mode in [TraceMode::Closest, TraceMode::Any] {
        let mut st = TraceStats::default();
        let rec = gpu::frame::trace_device(&dev, &dr, mode, &mut st);
        let recs: Vec<[u32; 4]> = full.read(&rec, n);
        let mut want = vec![Hit::MISS; n];
        let mut cst = TraceStats::default();
        cpu.trace(&rays, mode, &mut want, &mut cst);
        for (i, (r, h)) in recs.iter().zip(&want).enumerate() {
            if mode == TraceMode::Any {
                assert_eq!(r[0] != geom::NO_HIT, h.is_hit(), "ray {i}: hit or miss");
                continue;
            }
            assert_eq!(r[0], h.tri, "ray {i}: triangle");
            if h.is_hit() {
                assert_eq!(r[1], h.t.to_bits(), "ray {i}: t");
            }
        }
        assert_eq!(st.rays, n as u64);
        assert_eq!(st.hits, cst.hits, "{mode:?}: hits");
        assert_eq!(st.ray_tri_tests, cst.ray_tri_tests, "{mode:?}: tests");
    }
}

#[test]
fn frames_that_might_not_fit_a_binding_are_refused_with_the_reason() {
    // A device that binds just cornell's grid's largest array at once: a 16-pixel-wide frame
    // whose G-buffer fills a binding exactly fits there, but its shadow rays (16 bytes × 2
    // light slots per pixel) do not, so the frame is refused up front (the render command
    // then sequences it on the host, in parts); a small frame runs under the same limits.
    let Some(mut g) = gpu() else { return };
    let s = builtin::by_name("cornell").unwrap();
    let geo = Geometry::from_scene(&s);
    let cpu = GridEngine::new(&geo, &GridConfig::default()).unwrap();
    let gr = &cpu.grid;
    let limit = common::tight_binding(&cpu, &geo);
    g.limits.max_storage_buffer_binding_size = limit;
    let e = GpuGrid::upload(g.clone(), gr, &geo.tris, "grid-gpu").unwrap();
    let opts = RenderOptions {
        width: 16,
        height: (limit / 256) as u32,
        bounces: 1,
    };
    let why = gpu::frame::too_big(&g, &s, &opts).expect("too big");
    assert!(
        why.contains("generation 0") && why.contains("binding"),
        "{why}"
    );
    let small = RenderOptions {
        width: 16,
        height: 8,
        bounces: 1,
    };
    assert_eq!(gpu::frame::too_big(&g, &s, &small), None);
    let raster = GpuRaster::new(&g, &geo, &s.materials).unwrap();
    let err = gpu::frame::render(&e, &raster, &s, &geo, &opts, &())
        .err()
        .expect("refused");
    assert!(err.to_string().contains("generation 0"), "{err}");
    assert!(gpu::frame::render(&e, &raster, &s, &geo, &small, &()).is_ok());
}
