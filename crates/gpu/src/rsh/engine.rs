//! CRSH and RAH on the GPU, the twin of `crates/rsh/src/engine.rs`: [`GpuRsh`] implements
//! [`trace::Tracer`] with the same configuration ([`::rsh::RshConfig`]), the same phases and
//! the same counters as [`::rsh::RshEngine`], every step a WGSL kernel. Per trace call:
//! upload the rays, order them ([`super::order`]), build the hierarchy ([`super::build`]),
//! traverse it with the final tests ([`super::traverse`]; with the object tree built on
//! the device ([`crate::bvh::objects`]), the dual traversal, [`super::dual`]), then
//! recompute the records and read them back.
//! The host only sequences the kernels, reads back the few totals that size the next
//! buffers (as a CUDA/CUB version would), and mirrors the CPU's batching decisions
//! (triangle batches, budget splits), so the pair streams, and therefore all counters, are
//! the CPU's. In a frame, the bundles through the object tree read nothing back: the
//! trimmed rays' count and kinds (and CRSH's runs) stay on the device
//! ([`super::order::leaf_order_laid`]), which lays the hierarchy's levels out
//! ([`super::build::build_laid`]) and paces the dual traversal alone; whether it finished
//! comes back with the frame's image, and a frame whose trace did not is traced again with
//! the host pacing ([`crate::frame::render_frame`]).

use super::build::{build, build_laid, laid_caps};
use super::device_scene::{shuffle_table, DeviceScene, SceneBuffers};
use super::dual::{rounds_cap, GpuDual};
use super::order::{leaf_order, leaf_order_laid};
use super::traverse::GpuTraversal;
use crate::bvh::objects::{self, DeviceTree, TreeInput};
use crate::device::{Gpu, GpuError};
use crate::kernels::params::RecordsParams;
use crate::kernels::{launch, DevSize, Exec, Kernels};
use crate::rays::{records_to_hits, DeviceRays};
use ::rsh::traverse::Counters;
use ::rsh::{HashKind, Method, ObjectHierarchy, RshConfig, Schedule};
use scene::Geometry;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use trace::OptionError;
use trace::{Hit, Phase, RayBatch, TraceMode, TraceStats, Tracer};

/// The GPU engine. Scene data is uploaded once; each trace call builds its hierarchy.
pub struct GpuRsh {
    /// What the passes read: the device, kernels, configuration and scene buffers.
    s: DeviceScene,
    /// Most rays per hierarchy, from the binding limit (a larger batch is traced in parts).
    max_rays: usize,
    /// GPU seconds per phase of the last trace calls (drained by [`GpuRsh::take_times`]).
    times: Mutex<Vec<(Phase, f64)>>,
    /// With [`ObjectHierarchy::Bvh`]: the object tree on the device.
    tree: Option<TreeState>,
    /// The dual traversal's device rounds: rounds per level of a pass, and a bound on their
    /// buffers' pairs (tests only; `None`: [`GpuDual`]'s own).
    rounds: (usize, Option<u64>),
    /// Rounds per level a device-laid dual traversal encodes: [`GpuRsh::rounds`]'s first,
    /// then learned from each frame's traces ([`GpuRsh::take_incomplete`]).
    learned: AtomicUsize,
    /// The most rounds a level of this frame's device-laid traces took.
    frame_most: AtomicUsize,
    /// Pairs per leaf a device-laid dual traversal's buffers hold ([`GpuDual::room`]):
    /// 8, doubled after one overflowed.
    per_ray: AtomicU64,
    /// No more device-laid traces: one overflowed buffers that cannot grow.
    laid_off: AtomicBool,
    /// Every trace paced by the host ([`crate::GpuEngine::pace`]).
    paced: AtomicBool,
    /// Device-laid traces since the last look that did not finish
    /// ([`crate::GpuEngine::take_incomplete`]): bit 0 for want of rounds, bit 1 of room.
    incomplete: AtomicU32,
    /// Counter blocks of traces on the device not yet read ([`crate::GpuEngine::settle`]).
    pending: Mutex<Vec<Pending>>,
    /// The blocks [`GpuRsh::take_pending`] handed out last, in its order: what
    /// [`GpuRsh::settle`] parses their words as.
    settling: Mutex<Vec<Pending>>,
    /// Tests only: the value every 64-bit traversal counter starts from (its low word; 0
    /// in every real trace), so that a test can make the low words wrap.
    #[cfg(test)]
    counter_bias: std::sync::atomic::AtomicU32,
}

