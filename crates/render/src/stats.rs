//! Counters and timings: per trace call ([`TraceStats`]) and per render ([`RenderStats`]).
//!
//! Counts are deterministic for a given input and configuration and are the primary
//! efficiency figures; times are for orientation only.

use crate::RayKind;
use serde::{Serialize, Serializer};
use std::collections::BTreeMap;

/// An engine's internal phases, in pipeline order: CRSH (thesis §3.2, Tables 4.25–4.27)
/// hashes, trims, compresses, sorts and decompresses its rays, RAH puts them in screen order,
/// both then build the hierarchy, traverse it and finish with the final ray–triangle tests;
/// the GPU backend adds its transfers (upload before the first kernel, read-back after the
/// last). The CPU and GPU engines, the stats table, the JSON,
/// the frame CSV and the benchmarks all name phases through this type.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Phase {
    /// GPU: the rays uploaded before the first kernel.
    Upload,
    /// CRSH: every ray's hash key (§3.2.3).
    Hash,
    /// Rays that can hit nothing removed (stream compaction, §3.2.3).
    Trim,
    /// Runs of equal keys into chunks (§3.2.4).
    Compress,
    /// Chunks radix-sorted by key (§3.2.5).
    Sort,
    /// Chunks expanded back to rays in sorted order (§3.2.6).
    Decompress,
    /// RAH: rays in screen (pixel Z-) order.
    ScreenOrder,
    /// Sphere-cone nodes built bottom-up (§3.2.7).
    HierarchyCreation,
    /// Triangles pushed top-down through the nodes (§3.2.8).
    Traversal,
    /// Exact ray–triangle tests of the surviving pairs (§3.2.9).
    FinalTests,
    /// GPU: the hit records read back.
    ReadBack,
}

impl Phase {
    /// Every phase, in pipeline order.
    pub const ALL: [Phase; 11] = [
        Phase::Upload,
        Phase::Hash,
        Phase::Trim,
        Phase::Compress,
        Phase::Sort,
        Phase::Decompress,
        Phase::ScreenOrder,
        Phase::HierarchyCreation,
        Phase::Traversal,
        Phase::FinalTests,
        Phase::ReadBack,
    ];

    /// The phase's name in reports ("hierarchy creation", ...).
    pub fn as_str(self) -> &'static str {
        match self {
            Phase::Upload => "upload",
            Phase::Hash => "hash",
            Phase::Trim => "trim",
            Phase::Compress => "compress",
            Phase::Sort => "sort",
            Phase::Decompress => "decompress",
            Phase::ScreenOrder => "screen order",
            Phase::HierarchyCreation => "hierarchy creation",
            Phase::Traversal => "traversal",
            Phase::FinalTests => "final tests",
            Phase::ReadBack => "read-back",
        }
    }

    /// The GPU backend's transfers between host and device.
    pub fn is_transfer(self) -> bool {
        matches!(self, Phase::Upload | Phase::ReadBack)
    }

    /// Phases that build the ray hierarchy (ordering it and creating its nodes).
    pub fn is_build(self) -> bool {
        !self.is_transfer() && self < Phase::Traversal
    }
}

