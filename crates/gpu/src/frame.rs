//! A whole Whitted frame resident on the device: the twin of
//! [`render::whitted::render_with`] (thesis chapter 3, Figure 3.1) with every step a kernel
//! and nothing but the image and a few totals crossing to the host.
//!
//! Rasterize into a G-buffer that stays on the device ([`GpuRaster::rasterize_device`]) →
//! surfaces of the covered pixels (`frame.wgsl`, compacted by the backend's scan) → per
//! generation: shadow rays (`stages.wgsl`) traced by the engine on the device
//! ([`GpuEngine::trace_device_part`]) → occlusion flags → Blinn-Phong shading → colours added
//! to their pixels; reflection/refraction rays (`stages.wgsl`, compacted) → traced → the
//! background behind the misses → the next generation's surfaces from the hits. Finally the
//! image is encoded to sRGB bytes on the device and read back.
//!
//! What the host reads back per frame: the sRGB image (3 bytes per pixel), the sizes that
//! allocate the next buffers (4 bytes each), the engines' totals (hits, and the grid's step
//! and test sums: 20 bytes per 1024 rays) and the launches' parameter blocks going the other
//! way; [`crate::Gpu::bytes_moved`] counts every one of them.
//!
//! The pixel accumulation is order-independent of scheduling: one thread per run of equal
//! pixels adds that pixel's colours in surface order, which is the CPU loop's order, so a
//! frame's image bytes depend only on its inputs.

use crate::device::{Gpu, GpuError};
use crate::kernels::params::{
    EncodeParams, FrameCountParams, GbFlagsParams, GbSurfacesParams, KindCountParams, MissesParams,
    ShadowMetaParams, TotalsParams,
};
use crate::kernels::{launch, Exec};
use crate::raster::GpuRaster;
use crate::rays::DeviceRays;
use crate::stages::Surf;
use crate::GpuEngine;
use render::raster::default_near;
use render::stats::{FramePhase, RenderStats};
use render::whitted::{Progress, RenderOptions};
use render::View;
use scene::{Geometry, Scene};
use std::time::Instant;
use trace::{TraceMode, TraceStats};

/// Rays per chunk of [`totals`] (`fr_totals` in `frame.wgsl`).
const TOTALS_CHUNK: u64 = 1024;

/// A trace's totals as read back by [`totals`].
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Totals {
    pub hits: u64,
    pub steps: u64,
    pub tests: u64,
}

/// Hits among the `n` records `rec`, and with per-ray (steps, tests) counters `cnt` their
/// sums: per-chunk sums (64-bit, as two words) read back and added on the host.
pub(crate) fn totals(
    ex: &mut Exec,
    rec: &wgpu::Buffer,
    cnt: Option<&wgpu::Buffer>,
    n: u64,
) -> Totals {
    if n == 0 {
        return Totals::default();
    }
    let chunks = n.div_ceil(TOTALS_CHUNK);
    let out = ex.g.storage("trace totals", chunks * 20);
    let dummy;
    let cb = match cnt {
        Some(c) => c,
        None => {
            dummy = ex.g.storage("no counters", 8);
            &dummy
        }
    };
    ex.run(
        launch::FrTotals {
            rec,
            out_u: &out,
            cnt: cb,
        },
        TotalsParams {
            rays: n as u32,
            counters: cnt.is_some() as u32,
        },
        chunks,
        256,
    );
    let v: Vec<[u32; 5]> = ex.read(&out, chunks as usize);
    let w = |lo: u32, hi: u32| lo as u64 | (hi as u64) << 32;
    v.iter().fold(Totals::default(), |t, c| Totals {
        hits: t.hits + c[0] as u64,
        steps: t.steps + w(c[1], c[2]),
        tests: t.tests + w(c[3], c[4]),
    })
}

/// Trace rays `rays` on the device with `engine`, in parts of at most its
/// [`GpuEngine::max_rays`] (each part's rays copied out on the device, its records copied
/// back), counting into `stats` as [`trace::Tracer::trace`] does; the records (triangle, t,
/// u, v bits) stay on the device.
pub fn trace_device(
    engine: &dyn GpuEngine,
    rays: &DeviceRays,
    mode: TraceMode,
    stats: &mut TraceStats,
) -> wgpu::Buffer {
    let g = engine.gpu();
    let n = rays.len;
    stats.rays += n;
    let max = engine.max_rays().max(1) as u64;
    if n <= max {
        return engine.trace_device_part(rays, mode, stats);
    }
    let rec = g.storage("records", n * 16);
    let mut lo = 0;
    while lo < n {
        let m = max.min(n - lo);
        let part = {
            let mut ex = Exec::new(g, engine.kernels());
            let cut = |ex: &mut Exec, b: &wgpu::Buffer, size: u64, label| {
                let p = g.storage(label, m * size);
                ex.copy(b, lo * size, &p, m * size);
                p
            };
            let p = DeviceRays {
                org: cut(&mut ex, &rays.org, 16, "part org"),
                dir: cut(&mut ex, &rays.dir, 16, "part dir"),
                kl: cut(&mut ex, &rays.kl, 4, "part kind"),
                pix: cut(&mut ex, &rays.pix, 4, "part pixel"),
                pre: g.storage("part ray constants", m * 16),
                len: m,
                width: rays.width,
            };
            ex.finish();
            p
        };
        let r = engine.trace_device_part(&part, mode, stats);
        let mut ex = Exec::new(g, engine.kernels());
        ex.copy_at(&r, 0, &rec, lo * 16, m * 16);
        ex.finish();
        lo += m;
    }
    rec
}

