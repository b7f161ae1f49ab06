//! The batched Whitted loop of the hybrid renderer (thesis chapter 3, Figure 3.1), written
//! once for every backend.
//!
//! rasterize → G-buffer → surfaces; then per generation: shadow rays (any hit) → shade;
//! reflection/refraction rays (closest hit) → the background behind the misses and the next
//! generation's surfaces; up to `bounces` generations. [`run`] is the loop; a [`Backend`]
//! says where the surfaces, rays, hits and image live and runs each step over them: the CPU
//! backend ([`crate::cpu::CpuBackend`]) with host arrays and any [`Tracer`], the GPU backend
//! (`gpu::frame::GpuBackend`) with device buffers and kernels. Every batch goes to the
//! backend's one engine, so engines are compared on identical rays; contributions are
//! accumulated in surface order, so images are bit-reproducible.

use crate::cpu::CpuBackend;
use crate::raster::{default_near, GBuffer, RasterStats};
use crate::stats::{FramePhase, RenderStats};
use crate::view::View;
use geom::Vec3;
use scene::{Geometry, Scene};
use std::time::Instant;
use trace::batch::{Hit, RayBatch};
use trace::tracer::{TraceMode, Tracer};
use trace::TraceStats;

/// Largest accepted image side and bounce count (the CLI validates against these).
pub const MAX_SIDE: u32 = 16384;
/// Largest accepted Whitted recursion depth.
pub const MAX_BOUNCES: u32 = 16;

/// The memory model of a CPU render, in bytes per pixel: the G-buffer (68: triangle,
/// barycentrics, depth, position, normal, diffuse, specular), the image (12), one
/// generation's surfaces (88) and the rasterizer's tile bins (16, four triangles per pixel
/// on average), plus per ray of a generation — one shadow ray per light and two
/// reflection/refraction rays per surface — the batch (54), its hits (16) and an engine's
/// per-ray arrays (64: keys, order, leaves, constants).
pub const BYTES_PER_PIXEL: u64 = 68 + 12 + 88 + 16;
/// Bytes per traced ray in the model of [`BYTES_PER_PIXEL`].
pub const BYTES_PER_RAY: u64 = 54 + 16 + 64;

/// The peak bytes of a `width × height` render with `lights` lights, by the model of
/// [`BYTES_PER_PIXEL`] (checked before anything is allocated; the scene and the engine's
/// structure come on top).
pub fn render_bytes(width: u32, height: u32, lights: usize) -> u64 {
    let px = width as u64 * height as u64;
    let rays_per_pixel = lights.max(1) as u64 + 2;
    px * (BYTES_PER_PIXEL + rays_per_pixel * BYTES_PER_RAY)
}

/// The image and the recursion depth of a render.
#[derive(Clone, Copy, Debug)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Reflection/refraction generations after the rasterized one.
    pub bounces: u32,
    /// Samples per pixel (antialiasing): each a whole frame of a jittered view
    /// ([`crate::view::sample_offset`]), every sample's rays traced by the engine, the
    /// pixels their mean (a box filter). 1 (the papers' counts): the pixel centres only.
    pub spp: u32,
}

/// Largest accepted samples per pixel.
pub const MAX_SPP: u32 = 256;

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 512,
            height: 512,
            bounces: 3,
            spp: 1,
        }
    }
}

/// Receives stage names while a render runs (the CLI shows them on a progress bar).
pub trait Progress: Sync {
    /// A stage of the render begins (e.g. `shading, generation 2`).
    fn stage(&self, name: &str);
}

impl Progress for () {
    fn stage(&self, _: &str) {}
}

/// The result of a render: linear RGB pixels (or, from a device-resident GPU frame, only
/// their sRGB bytes), the G-buffer and the statistics.
pub struct Rendered {
    /// Linear RGB, row-major; empty when the frame stayed on a device that sent back only
    /// [`Rendered::srgb8`].
    pub pixels: Vec<Vec3>,
    /// The image as sRGB bytes, when a device encoded it (then `pixels` and `gbuffer` are
    /// empty: they never left the device).
    pub srgb8: Option<Vec<u8>>,
    /// The rasterized primary visibility.
    pub gbuffer: GBuffer,
    /// The rasterizer's counters.
    pub raster: RasterStats,
    /// Counters and times of the whole render.
    pub stats: RenderStats,
}

