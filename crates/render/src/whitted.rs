//! The batched Whitted loop of the hybrid renderer (thesis chapter 3, Figure 3.1).
//!
//! rasterize → G-buffer → surfaces; then per generation: shadow rays (any hit) → shade;
//! reflection/refraction rays (closest hit) → next generation's surfaces; up to `bounces`
//! generations. Every batch goes to the same [`Tracer`], so engines are compared on identical
//! rays. Contributions are accumulated in a fixed order, so images are bit-reproducible.

use crate::raster::{default_near, rasterize, GBuffer, RasterStats};
use crate::secondary::{bounce_rays, shadow_rays, Surfaces};
use crate::shade;
use crate::stats::{FramePhase, RenderStats};
use crate::view::View;
use geom::Vec3;
use rayon::prelude::*;
use scene::{Geometry, Light, Material, Scene};
use std::time::Instant;
use trace::batch::{Hit, RayBatch};
use trace::tracer::{TraceMode, Tracer};

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
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 512,
            height: 512,
            bounces: 3,
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

fn timed<T>(stats: &mut RenderStats, phase: FramePhase, f: impl FnOnce() -> T) -> T {
    let t0 = Instant::now();
    let r = f();
    stats.add_phase(phase, t0.elapsed().as_secs_f64());
    r
}

fn trace(
    tracer: &dyn Tracer,
    rays: &RayBatch,
    mode: TraceMode,
    stats: &mut RenderStats,
) -> Vec<Hit> {
    let mut hits = vec![Hit::MISS; rays.len()];
    let t0 = Instant::now();
    tracer.trace(rays, mode, &mut hits, &mut stats.trace);
    stats.add_phase(FramePhase::Trace, t0.elapsed().as_secs_f64());
    let [p, s, rl, rf] = rays.count_by_kind();
    stats.rays_primary_traced += p;
    stats.rays_shadow += s;
    stats.rays_reflection += rl;
    stats.rays_refraction += rf;
    hits
}

/// Render `scene` with `tracer`: the G-buffer from the CPU rasterizer, then the Whitted
/// generations (shadow, reflection and refraction rays traced by `tracer`) and shading on the
/// CPU ([`render_with`] lets a backend replace the rasterizer and the passes).
pub fn render(
    scene: &Scene,
    geo: &Geometry,
    tracer: &dyn Tracer,
    opts: &RenderOptions,
    progress: &dyn Progress,
) -> Rendered {
    render_with(
        scene,
        geo,
        tracer,
        opts,
        progress,
        &|view, near| rasterize(geo, &scene.materials, view, near),
        &CpuStages,
    )
}

/// Primary visibility from a rasterizer: the view and the near-plane distance in, a
/// G-buffer out (the CPU rasterizer, or the GPU backend's render pipeline).
pub type RasterFn<'a> = dyn Fn(&View, f32) -> (GBuffer, RasterStats) + 'a;

/// The per-generation passes of the Whitted loop around the traces: shadow-ray generation,
/// local shading and reflection/refraction-ray generation. The defaults are the CPU passes
/// (`secondary`, `shade`); the GPU backend implements them as kernels.
pub trait Stages {
    /// Shadow rays, one per (surface, light), surface-major ([`shadow_rays`]).
    fn shadow_rays(&self, s: &Surfaces, lights: &[Light]) -> RayBatch {
        shadow_rays(s, lights)
    }

    /// Local illumination of every surface times its throughput ([`shade::local`]) under
    /// the scene's materials and lights; `occluded[i · lights + l]` says whether light l is
    /// hidden from surface i.
    fn local_shading(&self, s: &Surfaces, scene: &Scene, occluded: &[bool]) -> Vec<Vec3> {
        let (materials, lights) = (&scene.materials, &scene.lights);
        let nl = lights.len();
        (0..s.len())
            .into_par_iter()
            .map(|i| {
                let visible: Vec<bool> = (0..nl).map(|l| !occluded[i * nl + l]).collect();
                let m = &materials[s.material[i] as usize];
                shade::local(s, i, m, lights, &visible, scene.ambient) * s.throughput[i]
            })
            .collect()
    }

    /// Reflection and refraction rays ([`bounce_rays`]).
    fn bounce_rays(&self, s: &Surfaces, materials: &[Material]) -> RayBatch {
        bounce_rays(s, materials)
    }

    /// The three passes of one generation over surfaces `s`, which the borrow keeps
    /// unchanged across them (so a backend may move them to its device once, not once per
    /// pass). The default runs the passes above with `s` each time.
    fn generation<'a>(&'a self, s: &'a Surfaces) -> Box<dyn Generation + 'a> {
        Box::new(EachPass { stages: self, s })
    }
}

