//! The `bvh` engine on the GPU, the twin of `crates/accel/src/bvh/mod.rs`: the object tree
//! built on the device every frame ([`objects`]: Karras's LBVH, the device's builder) and
//! walked by single rays, one thread each ([`single`]); no ray hierarchy. [`GpuBvh`] is a
//! [`trace::Tracer`] with the CPU engine's counters, so hits and counts are compared with
//! it on the same rays (the CPU engine with `RayPath::Single` and the LBVH builder). Packets
//! are the CPU's way of walking neighbouring rays side by side in vector lanes, which a
//! device's threads do on their own, so the device walks every batch as single rays.

pub mod objects;
pub mod single;

use crate::device::{Gpu, GpuError};
use crate::kernels::{DevSize, Exec, Kernels};
use crate::rays::{records_to_hits, DeviceRays};
use accel::bvh::{BvhConfig, ObjectBuilder, RayPath};
use objects::{DeviceTree, SceneArrays, TreeInput};
use scene::Geometry;
use std::sync::Mutex;
use trace::{Hit, OptionError, Phase, RayBatch, TraceMode, TraceStats, Tracer};

/// The GPU engine: the scene's triangles and the tree on the device.
pub struct GpuBvh {
    gpu: Gpu,
    kernels: std::sync::Arc<Kernels>,
    cfg: BvhConfig,
    /// Triangles as 3 × vec4 (the rasterizer draws from them too).
    tris: wgpu::Buffer,
    /// Triangles.
    ntri: u32,
    /// The tree and its build's seconds (kernels submitted and waited for).
    tree: (DeviceTree, f64),
    /// Most rays one walk takes (one binding of origins or directions).
    max_rays: usize,
    /// Stack entries a ray's walk may use in private memory ([`single::STACK`]).
    stack: u32,
    /// The second pass's stacks ([`single::deep_stacks`]).
    deep: wgpu::Buffer,
    /// GPU seconds per phase of the last trace calls (drained by `take_times`).
    times: Mutex<Vec<(Phase, f64)>>,
    /// Counter blocks of walks in a frame not yet read ([`crate::GpuEngine::settle`]).
    pending: Mutex<Vec<wgpu::Buffer>>,
}

impl GpuBvh {
    /// Upload the scene and build its tree on the device. The device builds the LBVH and
    /// walks single rays only: another builder or path is refused, naming the option.
    pub fn new(gpu: Gpu, geo: &Geometry, cfg: BvhConfig) -> Result<GpuBvh, GpuError> {
        lbvh_only(cfg.builder)?;
        if cfg.path != RayPath::Single {
            return Err(OptionError::new(
                "ray_path",
                cfg.path.name(),
                "the GPU backend walks single rays only",
            )
            .into());
        }
        let kernels = gpu.kernels();
        let deep = single::deep_stacks(&gpu);
        let (tris, ntri, tree) = Self::upload(&gpu, &kernels, geo)?;
        Ok(GpuBvh {
            max_rays: (gpu.max_binding() / 16).clamp(1, 1 << 26) as usize,
            gpu,
            kernels,
            cfg,
            tris,
            ntri,
            tree,
            stack: single::STACK,
            deep,
            times: Mutex::new(Vec::new()),
            pending: Mutex::new(Vec::new()),
        })
    }

    /// Tests only (public for the device tests): a ray's walk may use at most `entries`
    /// stack entries on the device, so that walks overflow into the second pass.
    #[doc(hidden)]
    pub fn with_stack(mut self, entries: u32) -> GpuBvh {
        self.stack = entries.clamp(1, single::STACK);
        self
    }

    /// `geo`'s triangles uploaded and their tree built (the triangle spheres and meshes the
    /// build reads are dropped after it).
    fn upload(
        gpu: &Gpu,
        kernels: &Kernels,
        geo: &Geometry,
    ) -> Result<(wgpu::Buffer, u32, (DeviceTree, f64)), GpuError> {
        let n = geo.tris.len();
        let max_tris = gpu.max_binding() / 48;
        if n as u64 > max_tris {
            return Err(GpuError::Limits(format!(
                "{n} triangles exceed one binding ({max_tris} at most)"
            )));
        }
        if n >= accel::bvh::objects::LEAF as usize {
            return Err(GpuError::Limits(format!(
                "{n} triangles exceed the object tree's 2^31"
            )));
        }
        let a = SceneArrays::of(geo);
        let tris = gpu.upload("triangles", &a.tris);
        let spheres = gpu.upload("triangle spheres", &a.spheres);
        let tri_mesh = gpu.upload("triangle meshes", &a.tri_mesh);
        let mut ex = Exec::new(gpu, kernels);
        ex.finish();
        let t0 = std::time::Instant::now();
        let inp = TreeInput {
            tris: &tris,
            tri_sphere: &spheres,
            tri_mesh: &tri_mesh,
            mesh_sphere: None,
            mesh_first: &geo.mesh_first,
            single: true,
        };
        let tree = objects::build(&mut ex, &inp, n as u32);
        ex.finish();
        Ok((tris, n as u32, (tree, t0.elapsed().as_secs_f64())))
    }

    /// The scene of a dynamic scene's next frame: its triangles uploaded and its tree built
    /// on the device; the device, kernels and configuration stay.
    pub fn rebuild(&mut self, geo: &Geometry) -> Result<(), GpuError> {
        let (tris, ntri, tree) = Self::upload(&self.gpu, &self.kernels, geo)?;
        self.tris = tris;
        self.ntri = ntri;
        self.tree = tree;
        Ok(())
    }

    /// The configuration.
    pub fn config(&self) -> &BvhConfig {
        &self.cfg
    }

