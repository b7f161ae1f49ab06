//! One Whitted frame on the wgpu backend, shared by `render --backend gpu` and the viewer:
//! the G-buffer from the GPU's render pipeline, CRSH/RAH or the grid (built and traversed by
//! kernels), secondary ray generation and shading as compute kernels; the Whitted loop's
//! sequencing, the surface records between generations and the pixel accumulation on the
//! CPU (thesis §3.1–3.3 on the GPU; see `crates/gpu`). The bytes moved between host and
//! device during the frame are reported (`host_device_bytes`).

use crate::engines::{Engine, EngineOptions};
use anyhow::{anyhow, Result};
use render::whitted::{Progress, RenderOptions, Rendered};
use scene::{Geometry, Scene};

/// A GPU engine built over one geometry (the rasterizer, which borrows its device, is
/// made per frame).
pub struct GpuFrame {
    engine: Box<dyn gpu::GpuEngine>,
    /// The adapter, as the backend describes it.
    pub describe: String,
    /// How the phase times are measured.
    pub timer: &'static str,
}

impl GpuFrame {
    /// Build `engine` (crsh, rah, grid or grid2l) over `geo` on a new device; `on_error`
    /// is called if the device is lost later.
    pub fn new(
        engine: Engine,
        eopts: &EngineOptions,
        scene: &Scene,
        geo: &Geometry,
        on_error: impl Fn(String) + Send + Sync + 'static,
    ) -> Result<GpuFrame> {
        if !matches!(
            engine,
            Engine::Crsh | Engine::Rah | Engine::Grid | Engine::Grid2l
        ) {
            anyhow::bail!(
                "--backend gpu: only --engine crsh, rah, grid and grid2l run on the GPU (not {})",
                engine.name()
            );
        }
        let g = gpu::Gpu::new().map_err(|e| anyhow!("--backend gpu: {e}"))?;
        g.on_device_error(move |e| on_error(e.to_string()));
        let describe = g.describe();
        let timer = match g.timer {
            gpu::device::PhaseTimer::Timestamps => "timestamp queries",
            gpu::device::PhaseTimer::WallClock => {
                "wall clock, waiting at every phase boundary: this adapter has no timestamp queries that time kernels"
            }
        };
        let engine: Box<dyn gpu::GpuEngine> = match engine.rsh_method() {
            Some(method) => Box::new(
                gpu::GpuRsh::new(g, geo, eopts.gpu_rsh_config(method))
                    .map_err(|e| anyhow!("--backend gpu: {e}"))?,
            ),
            None => {
                // The grid is built and traversed by kernels (gpu::grid::PASS_DEVICE).
                let cfg = eopts.grid_config(engine == Engine::Grid2l);
                eopts.validate(engine)?;
                Box::new(
                    gpu::GpuGrid::new(g, geo, &cfg)
                        .map_err(|e| anyhow!("--backend gpu --engine {}: {e}", engine.name()))?,
                )
            }
        };
        // The rasterizer's inputs are checked now, so that a scene it cannot take fails here.
        gpu::GpuRaster::new(engine.gpu(), geo, &scene.materials)
            .map_err(|e| anyhow!("--backend gpu: {e}"))?;
        Ok(GpuFrame {
            engine,
            describe,
            timer,
        })
    }

    /// A dynamic scene's next frame: rebuild the engine over `geo` on the same device, with
    /// the same kernels and configuration; returns the wall-clock seconds.
    pub fn rebuild(&mut self, geo: &Geometry) -> Result<f64> {
        let t0 = std::time::Instant::now();
        self.engine
            .rebuild(geo)
            .map_err(|e| anyhow!("--backend gpu: {e}"))?;
        Ok(t0.elapsed().as_secs_f64())
    }

    /// Render one frame; returns it with the GPU seconds per phase (rasterize, the
    /// engine's, the stages').
    pub fn render(
        &self,
        scene: &Scene,
        geo: &Geometry,
        opts: &RenderOptions,
        progress: &dyn Progress,
        build_seconds: f64,
    ) -> Result<(Rendered, Vec<(String, f64)>)> {
        let moved = self.engine.gpu().bytes_moved();
        let raster = gpu::GpuRaster::new(self.engine.gpu(), geo, &scene.materials)
            .map_err(|e| anyhow!("--backend gpu: {e}"))?;
        raster
            .check_size(opts.width, opts.height)
            .map_err(|e| anyhow!("--width/--height with --backend gpu: {e}"))?;
        let stages = gpu::GpuStages::new(self.engine.gpu(), self.engine.kernels());
        let mut out = render::whitted::render_with(
            scene,
            geo,
            self.engine.as_ref(),
            opts,
            progress,
            &|v, n| raster.rasterize(v, n),
            &stages,
        );
        out.stats
            .put_build(build_seconds, self.engine.build_passes());
        out.stats.host_device_bytes = Some(self.engine.gpu().bytes_moved() - moved);
        let mut phases: Vec<(String, f64)> = Vec::new();
        if let Some(t) = raster.last_gpu_seconds.get() {
            phases.push(("rasterize".into(), t));
        }
        phases.extend(
            self.engine
                .take_times()
                .into_iter()
                .map(|(p, t)| (p.to_string(), t)),
        );
        phases.extend(
            stages
                .times
                .borrow()
                .iter()
                .map(|(p, t)| (p.to_string(), *t)),
        );
        Ok((out, phases))
    }
}