impl std::fmt::Display for Phase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for Phase {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

/// Names of the engines' other counters, each defined once.
pub mod counter {
    /// Grids: cells visited per ray, summed (the paper's N_T).
    pub const TRAVERSAL_STEPS: &str = "traversal steps";
    /// CRSH: runs of equal hashes after trimming (thesis §3.2.3).
    pub const CHUNKS: &str = "chunks";
    /// Ray hierarchies: node–mesh-sphere tests at the top level (thesis §3.2.2).
    pub const MESH_SPHERE_TESTS: &str = "mesh-sphere tests";
    /// Ray hierarchies: (top node, mesh) pairs that passed the mesh-sphere test.
    pub const MESH_SPHERE_PASSES: &str = "mesh-sphere passes";
    /// Ray hierarchies: triangle batches of the top level (RAH's scene batches).
    pub const TRIANGLE_BATCHES: &str = "triangle batches";
    /// Ray hierarchies: levels halved because their pairs exceeded the pair budget.
    pub const BUDGET_SPLITS: &str = "budget splits";
    /// Ray hierarchies: nodes of the top level.
    pub const TOP_NODES: &str = "top nodes";
    /// Ray hierarchies with an object hierarchy: tests of ray nodes against inner object
    /// nodes (also counted in the level tests).
    pub const OBJECT_NODE_TESTS: &str = "object-node tests";
    /// Ray hierarchies with an object hierarchy: slab tests of single rays against object
    /// nodes' boxes (in the total tests, not in the level tables).
    pub const RAY_BOX_TESTS: &str = "ray-box tests";
    /// Ray hierarchies with an object hierarchy: ray-box tests that passed.
    pub const RAY_BOX_PASSES: &str = "ray-box passes";
    /// Ray hierarchies with an object hierarchy: the most (ray node, object node) pairs
    /// waiting at once.
    pub const PEAK_PAIRS: &str = "peak pairs";
    /// Ray hierarchies with an object hierarchy: the bytes those pairs took (depth first:
    /// one worker's most × the workers, the most they can hold at once).
    pub const PEAK_PAIR_BYTES: &str = "peak pair bytes";
    /// GPU backend: compute dispatches.
    pub const GPU_KERNEL_LAUNCHES: &str = "gpu kernel launches";
}

/// A ray hierarchy's tests and hits per level and ray kind, as the thesis's chapter-4 tables
/// give them; index `[level − 1][RayKind as usize]`, level 1 the nodes just above the rays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LevelCounts {
    /// Node–triangle tests per level and kind.
    pub tests: Vec<[u64; 4]>,
    /// Node–triangle tests that passed, per level and kind.
    pub hits: Vec<[u64; 4]>,
    /// Final ray–triangle tests per kind.
    pub final_tests: [u64; 4],
}

/// One row of [`LevelCounts::rows`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct LevelRow {
    /// Hierarchy level (1: the nodes just above the rays).
    pub level: u32,
    /// The kind's short name (`SH`, `RE`, `RF`, `PR`).
    pub kind: &'static str,
    /// Node–triangle tests.
    pub tests: u64,
    /// Tests that passed.
    pub hits: u64,
}

impl LevelCounts {
    /// No tests recorded (engines that are not ray hierarchies).
    pub fn is_empty(&self) -> bool {
        self.tests.iter().all(|t| *t == [0; 4]) && self.final_tests == [0; 4]
    }

    /// Add another call's counts.
    pub fn add(&mut self, o: &LevelCounts) {
        let n = self.tests.len().max(o.tests.len());
        self.tests.resize(n, [0; 4]);
        self.hits.resize(n, [0; 4]);
        for (l, (t, h)) in o.tests.iter().zip(&o.hits).enumerate() {
            for k in 0..4 {
                self.tests[l][k] += t[k];
                self.hits[l][k] += h[k];
            }
        }
        for k in 0..4 {
            self.final_tests[k] += o.final_tests[k];
        }
    }

    /// The (level, kind) cells with tests, top level first, kinds by short name.
    pub fn rows(&self) -> Vec<LevelRow> {
        let mut rows = Vec::new();
        for (l, (t, h)) in self.tests.iter().zip(&self.hits).enumerate().rev() {
            let mut level: Vec<LevelRow> = RayKind::ALL
                .iter()
                .filter(|&&k| t[k as usize] > 0)
                .map(|&k| LevelRow {
                    level: l as u32 + 1,
                    kind: k.short(),
                    tests: t[k as usize],
                    hits: h[k as usize],
                })
                .collect();
            level.sort_by_key(|r| r.kind);
            rows.extend(level);
        }
        rows
    }

