//! Counters and timings of trace calls ([`TraceStats`]): rays, tests and hits, the thesis's
//! per-level table ([`LevelCounts`], chapter 4), typed engine counters ([`Counter`]), the
//! engines' phases ([`Phase`]) and their build passes ([`BuildPass`]).
//!
//! Counts are deterministic for a given input and configuration and are the primary
//! efficiency figures; times are for orientation only.

use crate::RayKind;
use serde::{Serialize, Serializer};
use std::collections::BTreeMap;

/// What kind of work a [`Phase`] is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PhaseKind {
    /// Moving data between host and device (the GPU backend's uploads and read-backs).
    Transfer,
    /// Building a structure over the rays before they are traced (a ray hierarchy's
    /// ordering and node creation).
    Build,
    /// Tracing: walking a structure and testing triangles.
    Trace,
}

/// A timed step inside an engine's trace call. Each engine declares its own phases as
/// constants (pbrt's statistics register theirs the same way): the ray hierarchy's hash,
/// sort and hierarchy creation are `rsh`'s, the GPU's transfers are `gpu`'s; this crate
/// declares only [`TRAVERSAL`], which every engine has. A phase sorts by its rank, the
/// pipeline's order, so every report lists phases alike (the stats table, the JSON, the
/// frame CSV's columns, the benchmarks), and keeps the name it had as a string.
#[derive(Clone, Copy, Debug)]
pub struct Phase {
    rank: u16,
    name: &'static str,
    kind: PhaseKind,
}

impl Phase {
    /// The phase `name`, of `kind`, at `rank` in the pipeline (upload 0, the ray hierarchy's
    /// ordering 10–60, hierarchy creation 70, traversal 80, final tests 90, read-back 100).
    pub const fn new(rank: u16, name: &'static str, kind: PhaseKind) -> Phase {
        Phase { rank, name, kind }
    }

    /// The phase's name in reports ("hierarchy creation", ...).
    pub fn as_str(self) -> &'static str {
        self.name
    }

    /// Its place in the pipeline.
    pub fn rank(self) -> u16 {
        self.rank
    }

    /// The GPU backend's transfers between host and device.
    pub fn is_transfer(self) -> bool {
        self.kind == PhaseKind::Transfer
    }

    /// Phases that build the ray hierarchy (ordering it and creating its nodes).
    pub fn is_build(self) -> bool {
        self.kind == PhaseKind::Build
    }
}

/// Walking the engine's structure (every engine's; the ray hierarchy's traversal of §3.2.8).
pub const TRAVERSAL: Phase = Phase::new(80, "traversal", PhaseKind::Trace);

impl PartialEq for Phase {
    fn eq(&self, o: &Phase) -> bool {
        (self.rank, self.name) == (o.rank, o.name)
    }
}

impl Eq for Phase {}

impl PartialOrd for Phase {
    fn partial_cmp(&self, o: &Phase) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for Phase {
    fn cmp(&self, o: &Phase) -> std::cmp::Ordering {
        (self.rank, self.name).cmp(&(o.rank, o.name))
    }
}

impl std::hash::Hash for Phase {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        (self.rank, self.name).hash(h)
    }
}

impl std::fmt::Display for Phase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name)
    }
}

impl Serialize for Phase {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name)
    }
}

/// How a counter combines over trace calls (and within one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CounterKind {
    /// Values add up (tests, steps, nodes).
    Sum,
    /// The largest value is kept (a high-water mark such as the most pairs waiting at once).
    Peak,
}

/// A counter an engine declares, as a constant of its own crate (pbrt's statistics register
/// theirs the same way): its name in reports (a key of the `--stats` JSON's `counters`) and
/// how it combines. Counters compare and sort by name, so every report lists them alike
/// (the JSON's `counters` object, the stats table, `trace`'s summary lines); two engines
/// that report the same quantity use the same constant.
#[derive(Clone, Copy, Debug)]
pub struct Counter {
    name: &'static str,
    kind: CounterKind,
}

impl Counter {
    /// A counter whose values add up.
    pub const fn sum(name: &'static str) -> Counter {
        Counter {
            name,
            kind: CounterKind::Sum,
        }
    }

    /// A counter that keeps its largest value (its name starts with "peak").
    pub const fn peak(name: &'static str) -> Counter {
        Counter {
            name,
            kind: CounterKind::Peak,
        }
    }

    /// The counter's name in reports.
    pub fn name(self) -> &'static str {
        self.name
    }

    /// Whether the counter adds up or keeps its largest value.
    pub fn kind(self) -> CounterKind {
        self.kind
    }
}

impl PartialEq for Counter {
    fn eq(&self, o: &Counter) -> bool {
        self.name == o.name
    }
}

impl Eq for Counter {}