/// A dual traversal's counter block still on the device, with the hierarchy's levels and
/// whether the device laid them out (none for the mesh-sphere traversal, whose counters the
/// host has read).
type DualCounts = Option<(wgpu::Buffer, usize, bool)>;

/// The object tree of the scene's current frame, built on the device.
struct TreeState {
    dev: DeviceTree,
    /// Seconds of its build (kernels submitted and waited for).
    secs: f64,
}

impl TreeState {
    fn build(s: &DeviceScene) -> TreeState {
        let mut ex = Exec::new(&s.gpu, &s.kernels);
        ex.finish();
        let t0 = std::time::Instant::now();
        let inp = TreeInput {
            tris: &s.tris,
            tri_sphere: &s.tri_sphere,
            tri_mesh: &s.tri_mesh,
            mesh_sphere: s.cfg.mesh_culling.then_some(&s.mesh_sphere),
            mesh_first: &s.mesh_first,
            single: false,
        };
        let dev = objects::build(&mut ex, &inp, s.ntri);
        ex.finish();
        TreeState {
            dev,
            secs: t0.elapsed().as_secs_f64(),
        }
    }
}

impl GpuRsh {
    /// Upload the scene; fails when no adapter is found or the configuration is one the GPU
    /// pipeline does not implement (the 64-bit Morton hash).
    pub fn new(gpu: Gpu, geo: &Geometry, cfg: RshConfig) -> Result<GpuRsh, GpuError> {
        cfg.validate()?;
        if cfg.objects == ObjectHierarchy::Bvh {
            // The object tree is descended with the ray hierarchy's bundles level by level
            // (the dual traversal's breadth schedule); the depth-first schedule and the SAH
            // builder are the CPU's.
            if cfg.schedule != Schedule::Breadth {
                return Err(OptionError::new(
                    "schedule",
                    "depth",
                    "the GPU backend runs the dual traversal level by level (breadth) only",
                )
                .into());
            }
            if cfg.method == Method::Crsh && cfg.hash != HashKind::Thesis {
                return Err(OptionError::new(
                    "hash",
                    "morton64",
                    "the GPU backend implements the thesis's 32-bit hash only",
                )
                .into());
            }
            crate::bvh::lbvh_only(cfg.builder)?;
        } else if cfg.method == Method::Crsh && cfg.hash != HashKind::Thesis {
            return Err(OptionError::new(
                "hash",
                "morton64",
                "the GPU backend implements the thesis's 32-bit hash only",
            )
            .into());
        }
        let kernels = gpu.kernels();
        // Pair buffers hold at most `pair_budget` u32s each (as on the CPU, where the budget
        // bounds the same buffers); they must fit one binding.
        if cfg.pair_budget as u64 * 4 > gpu.max_binding() {
            return Err(OptionError::new(
                "pair_budget",
                cfg.pair_budget,
                format!(
                    "needs {} MiB per binding; this device allows {} MiB (use at most {})",
                    (cfg.pair_budget as u64 * 4) >> 20,
                    gpu.max_binding() >> 20,
                    gpu.max_binding() / 4
                ),
            )
            .into());
        }
        let sb = SceneBuffers::new(&gpu, geo, &cfg)?;
        let mut eng = GpuRsh {
            max_rays: sb.max_rays,
            s: DeviceScene {
                tris: sb.tris,
                tri_sphere: sb.tri_sphere,
                tri_mesh: sb.tri_mesh,
                mesh_sphere: sb.mesh_sphere,
                shuffles: gpu.upload("miniball shuffles", &shuffle_table(cfg.branching)),
                mesh_first: sb.mesh_first,
                ntri: sb.ntri,
                box_min: sb.box_min,
                box_ext: sb.box_ext,
                diag: sb.diag,
                gpu,
                kernels,
                cfg,
            },
            times: Mutex::new(Vec::new()),
            tree: None,
            rounds: (super::dual::ROUNDS, None),
            learned: AtomicUsize::new(super::dual::ROUNDS),
            frame_most: AtomicUsize::new(0),
            per_ray: AtomicU64::new(8),
            laid_off: AtomicBool::new(false),
            paced: AtomicBool::new(false),
            incomplete: AtomicU32::new(0),
            pending: Mutex::new(Vec::new()),
            settling: Mutex::new(Vec::new()),
            #[cfg(test)]
            counter_bias: Default::default(),
        };
        if eng.s.cfg.objects == ObjectHierarchy::Bvh {
            eng.tree = Some(TreeState::build(&eng.s));
        }
        Ok(eng)
    }

