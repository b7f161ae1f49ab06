//! What every GPU CRSH/RAH pass reads (`hash`, `order`, `build`, `traverse`): the device
//! and its compiled kernels, the configuration, and the frame's scene in buffers
//! (triangles, their bounding spheres and meshes, the mesh spheres of thesis §3.2.2, the
//! minimal-ball shuffles). [`super::GpuRsh`] owns one and hands it to the passes, so the
//! passes depend on this file and not on the engine's.

use crate::bvh::objects::SceneArrays;
use crate::device::{Gpu, GpuError};
use crate::kernels::Kernels;
use ::rsh::RshConfig;
use geom::Pcg32;
use scene::Geometry;

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

/// The CPU's fixed minimal-ball shuffle (`geom::miniball`) for every count 1..=b, as rows of
/// source indices; row c starts at c·(c−1)/2.
pub(super) fn shuffle_table(b: u32) -> Vec<u32> {
    let mut out = Vec::new();
    for c in 1..=b as usize {
        let mut perm: Vec<u32> = (0..c as u32).collect();
        let mut rng = Pcg32::new(0x6d696e69, 0x62616c6c);
        for i in (1..c).rev() {
            let j = rng.below(i as u32 + 1) as usize;
            perm.swap(i, j);
        }
        out.extend(perm);
    }
    out
}

/// What the engine uploads of one frame's scene (the fields of [`DeviceScene`] of the
/// same names, and the most rays one hierarchy takes).
#[allow(missing_docs)]
pub(super) struct SceneBuffers {
    pub tris: wgpu::Buffer,
    pub tri_sphere: wgpu::Buffer,
    pub tri_mesh: wgpu::Buffer,
    pub mesh_sphere: wgpu::Buffer,
    pub mesh_first: Vec<u32>,
    pub ntri: u32,
    pub box_min: [f32; 3],
    pub box_ext: [f32; 3],
    pub diag: f32,
    pub max_rays: usize,
}

impl SceneBuffers {
    /// Upload `geo`'s arrays; fails where its triangles pass one binding.
    pub fn new(gpu: &Gpu, geo: &Geometry, cfg: &RshConfig) -> Result<SceneBuffers, GpuError> {
        let ntri = geo.tris.len();
        let max_tris = gpu.max_binding() / 48;
        if ntri as u64 > max_tris {
            return Err(GpuError::Limits(format!(
                "{ntri} triangles exceed one binding ({max_tris} at most)"
            )));
        }
        let a = SceneArrays::of(geo);
        let nm = geo.mesh_first.len() - 1;
        let ext = geo.bounds.extent().max(geom::Vec3::splat(1e-30));
        let b = geo.bounds.min;
        // Rays: 16 bytes of origin and of direction per ray in one binding. The top level has
        // at most ⌈rays / b⌉ + 3 nodes, and its node × mesh pass bits must fit one binding
        // too (and index in u32); a larger batch is traced in parts.
        let bit_entries = (gpu.max_binding() * 8).min(1 << 31);
        let by_pass = (bit_entries / nm.max(1) as u64).saturating_sub(4) * cfg.branching as u64;
        let max_rays = (gpu.max_binding() / 16).min(1 << 26).min(by_pass).max(1) as usize;
        Ok(SceneBuffers {
            tris: gpu.upload("triangles", &a.tris),
            tri_sphere: gpu.upload("triangle spheres", &a.spheres),
            tri_mesh: gpu.upload("triangle meshes", &a.tri_mesh),
            mesh_sphere: gpu.upload("mesh spheres", &a.meshes),
            mesh_first: geo.mesh_first.clone(),
            ntri: ntri as u32,
            box_min: [b.x, b.y, b.z],
            box_ext: [ext.x, ext.y, ext.z],
            diag: geo.bounds.diagonal(),
            max_rays,
        })
    }
}
