//! The irregular grid (Pérard-Gayot et al. 2017) on the GPU, the twin of `accel::grid`:
//! [`GpuGrid`] implements [`trace::Tracer`] like `accel::GridEngine`, with the same
//! configuration ([`accel::grid::GridConfig`]) and the same counters (N_T traversal steps,
//! N_I triangle tests). The §5 traversal is a WGSL kernel ([`traverse`], `traverse.wgsl`
//! beside `accel/src/grid/traverse.rs`), closest and any hit.
//!
//! The build (§4) follows `accel::grid::PASSES`; [`PASS_DEVICE`] says where each runs. The
//! top-level references and the octrees ([`build`], `build.wgsl` beside
//! `accel/src/grid/build.rs`) and the cells with their voxel map ([`voxelmap`],
//! `voxelmap.wgsl` beside `accel/src/grid/voxelmap.rs`), SAH merging ([`merge`]) and
//! expansion ([`expand`]) are kernels whose results equal the CPU's bit for bit; the grid
//! never leaves the device ([`DeviceGrid`]): the host reads only the totals that size the
//! next buffers, and the traversal reads the build's buffers. Every pass is reported with
//! where it ran ([`GpuGrid::upload`] traces a CPU-built grid instead, for benchmarks).

pub mod build;
pub mod expand;
pub mod merge;
pub mod traverse;
pub mod voxelmap;

use crate::device::{Gpu, GpuError};
use crate::kernels::Kernels;
use accel::grid::{BuildStats, Grid, GridConfig};
use scene::Geometry;
use std::sync::Mutex;
use std::time::Instant;
use trace::{BuildPass, Device, PassTime, Phase};

/// Where [`GpuGrid::new`] runs each pass of `accel::grid::PASSES`, in the same order (a test
/// checks the passes, so a pass added to the CPU build must be placed here): as WGSL kernels
/// ([`Device::Gpu`]) or as the CPU pass of `accel::grid` on read-back data.
pub const PASS_DEVICE: [(BuildPass, Device); 5] = [
    (accel::grid::PASSES[0], Device::Gpu),
    (accel::grid::PASSES[1], Device::Gpu),
    (accel::grid::PASSES[2], Device::Gpu),
    (accel::grid::PASSES[3], Device::Gpu),
    (accel::grid::PASSES[4], Device::Gpu),
];

/// A grid being built on the device: its cells, references and voxel map in buffers, and
/// its frame (box, resolutions, voxel size, build statistics) on the host.
pub struct DeviceGrid {
    /// The frame, as a [`Grid`] whose per-cell arrays are empty.
    pub frame: Grid,
    /// The voxel map.
    pub entries: wgpu::Buffer,
    /// Its entries.
    pub nentries: u64,
    /// Cells' footprints on the virtual grid, min corners (`vec4<u32>`) …
    pub cell_min: wgpu::Buffer,
    /// … and max corners (exclusive).
    pub cell_max: wgpu::Buffer,
    /// Expanded exit boxes, min corners (`vec4<u32>`) …
    pub exp_min: wgpu::Buffer,
    /// … and max corners.
    pub exp_max: wgpu::Buffer,
    /// Cells.
    pub ncells: u64,
    /// Each cell's first reference (cells + 1 entries).
    pub ref_first: wgpu::Buffer,
    /// The references.
    pub refs: wgpu::Buffer,
    /// References.
    pub nrefs: u64,
}

impl DeviceGrid {
    /// The grid read back (tests compare it with the CPU's).
    pub fn read(&self, g: &Gpu, k: &Kernels) -> Grid {
        let mut ex = crate::kernels::Exec::new(g, k);
        let n = self.ncells as usize;
        let mut v3 = |b: &wgpu::Buffer| -> Vec<[u32; 3]> {
            ex.read::<[u32; 4]>(b, n)
                .iter()
                .map(|c| [c[0], c[1], c[2]])
                .collect()
        };
        let (cell_min, cell_max) = (v3(&self.cell_min), v3(&self.cell_max));
        let (exp_min, exp_max) = (v3(&self.exp_min), v3(&self.exp_max));
        Grid {
            cell_min,
            cell_max,
            exp_min,
            exp_max,
            ref_first: ex.read(&self.ref_first, n + 1),
            refs: ex.read(&self.refs, self.nrefs as usize),
            entries: ex.read(&self.entries, self.nentries as usize),
            ..self.frame.clone()
        }
    }
}

