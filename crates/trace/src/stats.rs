//! Counters and timings of trace calls ([`TraceStats`]): rays, tests and hits, the thesis's
//! per-level table ([`LevelCounts`], chapter 4), typed engine counters ([`Counter`]), the
//! engines' phases ([`Phase`]) and their build passes ([`BuildPass`]).
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

/// How a counter combines over trace calls (and within one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CounterKind {
    /// Values add up (tests, steps, nodes).
    Sum,
    /// The largest value is kept (a high-water mark such as the most pairs waiting at once).
    Peak,
}

macro_rules! counters {
    ($($(#[doc = $doc:literal])* $v:ident = $name:literal, $kind:ident;)*) => {
        /// The engines' counters besides rays, tests and hits, each named once. Variants are
        /// declared in the order of their names, so that every report lists them alike
        /// (the JSON's `counters` object, the stats table, `trace`'s summary lines).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub enum Counter {
            $($(#[doc = $doc])* $v,)*
        }

        impl Counter {
            /// Every counter, in the order of their names.
            pub const ALL: &'static [Counter] = &[$(Counter::$v),*];

            /// The counter's name in reports (a key of the `--stats` JSON's `counters`).
            pub fn name(self) -> &'static str {
                match self {
                    $(Counter::$v => $name,)*
                }
            }

            /// Whether the counter adds up or keeps its largest value.
            pub fn kind(self) -> CounterKind {
                match self {
                    $(Counter::$v => CounterKind::$kind,)*
                }
            }
        }
    };
}

counters! {
    /// Ray hierarchies: levels halved because their pairs exceeded the pair budget.
    BudgetSplits = "budget splits", Sum;
    /// CRSH/RAH with an object hierarchy: trace calls whose rays went as the ray
    /// hierarchy's bundles (the coherent path).
    BundledBatches = "bundled batches", Sum;
    /// CRSH: runs of equal hashes after trimming (thesis §3.2.3).
    Chunks = "chunks", Sum;
    /// GPU backend: compute dispatches.
    GpuKernelLaunches = "gpu kernel launches", Sum;
    /// GPU backend, single rays through the object tree: rays whose walk outgrew the
    /// private stack, walked again by the second pass with its stack in storage memory.
    GpuStackOverflows = "gpu stack overflows", Sum;
    /// Ray hierarchies: (top node, mesh) pairs that passed the mesh-sphere test.
    MeshSpherePasses = "mesh-sphere passes", Sum;
    /// Ray hierarchies: node–mesh-sphere tests at the top level (thesis §3.2.2).
    MeshSphereTests = "mesh-sphere tests", Sum;
    /// Ray hierarchies with an object hierarchy: tests of ray nodes against inner object
    /// nodes (also counted in the level tests).
    ObjectNodeTests = "object-node tests", Sum;
    /// CRSH/RAH with an object hierarchy: trace calls whose rays went through the object
    /// tree in packets of consecutive rays (the coherent batches of `--ray-path packets`).
    PacketBatches = "packet batches", Sum;
    /// Ray hierarchies with an object hierarchy: the bytes the most waiting pairs took
    /// (depth first: one worker's most × the workers, the most they can hold at once).
    PeakPairBytes = "peak pair bytes", Peak;
    /// Ray hierarchies with an object hierarchy: the most (ray node, object node) pairs
    /// waiting at once.
    PeakPairs = "peak pairs", Peak;
    /// Ray hierarchies with an object hierarchy: ray-box tests that passed.
    RayBoxPasses = "ray-box passes", Sum;
    /// Ray hierarchies with an object hierarchy: slab tests of single rays against object
    /// nodes' boxes (in the total tests, not in the level tables).
    RayBoxTests = "ray-box tests", Sum;
    /// CRSH/RAH with an object hierarchy: trace calls whose rays went one by one through the
    /// object tree (the incoherent path).
    SingleRayBatches = "single-ray batches", Sum;
    /// Ray hierarchies: nodes of the top level.
    TopNodes = "top nodes", Sum;
    /// Grids: cells visited per ray, summed (the paper's N_T).
    TraversalSteps = "traversal steps", Sum;
    /// Ray hierarchies: triangle batches of the top level (RAH's scene batches).
    TriangleBatches = "triangle batches", Sum;
}

impl std::fmt::Display for Counter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

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

    /// All intersection tests as the thesis counts them (§4.4): node–triangle tests of every
    /// hierarchy level plus the final ray–triangle tests.
    pub fn total_tests(&self) -> u64 {
        self.ray_tri_tests + self.node_tri_tests
    }
}

/// A pass of an engine's build (before any ray is traced), as the stats name it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum BuildPass {
    /// Irregular grid (§4.1): the top grid's references.
    TopRefs,
    /// Irregular grid (§4.1): the octrees below the top cells.
    Octrees,
    /// Irregular grid (§4.1): the initial cells and the voxel map.
    Cells,
    /// Irregular grid (§4.2): SAH cell merging.
    Merge,
    /// Irregular grid (§4.3): cell expansion.
    Expansion,
    /// CRSH/RAH with an object tree: the per-frame BVH over the triangles.
    ObjectHierarchy,
    /// GPU backend: the engine's WGSL modules compiled.
    KernelCompilation,
    /// GPU backend: a structure built on the host, uploaded.
    Upload,
}

