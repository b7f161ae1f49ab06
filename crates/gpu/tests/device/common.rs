//! Helpers shared by the GPU integration tests.

use accel::grid::GridEngine;
use rsh::{ObjectBuilder, ObjectHierarchy, RayPath, RshConfig};
use scene::Geometry;

/// CRSH as the GPU runs it by default: single rays through the object tree (LBVH).
pub fn crsh_single() -> RshConfig {
    RshConfig {
        objects: ObjectHierarchy::Bvh,
        path: RayPath::Single,
        builder: ObjectBuilder::Lbvh,
        ..RshConfig::crsh()
    }
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
