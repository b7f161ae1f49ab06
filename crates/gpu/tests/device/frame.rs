//! The GPU backend of the Whitted loop (`gpu::frame::GpuBackend`) against the CPU backend
//! over the GPU's own G-buffer (the same engine tracing, the same rays: the GPU generates
//! the CPU's rays bit for bit), so the same counters exactly and image bytes within one (the
//! device shades with its own `pow` and encodes sRGB with it), with at most the image's
//! bytes + 1 MiB moved between host and device; a generation held in parts against the same
//! frame in one part (the same bytes); and the device traces in parts against the CPU engine.
//!
//! The GPU's G-buffer against the CPU rasterizer's is checked in `raster.rs`; together they
//! bound the GPU frame against the CPU's.

use crate::common;

use accel::{GridConfig, GridEngine};
use gpu::frame::GpuBackend;
use gpu::{Gpu, GpuBvh, GpuEngine, GpuGrid, GpuRaster, GpuRsh};
use render::cpu::CpuBackend;
use render::whitted::{run, RenderOptions};
use rsh::RshConfig;
use scene::{builtin, Geometry, Scene};
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
        Box::new(GpuBvh::new(g.clone(), geo, common::bvh_single()).unwrap()),
        Box::new(GpuRsh::new(g.clone(), geo, crate::common::crsh_spheres()).unwrap()),
        Box::new(GpuRsh::new(g.clone(), geo, crate::common::rah_spheres()).unwrap()),
        Box::new(GpuRsh::new(g.clone(), geo, crate::common::rah_dual()).unwrap()),
        Box::new(GpuRsh::new(g.clone(), geo, crate::common::crsh_dual()).unwrap()),
        Box::new(GpuGrid::new(g.clone(), geo, &GridConfig::default()).unwrap()),
    ]
}

/// One frame of `s` on the GPU backend.
fn gpu_frame(
    e: &dyn GpuEngine,
    raster: &GpuRaster,
    s: &Scene,
    geo: &Geometry,
    opts: &RenderOptions,
) -> (render::whitted::Rendered, bool) {
    let f = gpu::frame::render_frame(e, raster, s, geo, opts, &(), false).unwrap();
    (f.out, f.in_parts)
}

/// The same frame as [`gpu_frame`] on the CPU backend, over the GPU's G-buffer.
fn cpu_frame(
    e: &dyn GpuEngine,
    raster: &GpuRaster,
    s: &Scene,
    geo: &Geometry,
    opts: &RenderOptions,
) -> render::whitted::Rendered {
    let view = render::View::new(&s.camera, opts.width, opts.height);
    let (gb, _) = raster.rasterize(&view, render::raster::default_near(geo));
    let tracer: &dyn Tracer = e;
    run(
        &mut CpuBackend::new(s, geo, tracer).with_gbuffer(gb),
        s,
        geo,
        opts,
        &(),
    )
}

/// `dev` (a GPU frame) is `host` (the CPU backend's frame over the same G-buffer and
/// engine): image bytes within one (the device's `pow`), every count equal.
fn same_frame(what: &str, host: &render::whitted::Rendered, dev: &render::whitted::Rendered) {
    let (a, b) = (srgb(&host.pixels), dev.rgb8());
    assert_eq!(a.len(), b.len(), "{what}: image size");
    let off = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    let far = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| x.abs_diff(**y) > 1)
        .count();
    eprintln!("{what}: {off} of {} bytes differ by one", a.len());
    assert_eq!(far, 0, "{what}: bytes differ by more than one");
    same_counts(what, &dev.stats, &host.stats);
}

/// Frame statistics `a` equal `b`: covered pixels, rays by kind, rays traced, hits and tests.
fn same_counts(what: &str, a: &render::stats::RenderStats, b: &render::stats::RenderStats) {
    assert_eq!(a.covered_pixels, b.covered_pixels, "{what}: covered");
    assert_eq!(
        (a.rays_shadow, a.rays_reflection, a.rays_refraction),
        (b.rays_shadow, b.rays_reflection, b.rays_refraction),
        "{what}: rays by kind"
    );
    assert_eq!(a.trace.rays, b.trace.rays, "{what}: traced");
    assert_eq!(a.trace.hits, b.trace.hits, "{what}: hits");
    assert_eq!(a.total_tests, b.total_tests, "{what}: tests");
    assert_eq!(a.brute_force_tests, b.brute_force_tests, "{what}");
    // Every engine counter (CRSH's chunks, the levels' tests, the batches' paths), the
    // GPU's own aside.
    let counters = |t: &TraceStats| gpu::rsh::engine::comparable_counters(t).counters;
    assert_eq!(counters(&a.trace), counters(&b.trace), "{what}: counters");
}

