//! One Whitted frame on the wgpu backend, shared by `render --backend gpu`, `bench gpu` and
//! the viewer (thesis §3.1–3.3 on the GPU; see `crates/gpu`).
//!
//! The frame is `render`'s one Whitted loop ([`render::whitted::run`]) on the GPU backend
//! ([`gpu::frame::GpuBackend`]), so it stays on the device: the G-buffer from the GPU's
//! render pipeline, the engine (built and traversed by kernels), the surfaces, the
//! ray generations, the shading and the pixel accumulation are kernels, and only the sRGB
//! image and a few totals come back (and the G-buffer, for the viewer's view of it). A
//! generation too large for one binding of the device is held in parts. The bytes moved
//! between host and device during the frame are reported (`host_device_bytes`).

use crate::engines::{Config, Engine};
use anyhow::{anyhow, Result};
use render::whitted::{Progress, RenderOptions, Rendered};
use scene::{Geometry, Scene};

/// The rasterizer over `geo`, drawing from the engine's triangles on the device (so a
/// frame's triangles are uploaded once, by the engine).
fn raster_over(
    engine: &dyn gpu::GpuEngine,
    scene: &Scene,
    geo: &Geometry,
) -> Result<gpu::GpuRaster> {
    gpu::GpuRaster::with_triangles(
        engine.gpu(),
        engine.triangles().clone(),
        geo,
        &scene.materials,
    )
    .map_err(|e| anyhow!("`backend`=gpu: {e}"))
}

/// A GPU engine built over one geometry (the rasterizer, which borrows its device, is
/// made per frame).
pub struct GpuFrame {
    engine: Box<dyn gpu::GpuEngine>,
    /// The rasterizer over the current geometry, on the engine's device.
    raster: gpu::GpuRaster,
    /// The adapter, as the backend describes it.
    pub describe: String,
    /// How the phase times are measured.
    pub timer: &'static str,
}

impl GpuFrame {
    /// Build `engine` (bvh, crsh, rah, grid or grid2l) with `cfg`, its configuration on the
    /// GPU backend ([`crate::engines::config::config`] with `Backend::Gpu`), over `geo` on a
    /// new device; `on_error` is called if the device is lost later.
    pub fn new(
        engine: Engine,
        cfg: &Config,
        scene: &Scene,
        geo: &Geometry,
        on_error: impl Fn(String) + Send + Sync + 'static,
    ) -> Result<GpuFrame> {
        let g = gpu::Gpu::new().map_err(|e| anyhow!("`backend`=gpu: {e}"))?;
        g.on_device_error(move |e| on_error(e.to_string()));
        let describe = g.describe();
        let timer = match g.timer {
            gpu::device::PhaseTimer::Timestamps => "timestamp queries",
            gpu::device::PhaseTimer::WallClock => {
                "wall clock, waiting at every phase boundary: this adapter has no timestamp queries that time kernels"
            }
        };
        let fail = |e: gpu::GpuError| anyhow!("`backend`=gpu `engine`={}: {e}", engine.name());
        let engine: Box<dyn gpu::GpuEngine> = match cfg {
            Config::Rsh(c) => Box::new(gpu::GpuRsh::new(g, geo, c.clone()).map_err(fail)?),
            Config::Bvh(c) => Box::new(gpu::GpuBvh::new(g, geo, c.clone()).map_err(fail)?),
            // The grid is built and traversed by kernels (gpu::grid::PASS_DEVICE).
            Config::Grid(c) => Box::new(gpu::GpuGrid::new(g, geo, c).map_err(fail)?),
            Config::Plain => anyhow::bail!(
                "`backend`=gpu: `engine`={} has no GPU path (the GPU runs {})",
                engine.name(),
                Engine::gpu_names().join(", ")
            ),
        };
        // The rasterizer's inputs are checked now, so that a scene it cannot take fails here.
        let raster = raster_over(engine.as_ref(), scene, geo)?;
        Ok(GpuFrame {
            engine,
            raster,
            describe,
            timer,
        })
    }