    /// The final tests with their kind's short name, kinds by short name.
    pub fn final_rows(&self) -> Vec<(&'static str, u64)> {
        let mut v: Vec<(&'static str, u64)> = RayKind::ALL
            .iter()
            .filter(|&&k| self.final_tests[k as usize] > 0)
            .map(|&k| (k.short(), self.final_tests[k as usize]))
            .collect();
        v.sort();
        v
    }
}

impl LevelCounts {
    /// The thesis's per-level table as markdown rows (with its header): tests, hits and
    /// misses per level and kind, top level first, then the final ray–triangle tests.
    pub fn markdown(&self) -> String {
        let mut s =
            String::from("\n| level | kind | tests | hits | misses |\n|---|---|---:|---:|---:|\n");
        for r in self.rows() {
            s += &format!(
                "| {} | {} | {} | {} | {} |\n",
                r.level,
                r.kind,
                r.tests,
                r.hits,
                r.tests - r.hits
            );
        }
        for (kind, v) in self.final_rows() {
            s += &format!("| final (ray-triangle) | {kind} | {v} | | |\n");
        }
        s
    }
}

/// In JSON: `{"levels": [{level, kind, tests, hits}, ...], "final_tests": {"SH": n, ...}}`.
impl Serialize for LevelCounts {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Json {
            levels: Vec<LevelRow>,
            final_tests: BTreeMap<&'static str, u64>,
        }
        Json {
            levels: self.rows(),
            final_tests: self.final_rows().into_iter().collect(),
        }
        .serialize(s)
    }
}

/// Counters accumulated by an engine over one or more trace calls.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct TraceStats {
    /// Rays traced.
    pub rays: u64,
    /// Exact ray–triangle intersection tests.
    pub ray_tri_tests: u64,
    /// Conservative node–triangle tests (ray-space hierarchies: every level's tests).
    pub node_tri_tests: u64,
    /// Rays that found a hit.
    pub hits: u64,
    /// Ray hierarchies: tests and hits per level and ray kind (a breakdown of
    /// `node_tri_tests` and `ray_tri_tests`, not added again).
    #[serde(skip_serializing_if = "LevelCounts::is_empty")]
    pub levels: LevelCounts,
    /// Engine-specific counters (named in [`counter`]), for reporting; they do not enter
    /// [`TraceStats::total_tests`].
    pub counters: BTreeMap<String, u64>,
    /// Engine-internal phase times in seconds (accumulated over calls).
    pub phases: BTreeMap<Phase, f64>,
}

impl TraceStats {
    /// Add another call's counters and times.
    pub fn add(&mut self, o: &TraceStats) {
        self.rays += o.rays;
        self.ray_tri_tests += o.ray_tri_tests;
        self.node_tri_tests += o.node_tri_tests;
        self.hits += o.hits;
        self.levels.add(&o.levels);
        for (k, v) in &o.counters {
            self.count(k, *v);
        }
        for (k, v) in &o.phases {
            *self.phases.entry(*k).or_default() += v;
        }
    }

    /// Add `n` to the counter `name` (one of [`counter`]); a peak (a name starting with
    /// "peak") keeps the largest value instead, over calls as within one.
    pub fn count(&mut self, name: &str, n: u64) {
        let c = self.counters.entry(name.to_string()).or_default();
        if name.starts_with("peak") {
            *c = (*c).max(n);
        } else {
            *c += n;
        }
    }

    /// Add `secs` to `phase`.
    pub fn time(&mut self, phase: Phase, secs: f64) {
        *self.phases.entry(phase).or_default() += secs;
    }

    /// Seconds spent in `phase` (0 when the engine has no such phase).
    pub fn seconds(&self, phase: Phase) -> f64 {
        self.phases.get(&phase).copied().unwrap_or(0.0)
    }

