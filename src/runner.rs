//! The frame runner: the one place a frame is made, whoever asks for it (`render`, its
//! `--frames`, the viewer, `bench gpu`, the report and Python's `render`/`frame`). A frame is
//! the papers' per-frame sequence (CRSH §3.2.2: the scene updated by its transforms; the
//! irregular grid rebuilt every frame, Pérard-Gayot §5.3): the geometry brought to the
//! frame's time, the engine built (or rebuilt on the device), the Whitted render on the
//! backend asked for, the statistics and the frame's `--frame-csv` record.
//!
//! The runner keeps what the next frame reuses: the geometry's and the renderer's buffers,
//! and on the GPU its device, kernels and engine. It also fits the engine to the memory
//! limit (the grid's budget, CRSH's and RAH's pair budget lowered to fit) before the first
//! build, so that every front end keeps the same limit the same way.

use crate::engines::{self, Backend, Config, Engine, EngineError};
use crate::frames::{FrameBuffers, FrameRow};
use render::whitted::{Progress, RenderOptions, Rendered};
use scene::{Geometry, Scene};
use std::time::Instant;
use trace::options::Value;
use trace::{Hit, RayBatch, TraceMode, Tracer};

/// Why a frame was not made.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    /// The engine refused its options, its input or its size.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The GPU backend failed (no adapter, a device limit, a lost device).
    #[error("{0}")]
    Gpu(String),
    /// The render's own buffers exceed the memory limit.
    #[error("`width`/`height`: the render needs {}, more than the {} memory limit", trace::memory::gib(*need), trace::memory::gib(*limit))]
    Memory {
        /// Its bytes.
        need: u64,
        /// The limit.
        limit: u64,
    },
}