impl PartialOrd for Counter {
    fn partial_cmp(&self, o: &Counter) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

impl Ord for Counter {
    fn cmp(&self, o: &Counter) -> std::cmp::Ordering {
        self.name.cmp(o.name)
    }
}

impl std::hash::Hash for Counter {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        self.name.hash(h)
    }
}

impl std::fmt::Display for Counter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name)
    }
}

/// Ray–box tests: single rays' slab tests against object nodes' boxes (the `bvh` engine's
/// walks, the dual traversal's single-ray level). One of the three kinds of test every
/// engine that makes them counts (with [`TraceStats::ray_tri_tests`] and
/// [`TraceStats::node_tri_tests`]), so it enters [`TraceStats::total_tests`].
pub const RAY_BOX_TESTS: Counter = Counter::sum("ray-box tests");

/// The counters an engine reported, each combined by its [`CounterKind`]; absent ones were
/// never reported (an engine without mesh culling has no mesh-sphere tests, not zero).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Counters(BTreeMap<Counter, u64>);

impl Counters {
    /// Combine `n` into `c`: added for a [`CounterKind::Sum`], the larger kept for a
    /// [`CounterKind::Peak`].
    pub fn record(&mut self, c: Counter, n: u64) {
        let v = self.0.entry(c).or_default();
        match c.kind() {
            CounterKind::Sum => *v += n,
            CounterKind::Peak => *v = (*v).max(n),
        }
    }

    /// The value of `c`, if reported.
    pub fn get(&self, c: Counter) -> Option<u64> {
        self.0.get(&c).copied()
    }

    /// Whether `c` was reported.
    pub fn contains(&self, c: Counter) -> bool {
        self.0.contains_key(&c)
    }

    /// Forget `c` (a backend that reports it elsewhere).
    pub fn remove(&mut self, c: Counter) -> Option<u64> {
        self.0.remove(&c)
    }

    /// The reported counters in the order of their names.
    pub fn iter(&self) -> impl Iterator<Item = (Counter, u64)> + '_ {
        self.0.iter().map(|(c, v)| (*c, *v))
    }

    /// Whether nothing was reported.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Combine every counter of `o` into these.
    pub fn add(&mut self, o: &Counters) {
        for (c, v) in o.iter() {
            self.record(c, v);
        }
    }
}

/// `counters[c]`: the value of a counter that must have been reported (panics otherwise,
/// as a map's index does).
impl std::ops::Index<Counter> for Counters {
    type Output = u64;
    fn index(&self, c: Counter) -> &u64 {
        self.0
            .get(&c)
            .unwrap_or_else(|| panic!("counter '{c}' was not reported"))
    }
}

/// In JSON: an object from each counter's name to its value, names in order.
impl Serialize for Counters {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(self.iter().map(|(c, v)| (c.name(), v)))
    }
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

/// Counters accumulated by an engine over one or more trace calls. Three kinds of test are
/// counted apart, each once, with the same meaning for every engine: exact ray–triangle
/// tests ([`TraceStats::ray_tri_tests`]), ray–box tests of single rays against object nodes
/// ([`RAY_BOX_TESTS`]) and the ray hierarchy's node tests, a cone and sphere against a
/// triangle or an object node ([`TraceStats::node_tri_tests`]).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct TraceStats {
    /// Rays traced.
    pub rays: u64,
    /// Exact ray–triangle intersection tests.
    pub ray_tri_tests: u64,
    /// Ray-hierarchy node tests: a node's sphere and cone against a triangle's sphere or an
    /// object node's (every level's tests; none for engines without a ray hierarchy).
    pub node_tri_tests: u64,
    /// Rays that found a hit.
    pub hits: u64,
    /// Ray hierarchies: tests and hits per level and ray kind (a breakdown of
    /// `node_tri_tests` and `ray_tri_tests`, not added again).
    #[serde(skip_serializing_if = "LevelCounts::is_empty")]
    pub levels: LevelCounts,
    /// Engine-specific counters, for reporting; they do not enter
    /// [`TraceStats::total_tests`].
    pub counters: Counters,
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
        self.counters.add(&o.counters);
        for (k, v) in &o.phases {
            *self.phases.entry(*k).or_default() += v;
        }
    }

    /// Combine `n` into the counter `c` (a sum adds, a peak keeps the largest, over calls
    /// as within one).
    pub fn count(&mut self, c: Counter, n: u64) {
        self.counters.record(c, n);
    }

    /// Add `secs` to `phase`.
    pub fn time(&mut self, phase: Phase, secs: f64) {
        *self.phases.entry(phase).or_default() += secs;
    }

    /// Seconds spent in `phase` (0 when the engine has no such phase).
    pub fn seconds(&self, phase: Phase) -> f64 {
        self.phases.get(&phase).copied().unwrap_or(0.0)
    }

    /// All intersection tests: the thesis's (§4.4: node tests of every hierarchy level plus
    /// the final ray–triangle tests) and ray–box tests.
    pub fn total_tests(&self) -> u64 {
        self.ray_tri_tests + self.node_tri_tests + self.counters.get(RAY_BOX_TESTS).unwrap_or(0)
    }

    /// Ray–triangle tests as a share of brute force's (rays × `triangles`), in percent: the
    /// same figure for every engine.
    pub fn percent_of_brute_force(&self, triangles: u64) -> f64 {
        100.0 * self.ray_tri_tests as f64 / (self.rays * triangles).max(1) as f64
    }
}