/// The grid on the device: what the traversal kernel reads.
pub struct GpuGrid {
    pub(crate) gpu: Gpu,
    pub(crate) kernels: std::sync::Arc<Kernels>,
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
    /// The configuration a GPU-built grid is rebuilt with (none for an uploaded grid).
    cfg: Option<GridConfig>,
    compile_seconds: f64,
    upload_seconds: f64,
    /// Built by [`GpuGrid::new`] (the passes of [`PASS_DEVICE`] on the GPU), not uploaded.
    built_on_gpu: bool,
    /// GPU seconds per phase of the last trace calls (drained by [`crate::GpuEngine::take_times`]).
    pub(crate) times: Mutex<Vec<(Phase, f64)>>,
    /// Totals of traces on the device not yet read ([`crate::GpuEngine::settle`]).
    pub(crate) pending: Mutex<Vec<(wgpu::Buffer, u64)>>,
}

impl GpuGrid {
    /// Build the grid of `cfg` over `geo` with kernels ([`build_on_device`]) and trace the
    /// buffers it built (`grid`, or `grid2l` when `cfg` neither merges nor expands).
    pub fn new(gpu: Gpu, geo: &Geometry, cfg: &GridConfig) -> Result<GpuGrid, GpuError> {
        cfg.validate()?;
        let name = if cfg.merge || cfg.expansion_passes > 0 {
            "grid-gpu"
        } else {
            "grid2l-gpu"
        };
        let t0 = Instant::now();
        let kernels = gpu.kernels();
        let compile_seconds = t0.elapsed().as_secs_f64();
        let b = Built::new(&gpu, &kernels, geo, cfg)?;
        Ok(GpuGrid {
            consts: b.consts,
            map: b.map,
            cells: b.cells,
            refs: b.refs,
            tris: b.tris,
            shift: b.frame.shift,
            dims: b.frame.dims,
            top_dims: b.frame.top_dims,
            max_rays: (gpu.max_binding() / 16).clamp(1, 1 << 26) as usize,
            name,
            build: b.frame.build,
            cfg: Some(cfg.clone()),
            compile_seconds,
            upload_seconds: 0.0,
            built_on_gpu: true,
            times: Mutex::new(Vec::new()),
            pending: Mutex::new(Vec::new()),
            kernels,
            gpu,
        })
    }

