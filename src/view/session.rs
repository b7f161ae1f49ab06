//! The viewer's state without a window: scene and time, camera, engine and backend, the
//! buffer shown, and one frame of it as RGB8 with its counters. The window
//! ([`super::window`]) only forwards input here and shows the pixels, so everything a frame
//! contains is testable headless, and a screenshot is exactly what `render` writes for the
//! same view.

use crate::engines::{self, Config, Engine};
use accel::oracle::Recorder;
use anyhow::{anyhow, Result};
use geom::{Vec3, NO_HIT};
use render::whitted::{render, RenderOptions, Rendered};
use scene::{Camera, Geometry, Scene};
use std::time::Instant;
use trace::{Hit, RayBatch, RayKind, TraceMode, TraceStats, Tracer};

/// What the window shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Buffer {
    /// The Whitted render.
    Shaded,
    /// The rasterized G-buffer's shading normals (×0.5 + 0.5 as RGB).
    Normals,
    /// Rays traced per pixel by kind: red shadow, green reflection, blue refraction.
    Kinds,
    /// Ray–triangle tests per pixel as a heat map.
    Tests,
}

impl Backend {
    pub fn name(self) -> &'static str {
        match self {
            Backend::Cpu => "CPU",
            Backend::Gpu => "GPU",
        }
    }
}

impl Buffer {
    const ALL: [Buffer; 4] = [
        Buffer::Shaded,
        Buffer::Normals,
        Buffer::Kinds,
        Buffer::Tests,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Buffer::Shaded => "shaded",
            Buffer::Normals => "normals",
            Buffer::Kinds => "ray kinds",
            Buffer::Tests => "tests per pixel",
        }
    }
}

/// Where the traced rays run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    Cpu,
    Gpu,
}

/// An orbit camera: the scene's own until the user moves it (so an untouched view is the
/// scene camera bit for bit, as `render` uses it).
#[derive(Clone, Debug)]
pub struct Orbit {
    pub target: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    pub distance: f32,
    pub moved: bool,
}

impl Orbit {
    fn from_camera(c: &Camera) -> Orbit {
        let d = c.eye - c.target;
        let distance = d.length().max(1e-3);
        Orbit {
            target: c.target,
            yaw: d.x.atan2(d.z),
            pitch: (d.y / distance).clamp(-1.0, 1.0).asin(),
            distance,
            moved: false,
        }
    }

    fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + Vec3::new(cp * sy, sp, cp * cy) * self.distance
    }
}

/// Counters and times of the last frame.
#[derive(Clone, Debug, Default)]
pub struct FrameInfo {
    /// Whole frame: engine (re)build if any, render, the buffer's extra work.
    pub seconds: f64,
    /// Engine build in this frame (0 when the built engine was reused).
    pub build_seconds: f64,
    /// The frame was rendered at 1/scale of the window's resolution (progressive).
    pub scale: u32,
    pub rays: u64,
    pub total_tests: u64,
    /// Percent of brute force (all tests ÷ rays × triangles).
    pub percent_of_brute_force: f64,
    /// Trace phases (name, ms).
    pub phases: Vec<(String, f64)>,
    /// Something the overlay must say (e.g. whose tests the heat map shows).
    pub note: Option<String>,
}

/// A frame's recorded batches (for the per-ray buffers) and GPU phase times.
type Recorded = Vec<(RayBatch, TraceMode)>;
type Phases = Vec<(String, f64)>;

enum Built {
    Cpu(Box<dyn Tracer + Send>),
    #[cfg(feature = "gpu")]
    Gpu(Box<crate::gpu_frame::GpuFrame>),
}

/// The viewer's state.
pub struct Session {
    base: Scene,
    /// The scene at `time`; its camera is set to [`Session::camera`] before each frame.
    scene: Scene,
    /// The scene's own camera at `time` (the view until the user moves it).
    scene_camera: Camera,
    geo: Geometry,
    pub engine: Engine,
    pub backend: Backend,
    pub bounces: u32,
    /// Samples per pixel of a full frame (antialiasing); previews take one.
    pub spp: u32,
    pub buffer: Buffer,
    pub width: u32,
    pub height: u32,
    pub time: f32,
    pub playing: bool,
    pub orbit: Orbit,
    /// The CPU renderer's buffers, kept from one frame to the next.
    arena: render::cpu::FrameArena,
    built: Option<(Engine, Backend, Built)>,
    /// The geometry moved since the engine was built (a GPU engine is rebuilt on its device
    /// at the next frame rather than made anew with a new device).
    moved: bool,
    /// A grid for the tests heat map of engines whose tests are not per ray.
    aux_grid: Option<Box<dyn Tracer + Send>>,
    pub last: FrameInfo,
}