/// One generation's passes over its surfaces (see [`Stages::generation`]).
pub trait Generation {
    /// [`Stages::shadow_rays`] of the generation's surfaces.
    fn shadow_rays(&self, lights: &[Light]) -> RayBatch;
    /// [`Stages::local_shading`] of the generation's surfaces.
    fn local_shading(&self, scene: &Scene, occluded: &[bool]) -> Vec<Vec3>;
    /// [`Stages::bounce_rays`] of the generation's surfaces.
    fn bounce_rays(&self, materials: &[Material]) -> RayBatch;
}

/// The default [`Generation`]: each pass called with the surfaces.
struct EachPass<'a, S: Stages + ?Sized> {
    stages: &'a S,
    s: &'a Surfaces,
}

impl<S: Stages + ?Sized> Generation for EachPass<'_, S> {
    fn shadow_rays(&self, lights: &[Light]) -> RayBatch {
        self.stages.shadow_rays(self.s, lights)
    }
    fn local_shading(&self, scene: &Scene, occluded: &[bool]) -> Vec<Vec3> {
        self.stages.local_shading(self.s, scene, occluded)
    }
    fn bounce_rays(&self, materials: &[Material]) -> RayBatch {
        self.stages.bounce_rays(self.s, materials)
    }
}

/// The CPU passes.
pub struct CpuStages;

impl Stages for CpuStages {}

/// [`render`] with another rasterizer for the primary visibility and other implementations
/// of the per-generation passes.
pub fn render_with(
    scene: &Scene,
    geo: &Geometry,
    tracer: &dyn Tracer,
    opts: &RenderOptions,
    progress: &dyn Progress,
    raster_fn: &RasterFn,
    stages: &dyn Stages,
) -> Rendered {
    let view = View::new(&scene.camera, opts.width, opts.height);
    let lights = &scene.lights;
    let mut stats = RenderStats {
        scene: scene.name.clone(),
        engine: tracer.name().to_string(),
        width: opts.width,
        height: opts.height,
        triangles: geo.len() as u64,
        meshes: geo.mesh_count() as u64,
        lights: lights.len() as u64,
        bounces: opts.bounces,
        ..Default::default()
    };
    progress.stage("rasterize");
    let (gb, raster) = timed(&mut stats, FramePhase::Rasterize, || {
        raster_fn(&view, default_near(geo))
    });
    let npix = (opts.width * opts.height) as usize;
    let mut pixels: Vec<Vec3> = gb
        .tri
        .iter()
        .map(|&t| {
            if t == geom::NO_HIT {
                scene.background
            } else {
                Vec3::ZERO
            }
        })
        .collect();
    let mut surfaces = timed(&mut stats, FramePhase::RayCreation, || {
        Surfaces::from_gbuffer(&gb, geo, view.eye)
    });
    stats.covered_pixels = surfaces.len() as u64;
    debug_assert_eq!(pixels.len(), npix);
    let mut generation = 0u32;
    loop {
        // The generation's passes share its surfaces (a backend moves them once).
        let gen = stages.generation(&surfaces);
        // Shadows of this generation's surfaces, then local shading.
        progress.stage(&format!("shadow rays, generation {generation}"));
        let shadows = timed(&mut stats, FramePhase::RayCreation, || {
            gen.shadow_rays(lights)
        });
        let occl = if shadows.is_empty() {
            Vec::new()
        } else {
            trace(tracer, &shadows, TraceMode::Any, &mut stats)
        };
        progress.stage(&format!("shading, generation {generation}"));
        timed(&mut stats, FramePhase::Shading, || {
            let occluded: Vec<bool> = occl.iter().map(|h| h.is_hit()).collect();
            let local = gen.local_shading(scene, &occluded);
            for (i, c) in local.into_iter().enumerate() {
                pixels[surfaces.pixel[i] as usize] += c;
            }
        });
        if generation >= opts.bounces {
            break;
        }
        progress.stage(&format!("secondary rays, generation {}", generation + 1));
        let rays = timed(&mut stats, FramePhase::RayCreation, || {
            gen.bounce_rays(&scene.materials)
        });
        drop(gen);
        if rays.is_empty() {
            break;
        }
        let hits = trace(tracer, &rays, TraceMode::Closest, &mut stats);
        surfaces = timed(&mut stats, FramePhase::Shading, || {
            for (i, h) in hits.iter().enumerate() {
                if !h.is_hit() {
                    pixels[rays.pixel[i] as usize] += scene.background * rays.throughput[i];
                }
            }
            Surfaces::from_hits(&rays, &hits, geo)
        });
        generation += 1;
    }
    stats.total_tests = stats.trace.total_tests();
    stats.brute_force_tests = stats.rays_traced() * geo.len() as u64;
    Rendered {
        pixels,
        srgb8: None,
        gbuffer: gb,
        raster,
        stats,
    }
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
