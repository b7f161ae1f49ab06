//! One frame of a dynamic scene (the papers' use case: CRSH §3.2.2 updates the mesh spheres
//! by transform, the irregular grid is rebuilt every frame, §5.3): update, rebuild, render,
//! with build and trace times apart, and the frame's `--frame-csv` record. The command
//! line's `render --frames` and the bindings' distributed frames both render through
//! [`frame`], so their images and records agree by construction; `--backend gpu` renders
//! through [`gpu_frame`] with the same record.

use crate::engines::{self, Config, Engine, EngineError};
use render::whitted::{RenderOptions, Rendered};
use scene::Geometry;
use serde::Serialize;
use std::time::Instant;
use trace::Phase;

/// One frame's record for `--frame-csv`.
#[derive(Clone, Debug, Serialize)]
pub struct FrameRow {
    pub frame: u32,
    pub time: f32,
    pub triangles: usize,
    pub update_ms: f64,
    pub build_ms: f64,
    /// The whole render (the CSV's `render_ms`): rasterization, ray creation, the engine's
    /// trace calls and shading, the four phase columns below.
    pub render_ms: f64,
    pub rays: u64,
    pub total_tests: u64,
    /// Engine phases inside the render (ms): for CRSH/RAH the per-frame ray-hierarchy build
    /// (hash … hierarchy creation) and its traversal, in [`engine_phases`] order.
    pub phases_ms: Vec<(Phase, f64)>,
    /// The render's phases (ms): primary visibility into the G-buffer, ray creation, the
    /// engine's trace calls, shading (the CSV's last four columns).
    pub raster_ms: f64,
    pub ray_creation_ms: f64,
    pub trace_ms: f64,
    pub shading_ms: f64,
}

/// The engine phases `--frame-csv` reports (the CPU's: no transfers; absent phases are 0).
pub fn engine_phases() -> impl Iterator<Item = Phase> {
    engines::phases().into_iter().filter(|p| !p.is_transfer())
}

impl FrameRow {
    /// The CSV header line (without the line end).
    pub fn csv_header() -> String {
        let mut h =
            String::from("frame,time,triangles,update_ms,build_ms,render_ms,rays,total_tests");
        for p in engine_phases() {
            h += &format!(",{}_ms", p.as_str().replace(' ', "_"));
        }
        h + ",raster_ms,ray_creation_ms,trace_ms,shading_ms"
    }

    /// The record as a CSV line (without the line end).
    pub fn csv_line(&self) -> String {
        let mut l = format!(
            "{},{},{},{:.3},{:.3},{:.3},{},{}",
            self.frame,
            self.time,
            self.triangles,
            self.update_ms,
            self.build_ms,
            self.render_ms,
            self.rays,
            self.total_tests
        );
        for (_, p) in &self.phases_ms {
            l += &format!(",{p:.3}");
        }
        l + &format!(
            ",{:.3},{:.3},{:.3},{:.3}",
            self.raster_ms, self.ray_creation_ms, self.trace_ms, self.shading_ms
        )
    }
}

/// What a sequence of frames keeps from one frame to the next: the geometry's buffers
/// and the renderer's ([`render::cpu::FrameArena`]), refilled in place each frame.
#[derive(Default)]
pub struct FrameBuffers {
    geo: Geometry,
    arena: render::cpu::FrameArena,
}

/// The scene at time `t` as a frame renders it (camera, lights, materials; the meshes'
/// triangles are `geo`'s, refilled in place: transforms and the meshes' culling spheres
/// updated), with the seconds it took.
fn update(scene: &scene::Scene, t: f32, geo: &mut Geometry) -> (scene::Scene, f64) {
    let t0 = Instant::now();
    let s = scene.frame_at(t);
    geo.refill_at(scene, t);
    (s, t0.elapsed().as_secs_f64())
}

/// Frame `index` of `scene` at time `t`: update the transforms, rebuild `engine` with its
/// configuration `cfg` ([`engines::config::config`] of a frame), render.
pub fn frame(
    scene: &scene::Scene,
    t: f32,
    index: u32,
    engine: Engine,
    cfg: &Config,
    opts: &RenderOptions,
) -> Result<(Rendered, FrameRow), EngineError> {
    frame_with(
        &mut FrameBuffers::default(),
        scene,
        t,
        index,
        engine,
        cfg,
        opts,
    )
}

/// [`frame`] with the buffers of the frames before it (`render --frames` keeps one
/// [`FrameBuffers`] for the whole sequence, so a steady frame allocates almost nothing).
pub fn frame_with(
    buffers: &mut FrameBuffers,
    scene: &scene::Scene,
    t: f32,
    index: u32,
    engine: Engine,
    cfg: &Config,
    opts: &RenderOptions,
) -> Result<(Rendered, FrameRow), EngineError> {
    let (s, update_s) = update(scene, t, &mut buffers.geo);
    let geo = &buffers.geo;
    let t1 = Instant::now();
    let tracer = engines::build(engine, cfg, geo)?.tracer;
    let build_s = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    let arena = std::mem::take(&mut buffers.arena);
    let mut backend = render::cpu::CpuBackend::new(&s, geo, tracer.as_ref()).with_arena(arena);
    let mut out = render::whitted::run(&mut backend, &s, geo, opts, &());
    buffers.arena = backend.into_arena();
    // A frame of a sequence is its image and record: its G-buffer goes back to the
    // buffers for the next frame's rasterization.
    buffers.arena.keep_gbuffer(std::mem::take(&mut out.gbuffer));
    let trace_s = t2.elapsed().as_secs_f64();
    let row = FrameRow::of(index, t, geo, [update_s, build_s, trace_s], &out);
    Ok((out, row))
}

impl FrameRow {
    /// The record of frame `index` at time `t`: seconds of update, build and render, and the
    /// render's counts and engine phases.
    fn of(index: u32, t: f32, geo: &Geometry, secs: [f64; 3], out: &Rendered) -> FrameRow {
        FrameRow {
            frame: index,
            time: t,
            triangles: geo.len(),
            update_ms: secs[0] * 1e3,
            build_ms: secs[1] * 1e3,
            render_ms: secs[2] * 1e3,
            rays: out.stats.rays_traced(),
            total_tests: out.stats.trace.total_tests(),
            phases_ms: engine_phases()
                .map(|p| (p, out.stats.trace.seconds(p) * 1e3))
                .collect(),
            raster_ms: out.stats.raster_ms,
            ray_creation_ms: out.stats.ray_creation_ms,
            trace_ms: out.stats.trace_ms,
            shading_ms: out.stats.shading_ms,
        }
    }
}

/// Frame `index` of `scene` at time `t` on the GPU backend: update the transforms, rebuild
/// `gf`'s engine on its device (one upload of the frame's geometry; the grid's every pass
/// as kernels), render. The record has the CPU's columns; the engine phases are GPU time.
#[cfg(feature = "gpu")]
pub fn gpu_frame(
    gf: &mut crate::gpu_frame::GpuFrame,
    scene: &scene::Scene,
    t: f32,
    index: u32,
    opts: &RenderOptions,
) -> anyhow::Result<(Rendered, FrameRow)> {
    let mut geo = Geometry::default();
    let (s, update_s) = update(scene, t, &mut geo);
    let build_s = gf.rebuild(&s, &geo)?;
    let t2 = Instant::now();
    let (out, _) = gf.render(&s, &geo, opts, &(), build_s)?;
    let trace_s = t2.elapsed().as_secs_f64();
    let row = FrameRow::of(index, t, &geo, [update_s, build_s, trace_s], &out);
    Ok((out, row))
}