/// The engines the `e` key cycles through (brute force last: it is slow).
pub fn engine_cycle() -> Vec<Engine> {
    let mut v = Engine::all_but_brute();
    v.push(Engine::Brute);
    v
}

fn gpu_capable(e: Engine) -> bool {
    e.has_gpu()
}

impl Session {
    /// A session on `scene` at `time` (clamped to the animation's interval).
    pub fn new(
        base: Scene,
        engine: Engine,
        backend: Backend,
        width: u32,
        height: u32,
        bounces: u32,
        time: Option<f32>,
    ) -> Result<Session> {
        if backend == Backend::Gpu && !gpu_capable(engine) {
            anyhow::bail!(
                "`backend`=gpu: only the engines {} run on the GPU (not `engine`={})",
                Engine::gpu_names().join(", "),
                engine.name()
            );
        }
        let t = match (&base.animation, time) {
            (Some(a), t) => t.unwrap_or(a.start).clamp(a.start, a.end),
            (None, _) => 0.0,
        };
        let scene = if base.animation.is_some() {
            base.at_time(t)
        } else {
            base.clone()
        };
        let geo = Geometry::from_scene(&scene);
        let orbit = Orbit::from_camera(&scene.camera);
        Ok(Session {
            base,
            scene_camera: scene.camera.clone(),
            scene,
            geo,
            engine,
            backend,
            bounces,
            spp: 1,
            buffer: Buffer::Shaded,
            width,
            height,
            time: t,
            playing: false,
            orbit,
            arena: Default::default(),
            built: None,
            moved: false,
            aux_grid: None,
            last: FrameInfo::default(),
        })
    }

    pub fn scene_name(&self) -> &str {
        &self.scene.name
    }

    pub fn triangles(&self) -> usize {
        self.geo.len()
    }

    pub fn animated(&self) -> bool {
        self.base.animation.is_some()
    }

    /// Next engine (on the GPU backend, the next one that runs there).
    pub fn cycle_engine(&mut self) {
        let list = engine_cycle();
        let mut i = list.iter().position(|&e| e == self.engine).unwrap_or(0);
        loop {
            i = (i + 1) % list.len();
            if self.backend == Backend::Cpu || gpu_capable(list[i]) {
                break;
            }
        }
        self.engine = list[i];
    }

    /// CPU ↔ GPU (switching to the grid if the engine has no GPU form).
    pub fn toggle_backend(&mut self) {
        self.backend = match self.backend {
            Backend::Cpu => {
                if !gpu_capable(self.engine) {
                    self.engine = Engine::Grid;
                }
                Backend::Gpu
            }
            Backend::Gpu => Backend::Cpu,
        };
    }

    pub fn cycle_buffer(&mut self) {
        let i = Buffer::ALL
            .iter()
            .position(|&b| b == self.buffer)
            .unwrap_or(0);
        self.buffer = Buffer::ALL[(i + 1) % Buffer::ALL.len()];
    }

    pub fn set_bounces(&mut self, b: u32) {
        self.bounces = b.min(render::whitted::MAX_BOUNCES);
    }

    /// Orbit by (dx, dy) radians around the target.
    pub fn orbit_by(&mut self, dx: f32, dy: f32) {
        self.orbit.yaw -= dx;
        self.orbit.pitch = (self.orbit.pitch + dy).clamp(-1.55, 1.55);
        self.orbit.moved = true;
    }

    /// Move towards the target by `factor` of the distance (negative: away).
    pub fn dolly(&mut self, factor: f32) {
        self.orbit.distance = (self.orbit.distance * (1.0 - factor)).max(1e-3);
        self.orbit.moved = true;
    }

    /// Fly: move eye and target along the view's right, up and forward axes by a fraction
    /// of the distance to the target.
    pub fn fly(&mut self, right: f32, up: f32, forward: f32) {
        let cam = self.camera();
        let (r, u, f) = cam.basis();
        self.orbit.target += (r * right + u * up + f * forward) * self.orbit.distance;
        self.orbit.moved = true;
    }

