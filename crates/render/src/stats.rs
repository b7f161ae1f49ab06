//! What a render reports ([`RenderStats`]): the scene, the rays traced by kind, the engine's
//! counters (a [`trace::TraceStats`]) and the frame's phases ([`FramePhase`]: the thesis's
//! Figure 3.1 steps, rasterize → ray creation → trace → shading, with the engine's build
//! and its passes first).
//!
//! Counts are deterministic for a given input and configuration and are the primary
//! efficiency figures; times are for orientation only.

use serde::{Serialize, Serializer};
use trace::{PassTime, TraceStats};

/// A timed step of a frame, as the stats table, the JSON's `phases` and the viewer name it.
#[derive(Clone, Debug, PartialEq)]
pub enum FramePhase {
    /// The engine's build (per frame for a dynamic scene).
    EngineBuild,
    /// One pass of that build: a breakdown of [`FramePhase::EngineBuild`], not added again.
    BuildPass(PassTime),
    /// Primary visibility into the G-buffer (§3.1).
    Rasterize,
    /// Surfaces and rays of every generation (shadow, reflection, refraction; §3.1), and
    /// the hit records each batch's trace writes into, made ready before it.
    RayCreation,
    /// Inside the engine's trace calls.
    Trace,
    /// Blinn-Phong shading and accumulation into the pixels (eqs. 3.17–3.19).
    Shading,
}

impl FramePhase {
    /// The phase's name in reports; a build pass is indented under the build
    /// (`  build: octrees`).
    pub fn name(&self) -> String {
        match self {
            FramePhase::EngineBuild => "engine build".into(),
            FramePhase::BuildPass(p) => format!("  build: {}", p.name()),
            FramePhase::Rasterize => "rasterize".into(),
            FramePhase::RayCreation => "ray creation".into(),
            FramePhase::Trace => "trace".into(),
            FramePhase::Shading => "shading".into(),
        }
    }

    /// Whether the phase breaks down another one (so is not added to a total again).
    pub fn is_breakdown(&self) -> bool {
        matches!(self, FramePhase::BuildPass(_))
    }

    /// Whether two entries are the same phase (a build pass by its name, not its time).
    fn same(&self, o: &FramePhase) -> bool {
        match (self, o) {
            (FramePhase::BuildPass(a), FramePhase::BuildPass(b)) => {
                a.pass == b.pass && a.device == b.device
            }
            _ => self == o,
        }
    }
}

impl std::fmt::Display for FramePhase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.name())
    }
}

impl Serialize for FramePhase {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.name())
    }
}

/// Everything a render reports (printed as a table by the CLI; `--stats` writes it as JSON).
#[derive(Clone, Debug, Default, Serialize)]
pub struct RenderStats {
    /// Scene name.
    pub scene: String,
    /// Engine name.
    pub engine: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Triangles in the scene.
    pub triangles: u64,
    /// Meshes (the unit of bounding-sphere culling).
    pub meshes: u64,
    /// Lights.
    pub lights: u64,
    /// Reflection/refraction generations after the rasterized one.
    pub bounces: u32,
    /// Samples per pixel (antialiasing; 1: the pixel centres).
    pub spp: u32,
    /// Pixels covered by rasterized geometry (the primary "rays" that were not traced).
    pub covered_pixels: u64,
    /// Traced rays by kind.
    pub rays_shadow: u64,
    /// Traced reflection rays.
    pub rays_reflection: u64,
    /// Traced refraction rays.
    pub rays_refraction: u64,
    /// Traced primary rays (none when primary visibility is rasterized).
    pub rays_primary_traced: u64,
    /// Ray–triangle tests, node tests etc. from the engine.
    pub trace: TraceStats,
    /// Every test: ray-hierarchy node tests + ray–box tests + ray–triangle tests
    /// ([`trace::TraceStats::total_tests`]).
    pub total_tests: u64,
    /// The brute-force reference: traced rays × triangles.
    pub brute_force_tests: u64,
    /// Wall-clock seconds per renderer phase, in execution order (in JSON, `[name,
    /// seconds]` pairs).
    pub phases: Vec<(FramePhase, f64)>,
    /// Milliseconds of the four renderer phases ([`RenderStats::set_phase_ms`]): primary
    /// visibility into the G-buffer, ...
    pub raster_ms: f64,
    /// ... the surfaces and rays of every generation, ...
    pub ray_creation_ms: f64,
    /// ... inside the engine's trace calls only, ...
    pub trace_ms: f64,
    /// ... and shading with the accumulation into the pixels; together the render.
    pub shading_ms: f64,
    /// GPU backend: bytes moved between host and device during the frame, both ways (every
    /// upload, launch parameter block and read-back; absent on the CPU).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host_device_bytes: Option<u64>,
    /// GPU backend: read-backs during the frame, each a wait for the device (sizes of the
    /// next buffers, totals, the image).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host_read_backs: Option<u64>,
    /// GPU backend: compute dispatches during the frame (the frame's kernels and the
    /// engine's traces; the engine's build, made before the frame, not counted).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_dispatches: Option<u64>,
    /// GPU backend: how the frame ran, `device-resident` (everything between the G-buffer
    /// and the sRGB image stayed on the device), said with the reason when a generation was
    /// held in parts.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_frame: Option<String>,
}