/// A pass of an engine's build (before any ray is traced), declared by its engine as a
/// constant (the grid's top references, octrees, cells, merge and expansion are
/// `accel::grid`'s, the object tree's build `accel::bvh`'s, the kernels' compilation the
/// GPU's), named as the stats name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct BuildPass(&'static str);

impl BuildPass {
    /// The pass called `name`.
    pub const fn new(name: &'static str) -> BuildPass {
        BuildPass(name)
    }

    /// The pass's name in reports.
    pub fn name(self) -> &'static str {
        self.0
    }
}

impl std::fmt::Display for BuildPass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.0)
    }
}

/// Where a pass ran, for backends that run some passes on either side.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Device {
    /// On the host.
    Cpu,
    /// As kernels on the device.
    Gpu,
}

/// A timed build pass, and where it ran when that is not implied.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassTime {
    /// The pass.
    pub pass: BuildPass,
    /// Where it ran (`None`: the engine's only place).
    pub device: Option<Device>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

impl PassTime {
    /// `pass` took `seconds`.
    pub fn new(pass: BuildPass, seconds: f64) -> PassTime {
        PassTime {
            pass,
            device: None,
            seconds,
        }
    }

    /// `pass` took `seconds` on `device`.
    pub fn on(pass: BuildPass, device: Device, seconds: f64) -> PassTime {
        PassTime {
            pass,
            device: Some(device),
            seconds,
        }
    }

    /// The name in reports: the pass's, with where it ran in brackets (`octrees (GPU)`).
    pub fn name(&self) -> String {
        match self.device {
            None => self.pass.name().to_string(),
            Some(Device::Cpu) => format!("{} (CPU)", self.pass),
            Some(Device::Gpu) => format!("{} (GPU)", self.pass),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PEAK: Counter = Counter::peak("peak pairs");
    const CHUNKS: Counter = Counter::sum("chunks");
    const STEPS: Counter = Counter::sum("traversal steps");
    const SPLITS: Counter = Counter::sum("budget splits");

    #[test]
    fn peaks_keep_the_largest_and_counts_add() {
        let mut a = TraceStats::default();
        a.count(PEAK, 30);
        a.count(PEAK, 12);
        a.count(CHUNKS, 5);
        let mut b = TraceStats::default();
        b.count(PEAK, 40);
        b.count(CHUNKS, 7);
        a.add(&b);
        assert_eq!(a.counters.get(PEAK).unwrap(), 40);
        assert_eq!(a.counters.get(CHUNKS).unwrap(), 12);
    }

    #[test]
    fn counters_serialize_by_name_in_name_order() {
        let mut c = Counters::default();
        c.record(STEPS, 3);
        c.record(SPLITS, 1);
        assert_eq!(
            serde_json::to_string(&c).unwrap(),
            r#"{"budget splits":1,"traversal steps":3}"#
        );
        assert_eq!(
            Counter::sum("a"),
            Counter::peak("a"),
            "one name, one counter"
        );
    }

    #[test]
    fn phases_sort_by_rank() {
        let hash = Phase::new(10, "hash", PhaseKind::Build);
        let up = Phase::new(0, "upload", PhaseKind::Transfer);
        let mut v = vec![TRAVERSAL, hash, up];
        v.sort();
        assert_eq!(v, [up, hash, TRAVERSAL]);
        assert!(hash.is_build() && up.is_transfer() && !TRAVERSAL.is_build());
        assert_eq!(serde_json::to_string(&TRAVERSAL).unwrap(), r#""traversal""#);
    }

    #[test]
    fn build_pass_names() {
        let octrees = BuildPass::new("octrees");
        assert_eq!(
            PassTime::on(octrees, Device::Gpu, 0.5).name(),
            "octrees (GPU)"
        );
        assert_eq!(PassTime::new(octrees, 0.5).name(), "octrees");
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
        a.count(STEPS, 100);
        a.count(RAY_BOX_TESTS, 7);
        let mut b = a.clone();
        b.add(&a);
        assert_eq!(b.rays, 4);
        assert_eq!(b.counters.get(STEPS).unwrap(), 200);
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
            44,
            "per-level counters are a breakdown, not added again; ray-box tests are"
        );
        assert_eq!(b.percent_of_brute_force(10), 50.0);
    }
}