    /// The camera of the next frame.
    pub fn camera(&self) -> Camera {
        if self.orbit.moved {
            Camera {
                eye: self.orbit.eye(),
                target: self.orbit.target,
                ..self.scene_camera.clone()
            }
        } else {
            self.scene_camera.clone()
        }
    }

    /// Move the animation to `t` (clamped; wraps when playing past the end).
    pub fn set_time(&mut self, t: f32) {
        let Some(a) = &self.base.animation else {
            return;
        };
        let (s, e) = (a.start, a.end);
        let t = if t > e && self.playing && e > s {
            s + (t - s) % (e - s)
        } else {
            t.clamp(s, e)
        };
        if t != self.time {
            self.time = t;
            self.scene = self.base.at_time(t);
            self.scene_camera = self.scene.camera.clone();
            self.geo = Geometry::from_scene(&self.scene);
            // Rebuilt every frame of a dynamic scene, as the papers do: a CPU engine anew, a
            // GPU engine on the device it has (kernels compiled once).
            match &self.built {
                #[cfg(feature = "gpu")]
                Some((_, _, Built::Gpu(_))) => self.moved = true,
                _ => self.built = None,
            }
            self.aux_grid = None;
            if !self.orbit.moved {
                self.orbit = Orbit::from_camera(&self.scene_camera);
            }
        }
    }

    fn build(&mut self) -> Result<f64> {
        #[allow(unused_variables)] // without the GPU backend nothing is rebuilt in place
        let moved = std::mem::take(&mut self.moved);
        if let Some((e, b, built)) = &mut self.built {
            if *e == self.engine && *b == self.backend {
                return match built {
                    #[cfg(feature = "gpu")]
                    Built::Gpu(g) if moved => g.rebuild(&self.scene, &self.geo),
                    _ => Ok(0.0),
                };
            }
        }
        let t0 = Instant::now();
        let built = match self.backend {
            Backend::Cpu => {
                Built::Cpu(engines::build(self.engine, &Config::of(self.engine), &self.geo)?.tracer)
            }
            #[cfg(feature = "gpu")]
            Backend::Gpu => Built::Gpu(Box::new(crate::gpu_frame::GpuFrame::new(
                self.engine,
                &engines::config::defaults(self.engine, engines::Backend::Gpu, false),
                &self.scene,
                &self.geo,
                |e| {
                    eprintln!("error: the GPU device failed ({e})");
                    std::process::exit(1);
                },
            )?)),
            #[cfg(not(feature = "gpu"))]
            Backend::Gpu => anyhow::bail!("`backend`=gpu: this build has no GPU backend"),
        };
        self.built = Some((self.engine, self.backend, built));
        Ok(t0.elapsed().as_secs_f64())
    }