    /// Tests only (public for the device tests): the dual traversal's device rounds take
    /// `per_pass` rounds per level between the host's looks, in buffers of at most `cap`
    /// pairs (`Some(0)`: never in rounds), so that traces take many passes or overflow.
    #[doc(hidden)]
    pub fn with_rounds(mut self, per_pass: usize, cap: Option<u64>) -> GpuRsh {
        self.rounds = (per_pass.max(1), cap);
        *self.learned.get_mut() = per_pass.max(1);
        self
    }

    /// The scene of a dynamic scene's next frame: its triangles, spheres and mesh spheres
    /// uploaded in place of the last frame's (the ray hierarchy is built per trace call
    /// anyway); the device, kernels and configuration stay.
    pub fn rebuild(&mut self, geo: &Geometry) -> Result<(), GpuError> {
        let sb = SceneBuffers::new(&self.s.gpu, geo, &self.s.cfg)?;
        let s = &mut self.s;
        s.tris = sb.tris;
        s.tri_sphere = sb.tri_sphere;
        s.tri_mesh = sb.tri_mesh;
        s.mesh_sphere = sb.mesh_sphere;
        s.mesh_first = sb.mesh_first;
        s.ntri = sb.ntri;
        s.box_min = sb.box_min;
        s.box_ext = sb.box_ext;
        s.diag = sb.diag;
        self.max_rays = sb.max_rays;
        if self.tree.is_some() {
            self.tree = Some(TreeState::build(&self.s));
        }
        Ok(())
    }

    /// The configuration.
    pub fn config(&self) -> &RshConfig {
        &self.s.cfg
    }

    /// The device.
    pub fn gpu(&self) -> &Gpu {
        &self.s.gpu
    }

    /// The compiled kernels (shared with [`crate::GpuStages`], so nothing compiles twice).
    pub fn kernels(&self) -> &Kernels {
        &self.s.kernels
    }

    /// GPU time per phase accumulated since the last call (empty without timestamp queries).
    pub fn take_times(&self) -> Vec<(Phase, f64)> {
        std::mem::take(&mut *self.times.lock().unwrap())
    }

    /// The hash pass alone: every ray's key and validity flag (`screen`: RAH's key), as
    /// `rsh::hash::{thesis_key, screen_key}` compute them on the CPU. For tests that pin a
    /// disagreement to this pass; [`Tracer::trace`] keeps the keys on the device.
    pub fn hash_keys(&self, rays: &RayBatch, screen: bool) -> (Vec<u32>, Vec<u32>) {
        let mut ex = Exec::new(&self.s.gpu, &self.s.kernels);
        let dr = DeviceRays::upload(&self.s.gpu, rays);
        let (keys, valid) = super::hash::hash_keys(&self.s, &mut ex, &dr, screen, None);
        let n = rays.len();
        (ex.read(&keys, n), ex.read(&valid, n))
    }

    /// The ordering and build passes alone: the leaf order (ray ids) and every level's
    /// node rows (sphere, cone, and sin α | cos α | longest ray | kind bits), bottom level
    /// first, as `rsh::build::build` makes them. For tests that pin a disagreement to a node.
    pub fn hierarchy(&self, rays: &RayBatch) -> (Vec<u32>, Vec<LevelRows>) {
        let mut ex = Exec::new(&self.s.gpu, &self.s.kernels);
        let dr = DeviceRays::upload(&self.s.gpu, rays);
        let (leaves, m, per_kind) =
            leaf_order(&self.s, &mut ex, &dr, &mut TraceStats::default(), None);
        let levels = build(&self.s, &mut ex, &dr, &leaves, per_kind);
        let order = ex.read(&leaves, m as usize);
        let rows = levels
            .iter()
            .map(|l| {
                let n = l.len() as usize;
                [
                    ex.read(&l.sphere, n),
                    ex.read(&l.cone, n),
                    ex.read(&l.sc, n),
                ]
            })
            .collect();
        (order, rows)
    }

