//! Helpers shared by the GPU integration tests.

use accel::bvh::{BvhConfig, RayPath};
use accel::grid::GridEngine;
use rsh::{ObjectBuilder, ObjectHierarchy, RshConfig, Schedule};
use scene::Geometry;

/// The `bvh` engine as the GPU runs it: single rays through the LBVH.
pub fn bvh_single() -> BvhConfig {
    BvhConfig {
        builder: ObjectBuilder::Lbvh,
        path: RayPath::Single,
    }
}

/// CRSH as the thesis runs it: every triangle pushed down the ray hierarchy behind the
/// per-mesh spheres.
pub fn crsh_spheres() -> RshConfig {
    RshConfig {
        objects: ObjectHierarchy::MeshSpheres,
        ..RshConfig::crsh()
    }
}

/// RAH behind no spheres (its own default), every triangle pushed down its pyramid.
pub fn rah_spheres() -> RshConfig {
    RshConfig {
        objects: ObjectHierarchy::MeshSpheres,
        ..RshConfig::rah()
    }
}

/// CRSH's bundles and the object tree (LBVH) descended together, level by level: the dual
/// traversal the GPU runs.
pub fn crsh_dual() -> RshConfig {
    RshConfig {
        objects: ObjectHierarchy::Bvh,
        builder: ObjectBuilder::Lbvh,
        schedule: Schedule::Breadth,
        ..RshConfig::crsh()
    }
}

/// RAH's screen-space bundles with the object tree, level by level.
pub fn rah_dual() -> RshConfig {
    RshConfig {
        objects: ObjectHierarchy::Bvh,
        builder: ObjectBuilder::Lbvh,
        schedule: Schedule::Breadth,
        ..RshConfig::rah()
    }
}

/// Traces `rays` on the CPU engine and on its GPU twin: every hit record and every
/// comparable counter must be equal. Returns both stats (CPU, GPU).
pub fn compare_traces(
    cpu: &dyn trace::Tracer,
    gpu: &dyn trace::Tracer,
    rays: &trace::RayBatch,
    mode: trace::TraceMode,
    what: &str,
) -> (trace::TraceStats, trace::TraceStats) {
    use trace::{Hit, TraceStats};
    let (mut hc, mut hg) = (vec![Hit::MISS; rays.len()], vec![Hit::MISS; rays.len()]);
    let (mut sc, mut sg) = (TraceStats::default(), TraceStats::default());
    cpu.trace(rays, mode, &mut hc, &mut sc);
    gpu.trace(rays, mode, &mut hg, &mut sg);
    for i in 0..rays.len() {
        assert_eq!(hg[i], hc[i], "{what}: ray {i} ({mode:?}) GPU vs CPU");
    }
    let counters = gpu::rsh::engine::comparable_counters;
    assert_eq!(counters(&sg), counters(&sc), "{what}: counters ({mode:?})");
    (sc, sg)
}

/// Dabrovic Sponza from the shared scenes, or `None` (said: `SKIPPED`, or a failure where
/// the scenes are required) when they are absent.
pub fn sponza() -> Option<scene::Scene> {
    let dir = testkit::scenes()?;
    let path = dir.join("dabrovic-sponza/sponza.obj");
    if !path.exists() {
        testkit::skip("scenes", format!("{} not present", path.display()));
        return None;
    }
    Some(scene::load(path.to_str().unwrap(), &Default::default()).unwrap())
}

/// A binding just large enough for `cpu`'s grid over `geo`: its largest array (references,
/// cell records, voxel map, triangles), to the next power of two.
pub fn tight_binding(cpu: &GridEngine, geo: &Geometry) -> u64 {
    let gr = &cpu.grid;
    [
        gr.refs.len() * 4,
        gr.cells() * 32,
        gr.entries.len() * 4,
        geo.len() * 48,
    ]
    .into_iter()
    .max()
    .unwrap()
    .next_power_of_two() as u64
}