    /// A dynamic scene's next frame: rebuild the engine over `geo` on the same device, with
    /// the same kernels and configuration, and give the rasterizer the frame's geometry;
    /// returns the wall-clock seconds.
    pub fn rebuild(&mut self, scene: &Scene, geo: &Geometry) -> Result<f64> {
        let t0 = std::time::Instant::now();
        self.engine
            .rebuild(geo)
            .map_err(|e| anyhow!("`backend`=gpu: {e}"))?;
        self.raster = raster_over(self.engine.as_ref(), scene, geo)?;
        Ok(t0.elapsed().as_secs_f64())
    }

    /// Render one frame on the device; returns it with the GPU seconds per phase
    /// (rasterize and the engine's). `geo` must be the geometry the engine was built or last
    /// rebuilt over.
    pub fn render(
        &self,
        scene: &Scene,
        geo: &Geometry,
        opts: &RenderOptions,
        progress: &dyn Progress,
        build_seconds: f64,
    ) -> Result<(Rendered, Vec<(String, f64)>)> {
        self.frame(scene, geo, opts, progress, build_seconds, false)
    }

    /// [`GpuFrame::render`], with the G-buffer read back too (`Rendered::gbuffer`: the
    /// viewer's normals view).
    pub fn render_with_gbuffer(
        &self,
        scene: &Scene,
        geo: &Geometry,
        opts: &RenderOptions,
        progress: &dyn Progress,
        build_seconds: f64,
    ) -> Result<(Rendered, Vec<(String, f64)>)> {
        self.frame(scene, geo, opts, progress, build_seconds, true)
    }

    fn frame(
        &self,
        scene: &Scene,
        geo: &Geometry,
        opts: &RenderOptions,
        progress: &dyn Progress,
        build_seconds: f64,
        keep_gbuffer: bool,
    ) -> Result<(Rendered, Vec<(String, f64)>)> {
        self.check_size(opts)?;
        let (f, moved) = self.traffic(|| {
            gpu::frame::render_frame(
                self.engine.as_ref(),
                &self.raster,
                scene,
                geo,
                opts,
                progress,
                keep_gbuffer,
            )
            .map_err(|e| anyhow!("`backend`=gpu: {e}"))
        })?;
        let (mut out, in_parts, again) = (f.out, f.in_parts, f.again);
        let stats = &mut out.stats;
        stats.put_build(build_seconds, self.engine.build_passes());
        (
            stats.host_device_bytes,
            stats.host_read_backs,
            stats.gpu_dispatches,
        ) = (Some(moved[0]), Some(moved[1]), Some(moved[2]));
        let mut how = String::from("device-resident");
        if in_parts {
            how += ", a generation in parts (it exceeded one binding)";
        }
        if again {
            how += ", traced twice (a trace the device paced alone did not finish; the second paced by the host)";
        }
        stats.gpu_frame = Some(how);
        Ok((out, self.phases()))
    }

    /// Whether the device takes a G-buffer of `opts`'s size.
    fn check_size(&self, opts: &RenderOptions) -> Result<()> {
        self.raster
            .check_size(opts.width, opts.height)
            .map_err(|e| anyhow!("`width`/`height` with `backend`=gpu: {e}"))
    }

    /// `f`'s result with the host↔device bytes, the read-backs and the compute dispatches
    /// it caused.
    fn traffic<T>(&self, f: impl FnOnce() -> Result<T>) -> Result<(T, [u64; 3])> {
        let g = self.engine.gpu();
        let (bytes, reads, runs) = (g.bytes_moved(), g.read_backs(), g.dispatches());
        let r = f()?;
        Ok((
            r,
            [
                g.bytes_moved() - bytes,
                g.read_backs() - reads,
                g.dispatches() - runs,
            ],
        ))
    }

    /// GPU seconds per phase since the last frame: rasterize and the engine's.
    fn phases(&self) -> Vec<(String, f64)> {
        let mut phases: Vec<(String, f64)> = Vec::new();
        if let Some(t) = self.raster.last_gpu_seconds.get() {
            phases.push(("rasterize".into(), t));
        }
        phases.extend(
            self.engine
                .take_times()
                .into_iter()
                .map(|(p, t)| (p.to_string(), t)),
        );
        phases
    }
}
