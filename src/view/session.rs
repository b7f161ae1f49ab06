//! The viewer's state without a window: scene and time, camera, engine and backend, the
//! buffer shown, and one frame of it as RGB8 with its counters. The window
//! ([`super::window`]) only forwards input here and shows the pixels, so everything a frame
//! contains is testable headless, and a screenshot is exactly what `render` writes for the
//! same view.

use crate::engines::{self, Config, Engine};
use crate::runner::Runner;
use accel::oracle::Recorder;
use anyhow::{anyhow, Result};
use geom::{Vec3, NO_HIT};
use render::whitted::{render, RenderOptions};
use scene::{Camera, Scene};
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

/// Where the traced rays run (the registry's backends).
pub use crate::engines::Backend;

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

/// The viewer's state.
pub struct Session {
    base: Scene,
    /// The scene's own camera at `time` (the view until the user moves it).
    scene_camera: Camera,
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
    /// The frames of the engine and backend shown (the runner every front end makes its
    /// frames with): it keeps the renderer's buffers, and rebuilds its engine (a GPU
    /// engine on its device) when the time moves.
    runner: Option<Runner>,
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
        let scene_camera = base.camera_at(t);
        let orbit = Orbit::from_camera(&scene_camera);
        Ok(Session {
            base,
            scene_camera,
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
            runner: None,
            aux_grid: None,
            last: FrameInfo::default(),
        })
    }

    pub fn scene_name(&self) -> &str {
        &self.base.name
    }

    pub fn triangles(&self) -> usize {
        self.base.triangle_count()
    }

    /// The animation time of the frame (None: a still scene, as it stands).
    fn at(&self) -> Option<f32> {
        self.base.animation.is_some().then_some(self.time)
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
            self.scene_camera = self.base.camera_at(t);
            // The runner rebuilds its engine at the next frame, as the papers rebuild every
            // frame of a dynamic scene (a GPU engine on the device it has).
            self.aux_grid = None;
            if !self.orbit.moved {
                self.orbit = Orbit::from_camera(&self.scene_camera);
            }
        }
    }

    /// The runner of the engine and backend shown (made anew when either changes).
    fn runner(&mut self) -> &mut Runner {
        let same = self
            .runner
            .as_ref()
            .is_some_and(|r| r.engine() == self.engine && r.backend() == self.backend);
        if !same {
            self.runner = None; // the last engine (and device) freed first
            let cfg = engines::config::defaults(self.engine, self.backend, false);
            self.runner = Some(
                Runner::new(self.engine, cfg, self.backend).on_device_error(|e| {
                    eprintln!("error: the GPU device failed ({e})");
                    std::process::exit(1);
                }),
            );
        }
        self.runner.as_mut().expect("made above")
    }

    /// Render the current view at 1/`scale` resolution, upscaled to `width × height`
    /// (nearest), as RGB8.
    pub fn frame(&mut self, scale: u32) -> Result<Vec<u8>> {
        let t0 = Instant::now();
        let scale = scale.clamp(1, 16);
        let (w, h) = ((self.width / scale).max(1), (self.height / scale).max(1));
        let opts = RenderOptions {
            width: w,
            height: h,
            bounces: self.bounces,
            spp: if scale > 1 { 1 } else { self.spp.max(1) },
        };
        let record = matches!(self.buffer, Buffer::Kinds | Buffer::Tests);
        let mut note = None;
        let (camera, at, buffer, backend) = (self.camera(), self.at(), self.buffer, self.backend);
        self.runner();
        let (base, runner) = (&self.base, self.runner.as_mut().expect("made"));
        runner.set_camera(Some(camera.clone()));
        // The per-ray views record the engine's batches (the CPU's); the normals view
        // keeps the G-buffer (on the GPU, read back with the image).
        runner.set_record(record);
        runner.set_keep_gbuffer(buffer == Buffer::Normals);
        let f = runner.render(base, at, 0, &opts, &())?;
        let build_seconds = f.row.build_ms / 1e3;
        let (out, phases) = (f.rendered, f.gpu_phases);
        let batches: Vec<(RayBatch, TraceMode)> =
            f.batches.into_iter().map(|x| (x.0, x.1)).collect();
        if record && backend == Backend::Gpu {
            note =
                Some("ray kinds and tests per pixel are drawn from the CPU backend's rays".into());
        }
        // On the GPU backend the per-ray views come from the same frame on the CPU (same
        // rays: the GPU's hits equal the CPU's).
        let batches = if record && batches.is_empty() {
            self.aux_grid()?;
            let grid = self.aux_grid.as_deref().expect("built above") as &dyn Tracer;
            let rec = Recorder::new(grid);
            let mut view = self.base.frame_at(self.time);
            view.camera = camera;
            let geo = self.runner.as_ref().expect("made").geometry();
            render(&view, geo, &rec, &opts, &());
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
                    self.runner
                        .as_ref()
                        .and_then(|r| r.tracer())
                        .ok_or_else(|| anyhow!("no engine"))?
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
                / (rays as f64 * self.base.triangle_count() as f64).max(1.0),
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
            let geo = self
                .runner
                .as_ref()
                .ok_or_else(|| anyhow!("no frame yet"))?
                .geometry();
            self.aux_grid =
                Some(engines::build(Engine::Grid, &Config::of(Engine::Grid), geo)?.tracer);
        }
        Ok(())
    }

    /// The overlay's lines.
    pub fn overlay(&self) -> Vec<String> {
        let l = &self.last;
        let mut v = vec![
            format!(
                "{} — {} triangles — {} on the {} — {} bounces — {}",
                self.base.name,
                self.base.triangle_count(),
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