    /// Order, build, traverse and make the hit records of rays `dr` on the device (thesis
    /// §3.2.3–3.2.9): the triangles pushed down the hierarchy ([`GpuTraversal`]), or with
    /// the object tree the dual traversal ([`GpuDual`]); the records stay there. Returns
    /// them with the traversal's counters, the number of top nodes and, for the dual
    /// traversal, its counter block still on the device (its counts not yet in the
    /// counters: [`GpuDual::counts`]).
    /// `count`: of the first `count.n` rays of `dr` only (a size on the device).
    fn records(
        &self,
        ex: &mut Exec,
        dr: &DeviceRays,
        mode: TraceMode,
        stats: &mut TraceStats,
        count: Option<&DevSize>,
    ) -> (wgpu::Buffer, Counters, u64, DualCounts) {
        let dual = self.tree.as_ref().filter(|_| self.s.ntri > 0);
        if dual.is_some() {
            stats.count(::rsh::stats::BUNDLED_BATCHES, 1);
        }
        let n = dr.len;
        let g = &self.s.gpu;
        let mut chunks = None;
        let (leaves, m, levels, laid) = if self.lays_out(n, count) {
            // Nothing read back: the device counts, lays out and paces it all.
            let (leaves, kinds, runs) = leaf_order_laid(&self.s, ex, dr, count);
            chunks = runs;
            ex.phase(::rsh::stats::HIERARCHY_CREATION);
            let (levels, laid) = build_laid(&self.s, ex, dr, &leaves, &kinds, n);
            (leaves, n, levels, Some(laid))
        } else {
            let (leaves, m, per_kind) = leaf_order(&self.s, ex, dr, stats, count);
            // Hierarchy (thesis §3.2.7).
            ex.phase(::rsh::stats::HIERARCHY_CREATION);
            let levels = build(&self.s, ex, dr, &leaves, per_kind);
            (leaves, m, levels, None)
        };
        // Traversal and final tests (thesis §3.2.8–3.2.9).
        // Every ray's best hit starts as none (u64::MAX), set on the device.
        let best = ex.filled("best", 2 * n, u32::MAX);
        let mut c = Counters {
            tests: vec![[0; 4]; levels.len()],
            hits: vec![[0; 4]; levels.len()],
            ..Default::default()
        };
        let mut on_device = None;
        if let (Some(t), Some(_)) = (dual, levels.last()) {
            let words = GpuDual::counter_words(levels.len());
            let counters = g.storage("dual traversal counters", words * 4);
            if let Some(w) = &chunks {
                // CRSH's chunks, counted on the device (GpuDual::outcome).
                let at = 4 * (GpuDual::counter_words(levels.len()) - 2);
                ex.copy_at(w, 0, &counters, at, 4);
            }
            let trav = GpuDual {
                eng: &self.s,
                tree: &t.dev,
                levels: &levels,
                rays: dr,
                leaves: &leaves,
                m,
                best: &best,
                counters: &counters,
                any: mode == TraceMode::Any,
                diag: self.s.diag,
                // Paced by the host: passes of the configured rounds; laid out on the
                // device: one pass of the rounds the engine learned.
                rounds: match laid {
                    Some(_) => (self.learned.load(Ordering::Relaxed), self.rounds.1),
                    None => self.rounds,
                },
                laid: laid.as_ref(),
                room: match laid {
                    Some(_) => self.per_ray.load(Ordering::Relaxed) * n,
                    None => 8 * m,
                },
            };
            trav.run(ex, &mut c);
            on_device = Some((counters, levels.len(), laid.is_some()));
        } else if self.s.ntri > 0 && levels.last().is_some_and(|l| !l.is_empty()) {
            let words = GpuTraversal::counter_words(levels.len());
            let counters = g.storage("traversal counters", words * 4);
            #[cfg(test)]
            {
                let bias = self.counter_bias.load(std::sync::atomic::Ordering::Relaxed);
                if bias != 0 {
                    let start: Vec<u32> = (0..words).map(|i| bias * (i % 2 == 0) as u32).collect();
                    ex.copy(&g.upload("counter bias", &start), 0, &counters, words * 4);
                }
            }
            let trav = GpuTraversal {
                eng: &self.s,
                levels: &levels,
                rays: dr,
                leaves: &leaves,
                best: &best,
                counters: &counters,
            };
            trav.run(ex, &mut c);
        }
        // Records: the winner's hit recomputed with the shared kernel, as on the CPU.
        ex.phase(::rsh::stats::FINAL_TESTS);
        let rec = self.hit_records(ex, dr, &best);
        // (Laid out on the device: its own count, read with the counters.)
        let top = match (&laid, levels.last()) {
            (None, Some(l)) => l.len() as u64,
            _ => 0,
        };
        (rec, c, top, on_device)
    }