    /// Walk rays `dr` (of the first `count.n` only, where given) on the device; the records
    /// stay there, the counter block too (`single::Walked`).
    fn walk(
        &self,
        ex: &mut Exec,
        dr: &DeviceRays,
        mode: TraceMode,
        stats: &mut TraceStats,
        count: Option<&DevSize>,
    ) -> single::Walked {
        ex.phase(trace::TRAVERSAL);
        let w = single::walk(
            ex,
            &self.tree.0,
            dr,
            mode == TraceMode::Any,
            self.stack,
            &self.deep,
            count,
        );
        stats.count(accel::bvh::SINGLE_RAY_BATCHES, 1);
        stats.count(accel::bvh::PACKET_BATCHES, 0);
        w
    }

    /// A walk's counter block's words into `stats`, as the CPU engine reports them.
    fn settle_walk(head: &[u32], stats: &mut TraceStats) {
        let (c, deep) = single::counts_of(head);
        stats.count(crate::stats::STACK_OVERFLOWS, deep);
        accel::bvh::report(&c, stats);
    }

    /// Rays of one binding traced: the walk, then the records and the counters in one
    /// read-back.
    fn trace_part(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], st: &mut TraceStats) {
        let n = rays.len();
        let g = &self.gpu;
        let mut ex = Exec::new(g, &self.kernels);
        let dr = DeviceRays::upload(g, rays);
        let w = self.walk(&mut ex, &dr, mode, st, None);
        ex.phase(crate::stats::READ_BACK);
        let (head, bytes) = (single::HEAD as u64 * 4, n as u64 * 16);
        let both = g.storage("records and counters", bytes + head);
        ex.copy(&w.rec, 0, &both, bytes);
        ex.copy_at(&w.cnt, 0, &both, bytes, head);
        let words: Vec<u32> = ex.read(&both, 4 * n + single::HEAD);
        records_to_hits(bytemuck::cast_slice(&words[..4 * n]), hits);
        Self::settle_walk(&words[4 * n..], st);
        ex.report(st, &self.times);
    }

    /// Rays `dr` walked on the device (of the first `count.n` only, where given): nothing
    /// is read back; the counter block waits for the frame's end (`GpuEngine::settle`).
    fn trace_on_device(
        &self,
        dr: &DeviceRays,
        mode: TraceMode,
        stats: &mut TraceStats,
        count: Option<&DevSize>,
    ) -> wgpu::Buffer {
        let mut ex = Exec::new(&self.gpu, &self.kernels);
        let w = self.walk(&mut ex, dr, mode, stats, count);
        self.pending.lock().unwrap().push(w.cnt);
        ex.report(stats, &self.times);
        w.rec
    }
}

/// The device builds the LBVH only (`bvh`'s tree and the dual traversal's): another builder
/// is refused, naming the option.
pub(crate) fn lbvh_only(builder: ObjectBuilder) -> Result<(), GpuError> {
    if builder == ObjectBuilder::Lbvh {
        return Ok(());
    }
    Err(OptionError::new(
        "object_builder",
        "sah",
        "the GPU backend builds the LBVH only",
    )
    .into())
}

impl Tracer for GpuBvh {
    fn name(&self) -> &str {
        "bvh-gpu"
    }

    fn build_passes(&self) -> Vec<trace::PassTime> {
        vec![trace::PassTime::new(
            accel::bvh::OBJECT_HIERARCHY,
            self.tree.1,
        )]
    }

    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        assert_eq!(hits.len(), rays.len(), "one hit record per ray");
        stats.rays += rays.len() as u64;
        if rays.is_empty() {
            return;
        }
        if self.ntri == 0 {
            hits.iter_mut().for_each(|h| *h = Hit::MISS);
            return;
        }
        for (p, out) in hits.chunks_mut(self.max_rays).enumerate() {
            let lo = p * self.max_rays;
            let part = rays.slice(lo..lo + out.len());
            self.trace_part(&part, mode, out, stats);
        }
    }
}

impl crate::GpuEngine for GpuBvh {
    fn gpu(&self) -> &Gpu {
        &self.gpu
    }
    fn kernels(&self) -> &Kernels {
        &self.kernels
    }
    fn take_times(&self) -> Vec<(Phase, f64)> {
        std::mem::take(&mut *self.times.lock().unwrap())
    }
    fn rebuild(&mut self, geo: &Geometry) -> Result<(), GpuError> {
        GpuBvh::rebuild(self, geo)
    }
    fn max_rays(&self) -> usize {
        self.max_rays
    }
    fn triangles(&self) -> &wgpu::Buffer {
        &self.tris
    }
    fn trace_device_part(
        &self,
        rays: &DeviceRays,
        mode: TraceMode,
        stats: &mut TraceStats,
    ) -> wgpu::Buffer {
        self.trace_on_device(rays, mode, stats, None)
    }
    fn counts_on_device(&self) -> bool {
        true
    }
    fn trace_device_counted(
        &self,
        rays: &DeviceRays,
        count: &DevSize,
        mode: TraceMode,
        stats: &mut TraceStats,
    ) -> Option<wgpu::Buffer> {
        Some(self.trace_on_device(rays, mode, stats, Some(count)))
    }
    fn take_pending(&self) -> Vec<(wgpu::Buffer, u64)> {
        std::mem::take(&mut *self.pending.lock().unwrap())
            .into_iter()
            .map(|b| (b, single::HEAD as u64))
            .collect()
    }
    fn settle(&self, words: &[u32], stats: &mut TraceStats) {
        for head in words.chunks_exact(single::HEAD) {
            Self::settle_walk(head, stats);
        }
    }
}