#[test]
fn gpu_frames_equal_cpu_frames_over_the_gpu_gbuffer() {
    let Some(g) = gpu() else { return };
    for (name, w, h, bounces) in [
        ("cornell", 96, 72, 3),
        ("spheres", 80, 64, 3),
        ("office", 64, 48, 2),
        ("stadium", 48, 40, 1),
        ("soup", 40, 32, 0),
        // Batches of at most 8 rays: a ray hierarchy of one level below its configured two
        // (the device lays out two and builds one).
        ("cornell", 2, 2, 2),
    ] {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let opts = RenderOptions {
            width: w,
            height: h,
            bounces,
            spp: 1,
        };
        let raster = GpuRaster::new(&g, &geo, &s.materials).unwrap();
        for e in engines(&g, &geo) {
            let what = format!("{name} {}", e.name());
            let host = cpu_frame(e.as_ref(), &raster, &s, &geo, &opts);
            let moved = e.gpu().bytes_moved();
            let (dev, in_parts) = gpu_frame(e.as_ref(), &raster, &s, &geo, &opts);
            assert!(!in_parts, "{what}: one part");
            let bytes = e.gpu().bytes_moved() - moved;
            let image = (w * h * 3) as u64;
            eprintln!("{what}: {bytes} bytes moved, image {image}");
            assert!(
                bytes <= image + (1 << 20),
                "{what}: {bytes} bytes moved for a {image}-byte image"
            );
            same_frame(&what, &host, &dev);
            let (b, ds) = (dev.rgb8(), &dev.stats);
            assert!(
                ds.phases.iter().any(|p| p.0 == render::FramePhase::Trace),
                "{what}: phases"
            );
            // Deterministic: the same frame again gives the same bytes and counts.
            let (again, _) = gpu_frame(e.as_ref(), &raster, &s, &geo, &opts);
            assert_eq!(again.rgb8(), b, "{what}: a second frame");
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
        gpu::frame::settle(&dev, &mut st);
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
fn generations_beyond_one_binding_run_in_parts_with_the_same_bytes() {
    // A device that binds just cornell's grid's largest array at once: a 16-pixel-wide frame
    // whose G-buffer fills a binding exactly fits there, but its shadow rays (16 bytes × 2
    // light slots per pixel) do not, so its generations are held in parts; the image and
    // every count equal the same frame's on the device as it is (one part). A G-buffer
    // beyond one binding is refused with the reason.
    let Some(mut g) = gpu() else { return };
    let s = builtin::by_name("cornell").unwrap();
    let geo = Geometry::from_scene(&s);
    let cpu = GridEngine::new(&geo, &GridConfig::default()).unwrap();
    let gr = &cpu.grid;
    let limit = common::tight_binding(&cpu, &geo);
    let full = g.clone();
    g.limits.max_storage_buffer_binding_size = limit;
    let opts = RenderOptions {
        width: 16,
        height: (limit / 256) as u32,
        bounces: 2,
        spp: 1,
    };
    let whole = {
        let e = GpuGrid::upload(full.clone(), gr, &geo.tris, "grid-gpu").unwrap();
        let raster = GpuRaster::new(&full, &geo, &s.materials).unwrap();
        let (out, in_parts) = gpu_frame(&e, &raster, &s, &geo, &opts);
        assert!(!in_parts, "one part on the device as it is");
        out
    };
    let e = GpuGrid::upload(g.clone(), gr, &geo.tris, "grid-gpu").unwrap();
    let raster = GpuRaster::new(&g, &geo, &s.materials).unwrap();
    assert!(GpuBackend::part_size(&g, &s) < whole.stats.covered_pixels);
    let (parts, in_parts) = gpu_frame(&e, &raster, &s, &geo, &opts);
    assert!(in_parts, "the generations come in parts");
    assert_eq!(parts.rgb8(), whole.rgb8(), "image bytes");
    let (a, b) = (&parts.stats, &whole.stats);
    assert_eq!(a.covered_pixels, b.covered_pixels);
    assert_eq!(
        (a.rays_shadow, a.rays_reflection, a.rays_refraction),
        (b.rays_shadow, b.rays_reflection, b.rays_refraction)
    );
    assert_eq!(a.trace.hits, b.trace.hits);
    assert_eq!(a.total_tests, b.total_tests);
    // One row more than a binding holds: refused up front, with the reason.
    let tall = RenderOptions {
        height: opts.height + 1,
        ..opts
    };
    let why = gpu::frame::too_big(&g, &tall).expect("too big");
    assert!(why.contains("G-buffer") && why.contains("binding"), "{why}");
    let err = GpuBackend::new(&e, &raster, &s, &tall, false)
        .err()
        .expect("refused");
    assert!(err.to_string().contains("binding"), "{err}");
}

#[test]
fn device_sized_generations_read_back_once_and_equal_read_counts() {
    // The same frames with every count read back (budget 0), with only the first
    // generation sized by its bound (a budget for one surface per pixel), and with every
    // generation sized (the default): the same image bytes and counts, the default reading
    // back once (the image with every count), the others more.
    let Some(g) = gpu() else { return };
    for (name, w, h, bounces) in [("office", 64, 48, 3), ("cornell", 48, 40, 3)] {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let opts = RenderOptions {
            width: w,
            height: h,
            bounces,
            spp: 1,
        };
        let raster = GpuRaster::new(&g, &geo, &s.materials).unwrap();
        let first = (w * h) as u64 * gpu::frame::sizes::bytes_per_surface(s.lights.len() as u64);
        let sized: Vec<Box<dyn GpuEngine>> = vec![
            Box::new(GpuBvh::new(g.clone(), &geo, common::bvh_single()).unwrap()),
            Box::new(GpuGrid::new(g.clone(), &geo, &GridConfig::default()).unwrap()),
            // The bundles through the object tree: laid out and paced by the device.
            Box::new(GpuRsh::new(g.clone(), &geo, common::rah_dual()).unwrap()),
            Box::new(GpuRsh::new(g.clone(), &geo, common::crsh_dual()).unwrap()),
        ];
        for e in sized {
            assert!(e.counts_on_device(), "{name} {}", e.name());
            let mut runs = Vec::new();
            for budget in [0, first, gpu::frame::sizes::BUDGET] {
                let what = format!("{name} {} budget {budget}", e.name());
                let reads = g.read_backs();
                let mut b = GpuBackend::new(e.as_ref(), &raster, &s, &opts, false)
                    .unwrap()
                    .with_sized_budget(budget);
                let out = run(&mut b, &s, &geo, &opts, &());
                // (Outside render_frame: a trace that did not finish would go unseen.)
                assert!(!e.take_incomplete(), "{what}: every trace finished");
                runs.push((what, out, g.read_backs() - reads));
            }
            let (what0, base, reads0) = &runs[0];
            assert!(*reads0 > 2, "{what0}: {reads0} read-backs");
            for (what, out, reads) in &runs[1..] {
                assert_eq!(out.rgb8(), base.rgb8(), "{what}: image bytes");
                same_counts(what, &out.stats, &base.stats);
                assert!(reads < reads0, "{what}: {reads} read-backs, {reads0} read");
            }
            let (what, _, reads) = &runs[2];
            assert_eq!(*reads, 1, "{what}: the image and the counts, once");
            assert!(runs[1].2 > 1, "{}: reads the later counts", runs[1].0);
        }
        // The thesis's bundles behind mesh spheres take device-sized
        // batches too: their traversals still read the sizes their passes need, so a sized
        // frame reads back fewer times than one that reads every count, but more than once;
        // the image and every count are the same.
        for c in [crate::common::rah_spheres(), crate::common::crsh_spheres()] {
            let e = GpuRsh::new(g.clone(), &geo, c).unwrap();
            assert!(e.counts_on_device(), "{name} {}", e.name());
            let mut runs = Vec::new();
            for budget in [0, gpu::frame::sizes::BUDGET] {
                let reads = g.read_backs();
                let mut b = GpuBackend::new(&e, &raster, &s, &opts, false)
                    .unwrap()
                    .with_sized_budget(budget);
                let out = run(&mut b, &s, &geo, &opts, &());
                runs.push((out, g.read_backs() - reads));
            }
            let what = format!("{name} {} {:?}", e.name(), e.config().objects);
            assert_eq!(runs[1].0.rgb8(), runs[0].0.rgb8(), "{what}: image bytes");
            same_counts(&what, &runs[1].0.stats, &runs[0].0.stats);
            assert!(
                runs[1].1 < runs[0].1,
                "{what}: {} vs {} read-backs",
                runs[1].1,
                runs[0].1
            );
        }
    }
}

#[test]
fn real_scene_frames_read_back_once_and_equal_cpu_frames() {
    // BART's kitchen (materials that reflect or refract, one bounce ray per surface at most)
    // and Sponza (none: the loop stops after the first generation without a count) at 3
    // bounces, device-sized with CRSH's single-ray path and the grid: one read-back, and
    // the CPU backend's counts and image over the same G-buffer.
    if testkit::scenes().is_none() {
        return;
    }
    let Some(g) = gpu() else { return };
    for name in ["kitchen", "sponza"] {
        let s = scene::load(name, &Default::default()).unwrap();
        let geo = Geometry::from_scene(&s);
        let (w, h) = (64, 48);
        let opts = RenderOptions {
            width: w,
            height: h,
            bounces: 3,
            spp: 1,
        };
        let raster = GpuRaster::new(&g, &geo, &s.materials).unwrap();
        let sized: Vec<Box<dyn GpuEngine>> = vec![
            Box::new(GpuBvh::new(g.clone(), &geo, common::bvh_single()).unwrap()),
            Box::new(GpuGrid::new(g.clone(), &geo, &GridConfig::default()).unwrap()),
            Box::new(GpuRsh::new(g.clone(), &geo, common::rah_dual()).unwrap()),
            Box::new(GpuRsh::new(g.clone(), &geo, common::crsh_dual()).unwrap()),
        ];
        for e in sized {
            let what = format!("{name} {}", e.name());
            let host = cpu_frame(e.as_ref(), &raster, &s, &geo, &opts);
            let reads = g.read_backs();
            let (dev, in_parts) = gpu_frame(e.as_ref(), &raster, &s, &geo, &opts);
            assert!(!in_parts, "{what}: one part");
            assert_eq!(g.read_backs() - reads, 1, "{what}: one read-back");
            same_frame(&what, &host, &dev);
        }
    }
}

#[test]
fn device_paced_traces_that_do_not_finish_trace_the_frame_again() {
    // RAH's dual traversal, laid out and paced by the device, given one round per level (its
    // traces need more) or buffers of 64 pairs (its rounds overflow): the frame sees it with
    // its image, is traced again with the host pacing, and equals the CPU's frame; the
    // engine then takes more rounds, so the next frame finishes on the device and reads
    // back once. Buffers that cannot grow past the bound overflow again, until the engine
    // stops laying traces out.
    let Some(g) = gpu() else { return };
    let s = builtin::by_name("office").unwrap();
    let geo = Geometry::from_scene(&s);
    let opts = RenderOptions {
        width: 32,
        height: 24,
        bounces: 2,
        spp: 1,
    };
    let raster = GpuRaster::new(&g, &geo, &s.materials).unwrap();
    let frame = |e: &GpuRsh| {
        let reads = g.read_backs();
        let f = gpu::frame::render_frame(e, &raster, &s, &geo, &opts, &(), false).unwrap();
        (f.out, f.again, g.read_backs() - reads)
    };
    let e = GpuRsh::new(g.clone(), &geo, common::rah_dual())
        .unwrap()
        .with_rounds(1, None);
    let host = cpu_frame(&e, &raster, &s, &geo, &opts);
    let (dev, again, reads) = frame(&e);
    assert!(again, "one round per level does not finish");
    assert!(reads > 2, "the second trace is paced: {reads} read-backs");
    same_frame("office, one round", &host, &dev);
    let (next, again, reads) = frame(&e);
    assert!(!again, "the engine learned the rounds");
    assert_eq!(reads, 1, "the next frame reads back once");
    same_frame("office, learned rounds", &host, &next);

    let e = GpuRsh::new(g.clone(), &geo, common::rah_dual())
        .unwrap()
        .with_rounds(12, Some(64));
    let mut agains = 0;
    for k in 0..5 {
        let (dev, again, _) = frame(&e);
        same_frame(&format!("office, 64 pairs, frame {k}"), &host, &dev);
        agains += again as usize;
    }
    // 8 → 16 → 32 → 64 pairs per ray, then none laid out.
    assert_eq!(agains, 4, "overflowing frames");

    // Levels until one root per kind: the device lays out as many as the batch's bound
    // could need and builds fewer (a bounce batch holds fewer rays than its bound), so the
    // traversal starts below the layout's top, at a level of several nodes.
    let cfg = RshConfig {
        levels: 0,
        ..common::rah_dual()
    };
    let opts = RenderOptions {
        width: 48,
        height: 40,
        ..opts
    };
    let e = GpuRsh::new(g.clone(), &geo, cfg).unwrap();
    let host = cpu_frame(&e, &raster, &s, &geo, &opts);
    let reads = g.read_backs();
    let f = gpu::frame::render_frame(&e, &raster, &s, &geo, &opts, &(), false).unwrap();
    assert!(!f.again, "levels to one root: finished on the device");
    assert_eq!(
        g.read_backs() - reads,
        1,
        "levels to one root: one read-back"
    );
    same_frame("office, levels to one root", &host, &f.out);
}