    /// Whether a trace of `n` rays (of which the device holds the count) is laid out and
    /// paced by the device, reading nothing back: the bundles through the object tree, in
    /// a frame not paced by the host, where the
    /// rounds' buffers keep the host's schedule (their bound below the smallest chunk, the
    /// top level's bound within it).
    fn lays_out(&self, n: u64, count: Option<&DevSize>) -> bool {
        if count.is_none()
            || self.tree.is_none()
            || self.s.ntri == 0
            || self.paced.load(Ordering::Relaxed)
            || self.laid_off.load(Ordering::Relaxed)
        {
            return false;
        }
        let b = self.s.cfg.branching as u64;
        let chunk = (self.s.cfg.pair_budget as u64 / b.max(2)).max(1);
        let nt = *laid_caps(n, b, self.s.cfg.levels).last().unwrap_or(&0);
        let room = self.per_ray.load(Ordering::Relaxed) * n;
        rounds_cap(room, nt, chunk, self.rounds.1).is_some()
    }

    /// One record per ray of `dr` from its best (triangle, t bits) in `best`: the winner's
    /// hit recomputed with the shared kernel, as on the CPU (`final.wgsl`'s `records`).
    fn hit_records(&self, ex: &mut Exec, dr: &DeviceRays, best: &wgpu::Buffer) -> wgpu::Buffer {
        let n = dr.len;
        let rec = self.s.gpu.storage("records", n * 16);
        ex.run(
            launch::Records {
                f_org: &dr.org,
                f_dir: &dr.dir,
                f_pre: &dr.pre,
                f_tris: &self.s.tris,
                f_best_pair: best,
                f_rec: &rec,
            },
            RecordsParams { rays: n as u32 },
            n,
            256,
        );
        rec
    }

    fn trace_part(
        &self,
        rays: &RayBatch,
        mode: TraceMode,
        hits: &mut [Hit],
        stats: &mut TraceStats,
    ) {
        let n = rays.len();
        let g = &self.s.gpu;
        let mut ex = Exec::new(g, &self.s.kernels);
        let dr = DeviceRays::upload(g, rays);
        let (rec, mut c, top, dual) = self.records(&mut ex, &dr, mode, stats, None);
        ex.phase(crate::stats::READ_BACK);
        match dual {
            None => records_to_hits(&ex.read(&rec, n), hits),
            Some((cnt, levels, _)) => {
                // The records and the counters in one read-back.
                let (bytes, words) = (n as u64 * 16, GpuDual::counter_words(levels));
                let both = g.storage("records and counters", bytes + words * 4);
                ex.copy(&rec, 0, &both, bytes);
                ex.copy_at(&cnt, 0, &both, bytes, words * 4);
                let w: Vec<u32> = ex.read(&both, 4 * n + words as usize);
                records_to_hits(bytemuck::cast_slice(&w[..4 * n]), hits);
                let over = GpuDual::counts(&w[4 * n..], levels, &mut c);
                stats.count(crate::stats::STACK_OVERFLOWS, over);
            }
        }
        ex.report(stats, &self.times);
        let nhits = hits.iter().filter(|h| h.is_hit()).count() as u64;
        self.report(&c, top, nhits, stats);
    }

    /// [`crate::GpuEngine::trace_device`]: rays `dr` (at most the engine's part size) traced
    /// on the device ([`GpuRsh::trace_on_device`]); the records and counts stay there.
    pub(crate) fn trace_device_part(
        &self,
        dr: &DeviceRays,
        mode: TraceMode,
        stats: &mut TraceStats,
    ) -> wgpu::Buffer {
        self.trace_on_device(dr, mode, stats, None)
    }

    /// Rays `dr` (of the first `count.n` only, where given) traced on the device, the
    /// records left there and the counts too, until the frame's end (`GpuEngine::settle`):
    /// the bundles' first read-back is the trim's count (the hash runs over the device's
    /// count), and their traversal reads the sizes its passes need (none where the device
    /// lays the hierarchy out).
    fn trace_on_device(
        &self,
        dr: &DeviceRays,
        mode: TraceMode,
        stats: &mut TraceStats,
        count: Option<&DevSize>,
    ) -> wgpu::Buffer {
        let mut ex = Exec::new(&self.s.gpu, &self.s.kernels);
        let rec = self.bundles_on_device(&mut ex, dr, mode, stats, count);
        ex.report(stats, &self.times);
        rec
    }

