//! What every GPU CRSH/RAH pass reads (`hash`, `order`, `build`, `traverse`): the device
//! and its compiled kernels, the configuration, and the frame's scene in buffers
//! (triangles, their bounding spheres and meshes, the mesh spheres of thesis §3.2.2, the
//! minimal-ball shuffles). [`super::GpuRsh`] owns one and hands it to the passes, so the
//! passes depend on this file and not on the engine's.

use crate::device::Gpu;
use crate::kernels::Kernels;
use ::rsh::RshConfig;
use geom::Sphere;

/// The engine's device-side state, as the passes read it.
pub struct DeviceScene {
    /// The device.
    pub gpu: Gpu,
    /// The device's compiled kernels ([`crate::Gpu::kernels`]).
    pub kernels: std::sync::Arc<Kernels>,
    /// The configuration (validated).
    pub cfg: RshConfig,
    /// Triangles.
    pub ntri: u32,
    /// Triangles as 3 × vec4.
    pub tris: wgpu::Buffer,
    /// Per-triangle bounding spheres (centre, radius).
    pub tri_sphere: wgpu::Buffer,
    /// Each triangle's mesh.
    pub tri_mesh: wgpu::Buffer,
    /// Per-mesh bounding spheres (thesis §3.2.2).
    pub mesh_sphere: wgpu::Buffer,
    /// First triangle of each mesh, and one past the last.
    pub mesh_first: Vec<u32>,
    /// The CPU's minimal-ball shuffle rows (`geom::miniball`).
    pub shuffles: wgpu::Buffer,
    /// The scene box's minimum corner (the hash's origin quantisation).
    pub box_min: [f32; 3],
    /// The scene box's extent.
    pub box_ext: [f32; 3],
    /// The scene box's diagonal (the dual traversal's cap on unbounded rays).
    pub diag: f32,
}

/// The scene's per-triangle and per-mesh arrays in the layouts the kernels read: triangles
/// (3 × vec4), their spheres and the mesh spheres (centre, radius), each triangle's mesh.
pub(crate) struct SceneArrays {
    pub tris: Vec<[f32; 4]>,
    pub spheres: Vec<[f32; 4]>,
    pub tri_mesh: Vec<u32>,
    pub meshes: Vec<[f32; 4]>,
}

impl SceneArrays {
    pub fn of(geo: &scene::Geometry) -> SceneArrays {
        let v4 = |s: &Sphere| [s.center.x, s.center.y, s.center.z, s.radius];
        let nm = geo.mesh_first.len().saturating_sub(1);
        let mut tri_mesh = vec![0u32; geo.tris.len()];
        for m in 0..nm {
            for t in geo.mesh_first[m]..geo.mesh_first[m + 1] {
                tri_mesh[t as usize] = m as u32;
            }
        }
        SceneArrays {
            tris: geo
                .tris
                .iter()
                .flat_map(|t| t.map(|v| [v.x, v.y, v.z, 0.0]))
                .collect(),
            spheres: geo
                .tris
                .iter()
                .map(|t| v4(&Sphere::of_triangle(t[0], t[1], t[2])))
                .collect(),
            tri_mesh,
            meshes: geo.mesh_sphere.iter().map(v4).collect(),
        }
    }
}