impl BuildPass {
    /// The irregular grid's passes, in build order.
    pub const GRID: [BuildPass; 5] = [
        BuildPass::TopRefs,
        BuildPass::Octrees,
        BuildPass::Cells,
        BuildPass::Merge,
        BuildPass::Expansion,
    ];

    /// The pass's name in reports.
    pub fn name(self) -> &'static str {
        match self {
            BuildPass::TopRefs => "top_refs",
            BuildPass::Octrees => "octrees",
            BuildPass::Cells => "cells",
            BuildPass::Merge => "merge",
            BuildPass::Expansion => "expansion",
            BuildPass::ObjectHierarchy => "object hierarchy",
            BuildPass::KernelCompilation => "kernel compilation",
            BuildPass::Upload => "upload",
        }
    }
}

impl std::fmt::Display for BuildPass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
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

    #[test]
    fn peaks_keep_the_largest_and_counts_add() {
        let mut a = TraceStats::default();
        a.count(Counter::PeakPairs, 30);
        a.count(Counter::PeakPairs, 12);
        a.count(Counter::Chunks, 5);
        let mut b = TraceStats::default();
        b.count(Counter::PeakPairs, 40);
        b.count(Counter::Chunks, 7);
        a.add(&b);
        assert_eq!(a.counters.get(Counter::PeakPairs).unwrap(), 40);
        assert_eq!(a.counters.get(Counter::Chunks).unwrap(), 12);
    }

    #[test]
    fn counters_are_declared_in_name_order_and_serialize_by_name() {
        let names: Vec<&str> = Counter::ALL.iter().map(|c| c.name()).collect();
        let mut sorted = names.clone();
        sorted.sort_unstable();
        assert_eq!(names, sorted, "reports list counters by name");
        let mut c = Counters::default();
        c.record(Counter::TraversalSteps, 3);
        c.record(Counter::BudgetSplits, 1);
        assert_eq!(
            serde_json::to_string(&c).unwrap(),
            r#"{"budget splits":1,"traversal steps":3}"#
        );
        assert!(Counter::ALL
            .iter()
            .all(|c| (c.kind() == CounterKind::Peak) == c.name().starts_with("peak")));
    }

    #[test]
    fn build_pass_names() {
        assert_eq!(
            PassTime::on(BuildPass::Octrees, Device::Gpu, 0.5).name(),
            "octrees (GPU)"
        );
        assert_eq!(
            PassTime::new(BuildPass::ObjectHierarchy, 0.5).name(),
            "object hierarchy"
        );
        let names: Vec<&str> = BuildPass::GRID.iter().map(|p| p.name()).collect();
        assert_eq!(
            names,
            ["top_refs", "octrees", "cells", "merge", "expansion"]
        );
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
        a.count(Counter::TraversalSteps, 100);
        let mut b = a.clone();
        b.add(&a);
        assert_eq!(b.rays, 4);
        assert_eq!(b.counters.get(Counter::TraversalSteps).unwrap(), 200);
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