/// An option the runner lowered to fit the memory limit: its keyword, the value asked for
/// and the value used.
pub type Adapted = (&'static str, Value, Value);

/// One frame: its image and statistics, its record, and what the build said.
pub struct Frame {
    /// The render (pixels, G-buffer where kept, statistics with the build's phases first).
    pub rendered: Rendered,
    /// The frame's `--frame-csv` record.
    pub row: FrameRow,
    /// What was built, in one line, where the engine says (the grids).
    pub build_report: Option<String>,
    /// The resident bytes the build added at its peak, where measured
    /// ([`Runner::watch_build_memory`]).
    pub build_peak: Option<u64>,
    /// The engine's structure in bytes, where it says.
    pub structure_bytes: Option<u64>,
    /// GPU seconds per phase (rasterize and the engine's), on the GPU backend.
    pub gpu_phases: Vec<(String, f64)>,
    /// Every batch the engine traced with its answers, when recording
    /// ([`Runner::record`]; the CPU backend's).
    pub batches: Vec<(RayBatch, TraceMode, Vec<Hit>)>,
}

/// The engine as built for the current geometry.
enum Built {
    Cpu(Box<dyn Tracer + Send>, Option<String>),
    #[cfg(feature = "gpu")]
    Gpu(Box<crate::gpu_frame::GpuFrame>),
}

/// What a device failure is told to (the GPU reports it from its own thread).
type OnDeviceError = std::sync::Arc<dyn Fn(String) + Send + Sync>;

/// Frames of one engine on one backend, with what they share (see the module docs).
pub struct Runner {
    engine: Engine,
    /// The configuration asked for, and the one the frames run with (fitted to memory).
    asked: Config,
    cfg: Config,
    backend: Backend,
    buffers: FrameBuffers,
    built: Option<Built>,
    /// The scene state and time the engine was built for.
    built_for: Option<(u64, Option<u32>)>,
    adapted: Vec<Adapted>,
    watch: bool,
    record: bool,
    keep_gbuffer: bool,
    /// A camera that replaces the scene's (the viewer's orbit).
    camera: Option<scene::Camera>,
    #[allow(dead_code)] // read only with the GPU backend
    on_device_error: OnDeviceError,
}

impl Runner {
    /// Frames of `engine` configured as `cfg` (its configuration on `backend`:
    /// [`engines::config::config`]).
    pub fn new(engine: Engine, cfg: Config, backend: Backend) -> Runner {
        Runner {
            engine,
            asked: cfg.clone(),
            cfg,
            backend,
            buffers: FrameBuffers::default(),
            built: None,
            built_for: None,
            adapted: Vec::new(),
            watch: false,
            record: false,
            keep_gbuffer: false,
            camera: None,
            on_device_error: std::sync::Arc::new(|e| {
                eprintln!("error: the GPU device failed ({e})");
                std::process::exit(1);
            }),
        }
    }

    /// Start from `geo`, the scene's geometry as already made (the next frame rewrites
    /// only what moved since).
    pub fn with_geometry(mut self, geo: Geometry) -> Runner {
        self.buffers.geo = geo;
        self
    }

    /// Measure the resident bytes each CPU build adds at its peak ([`Frame::build_peak`];
    /// it reads and writes `/proc`, so a long sequence of frames leaves it off).
    pub fn watch_build_memory(mut self, on: bool) -> Runner {
        self.watch = on;
        self
    }

    /// Keep every batch the engine traces with its answers ([`Frame::batches`]: the report's
    /// and the viewer's ray kinds and tests).
    pub fn record(mut self, on: bool) -> Runner {
        self.record = on;
        self
    }

    /// Hand the G-buffer back with the image (the viewer's normals view) instead of keeping
    /// it for the next frame's rasterization.
    pub fn keep_gbuffer(mut self, on: bool) -> Runner {
        self.keep_gbuffer = on;
        self
    }

    /// [`Runner::record`] from now on.
    pub fn set_record(&mut self, on: bool) {
        self.record = on;
    }

    /// [`Runner::keep_gbuffer`] from now on.
    pub fn set_keep_gbuffer(&mut self, on: bool) {
        self.keep_gbuffer = on;
    }

    /// Look through `camera` instead of the scene's (None: the scene's again); the engine
    /// is not rebuilt for it.
    pub fn set_camera(&mut self, camera: Option<scene::Camera>) {
        self.camera = camera;
    }

    /// The geometry of the last frame.
    pub fn geometry(&self) -> &Geometry {
        &self.buffers.geo
    }

    /// The engine built for the last frame, on the CPU backend.
    pub fn tracer(&self) -> Option<&dyn Tracer> {
        match &self.built {
            Some(Built::Cpu(t, _)) => Some(t.as_ref()),
            _ => None,
        }
    }

    /// What a failure of the device reported later, from the device's thread, does (by
    /// default: one line and status 1; a front end names its own option).
    pub fn on_device_error(mut self, f: impl Fn(String) + Send + Sync + 'static) -> Runner {
        self.on_device_error = std::sync::Arc::new(f);
        self
    }

    /// The engine.
    pub fn engine(&self) -> Engine {
        self.engine
    }

    /// The backend.
    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// The configuration asked for (before [`Runner::fit_memory`]).
    pub fn asked(&self) -> &Config {
        &self.asked
    }

    /// The configuration the frames run with (after [`Runner::fit_memory`]).
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// The options lowered to fit the memory limit.
    pub fn adapted(&self) -> &[Adapted] {
        &self.adapted
    }

    /// The adapter, as the GPU backend describes it, and how its phases are timed, once a
    /// frame has been made on it.
    pub fn gpu_describe(&self) -> Option<(&str, &'static str)> {
        match &self.built {
            #[cfg(feature = "gpu")]
            Some(Built::Gpu(g)) => Some((&g.describe, g.timer)),
            _ => None,
        }
    }

    /// Where the GPU frame (its device, kernels and engine) lives, once made: the same
    /// address from frame to frame says the engine was rebuilt on the device it had.
    pub fn gpu_frame_address(&self) -> Option<usize> {
        match &self.built {
            #[cfg(feature = "gpu")]
            Some(Built::Gpu(g)) => Some(&**g as *const crate::gpu_frame::GpuFrame as usize),
            _ => None,
        }
    }

    /// Fit the engine's build over `triangles` into `bytes` (what the memory limit leaves
    /// after the process and the render: [`memory_left`]): refused when its model does not
    /// fit, the grid checks its levels against it, CRSH/RAH lower their pair budget. Returns
    /// what it lowered. (On the GPU the structure lives on the device: nothing to fit.)
    pub fn fit_memory(&mut self, triangles: u64, bytes: u64) -> Result<&[Adapted], EngineError> {
        if self.backend == Backend::Cpu {
            let mut cfg = self.asked.clone();
            self.adapted = cfg.fit_memory(self.engine, triangles, bytes)?;
            if cfg != self.cfg {
                self.built_for = None; // the next frame builds with the fitted options
            }
            self.cfg = cfg;
        }
        Ok(&self.adapted)
    }

    /// The papers' frame at time `t` (None: the scene as it stands): the geometry brought
    /// to it, the engine built again (every frame: its build is part of the frame), the
    /// render. Frame `index` names the record.
    pub fn frame(
        &mut self,
        scene: &Scene,
        t: Option<f32>,
        index: u32,
        opts: &RenderOptions,
        progress: &dyn Progress,
    ) -> Result<Frame, FrameError> {
        self.built_for = None;
        self.render(scene, t, index, opts, progress)
    }

    /// A frame at time `t` (None: the scene as it stands) with the engine built before when
    /// it was built for this scene state and time (the viewer's redraws of a still scene:
    /// a camera moved, nothing rebuilt), else as [`Runner::frame`].
    pub fn render(
        &mut self,
        scene: &Scene,
        t: Option<f32>,
        index: u32,
        opts: &RenderOptions,
        progress: &dyn Progress,
    ) -> Result<Frame, FrameError> {
        let key = (scene.id.get(), t.map(f32::to_bits));
        let fresh = self.built_for != Some(key);
        // The geometry at the frame's time, refilled in place (what did not move is left
        // as it was), and the camera, lights and materials of that time.
        let t0 = Instant::now();
        if fresh {
            match t {
                Some(t) => self.buffers.geo.refill_at(scene, t),
                None => self.buffers.geo.refill(scene),
            }
        }
        // What the render reads besides the triangles (camera, lights, materials): the
        // scene itself as it stands, else its state at `t` without its meshes, looking
        // through the runner's camera where one is set.
        let at;
        let view: &Scene = match (t, &self.camera) {
            (None, None) => scene,
            (t, camera) => {
                let mut v = scene.frame_at(t.unwrap_or(0.0));
                if t.is_none() {
                    v.camera = scene.camera.clone();
                }
                if let Some(c) = camera {
                    v.camera = c.clone();
                }
                at = v;
                &at
            }
        };
        let update_s = t0.elapsed().as_secs_f64();
        let (mut build_s, mut build_peak) = (0.0, None);
        if fresh {
            let watch = if self.watch && self.backend == Backend::Cpu {
                trace::memory::PeakWatch::start()
            } else {
                None
            };
            let t1 = Instant::now();
            self.build(view)?;
            build_s = t1.elapsed().as_secs_f64();
            build_peak = watch.and_then(|w| w.added());
            self.built_for = Some(key);
        }
        let t2 = Instant::now();
        let geo = &self.buffers.geo;
        let arena = std::mem::take(&mut self.buffers.arena);
        let (rendered, arena, gpu_phases, batches, build_report, structure_bytes) =
            match self.built.as_ref().expect("built above") {
                Built::Cpu(tracer, report) => {
                    let (mut out, arena, batches) = if self.record {
                        let rec = accel::oracle::Recorder::new(tracer.as_ref());
                        let (out, arena) = run_cpu(view, geo, &rec, opts, progress, arena);
                        (out, arena, rec.into_batches())
                    } else {
                        let (out, arena) =
                            run_cpu(view, geo, tracer.as_ref(), opts, progress, arena);
                        (out, arena, Vec::new())
                    };
                    out.stats.put_build(build_s, tracer.build_passes());
                    let sb = tracer.structure_bytes();
                    (out, arena, Vec::new(), batches, report.clone(), sb)
                }
                #[cfg(feature = "gpu")]
                Built::Gpu(g) => {
                    let r = if self.keep_gbuffer {
                        g.render_with_gbuffer(view, geo, opts, progress, build_s)
                    } else {
                        g.render(view, geo, opts, progress, build_s)
                    };
                    let (out, phases) = r.map_err(|e| FrameError::Gpu(format!("{e:#}")))?;
                    (out, arena, phases, Vec::new(), None, None)
                }
            };
        self.buffers.arena = arena;
        let mut rendered = rendered;
        if !self.keep_gbuffer {
            // The G-buffer goes back to the buffers for the next frame's rasterization.
            self.buffers
                .arena
                .keep_gbuffer(std::mem::take(&mut rendered.gbuffer));
        }
        let render_s = t2.elapsed().as_secs_f64();
        let row = FrameRow::of(
            index,
            t.unwrap_or(0.0),
            &self.buffers.geo,
            [update_s, build_s, render_s],
            &rendered,
        );
        Ok(Frame {
            rendered,
            row,
            build_report: if fresh { build_report } else { None },
            build_peak,
            structure_bytes,
            gpu_phases,
            batches,
        })
    }

    /// Build the engine over the buffers' geometry (on the GPU: the device made at the
    /// first frame, the engine rebuilt on it after).
    fn build(&mut self, view: &Scene) -> Result<(), FrameError> {
        let geo = &self.buffers.geo;
        match self.backend {
            Backend::Cpu => {
                self.built = None; // the last frame's structure is freed before the next
                let b = engines::build(self.engine, &self.cfg, geo)?;
                self.built = Some(Built::Cpu(b.tracer, b.report));
                Ok(())
            }
            #[cfg(feature = "gpu")]
            Backend::Gpu => {
                let gpu = |e: anyhow::Error| FrameError::Gpu(format!("{e:#}"));
                if let Some(Built::Gpu(g)) = &mut self.built {
                    g.rebuild(view, geo).map_err(gpu)?;
                } else {
                    let on = self.on_device_error.clone();
                    let g = crate::gpu_frame::GpuFrame::new(
                        self.engine,
                        &self.cfg,
                        view,
                        geo,
                        move |e| on(e),
                    )
                    .map_err(gpu)?;
                    self.built = Some(Built::Gpu(Box::new(g)));
                }
                Ok(())
            }
            #[cfg(not(feature = "gpu"))]
            Backend::Gpu => {
                let _ = view;
                Err(FrameError::Gpu(
                    "`backend`=gpu: this build has no GPU backend; build with `cargo build --release --features gpu`".into(),
                ))
            }
        }
    }
}

/// The CPU render of `view` over `geo` with `tracer`, in the renderer's kept buffers
/// (handed back for the next frame).
fn run_cpu(
    view: &Scene,
    geo: &Geometry,
    tracer: &dyn Tracer,
    opts: &RenderOptions,
    progress: &dyn Progress,
    arena: render::cpu::FrameArena,
) -> (Rendered, render::cpu::FrameArena) {
    let mut backend = render::cpu::CpuBackend::new(view, geo, tracer).with_arena(arena);
    let out = render::whitted::run(&mut backend, view, geo, opts, progress);
    (out, backend.into_arena())
}

/// What the memory limit leaves the engine's build once the process (as it holds now:
/// the interpreter, the scene) and a render of `opts` with `lights` lights are counted; the
/// render alone over the limit is refused.
pub fn memory_left(limit: u64, opts: &RenderOptions, lights: usize) -> Result<u64, FrameError> {
    let need = render::whitted::render_bytes(opts.width, opts.height, lights);
    if need > limit {
        return Err(FrameError::Memory { need, limit });
    }
    let held = trace::memory::current_rss().unwrap_or(0);
    Ok(limit.saturating_sub(need + held))
}

/// One frame of `scene` as it stands with `engine` (its defaults on the CPU), fitted to
/// the process's memory limit: the front door's render.
pub fn render(scene: &Scene, engine: Engine, opts: &RenderOptions) -> Result<Rendered, FrameError> {
    let mut r = Runner::new(
        engine,
        engines::config::defaults(engine, Backend::Cpu, false),
        Backend::Cpu,
    );
    let left = memory_left(trace::memory::limit(None), opts, scene.lights.len())?;
    r.fit_memory(scene.triangle_count() as u64, left)?;
    Ok(r.frame(scene, None, 0, opts, &())?.rendered)
}