impl Rendered {
    /// The image as row-major sRGB bytes (r, g, b per pixel): what the PNG stores.
    pub fn rgb8(&self) -> Vec<u8> {
        match &self.srgb8 {
            Some(b) => b.clone(),
            None => {
                crate::output::to_rgb8(&self.pixels, self.stats.width, self.stats.height).into_raw()
            }
        }
    }
}

/// Where a render's data lives and how each step of the loop runs on it. The loop ([`run`])
/// calls the steps in a fixed order and times them; a backend only does the work (and, at
/// [`Backend::sync`], waits for work it queued, so that a phase's time is its own).
pub trait Backend {
    /// One generation's surfaces (host arrays or device buffers).
    type Surfaces;
    /// A batch of rays.
    type Rays;
    /// The hits of a traced batch.
    type Hits;

    /// The engine's name (the `engine` of the statistics).
    fn engine_name(&self) -> String;
    /// Rasterize the primary visibility of `view` (near plane at `near`) into a G-buffer.
    fn rasterize(&mut self, view: &View, near: f32);
    /// The G-buffer's surfaces, in pixel order; the image starts as the background where
    /// nothing is seen and black elsewhere.
    fn primary_surfaces(&mut self, view: &View) -> Self::Surfaces;
    /// How many surfaces `s` holds; `None` when only the backend's device knows (a backend
    /// that says so adds the count to the statistics itself, in [`Backend::finish`]).
    fn surfaces_len(&self, s: &Self::Surfaces) -> Option<u64>;
    /// Shadow rays, one per (surface, light), surface-major (eqs. 3.1–3.2).
    fn shadow_rays(&mut self, s: &Self::Surfaces) -> Self::Rays;
    /// Reflection and refraction rays of the surfaces, surface-major (eqs. 3.3–3.7).
    fn bounce_rays(&mut self, s: &Self::Surfaces) -> Self::Rays;
    /// How many rays `r` holds; `None` when only the backend's device knows.
    fn rays_len(&self, r: &Self::Rays) -> Option<u64>;
    /// `r`'s rays by kind (primary, shadow, reflection, refraction), of the parts whose
    /// sizes the host knows: a backend adds the others to the statistics in
    /// [`Backend::finish`].
    fn count_kinds(&mut self, r: &Self::Rays) -> [u64; 4];
    /// The hit records `r`'s trace writes into, made ready before the trace is timed (the
    /// CPU's: one miss record per ray, in buffers kept from earlier batches), so that the
    /// trace phase is the engine's work only.
    fn hit_records(&mut self, r: &Self::Rays) -> Self::Hits;
    /// Trace `r` with the backend's engine into `hits` (from [`Backend::hit_records`]),
    /// counting into `stats`.
    fn trace(
        &mut self,
        r: &Self::Rays,
        hits: &mut Self::Hits,
        mode: TraceMode,
        stats: &mut TraceStats,
    );
    /// Local illumination of every surface times its throughput (eqs. 3.17–3.19), added to
    /// its pixel in surface order; `shadows` are the shadow rays and their any-hit results
    /// (`None`: no shadow ray, so no light is hidden).
    fn shade(&mut self, s: &Self::Surfaces, shadows: Option<(&Self::Rays, &Self::Hits)>);
    /// The background times the weight of every ray of `r` that hit nothing, added to its
    /// pixel in ray order, then the surfaces of the hits, in ray order.
    fn next_surfaces(&mut self, r: &Self::Rays, h: &Self::Hits) -> Self::Surfaces;
    /// Take back a batch and its hits the loop is done with (a backend may keep their
    /// buffers for the next generation or frame).
    fn recycle(&mut self, _rays: Self::Rays, _hits: Option<Self::Hits>) {}
    /// Take back surfaces the loop is done with.
    fn recycle_surfaces(&mut self, _s: Self::Surfaces) {}
    /// Wait for the work queued so far (a device backend; the CPU's is done already).
    fn sync(&mut self);
    /// The image and the G-buffer as the render's result, with `stats` (to whose `trace` a
    /// backend adds the counts it kept on its device until now); `linear`: the caller needs
    /// the linear pixels (it averages samples), not only the sRGB bytes.
    fn finish(&mut self, stats: RenderStats, linear: bool) -> Rendered;
}