/// One generation's surfaces on the device: `stages.wgsl`'s six arrays (bindings 1–6) and
/// their pixels (binding 7 of `frame.wgsl`).
struct DeviceSurfaces {
    s: Surf,
    pix: wgpu::Buffer,
    len: u64,
}

impl DeviceSurfaces {
    fn new(g: &Gpu, n: u64) -> DeviceSurfaces {
        DeviceSurfaces {
            s: Surf::new(g, n),
            pix: g.storage("surface pixel", n * 4),
            len: n,
        }
    }
}

/// The result of a device frame.
pub struct FrameOut {
    /// The image as sRGB bytes (r, g, b per pixel, row-major): what the PNG stores, encoded
    /// on the device by `render::output::srgb_encode`'s formula (the device's `pow`, so a
    /// byte may differ from the CPU encoding of the same linear value by one).
    pub srgb8: Vec<u8>,
    /// The render's counters and phase times (wall clock, waiting at each phase's end),
    /// as [`render::whitted::render_with`] reports them.
    pub stats: RenderStats,
}

/// Why a frame cannot stay on the device, or `None` when it can: every buffer a kernel binds
/// (the G-buffer, the image, a generation's surfaces, shadow rays and bounce slots) must fit
/// one binding and index in u32. A generation has at most `pixels · bᵍ` surfaces, b being the most bounce rays one
/// material spawns (reflection and refraction: 2).
pub fn too_big(gpu: &Gpu, scene: &Scene, opts: &RenderOptions) -> Option<String> {
    let b = scene
        .materials
        .iter()
        .map(|m| (m.reflectivity > 0.0) as u64 + (m.transparency > 0.0) as u64)
        .max()
        .unwrap_or(0);
    let nl = scene.lights.len().max(2) as u64;
    let cap = gpu.max_binding().min(gpu.limits.max_buffer_size);
    // The G-buffer's targets (rows padded to 256 bytes) and the image, 16 bytes per pixel.
    let gbuffer = (opts.width as u64 * 16).next_multiple_of(256) * opts.height as u64;
    if gbuffer > cap {
        return Some(format!(
            "the G-buffer needs {} MiB in one binding (the device allows {} MiB)",
            gbuffer >> 20,
            cap >> 20
        ));
    }
    let mut s = opts.width as u64 * opts.height as u64;
    for g in 0..=opts.bounces {
        // Shadow rays (vec4 origins) or bounce slots, whichever is larger.
        let bytes = s.saturating_mul(nl).saturating_mul(16);
        if bytes > cap || s.saturating_mul(nl) > u32::MAX as u64 {
            return Some(format!(
                "generation {g} may have {s} surfaces, whose rays need {} MiB in one binding (the device allows {} MiB)",
                bytes >> 20,
                cap >> 20
            ));
        }
        s = s.saturating_mul(b);
        if s == 0 {
            break;
        }
    }
    None
}

/// Wall-clock phases of a frame: each ends by waiting for the device.
struct Clock {
    t0: Instant,
}

impl Clock {
    fn start() -> Clock {
        Clock { t0: Instant::now() }
    }

    /// Finish `ex`'s work, add the time since the last lap to `phase`.
    fn lap(&mut self, ex: &mut Exec, stats: &mut RenderStats, phase: FramePhase) {
        ex.finish();
        ex.g.device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("GPU device lost");
        let now = Instant::now();
        stats.add_phase(phase, (now - self.t0).as_secs_f64());
        self.t0 = now;
    }
}