    /// Rebuild the grid over `geo` (a dynamic scene's next frame) with the same device,
    /// kernels and configuration: the triangles uploaded once, every pass run again on the
    /// device. A grid made by [`GpuGrid::upload`] has no configuration to rebuild with.
    pub fn rebuild(&mut self, geo: &Geometry) -> Result<(), GpuError> {
        let Some(cfg) = self.cfg.clone() else {
            return Err(GpuError::Unsupported(
                "a grid uploaded from the CPU cannot be rebuilt on the GPU",
            ));
        };
        let b = Built::new(&self.gpu, &self.kernels, geo, &cfg)?;
        self.consts = b.consts;
        self.map = b.map;
        self.cells = b.cells;
        self.refs = b.refs;
        self.tris = b.tris;
        self.shift = b.frame.shift;
        self.dims = b.frame.dims;
        self.top_dims = b.frame.top_dims;
        self.build = b.frame.build;
        self.compile_seconds = 0.0;
        Ok(())
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
        let check = binding_check(&gpu);
        check("references", grid.refs.len() as u64 * 4)?;
        check("cells", grid.cells() as u64 * 32)?;
        check("voxel map entries", grid.entries.len() as u64 * 4)?;
        check("triangles", tris.len() as u64 * 48)?;
        let t0 = Instant::now();
        let kernels = gpu.kernels();
        let compile_seconds = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let cells: Vec<[u32; 8]> = grid
            .trav
            .iter()
            .map(|c| {
                [
                    c.lo[0], c.lo[1], c.lo[2], c.begin, c.hi[0], c.hi[1], c.hi[2], c.end,
                ]
            })
            .collect();
        let g = GpuGrid {
            consts: upload_consts(&gpu, grid),
            map: gpu.upload("voxel map", &grid.entries),
            cells: gpu.upload("grid cells", &cells),
            refs: gpu.upload("grid references", &grid.refs),
            tris: gpu.upload("triangles", &tri4(tris)),
            shift: grid.shift,
            dims: grid.dims,
            top_dims: grid.top_dims,
            max_rays: (limit / 16).clamp(1, 1 << 26) as usize,
            name,
            build: grid.build.clone(),
            cfg: None,
            compile_seconds,
            upload_seconds: 0.0,
            built_on_gpu: false,
            times: Mutex::new(Vec::new()),
            pending: Mutex::new(Vec::new()),
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

/// What one build on the device leaves for traversal.
struct Built {
    consts: wgpu::Buffer,
    map: wgpu::Buffer,
    cells: wgpu::Buffer,
    refs: wgpu::Buffer,
    tris: wgpu::Buffer,
    frame: Grid,
}

impl Built {
    /// Upload `geo`'s triangles (the frame's one upload of geometry) and build over them.
    fn new(
        gpu: &Gpu,
        kernels: &Kernels,
        geo: &Geometry,
        cfg: &GridConfig,
    ) -> Result<Built, GpuError> {
        binding_check(gpu)("triangles", geo.tris.len() as u64 * 48)?;
        let tris = gpu.upload("triangles", &tri4(&geo.tris));
        let d = build_on_device(gpu, kernels, &tris, geo.tris.len(), cfg)?;
        let check = binding_check(gpu);
        check("references", d.nrefs * 4)?;
        check("cells", d.ncells * 32)?;
        check("voxel map entries", d.nentries * 4)?;
        let cells = expand::records(gpu, kernels, &d);
        Ok(Built {
            consts: upload_consts(gpu, &d.frame),
            map: d.entries,
            cells,
            refs: d.refs,
            tris,
            frame: d.frame,
        })
    }
}

/// The traversal's grid constants: box min, box max, voxel size, 1 / voxel size (vec4 each).
fn upload_consts(gpu: &Gpu, g: &Grid) -> wgpu::Buffer {
    let v4 = |v: geom::Vec3| [v.x, v.y, v.z, 0.0];
    let consts = [
        v4(g.bounds.min),
        v4(g.bounds.max),
        v4(g.voxel),
        v4(g.inv_voxel),
    ];
    gpu.upload("grid constants", &consts)
}

/// The check of one binding's size against the device's limit, naming what needs it.
fn binding_check(gpu: &Gpu) -> impl Fn(&str, u64) -> Result<(), GpuError> {
    let limit = gpu.max_binding();
    move |what: &str, bytes: u64| {
        if bytes > limit {
            Err(GpuError::Limits(format!(
                "the grid's {what} need {} MiB in one binding; this device allows {} MiB (raise `grid_top_density` or lower `grid_leaf_density` for fewer references)",
                bytes.div_ceil(1 << 20),
                limit >> 20
            )))
        } else {
            Ok(())
        }
    }
}

/// Build the grid of `cfg` over the `ntris` triangles in `tris` (3 × vec4 each) with the
/// passes of `accel::grid::PASSES`, every one as kernels; each pass's wall-clock time (with
/// its totals' read-backs and a wait at its end) goes into the frame's build statistics.
pub fn build_on_device(
    gpu: &Gpu,
    kernels: &Kernels,
    tris: &wgpu::Buffer,
    ntris: usize,
    cfg: &GridConfig,
) -> Result<DeviceGrid, GpuError> {
    let (st, oct, [top_refs_seconds, octree_seconds]) =
        build::subdivide_on_device(gpu, kernels, tris, ntris, cfg)?;
    let t0 = Instant::now();
    let mut d = voxelmap::finish(gpu, kernels, &st, &oct)?;
    drop(oct);
    let b = &mut d.frame.build;
    b.voxel_map_seconds = t0.elapsed().as_secs_f64();
    b.top_refs_seconds = top_refs_seconds;
    b.octree_seconds = octree_seconds;
    if cfg.merge {
        let t0 = Instant::now();
        let rounds = merge::merge(
            gpu,
            kernels,
            &mut d,
            cfg.alpha,
            cfg.empty_only,
            cfg.merge_rule,
        );
        d.frame.build.merge_rounds = rounds;
        d.frame.build.merge_seconds = t0.elapsed().as_secs_f64();
    }
    if cfg.expansion_passes > 0 {
        let t0 = Instant::now();
        expand::expand(gpu, kernels, &mut d, cfg.expansion_passes, cfg.empty_only);
        d.frame.build.expand_seconds = t0.elapsed().as_secs_f64();
    }
    Ok(d)
}

/// Triangles as the kernels read them: 3 × vec4 each.
fn tri4(tris: &[[geom::Vec3; 3]]) -> Vec<[f32; 4]> {
    tris.iter()
        .flat_map(|t| t.map(|v| [v.x, v.y, v.z, 0.0]))
        .collect()
}

impl trace::Tracer for GpuGrid {
    fn name(&self) -> &str {
        self.name
    }

    fn build_passes(&self) -> Vec<PassTime> {
        let mut v: Vec<PassTime> = self
            .build
            .passes()
            .iter()
            .zip(PASS_DEVICE)
            .map(|(p, (_, d))| {
                let on = match (self.built_on_gpu, d) {
                    (true, Device::Gpu) => Device::Gpu,
                    _ => Device::Cpu,
                };
                PassTime::on(p.pass, on, p.seconds)
            })
            .collect();
        v.push(PassTime::new(
            crate::stats::KERNEL_COMPILATION,
            self.compile_seconds,
        ));
        if !self.built_on_gpu {
            v.push(PassTime::new(
                crate::stats::UPLOAD_PASS,
                self.upload_seconds,
            ));
        }
        v
    }

    fn trace(
        &self,
        rays: &trace::RayBatch,
        mode: trace::TraceMode,
        hits: &mut [trace::Hit],
        stats: &mut trace::TraceStats,
    ) {
        traverse::trace(self, rays, mode, hits, stats);
    }
}
