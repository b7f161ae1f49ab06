//! What CRSH and RAH report: their phases (the thesis's pipeline, §3.2.3–3.2.9, in the
//! frame CSV's column order), their counters, and the functions that put a traversal's
//! counts into [`TraceStats`] (shared with the GPU twin, whose counts are the same).

use crate::traverse::Counters;
use trace::{Counter, LevelCounts, Phase, PhaseKind, TraceStats};

/// CRSH: every ray's hash key (§3.2.3).
pub const HASH: Phase = Phase::new(10, "hash", PhaseKind::Build);
/// Rays that can hit nothing removed (stream compaction, §3.2.3).
pub const TRIM: Phase = Phase::new(20, "trim", PhaseKind::Build);
/// Runs of equal keys into chunks (§3.2.4).
pub const COMPRESS: Phase = Phase::new(30, "compress", PhaseKind::Build);
/// Chunks radix-sorted by key (§3.2.5).
pub const SORT: Phase = Phase::new(40, "sort", PhaseKind::Build);
/// Chunks expanded back to rays in sorted order (§3.2.6).
pub const DECOMPRESS: Phase = Phase::new(50, "decompress", PhaseKind::Build);
/// RAH: rays in screen (pixel Z-) order.
pub const SCREEN_ORDER: Phase = Phase::new(60, "screen order", PhaseKind::Build);
/// Sphere-cone nodes built bottom-up (§3.2.7).
pub const HIERARCHY_CREATION: Phase = Phase::new(70, "hierarchy creation", PhaseKind::Build);
/// Exact ray–triangle tests of the surviving pairs (§3.2.9).
pub const FINAL_TESTS: Phase = Phase::new(90, "final tests", PhaseKind::Trace);

/// Every phase of CRSH and RAH, in pipeline order (the traversal, §3.2.8, is
/// [`trace::TRAVERSAL`]).
pub const PHASES: [Phase; 9] = [
    HASH,
    TRIM,
    COMPRESS,
    SORT,
    DECOMPRESS,
    SCREEN_ORDER,
    HIERARCHY_CREATION,
    trace::TRAVERSAL,
    FINAL_TESTS,
];

/// Levels halved because their pairs exceeded the pair budget.
pub const BUDGET_SPLITS: Counter = Counter::sum("budget splits");
/// Trace calls whose rays went as the ray hierarchy's bundles (with the object tree).
pub const BUNDLED_BATCHES: Counter = Counter::sum("bundled batches");
/// CRSH: runs of equal hashes after trimming (thesis §3.2.3).
pub const CHUNKS: Counter = Counter::sum("chunks");
/// (Top node, mesh) pairs that passed the mesh-sphere test.
pub const MESH_SPHERE_PASSES: Counter = Counter::sum("mesh-sphere passes");
/// Node–mesh-sphere tests at the top level (thesis §3.2.2).
pub const MESH_SPHERE_TESTS: Counter = Counter::sum("mesh-sphere tests");
/// With the object tree: node tests of ray nodes against inner object nodes, a breakdown of
/// the node tests ([`TraceStats::node_tri_tests`], which count them once).
pub const OBJECT_NODE_TESTS: Counter = Counter::sum("object-node tests");
/// With the object tree: the bytes the most waiting pairs took (depth first: one worker's
/// most × the workers, the most they can hold at once).
pub const PEAK_PAIR_BYTES: Counter = Counter::peak("peak pair bytes");
/// With the object tree: the most (ray node, object node) pairs waiting at once.
pub const PEAK_PAIRS: Counter = Counter::peak("peak pairs");
/// Nodes of the top level.
pub const TOP_NODES: Counter = Counter::sum("top nodes");
/// Triangle batches of the top level (RAH's scene batches).
pub const TRIANGLE_BATCHES: Counter = Counter::sum("triangle batches");

/// Every counter CRSH and RAH report (with `trace::RAY_BOX_TESTS` and
/// `accel::bvh::RAY_BOX_PASSES` of the dual traversal's single-ray level).
pub const COUNTERS: [Counter; 10] = [
    BUDGET_SPLITS,
    BUNDLED_BATCHES,
    CHUNKS,
    MESH_SPHERE_PASSES,
    MESH_SPHERE_TESTS,
    OBJECT_NODE_TESTS,
    PEAK_PAIR_BYTES,
    PEAK_PAIRS,
    TOP_NODES,
    TRIANGLE_BATCHES,
];

/// The traversal's counters into `stats` (also used by the GPU backend, whose counters are
/// the same): per level and ray kind, the node tests, the final tests, and the named ones.
pub fn report_counters(c: &Counters, mesh_culling: bool, top_nodes: u64, stats: &mut TraceStats) {
    stats.levels.add(&LevelCounts {
        tests: c.tests.clone(),
        hits: c.hits.clone(),
        final_tests: c.final_tests,
    });
    stats.node_tri_tests += c.tests.iter().flatten().sum::<u64>();
    stats.ray_tri_tests += c.final_tests.iter().sum::<u64>();
    if mesh_culling {
        stats.count(MESH_SPHERE_TESTS, c.mesh_tests);
        stats.count(MESH_SPHERE_PASSES, c.mesh_passes);
    }
    stats.count(TRIANGLE_BATCHES, c.batches);
    stats.count(BUDGET_SPLITS, c.splits);
    stats.count(TOP_NODES, top_nodes);
}

/// The object tree's counters into `stats`: tests of ray nodes against object nodes (in the
/// level tests), and single rays' slab tests against object nodes' boxes (ray–box tests,
/// counted there only).
pub fn object_counters(c: &Counters, stats: &mut TraceStats) {
    stats.count(OBJECT_NODE_TESTS, c.object_tests);
    stats.count(trace::RAY_BOX_TESTS, c.ray_box_tests);
    stats.count(accel::bvh::RAY_BOX_PASSES, c.ray_box_passes);
    stats.count(PEAK_PAIRS, c.peak_pairs);
    stats.count(PEAK_PAIR_BYTES, c.peak_pair_bytes);
}
