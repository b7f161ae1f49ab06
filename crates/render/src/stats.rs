//! Counters and timings: per trace call ([`TraceStats`]) and per render ([`RenderStats`]).
//!
//! Counts are deterministic for a given input and configuration and are the primary
//! efficiency figures; times are for orientation only.

use serde::Serialize;
use std::collections::BTreeMap;

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
    /// Engine-specific counters (tests per level and ray kind, traversal steps, ...), for
    /// reporting; they do not enter [`TraceStats::total_tests`].
    pub counters: BTreeMap<String, u64>,
    /// Engine-internal phase times in seconds (accumulated over calls).
    pub phases: BTreeMap<String, f64>,
}

impl TraceStats {
    pub fn add(&mut self, o: &TraceStats) {
        self.rays += o.rays;
        self.ray_tri_tests += o.ray_tri_tests;
        self.node_tri_tests += o.node_tri_tests;
        self.hits += o.hits;
        for (k, v) in &o.counters {
            *self.counters.entry(k.clone()).or_default() += v;
        }
        for (k, v) in &o.phases {
            *self.phases.entry(k.clone()).or_default() += v;
        }
    }

    pub fn count(&mut self, name: &str, n: u64) {
        *self.counters.entry(name.to_string()).or_default() += n;
    }

    pub fn time(&mut self, name: &str, secs: f64) {
        *self.phases.entry(name.to_string()).or_default() += secs;
    }

    /// Per-level rows (level, kind, tests, hits) from counters named `L<n> <KIND> tests|hits`,
    /// top level first, as in the thesis's tables.
    pub fn level_table(&self) -> Vec<(u32, String, u64, u64)> {
        let mut rows: Vec<(u32, String, u64, u64)> = Vec::new();
        for (k, &v) in &self.counters {
            let mut it = k.split(' ');
            let (Some(l), Some(kind), Some(what), None) =
                (it.next(), it.next(), it.next(), it.next())
            else {
                continue;
            };
            let Some(level) = l.strip_prefix('L').and_then(|n| n.parse::<u32>().ok()) else {
                continue;
            };
            if what != "tests" {
                continue;
            }
            let hits = self
                .counters
                .get(&format!("L{level} {kind} hits"))
                .copied()
                .unwrap_or(0);
            rows.push((level, kind.to_string(), v, hits));
        }
        rows.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
        rows
    }

    /// All intersection tests as the thesis counts them (§4.4): node–triangle tests of every
    /// hierarchy level plus the final ray–triangle tests.
    pub fn total_tests(&self) -> u64 {
        self.ray_tri_tests + self.node_tri_tests
    }
}

fn is_level_counter(k: &str) -> bool {
    let mut it = k.split(' ');
    matches!((it.next(), it.next(), it.next()), (Some(l), Some(_), Some("tests" | "hits")) if l.starts_with('L') && l[1..].parse::<u32>().is_ok())
        || (k.starts_with("final ") && k.ends_with(" tests"))
}

/// Everything a render reports (printed as a table by the CLI; `--stats` writes it as JSON).
#[derive(Clone, Debug, Default, Serialize)]
pub struct RenderStats {
    pub scene: String,
    pub engine: String,
    pub width: u32,
    pub height: u32,
    pub triangles: u64,
    pub meshes: u64,
    pub lights: u64,
    pub bounces: u32,
    /// Pixels covered by rasterized geometry (the primary "rays" that were not traced).
    pub covered_pixels: u64,
    /// Traced rays by kind.
    pub rays_shadow: u64,
    pub rays_reflection: u64,
    pub rays_refraction: u64,
    pub rays_primary_traced: u64,
    /// Ray–triangle tests, node tests etc. from the engine.
    pub trace: TraceStats,
    /// Σ node–triangle + ray–triangle tests.
    pub total_tests: u64,
    /// The brute-force reference: traced rays × triangles.
    pub brute_force_tests: u64,
    /// Wall-clock seconds per renderer phase, in execution order.
    pub phases: Vec<(String, f64)>,
}

impl RenderStats {
    pub fn rays_traced(&self) -> u64 {
        self.rays_shadow + self.rays_reflection + self.rays_refraction + self.rays_primary_traced
    }

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
        let levels = self.trace.level_table();
        for (k, v) in &self.trace.counters {
            if levels.is_empty() || !is_level_counter(k) {
                s += &format!("| {k} | {v} |\n");
            }
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
        if !levels.is_empty() {
            s += "\n| level | kind | tests | hits | misses |\n|---|---|---:|---:|---:|\n";
            for (level, kind, tests, hits) in &levels {
                s += &format!(
                    "| {level} | {kind} | {tests} | {hits} | {} |\n",
                    tests - hits
                );
            }
            for (k, v) in &self.trace.counters {
                if let Some(kind) = k
                    .strip_prefix("final ")
                    .and_then(|r| r.strip_suffix(" tests"))
                {
                    s += &format!("| final (ray-triangle) | {kind} | {v} | | |\n");
                }
            }
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
    fn totals_and_merge() {
        let mut a = TraceStats {
            rays: 2,
            ray_tri_tests: 10,
            node_tri_tests: 5,
            hits: 1,
            ..Default::default()
        };
        a.count("L1 SH tests", 5);
        a.count("traversal steps", 100);
        let mut b = a.clone();
        b.add(&a);
        assert_eq!(b.rays, 4);
        assert_eq!(b.counters["traversal steps"], 200);
        assert_eq!(
            b.total_tests(),
            30,
            "per-level counters are a breakdown, not added again"
        );
    }
}