    /// All intersection tests as the thesis counts them (§4.4): node–triangle tests of every
    /// hierarchy level plus the final ray–triangle tests.
    pub fn total_tests(&self) -> u64 {
        self.ray_tri_tests + self.node_tri_tests
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
    /// Σ node–triangle + ray–triangle tests.
    pub total_tests: u64,
    /// The brute-force reference: traced rays × triangles.
    pub brute_force_tests: u64,
    /// Wall-clock seconds per renderer phase, in execution order.
    pub phases: Vec<(String, f64)>,
    /// GPU backend: bytes moved between host and device during the frame, both ways (every
    /// upload, launch parameter block and read-back; absent on the CPU).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host_device_bytes: Option<u64>,
    /// GPU backend: read-backs during the frame, each a wait for the device (sizes of the
    /// next buffers, totals, the image).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host_read_backs: Option<u64>,
    /// GPU backend: how the frame ran, `device-resident` (everything between the G-buffer
    /// and the sRGB image stayed on the device) or `host-sequenced` with the reason.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpu_frame: Option<String>,
}

impl RenderStats {
    /// Put the engine's build first among the phases: "engine build" (`seconds`), then its
    /// passes indented under it ("  build: octrees", ...), as the table and the JSON show them.
    pub fn put_build(&mut self, seconds: f64, passes: Vec<(String, f64)>) {
        let rows = std::iter::once(("engine build".to_string(), seconds)).chain(
            passes
                .into_iter()
                .map(|(p, t)| (format!("  build: {p}"), t)),
        );
        self.phases.splice(0..0, rows);
    }

    /// All traced rays.
    pub fn rays_traced(&self) -> u64 {
        self.rays_shadow + self.rays_reflection + self.rays_refraction + self.rays_primary_traced
    }

    /// Add `secs` to the renderer phase `name` (appended in first-seen order).
    pub fn add_phase(&mut self, name: &str, secs: f64) {
        match self.phases.iter_mut().find(|(n, _)| n == name) {
            Some((_, s)) => *s += secs,
            None => self.phases.push((name.to_string(), secs)),
        }
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
            // Indented rows break down the phase above them and are not added again.
            if !n.starts_with(' ') {
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
        for (k, v) in &self.trace.counters {
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
        s += &format!("| total tests | {} |\n", self.total_tests);
        s += &format!(
            "| brute force (rays x triangles) | {} |\n",
            self.brute_force_tests
        );
        s += &format!(
            "| total as % of brute force | {:.3} % |\n",
            pct(self.total_tests, self.brute_force_tests)
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

    #[test]
    fn peaks_keep_the_largest_and_counts_add() {
        let mut a = TraceStats::default();
        a.count(counter::PEAK_PAIRS, 30);
        a.count(counter::PEAK_PAIRS, 12);
        a.count(counter::CHUNKS, 5);
        let mut b = TraceStats::default();
        b.count(counter::PEAK_PAIRS, 40);
        b.count(counter::CHUNKS, 7);
        a.add(&b);
        assert_eq!(a.counters[counter::PEAK_PAIRS], 40);
        assert_eq!(a.counters[counter::CHUNKS], 12);
    }

    #[test]
    fn totals_and_merge() {
        let mut a = TraceStats {
            rays: 2,
            ray_tri_tests: 10,
            node_tri_tests: 5,
            hits: 1,
            ..Default::default()
        };
        a.levels.tests = vec![[0, 5, 0, 0]];
        a.levels.hits = vec![[0, 2, 0, 0]];
        a.count(counter::TRAVERSAL_STEPS, 100);
        let mut b = a.clone();
        b.add(&a);
        assert_eq!(b.rays, 4);
        assert_eq!(b.counters[counter::TRAVERSAL_STEPS], 200);
        assert_eq!(b.levels.tests, vec![[0, 10, 0, 0]]);
        assert_eq!(
            b.levels.rows(),
            vec![LevelRow {
                level: 1,
                kind: "SH",
                tests: 10,
                hits: 4
            }]
        );
        assert_eq!(
            b.total_tests(),
            30,
            "per-level counters are a breakdown, not added again"
        );
    }
}