/// Render one frame of `scene` with `engine` on its device, everything between the G-buffer
/// and the image staying there. `raster` holds `geo` (made on the engine's device);
/// [`too_big`] must have accepted the frame's size.
pub fn render(
    engine: &dyn GpuEngine,
    raster: &GpuRaster,
    scene: &Scene,
    geo: &Geometry,
    opts: &RenderOptions,
    progress: &dyn Progress,
) -> Result<FrameOut, GpuError> {
    let g = engine.gpu();
    raster.check_size(opts.width, opts.height)?;
    if let Some(why) = too_big(g, scene, opts) {
        return Err(GpuError::Limits(why));
    }
    let (w, h) = (opts.width, opts.height);
    let npix = w as u64 * h as u64;
    let nl = scene.lights.len() as u64;
    let view = View::new(&scene.camera, w, h);
    let mut stats = RenderStats {
        scene: scene.name.clone(),
        engine: engine.name().to_string(),
        width: w,
        height: h,
        triangles: geo.len() as u64,
        meshes: geo.mesh_count() as u64,
        lights: nl,
        bounces: opts.bounces,
        ..Default::default()
    };
    let mut clock = Clock::start();
    let mut ex = Exec::new(g, engine.kernels());
    progress.stage("rasterize");
    let gb = raster.rasterize_device(&view, default_near(geo));
    clock.lap(&mut ex, &mut stats, FramePhase::Rasterize);

    let bg = scene.background;
    let lights = g.upload("lights", &crate::stages::light_rows(&scene.lights));
    let mats = g.upload(
        "materials",
        &crate::stages::material_rows(&scene.materials, scene.ambient),
    );
    let (tris, normals, material) = raster.scene_buffers();
    let img = g.storage("image", npix * 16);
    // Surfaces of the covered pixels, in pixel order.
    let mut surf = {
        let flags = g.storage("covered", npix * 4);
        let offs = g.storage("covered offsets", (npix + 1) * 4);
        let p = GbFlagsParams {
            pixels: npix as u32,
            width: w,
            stride: gb.stride,
            background: bg.to_array(),
        };
        ex.run(
            launch::FrGbFlags {
                gb_id: &gb.id,
                flags: &flags,
                img: &img,
            },
            p,
            npix,
            256,
        );
        ex.scan(&flags, &offs, npix);
        let n = ex.read_at(&offs, npix as usize) as u64;
        let s = DeviceSurfaces::new(g, n);
        let p = GbSurfacesParams {
            pixels: npix as u32,
            width: w,
            stride: gb.stride,
            eye: view.eye.to_array(),
        };
        let l = launch::FrGbSurfaces {
            flags: &flags,
            offs: &offs,
            g_tris: tris,
            g_material: material,
            gb_pos: &gb.pos,
            gb_nrm: &gb.normal,
            gb_id: &gb.id,
            s_pos: &s.s.pos,
            s_ng: &s.s.ng,
            s_ns: &s.s.ns,
            s_inc: &s.s.inc,
            s_tw: &s.s.tw,
            s_mat: &s.s.mat,
            s_pix: &s.pix,
        };
        ex.run(l, p, npix, 256);
        s
    };
    stats.covered_pixels = surf.len;
    clock.lap(&mut ex, &mut stats, FramePhase::RayCreation);

    let mut generation = 0u32;
    loop {
        let n = surf.len;
        // Shadows of this generation's surfaces, then local shading.
        progress.stage(&format!("shadow rays, generation {generation}"));
        let m = n * nl;
        let occ = g.storage("occluded", m * 4);
        if m > 0 {
            let rays = DeviceRays::storage(g, "shadow", m);
            surf.s
                .shadow_rays(&mut ex, &lights, &rays.org, &rays.dir, n, nl);
            ex.run(
                launch::FrShadowMeta {
                    s_pix: &surf.pix,
                    r_kl: &rays.kl,
                    r_pix: &rays.pix,
                },
                ShadowMetaParams {
                    rays: m as u32,
                    lights: nl as u32,
                },
                m,
                256,
            );
            clock.lap(&mut ex, &mut stats, FramePhase::RayCreation);
            let rec = trace_device(engine, &rays, TraceMode::Any, &mut stats.trace);
            stats.rays_shadow += m;
            clock.lap(&mut ex, &mut stats, FramePhase::Trace);
            ex.run(
                launch::FrOccluded {
                    rec: &rec,
                    out_u: &occ,
                },
                FrameCountParams { n: m as u32 },
                m,
                256,
            );
        }
        progress.stage(&format!("shading, generation {generation}"));
        if n > 0 {
            let colour = g.storage("colour", n * 16);
            surf.s.shade(&mut ex, &lights, &mats, &occ, &colour, n, nl);
            ex.run(
                launch::FrAccumulate {
                    s_pix: &surf.pix,
                    img: &img,
                    col: &colour,
                },
                FrameCountParams { n: n as u32 },
                n,
                256,
            );
        }
        clock.lap(&mut ex, &mut stats, FramePhase::Shading);
        if generation >= opts.bounces || n == 0 {
            break;
        }
        progress.stage(&format!("secondary rays, generation {}", generation + 1));
        let slots = 2 * n;
        let (b_org, b_dir, b_w) = (
            g.storage("slot org", slots * 16),
            g.storage("slot dir", slots * 16),
            g.storage("slot weight", slots * 16),
        );
        surf.s
            .bounce_rays(&mut ex, &mats, [&b_org, &b_dir, &b_w], n);
        let flags = g.storage("slot flags", slots * 4);
        let offs = g.storage("slot offsets", (slots + 1) * 4);
        ex.run(
            launch::FrSlotFlags {
                col: &b_w,
                flags: &flags,
            },
            FrameCountParams { n: slots as u32 },
            slots,
            256,
        );
        ex.scan(&flags, &offs, slots);
        let r = ex.read_at(&offs, slots as usize) as u64;
        if r == 0 {
            clock.lap(&mut ex, &mut stats, FramePhase::RayCreation);
            break;
        }
        let rays = DeviceRays::storage(g, "bounce", r);
        let weight = g.storage("bounce weight", r * 16);
        ex.run(
            launch::FrBounceEmit {
                flags: &flags,
                offs: &offs,
                b_org: &b_org,
                b_dir: &b_dir,
                col: &b_w,
                s_pix: &surf.pix,
                r_org: &rays.org,
                r_dir: &rays.dir,
                r_kl: &rays.kl,
                r_pix: &rays.pix,
                r_w: &weight,
            },
            FrameCountParams { n: slots as u32 },
            slots,
            256,
        );
        let refractions = kind_count(&mut ex, &rays.kl, r);
        stats.rays_refraction += refractions;
        stats.rays_reflection += r - refractions;
        clock.lap(&mut ex, &mut stats, FramePhase::RayCreation);
        let rec = trace_device(engine, &rays, TraceMode::Closest, &mut stats.trace);
        clock.lap(&mut ex, &mut stats, FramePhase::Trace);
        // The background behind the misses, then the next generation's surfaces.
        let p = MissesParams {
            rays: r as u32,
            background: bg.to_array(),
        };
        ex.run(
            launch::FrMisses {
                r_pix: &rays.pix,
                r_w: &weight,
                rec: &rec,
                img: &img,
            },
            p,
            r,
            256,
        );
        let hflags = g.storage("hit flags", r * 4);
        let hoffs = g.storage("hit offsets", (r + 1) * 4);
        ex.run(
            launch::FrHitFlags {
                rec: &rec,
                flags: &hflags,
            },
            FrameCountParams { n: r as u32 },
            r,
            256,
        );
        ex.scan(&hflags, &hoffs, r);
        let nh = ex.read_at(&hoffs, r as usize) as u64;
        let next = DeviceSurfaces::new(g, nh);
        let l = launch::FrHitSurfaces {
            flags: &hflags,
            offs: &hoffs,
            rec: &rec,
            r_dir: &rays.dir,
            r_pix: &rays.pix,
            r_w: &weight,
            g_tris: tris,
            g_normals: normals,
            g_material: material,
            s_pos: &next.s.pos,
            s_ng: &next.s.ng,
            s_ns: &next.s.ns,
            s_inc: &next.s.inc,
            s_tw: &next.s.tw,
            s_mat: &next.s.mat,
            s_pix: &next.pix,
        };
        ex.run(l, FrameCountParams { n: r as u32 }, r, 256);
        surf = next;
        clock.lap(&mut ex, &mut stats, FramePhase::Shading);
        generation += 1;
    }
    // The image out, as sRGB bytes.
    let words = (3 * npix).div_ceil(4);
    let enc = g.storage("srgb", words * 4);
    ex.run(
        launch::FrEncode {
            img: &img,
            out_u: &enc,
        },
        EncodeParams {
            words: words as u32,
            pixels: npix as u32,
        },
        words,
        256,
    );
    let raw: Vec<u32> = ex.read(&enc, words as usize);
    let mut srgb8: Vec<u8> = raw.iter().flat_map(|w| w.to_le_bytes()).collect();
    srgb8.truncate(3 * npix as usize);
    clock.lap(&mut ex, &mut stats, FramePhase::Shading);
    stats.total_tests = stats.trace.total_tests();
    stats.brute_force_tests = stats.rays_traced() * geo.len() as u64;
    Ok(FrameOut { srgb8, stats })
}

/// Refraction rays (kind 3) among the `n` rays of `kl`, counted per chunk on the device.
fn kind_count(ex: &mut Exec, kl: &wgpu::Buffer, n: u64) -> u64 {
    let chunks = n.div_ceil(TOTALS_CHUNK);
    let out = ex.g.storage("kind counts", chunks * 4);
    ex.run(
        launch::FrKindCount {
            r_kl: kl,
            out_u: &out,
        },
        KindCountParams {
            rays: n as u32,
            kind: 3,
        },
        chunks,
        256,
    );
    let v: Vec<u32> = ex.read(&out, chunks as usize);
    v.iter().map(|&c| c as u64).sum()
}