    /// The bundles' trace of rays `dr` on the device (of the first `count.n` only where
    /// given), its counts left there until the frame reads them with its image
    /// (`GpuEngine::settle`): the dual traversal's counter block, then the records'
    /// totals. (The mesh-sphere traversal, and a dual traversal the host paces, read back
    /// the sizes their passes need; one laid out on the device reads nothing.)
    fn bundles_on_device(
        &self,
        ex: &mut Exec,
        dr: &DeviceRays,
        mode: TraceMode,
        stats: &mut TraceStats,
        count: Option<&DevSize>,
    ) -> wgpu::Buffer {
        let (rec, c, top, dual) = self.records(ex, dr, mode, stats, count);
        let cw = dual.as_ref().map_or(0, |d| GpuDual::counter_words(d.1));
        let totals = crate::frame::totals_on_device(ex, &rec, None, dr.len, count);
        let tw = totals.as_ref().map_or(0, |t| t.1);
        let block = self.s.gpu.storage("bundles' counts", (cw + tw) * 4);
        if let Some((cnt, ..)) = &dual {
            ex.copy(cnt, 0, &block, cw * 4);
        }
        if let Some((t, w)) = &totals {
            ex.copy_at(t, 0, &block, cw * 4, w * 4);
        }
        self.pending.lock().unwrap().push(Pending::Bundles {
            block,
            words: cw + tw,
            levels: dual.as_ref().map(|d| d.1),
            c,
            top,
            laid: dual.is_some_and(|d| d.2),
        });
        rec
    }

    /// [`crate::GpuEngine::trace_device_counted`] ([`GpuRsh::trace_on_device`]).
    pub(crate) fn trace_device_counted(
        &self,
        dr: &DeviceRays,
        count: &DevSize,
        mode: TraceMode,
        stats: &mut TraceStats,
    ) -> Option<wgpu::Buffer> {
        Some(self.trace_on_device(dr, mode, stats, Some(count)))
    }

    /// The scene's triangles on the device (3 × vec4 per triangle).
    pub(crate) fn triangles(&self) -> &wgpu::Buffer {
        &self.s.tris
    }

    /// Most rays one hierarchy takes (a larger batch is traced in parts).
    pub(crate) fn max_rays(&self) -> usize {
        self.max_rays
    }

    /// Counters into `stats`, as the CPU engine reports them.
    fn report(&self, c: &Counters, top: u64, hits: u64, stats: &mut TraceStats) {
        stats.hits += hits;
        // With the object tree the mesh spheres are in the tree, not a pass of their own.
        let tree = self.tree.is_some();
        ::rsh::stats::report_counters(c, self.s.cfg.mesh_culling && !tree, top, stats);
        if tree {
            ::rsh::stats::object_counters(c, stats);
        }
    }
}

/// One level of nodes as read back by [`GpuRsh::hierarchy`]: per node its sphere
/// (centre, radius), its cone (axis, half-angle) and sin α | cos α | longest ray | kind bits.
pub type LevelRows = [Vec<[f32; 4]>; 3];

/// The counts of a trace that the GPU engine must reproduce: everything in `s` (rays, hits,
/// test totals, per-level counts, engine counters) but the times and the GPU-only counter.
pub fn comparable_counters(s: &TraceStats) -> TraceStats {
    let mut c = s.clone();
    c.phases.clear();
    c.counters.remove(crate::stats::KERNEL_LAUNCHES);
    c.counters.remove(crate::stats::STACK_OVERFLOWS);
    c
}

impl Tracer for GpuRsh {
    fn name(&self) -> &str {
        match self.s.cfg.method {
            Method::Crsh => "crsh-gpu",
            Method::Rah => "rah-gpu",
        }
    }

    fn build_passes(&self) -> Vec<trace::PassTime> {
        match &self.tree {
            Some(t) => vec![trace::PassTime::new(accel::bvh::OBJECT_HIERARCHY, t.secs)],
            None => Vec::new(),
        }
    }

    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        assert_eq!(hits.len(), rays.len(), "one hit record per ray");
        stats.rays += rays.len() as u64;
        if rays.is_empty() {
            return;
        }
        if rays.len() <= self.max_rays {
            self.trace_part(rays, mode, hits, stats);
            return;
        }
        // Larger than one binding: consecutive parts, each with its own hierarchy.
        for (p, out) in hits.chunks_mut(self.max_rays).enumerate() {
            let lo = p * self.max_rays;
            let part = rays.slice(lo..lo + out.len());
            self.trace_part(&part, mode, out, stats);
        }
    }
}

mod pending;
use pending::Pending;

#[cfg(test)]
mod tests;