impl RenderStats {
    /// Put the engine's build first among the phases: "engine build" (`seconds`), then its
    /// passes indented under it ("  build: octrees", ...), as the table and the JSON show them.
    pub fn put_build(&mut self, seconds: f64, passes: Vec<PassTime>) {
        let rows = std::iter::once((FramePhase::EngineBuild, seconds)).chain(
            passes
                .into_iter()
                .map(|p| (FramePhase::BuildPass(p), p.seconds)),
        );
        self.phases.splice(0..0, rows);
    }

    /// Add another sample's counts and times (antialiasing's samples of one image): rays,
    /// tests, the engine's counters, the phases and the GPU's transfers.
    pub fn add_sample(&mut self, o: &RenderStats) {
        self.rays_shadow += o.rays_shadow;
        self.rays_reflection += o.rays_reflection;
        self.rays_refraction += o.rays_refraction;
        self.rays_primary_traced += o.rays_primary_traced;
        self.trace.add(&o.trace);
        self.total_tests += o.total_tests;
        self.brute_force_tests += o.brute_force_tests;
        for (p, t) in &o.phases {
            self.add_phase(p.clone(), *t);
        }
        let add = |a: &mut Option<u64>, b: Option<u64>| {
            if let Some(b) = b {
                *a = Some(a.unwrap_or(0) + b);
            }
        };
        add(&mut self.host_device_bytes, o.host_device_bytes);
        add(&mut self.host_read_backs, o.host_read_backs);
        add(&mut self.gpu_dispatches, o.gpu_dispatches);
    }

    /// The four phase figures (`raster_ms`, `ray_creation_ms`, `trace_ms`, `shading_ms`)
    /// from [`RenderStats::phases`], as the frame CSV and the JSON report them.
    pub fn set_phase_ms(&mut self) {
        let ms = |s: &Self, p: FramePhase| s.phase_seconds(&p) * 1e3;
        self.raster_ms = ms(self, FramePhase::Rasterize);
        self.ray_creation_ms = ms(self, FramePhase::RayCreation);
        self.trace_ms = ms(self, FramePhase::Trace);
        self.shading_ms = ms(self, FramePhase::Shading);
    }

    /// All traced rays.
    pub fn rays_traced(&self) -> u64 {
        self.rays_shadow + self.rays_reflection + self.rays_refraction + self.rays_primary_traced
    }

    /// Add `secs` to `phase` (appended in first-seen order).
    pub fn add_phase(&mut self, phase: FramePhase, secs: f64) {
        match self.phases.iter_mut().find(|(p, _)| p.same(&phase)) {
            Some((_, s)) => *s += secs,
            None => self.phases.push((phase, secs)),
        }
    }

    /// Seconds spent in `phase` (0 when the render had no such phase).
    pub fn phase_seconds(&self, phase: &FramePhase) -> f64 {
        self.phases
            .iter()
            .filter(|(p, _)| p.same(phase))
            .map(|(_, s)| s)
            .sum()
    }