/// `f` timed into `phase`, the backend's queued work included.
fn timed<B: Backend, T>(
    b: &mut B,
    stats: &mut RenderStats,
    phase: FramePhase,
    f: impl FnOnce(&mut B) -> T,
) -> T {
    let t0 = Instant::now();
    let r = f(b);
    b.sync();
    stats.add_phase(phase, t0.elapsed().as_secs_f64());
    r
}

/// `r` traced, timed and counted by kind: its hit records made ready as part of the ray
/// creation, then the engine's trace call alone timed as the trace.
fn trace<B: Backend>(b: &mut B, r: &B::Rays, mode: TraceMode, stats: &mut RenderStats) -> B::Hits {
    let [p, s, rl, rf] = b.count_kinds(r);
    stats.rays_primary_traced += p;
    stats.rays_shadow += s;
    stats.rays_reflection += rl;
    stats.rays_refraction += rf;
    let mut h = timed(b, stats, FramePhase::RayCreation, |b| b.hit_records(r));
    let t0 = Instant::now();
    b.trace(r, &mut h, mode, &mut stats.trace);
    b.sync();
    stats.add_phase(FramePhase::Trace, t0.elapsed().as_secs_f64());
    h
}

/// Render `scene` with `tracer` on the CPU: the CPU rasterizer's G-buffer, then the Whitted
/// generations with every batch traced by `tracer` ([`run`] on a [`CpuBackend`]).
pub fn render(
    scene: &Scene,
    geo: &Geometry,
    tracer: &dyn Tracer,
    opts: &RenderOptions,
    progress: &dyn Progress,
) -> Rendered {
    run(
        &mut CpuBackend::new(scene, geo, tracer),
        scene,
        geo,
        opts,
        progress,
    )
}

/// The Whitted loop: one frame of `scene` (whose geometry is `geo`) on `backend`, with
/// `opts.spp` samples per pixel.
///
/// More than one sample renders the frame once per sample, from views jittered inside
/// the pixels, and averages the linear pixels in sample order (a box filter, so the bytes
/// do not depend on threads); the statistics add up every sample's rays, tests and phase
/// times, and `covered_pixels` is the first sample's.
pub fn run<B: Backend>(
    backend: &mut B,
    scene: &Scene,
    geo: &Geometry,
    opts: &RenderOptions,
    progress: &dyn Progress,
) -> Rendered {
    let base = View::new(&scene.camera, opts.width, opts.height);
    let spp = opts.spp.max(1);
    if spp == 1 {
        return frame(backend, scene, geo, opts, &base, progress, false);
    }
    let mut out: Option<Rendered> = None;
    for i in 0..spp {
        let p = Sample {
            inner: progress,
            i,
            n: spp,
        };
        let view = base.jittered(crate::view::sample_offset(i, spp));
        let r = frame(backend, scene, geo, opts, &view, &p, true);
        match &mut out {
            None => out = Some(r),
            Some(acc) => {
                for (a, b) in acc.pixels.iter_mut().zip(&r.pixels) {
                    *a += *b;
                }
                acc.stats.add_sample(&r.stats);
            }
        }
    }
    let mut out = out.expect("at least one sample");
    let n = spp as f32;
    for p in &mut out.pixels {
        *p /= n;
    }
    out.srgb8 = None;
    out.stats.spp = spp;
    out.stats.set_phase_ms();
    out
}

