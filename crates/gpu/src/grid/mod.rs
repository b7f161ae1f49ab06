//! The irregular grid (Pérard-Gayot et al. 2017) on the GPU, the twin of `accel::grid`:
//! [`GpuGrid`] implements [`render::Tracer`] like `accel::GridEngine`, with the same
//! configuration ([`accel::grid::GridConfig`]) and the same counters (N_T traversal steps,
//! N_I triangle tests). The §5 traversal is a WGSL kernel ([`traverse`], `traverse.wgsl`
//! beside `accel/src/grid/traverse.rs`), closest and any hit.
//!
//! The build (§4) still runs on the CPU: `accel::grid::build_grid` makes the cells, the
//! references and the voxel map, which are uploaded once; its passes are reported as the
//! CPU's, with the upload beside them. The build's passes as kernels are not written yet.

pub mod traverse;

use crate::device::{Gpu, GpuError};
use crate::kernels::Kernels;
use accel::grid::{build_grid, BuildStats, Grid, GridConfig};
use render::Phase;
use scene::Geometry;
use std::sync::Mutex;
use std::time::Instant;

/// The grid on the device: what the traversal kernel reads.
pub struct GpuGrid {
    pub(crate) gpu: Gpu,
    pub(crate) kernels: Kernels,
    /// Box min, box max, voxel size, 1 / voxel size (vec4 each).
    pub(crate) consts: wgpu::Buffer,
    pub(crate) map: wgpu::Buffer,
    pub(crate) cells: wgpu::Buffer,
    pub(crate) refs: wgpu::Buffer,
    pub(crate) tris: wgpu::Buffer,
    pub(crate) shift: u32,
    pub(crate) dims: [u32; 3],
    pub(crate) top_dims: [u32; 3],
    /// Most rays per kernel launch (16 bytes each per binding); larger batches go in parts.
    pub(crate) max_rays: usize,
    name: &'static str,
    build: BuildStats,
    compile_seconds: f64,
    upload_seconds: f64,
    /// GPU seconds per phase of the last trace calls (drained by [`crate::GpuEngine::take_times`]).
    pub(crate) times: Mutex<Vec<(Phase, f64)>>,
}

impl GpuGrid {
    /// Build the grid of `cfg` over `geo` on the CPU and upload it (`grid`, or `grid2l` when
    /// `cfg` neither merges nor expands).
    pub fn new(gpu: Gpu, geo: &Geometry, cfg: &GridConfig) -> Result<GpuGrid, GpuError> {
        cfg.validate().map_err(GpuError::Config)?;
        let grid = build_grid(&geo.tris, cfg).map_err(GpuError::Config)?;
        let name = if cfg.merge || cfg.expansion_passes > 0 {
            "grid-gpu"
        } else {
            "grid2l-gpu"
        };
        Self::upload(gpu, &grid, &geo.tris, name)
    }

    /// Upload a grid built on the CPU over `tris` (benchmarks trace the very grid the CPU
    /// engine traces).
    pub fn upload(
        gpu: Gpu,
        grid: &Grid,
        tris: &[[geom::Vec3; 3]],
        name: &'static str,
    ) -> Result<GpuGrid, GpuError> {
        let limit = gpu.max_binding();
        let check = |what: &str, bytes: u64| {
            if bytes > limit {
                Err(GpuError::Limits(format!(
                    "the grid's {what} need {} MiB in one binding; this device allows {} MiB (raise --grid-top-density or lower --grid-leaf-density for fewer references)",
                    bytes.div_ceil(1 << 20),
                    limit >> 20
                )))
            } else {
                Ok(())
            }
        };
        check("references", grid.refs.len() as u64 * 4)?;
        check("cells", grid.cells() as u64 * 32)?;
        check("voxel map entries", grid.entries.len() as u64 * 4)?;
        check("triangles", tris.len() as u64 * 48)?;
        let t0 = Instant::now();
        let kernels = Kernels::new(&gpu);
        let compile_seconds = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let v4 = |v: geom::Vec3| [v.x, v.y, v.z, 0.0];
        let consts = [
            v4(grid.bounds.min),
            v4(grid.bounds.max),
            v4(grid.voxel),
            v4(grid.inv_voxel),
        ];
        let cells: Vec<[u32; 8]> = grid
            .trav
            .iter()
            .map(|c| {
                [
                    c.lo[0], c.lo[1], c.lo[2], c.begin, c.hi[0], c.hi[1], c.hi[2], c.end,
                ]
            })
            .collect();
        let tri4: Vec<[f32; 4]> = tris.iter().flat_map(|t| t.map(v4)).collect();
        let g = GpuGrid {
            consts: gpu.upload("grid constants", &consts),
            map: gpu.upload("voxel map", &grid.entries),
            cells: gpu.upload("grid cells", &cells),
            refs: gpu.upload("grid references", &grid.refs),
            tris: gpu.upload("triangles", &tri4),
            shift: grid.shift,
            dims: grid.dims,
            top_dims: grid.top_dims,
            max_rays: (limit / 16).clamp(1, 1 << 26) as usize,
            name,
            build: grid.build.clone(),
            compile_seconds,
            upload_seconds: 0.0,
            times: Mutex::new(Vec::new()),
            kernels,
            gpu,
        };
        g.gpu
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(GpuGrid {
            upload_seconds: t0.elapsed().as_secs_f64(),
            ..g
        })
    }
}

impl render::Tracer for GpuGrid {
    fn name(&self) -> &str {
        self.name
    }

    fn build_passes(&self) -> Vec<(String, f64)> {
        let mut v: Vec<(String, f64)> = self
            .build
            .passes()
            .iter()
            .map(|(n, t)| (format!("{n} (CPU)"), *t))
            .collect();
        v.push(("kernel compilation".into(), self.compile_seconds));
        v.push(("upload".into(), self.upload_seconds));
        v
    }

    fn trace(
        &self,
        rays: &render::RayBatch,
        mode: render::TraceMode,
        hits: &mut [render::Hit],
        stats: &mut render::TraceStats,
    ) {
        traverse::trace(self, rays, mode, hits, stats);
    }
}