    /// A human-readable table.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let pct = |a: u64, b: u64| {
            if b == 0 {
                0.0
            } else {
                100.0 * a as f64 / b as f64
            }
        };
        s += &format!(
            "scene {}  engine {}  {}x{}  bounces {}\n",
            self.scene, self.engine, self.width, self.height, self.bounces
        );
        s += &format!(
            "triangles {}  meshes {}  lights {}\n\n",
            self.triangles, self.meshes, self.lights
        );
        s += "| phase | time (ms) |\n|---|---:|\n";
        let mut total = 0.0;
        for (n, t) in &self.phases {
            s += &format!("| {n} | {:.1} |\n", t * 1e3);
            // Breakdown rows (indented) detail the phase above them and are not added again.
            if !n.is_breakdown() {
                total += t;
            }
        }
        s += &format!("| **total** | {:.1} |\n\n", total * 1e3);
        s += "| count | value |\n|---|---:|\n";
        let rows: Vec<(String, u64)> = vec![
            (
                "covered pixels (rasterized primaries)".into(),
                self.covered_pixels,
            ),
            ("shadow rays".into(), self.rays_shadow),
            ("reflection rays".into(), self.rays_reflection),
            ("refraction rays".into(), self.rays_refraction),
            ("rays traced".into(), self.rays_traced()),
            ("node-triangle tests".into(), self.trace.node_tri_tests),
            ("ray-triangle tests".into(), self.trace.ray_tri_tests),
            ("hits".into(), self.trace.hits),
        ];
        for (n, v) in rows {
            s += &format!("| {n} | {v} |\n");
        }
        for (k, v) in self.trace.counters.iter() {
            s += &format!("| {k} | {v} |\n");
        }
        if let Some(f) = &self.gpu_frame {
            s += &format!("| GPU frame | {f} |\n");
        }
        if let Some(b) = self.host_device_bytes {
            s += &format!("| host-device bytes (both ways) | {b} |\n");
        }
        if let Some(r) = self.host_read_backs {
            s += &format!("| host read-backs (waits for the device) | {r} |\n");
        }
        if let Some(d) = self.gpu_dispatches {
            s += &format!("| GPU compute dispatches | {d} |\n");
        }
        s += &format!("| total tests | {} |\n", self.total_tests);
        s += &format!(
            "| brute force (rays x triangles) | {} |\n",
            self.brute_force_tests
        );
        s += &format!(
            "| total as % of brute force | {:.3} % |\n",
            pct(self.total_tests, self.brute_force_tests)
        );
        // The same figure for every engine: its exact triangle tests against brute force's.
        s += &format!(
            "| ray-triangle tests as % of brute force | {:.4} % |\n",
            pct(self.trace.ray_tri_tests, self.brute_force_tests)
        );
        if !self.trace.levels.is_empty() {
            s += &self.trace.levels.markdown();
        }
        if !self.trace.phases.is_empty() {
            s += "\n| engine phase | time (ms) |\n|---|---:|\n";
            for (n, t) in &self.trace.phases {
                s += &format!("| {n} | {:.1} |\n", t * 1e3);
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use trace::{BuildPass, Device};

    #[test]
    fn phases_add_up_by_kind_and_serialize_by_name() {
        let mut s = RenderStats::default();
        s.add_phase(FramePhase::Rasterize, 1.0);
        s.add_phase(FramePhase::Trace, 2.0);
        s.add_phase(FramePhase::Trace, 0.5);
        s.put_build(
            3.0,
            vec![
                PassTime::on(BuildPass::new("octrees"), Device::Gpu, 1.0),
                PassTime::new(BuildPass::new("merge"), 2.0),
            ],
        );
        assert_eq!(s.phase_seconds(&FramePhase::Trace), 2.5);
        let j = serde_json::to_value(&s.phases).unwrap();
        assert_eq!(
            j,
            serde_json::json!([
                ["engine build", 3.0],
                ["  build: octrees (GPU)", 1.0],
                ["  build: merge", 2.0],
                ["rasterize", 1.0],
                ["trace", 2.5]
            ])
        );
        assert!(
            s.table().contains("| **total** | 6500.0 |"),
            "{}",
            s.table()
        );
    }
}