    /// Render the current view at 1/`scale` resolution, upscaled to `width × height`
    /// (nearest), as RGB8.
    pub fn frame(&mut self, scale: u32) -> Result<Vec<u8>> {
        let t0 = Instant::now();
        let scale = scale.clamp(1, 16);
        let build_seconds = self.build()?;
        let (w, h) = ((self.width / scale).max(1), (self.height / scale).max(1));
        // The view's camera goes into the scene itself: cloning the scene (its meshes)
        // every frame would copy the whole model.
        self.scene.camera = self.camera();
        let opts = RenderOptions {
            width: w,
            height: h,
            bounces: self.bounces,
            spp: if scale > 1 { 1 } else { self.spp.max(1) },
        };
        let record = matches!(self.buffer, Buffer::Kinds | Buffer::Tests);
        let mut note = None;
        let (out, batches, phases): (Rendered, Recorded, Phases) =
            match &self.built.as_ref().ok_or_else(|| anyhow!("no engine"))?.2 {
                Built::Cpu(t) => {
                    if record {
                        let rec = Recorder::new(t.as_ref());
                        let out = render(&self.scene, &self.geo, &rec, &opts, &());
                        let b = rec.into_batches().into_iter().map(|x| (x.0, x.1)).collect();
                        (out, b, Vec::new())
                    } else {
                        // The renderer's buffers are kept from frame to frame.
                        let arena = std::mem::take(&mut self.arena);
                        let mut backend =
                            render::cpu::CpuBackend::new(&self.scene, &self.geo, t.as_ref())
                                .with_arena(arena);
                        let out =
                            render::whitted::run(&mut backend, &self.scene, &self.geo, &opts, &());
                        self.arena = backend.into_arena();
                        (out, Vec::new(), Vec::new())
                    }
                }
                #[cfg(feature = "gpu")]
                Built::Gpu(g) => {
                    // The normals view needs the G-buffer on the host: the frame reads it
                    // back too; every other view brings back only the image.
                    let (out, phases) = if self.buffer == Buffer::Normals {
                        g.render_with_gbuffer(&self.scene, &self.geo, &opts, &(), build_seconds)?
                    } else {
                        g.render(&self.scene, &self.geo, &opts, &(), build_seconds)?
                    };
                    if record {
                        note = Some(
                            "ray kinds and tests per pixel are drawn from the CPU backend's rays"
                                .into(),
                        );
                    }
                    (out, Vec::new(), phases)
                }
            };
        // On the GPU backend the per-ray views come from the same frame on the CPU (same
        // rays: the GPU's hits equal the CPU's).
        let batches = if record && batches.is_empty() {
            self.aux_grid()?;
            let grid = self.aux_grid.as_deref().expect("built above") as &dyn Tracer;
            let rec = Recorder::new(grid);
            render(&self.scene, &self.geo, &rec, &opts, &());
            rec.into_batches().into_iter().map(|x| (x.0, x.1)).collect()
        } else {
            batches
        };
        let npix = (w * h) as usize;
        let rgb: Vec<u8> = match self.buffer {
            Buffer::Shaded => out.rgb8(),
            Buffer::Normals => (0..npix)
                .flat_map(|i| {
                    if out.gbuffer.tri[i] == NO_HIT {
                        [0, 0, 0]
                    } else {
                        let n = out.gbuffer.normal[i] * 0.5 + Vec3::splat(0.5);
                        [n.x, n.y, n.z].map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
                    }
                })
                .collect(),
            Buffer::Kinds => {
                let mut c = vec![[0u32; 3]; npix];
                for (b, _) in &batches {
                    for (&k, &p) in b.kind.iter().zip(&b.pixel) {
                        let ch = match RayKind::from_u8(k) {
                            RayKind::Shadow => 0,
                            RayKind::Reflection => 1,
                            RayKind::Refraction => 2,
                            RayKind::Primary => continue,
                        };
                        if let Some(px) = c.get_mut(p as usize) {
                            px[ch] += 1;
                        }
                    }
                }
                let mut max = [1u32; 3];
                for px in &c {
                    for k in 0..3 {
                        max[k] = max[k].max(px[k]);
                    }
                }
                c.iter()
                    .flat_map(|px| {
                        [0, 1, 2].map(|k| (px[k] as f32 / max[k] as f32 * 255.0).round() as u8)
                    })
                    .collect()
            }
            Buffer::Tests => {
                let per_ray = matches!(self.engine, Engine::Crsh | Engine::Rah)
                    || self.backend == Backend::Gpu;
                if per_ray {
                    note = Some(format!(
                        "tests per pixel: the grid's on the same rays ({} tests are shared by ray nodes, not per pixel)",
                        self.engine.name()
                    ));
                }
                if per_ray {
                    self.aux_grid()?;
                }
                let tracer: &dyn Tracer = if per_ray {
                    self.aux_grid.as_deref().expect("built above") as &dyn Tracer
                } else {
                    match &self.built.as_ref().ok_or_else(|| anyhow!("no engine"))?.2 {
                        Built::Cpu(t) => t.as_ref(),
                        #[cfg(feature = "gpu")]
                        Built::Gpu(_) => unreachable!("per_ray is set on the GPU backend"),
                    }
                };
                let counts = tests_per_pixel(tracer, &batches, npix);
                render::output::heat_rgb8(&counts)
            }
        };
        let rgb = upscale(&rgb, w, h, self.width, self.height);
        let st = &out.stats;
        let rays = st.rays_traced();
        let total = st.trace.total_tests();
        self.last = FrameInfo {
            seconds: t0.elapsed().as_secs_f64(),
            build_seconds,
            scale,
            rays,
            total_tests: total,
            percent_of_brute_force: 100.0 * total as f64
                / (rays as f64 * self.geo.len() as f64).max(1.0),
            phases: if phases.is_empty() {
                st.trace
                    .phases
                    .iter()
                    .map(|(p, s)| (p.to_string(), s * 1e3))
                    .collect()
            } else {
                phases.into_iter().map(|(p, s)| (p, s * 1e3)).collect()
            },
            note,
        };
        Ok(rgb)
    }