/// Stage names of sample `i` of `n` (`sample 2/4: shading, generation 1`).
struct Sample<'a> {
    inner: &'a dyn Progress,
    i: u32,
    n: u32,
}

impl Progress for Sample<'_> {
    fn stage(&self, name: &str) {
        self.inner
            .stage(&format!("sample {}/{}: {name}", self.i + 1, self.n));
    }
}

/// One frame of `view` (one sample per pixel); `linear`: keep the linear pixels.
fn frame<B: Backend>(
    backend: &mut B,
    scene: &Scene,
    geo: &Geometry,
    opts: &RenderOptions,
    view: &View,
    progress: &dyn Progress,
    linear: bool,
) -> Rendered {
    let view = *view;
    let mut stats = RenderStats {
        scene: scene.name.clone(),
        engine: backend.engine_name(),
        width: opts.width,
        height: opts.height,
        triangles: geo.len() as u64,
        meshes: geo.mesh_count() as u64,
        lights: scene.lights.len() as u64,
        bounces: opts.bounces,
        spp: 1,
        ..Default::default()
    };
    let st = &mut stats;
    progress.stage("rasterize");
    timed(backend, st, FramePhase::Rasterize, |b| {
        b.rasterize(&view, default_near(geo))
    });
    let mut surfaces = timed(backend, st, FramePhase::RayCreation, |b| {
        b.primary_surfaces(&view)
    });
    // A device-sized generation's count comes with the image (`finish`).
    st.covered_pixels = backend.surfaces_len(&surfaces).unwrap_or(0);
    let mut generation = 0u32;
    loop {
        let n = backend.surfaces_len(&surfaces);
        // Shadows of this generation's surfaces, then local shading.
        progress.stage(&format!("shadow rays, generation {generation}"));
        let shadows = timed(backend, st, FramePhase::RayCreation, |b| {
            b.shadow_rays(&surfaces)
        });
        let occluded = (backend.rays_len(&shadows) != Some(0))
            .then(|| trace(backend, &shadows, TraceMode::Any, st));
        progress.stage(&format!("shading, generation {generation}"));
        timed(backend, st, FramePhase::Shading, |b| {
            b.shade(&surfaces, occluded.as_ref().map(|h| (&shadows, h)))
        });
        backend.recycle(shadows, occluded);
        // A generation whose size only the device knows goes on: its launches read the
        // size there, and an empty one does nothing.
        if generation >= opts.bounces || n == Some(0) {
            break;
        }
        progress.stage(&format!("secondary rays, generation {}", generation + 1));
        let rays = timed(backend, st, FramePhase::RayCreation, |b| {
            b.bounce_rays(&surfaces)
        });
        if backend.rays_len(&rays) == Some(0) {
            backend.recycle(rays, None);
            break;
        }
        let hits = trace(backend, &rays, TraceMode::Closest, st);
        let next = timed(backend, st, FramePhase::Shading, |b| {
            b.next_surfaces(&rays, &hits)
        });
        backend.recycle(rays, Some(hits));
        backend.recycle_surfaces(std::mem::replace(&mut surfaces, next));
        generation += 1;
    }
    backend.recycle_surfaces(surfaces);
    let mut out = backend.finish(stats, linear);
    // After `finish`: a backend may add counts it held on the device until then.
    out.stats.brute_force_tests = out.stats.rays_traced() * geo.len() as u64;
    out.stats.total_tests = out.stats.trace.total_tests();
    out.stats.set_phase_ms();
    out
}

/// Trace primary rays through every pixel centre (closest hit): the reference the
/// rasterizer is checked against, and the `primary` ray kind of the evaluation.
pub fn trace_primary(view: &View, tracer: &dyn Tracer) -> (RayBatch, Vec<Hit>, trace::TraceStats) {
    let rays = view.primary_rays();
    let mut hits = vec![Hit::MISS; rays.len()];
    let mut st = Default::default();
    tracer.trace(&rays, TraceMode::Closest, &mut hits, &mut st);
    (rays, hits, st)
}