    /// Build the grid that draws per-ray views for engines without per-ray counts.
    fn aux_grid(&mut self) -> Result<()> {
        if self.aux_grid.is_none() {
            self.aux_grid =
                Some(engines::build(Engine::Grid, &Config::of(Engine::Grid), &self.geo)?.tracer);
        }
        Ok(())
    }

    /// The overlay's lines.
    pub fn overlay(&self) -> Vec<String> {
        let l = &self.last;
        let mut v = vec![
            format!(
                "{} — {} triangles — {} on the {} — {} bounces — {}",
                self.scene.name,
                self.geo.len(),
                self.engine.name(),
                self.backend.name(),
                self.bounces,
                self.buffer.name()
            ),
            format!(
                "frame {:.1} ms ({:.1} fps){}{}",
                l.seconds * 1e3,
                1.0 / l.seconds.max(1e-6),
                if l.build_seconds > 0.0 {
                    format!(", build {:.1} ms", l.build_seconds * 1e3)
                } else {
                    String::new()
                },
                if l.scale > 1 {
                    format!(", preview at 1/{}", l.scale)
                } else {
                    String::new()
                }
            ),
            format!(
                "{} rays, {} tests, {:.3} % of brute force",
                l.rays, l.total_tests, l.percent_of_brute_force
            ),
        ];
        let mut ph: Vec<&(String, f64)> = l.phases.iter().filter(|p| p.1 >= 0.05).collect();
        ph.sort_by(|a, b| b.1.total_cmp(&a.1));
        if !ph.is_empty() {
            v.push(
                ph.iter()
                    .take(5)
                    .map(|(p, ms)| format!("{p} {ms:.1}"))
                    .collect::<Vec<_>>()
                    .join(", ")
                    + " ms",
            );
        }
        if self.animated() {
            v.push(format!(
                "t = {:.2} s {}",
                self.time,
                if self.playing {
                    "(playing)"
                } else {
                    "(paused)"
                }
            ));
        }
        if let Some(n) = &l.note {
            v.push(n.clone());
        }
        v.push("keys: e engine, g backend, b/B bounces, v buffer, space play, [ ] scrub".into());
        v.push(
            "mouse: drag orbit, right-drag pan, wheel zoom; wasdqz fly; o overlay; esc quit".into(),
        );
        v
    }
}

/// Ray–triangle tests per pixel: each recorded ray traced alone, so its tests are its own.
fn tests_per_pixel(
    tracer: &dyn Tracer,
    batches: &[(RayBatch, TraceMode)],
    npix: usize,
) -> Vec<u32> {
    use rayon::prelude::*;
    let mut counts = vec![0u32; npix];
    for (b, mode) in batches {
        let per: Vec<(u32, u32)> = (0..b.len())
            .into_par_iter()
            .map(|i| {
                let mut one = RayBatch::with_capacity(1);
                let r = b.ray(i);
                one.push(
                    r,
                    RayKind::from_u8(b.kind[i]),
                    b.pixel[i],
                    b.light[i],
                    b.throughput[i],
                    b.depth[i],
                );
                let mut hits = [Hit::MISS];
                let mut st = TraceStats::default();
                tracer.trace(&one, *mode, &mut hits, &mut st);
                (b.pixel[i], st.ray_tri_tests.min(u32::MAX as u64) as u32)
            })
            .collect();
        for (p, n) in per {
            if let Some(c) = counts.get_mut(p as usize) {
                *c = c.saturating_add(n);
            }
        }
    }
    counts
}

/// Nearest-neighbour upscale of an RGB8 image.
fn upscale(rgb: &[u8], w: u32, h: u32, tw: u32, th: u32) -> Vec<u8> {
    if (w, h) == (tw, th) {
        return rgb.to_vec();
    }
    let mut out = vec![0u8; tw as usize * th as usize * 3];
    for y in 0..th {
        let sy = (y as u64 * h as u64 / th as u64) as usize;
        for x in 0..tw {
            let sx = (x as u64 * w as u64 / tw as u64) as usize;
            let s = (sy * w as usize + sx) * 3;
            let d = (y as usize * tw as usize + x as usize) * 3;
            out[d..d + 3].copy_from_slice(&rgb[s..s + 3]);
        }
    }
    out
}

#[cfg(test)]
mod tests;
