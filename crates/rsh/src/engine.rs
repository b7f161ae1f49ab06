//! CRSH and RAH as engines of [`trace::Tracer`]: one node type, one builder, one traversal;
//! they differ only where the papers differ (leaf order, mesh culling, defaults).

use crate::build::build;
use crate::dual::{RaySide, Schedule};
use crate::options::{Method, ObjectHierarchy, RshConfig};
use crate::order::{leaf_order, Grouping};
use crate::traverse::{unpack_uv, Counters, SceneData, Traversal};
use accel::bvh::objects::{self, ObjectTree};
use geom::tri::RayPre;
use geom::tri8::RayLanes;
use geom::{intersect, Aabb, Sphere, Vec3};
use par::SharedMut;
use rayon::prelude::*;
use scene::Geometry;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;
use trace::OptionError;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

/// The memory model of the engine's build: resident bytes added per triangle at its peak,
/// with the object tree (the tree with the dual traversal's records: measured 357–358 on
/// hairball and city scenes, `bench/results/2026-12-07-2core/memory.txt`) and with the mesh
/// spheres (the triangles and their spheres: 53–56), checked against the memory limit before
/// the build; the pair buffers of the traversal are `RshConfig::pair_bytes`'s.
pub fn build_bytes_per_triangle(cfg: &RshConfig) -> u64 {
    match cfg.objects {
        ObjectHierarchy::Bvh => 400,
        ObjectHierarchy::MeshSpheres => 64,
    }
}

/// Why a CRSH/RAH engine cannot be built.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RshError {
    /// A configuration value out of range.
    #[error(transparent)]
    Option(#[from] OptionError),
    /// More triangles than the object tree's 31-bit node ids hold.
    #[error("{0} triangles exceed the object tree's 2^31")]
    ObjectTreeSize(usize),
}

/// The engine: per-triangle bounding spheres (the thesis's traversal) or the object tree,
/// and the mesh spheres, built once per scene (per frame for dynamic scenes); the ray
/// hierarchy is built per trace call.
pub struct RshEngine {
    cfg: RshConfig,
    tris: Vec<[Vec3; 3]>,
    /// Per-triangle spheres (empty with the object tree, whose leaves hold them).
    tri_center: Vec<Vec3>,
    tri_radius: Vec<f32>,
    mesh_first: Vec<u32>,
    mesh_sphere: Vec<Sphere>,
    bounds: Aabb,
    /// The object hierarchy ([`ObjectHierarchy::Bvh`]) and its build time.
    tree: Option<(ObjectTree, f64)>,
}

/// The rays' geometric fields (origin, direction, t range, kind) gathered into leaf order,
/// in parallel: all that the hierarchy's build and the dual traversal read of a ray. The
/// shading fields (pixel, light, throughput, depth) stay empty.
fn gather_leaves(rays: &RayBatch, order: &[u32]) -> RayBatch {
    fn gather<T: Copy + Send + Sync>(v: &[T], order: &[u32]) -> Vec<T> {
        order
            .par_iter()
            .with_min_len(4096)
            .map(|&r| v[r as usize])
            .collect()
    }
    RayBatch {
        org: gather(&rays.org, order),
        dir: gather(&rays.dir, order),
        t_min: gather(&rays.t_min, order),
        t_max: gather(&rays.t_max, order),
        kind: gather(&rays.kind, order),
        width: rays.width,
        ..RayBatch::default()
    }
}

impl RshEngine {
    /// The engine over `geo` (per-triangle and per-mesh spheres); the configuration is
    /// validated first.
    pub fn new(geo: &Geometry, cfg: RshConfig) -> Result<Self, RshError> {
        cfg.validate()?;
        // Per-triangle spheres for the thesis's traversal; the object tree's leaves hold
        // their own (one pass over the triangles, not two).
        let (tri_center, tri_radius): (Vec<Vec3>, Vec<f32>) = match cfg.objects {
            ObjectHierarchy::MeshSpheres => geo
                .tris
                .par_iter()
                .map(|t| {
                    let s = Sphere::of_triangle(t[0], t[1], t[2]);
                    (s.center, s.radius)
                })
                .unzip(),
            ObjectHierarchy::Bvh => Default::default(),
        };
        if cfg.objects == ObjectHierarchy::Bvh && geo.tris.len() >= objects::LEAF as usize {
            return Err(RshError::ObjectTreeSize(geo.tris.len()));
        }
        let tree = (cfg.objects == ObjectHierarchy::Bvh).then(|| {
            let t0 = Instant::now();
            let spheres = cfg.mesh_culling.then_some(&geo.mesh_sphere[..]);
            // The dual traversal's records only (the single rays' are the `bvh` engine's).
            let parts = objects::Parts {
                dual: true,
                single: false,
            };
            let t = objects::build(&geo.tris, &geo.mesh_first, spheres, cfg.builder, parts);
            (t, t0.elapsed().as_secs_f64())
        });
        Ok(RshEngine {
            cfg,
            tris: geo.tris.clone(),
            tri_center,
            tri_radius,
            mesh_first: geo.mesh_first.clone(),
            mesh_sphere: geo.mesh_sphere.clone(),
            bounds: geo.bounds,
            tree,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &RshConfig {
        &self.cfg
    }
}

impl RshEngine {
    /// The thesis's traversal (§3.2.7–3.2.9): the hierarchy over the rays in `order`, every
    /// triangle pushed down it behind the mesh spheres, exact final tests, and the winners'
    /// records recomputed with the shared kernel.
    fn trace_mesh_spheres(
        &self,
        rays: &RayBatch,
        order: Vec<u32>,
        hits: &mut [Hit],
        stats: &mut TraceStats,
    ) {
        let n = rays.len();
        let t0 = Instant::now();
        let h = build(
            rays,
            order,
            self.cfg.branching as usize,
            self.cfg.levels,
            self.cfg.union,
        );
        stats.time(crate::stats::HIERARCHY_CREATION, t0.elapsed().as_secs_f64());
        let best: Vec<AtomicU64> = (0..n)
            .into_par_iter()
            .map(|_| AtomicU64::new(u64::MAX))
            .collect();
        // The rays' constants in leaf order, 8 lanes at a time (geom::tri8).
        let lanes = RayLanes::build(h.order.len(), |p| {
            RayPre::new(&rays.ray(h.order[p] as usize))
        });
        let trav = self.traversal(&h, &lanes, &best, None);
        let mut c = Counters::default();
        let t1 = Instant::now();
        if !self.tris.is_empty() {
            trav.run(&mut c);
        }
        let total = t1.elapsed().as_secs_f64();
        stats.time(trace::TRAVERSAL, total - c.final_seconds);
        stats.time(crate::stats::FINAL_TESTS, c.final_seconds);
        stats.hits += hits
            .par_iter_mut()
            .enumerate()
            .map(|(i, out)| {
                let b = best[i].load(Ordering::Relaxed);
                *out = if b == u64::MAX {
                    Hit::MISS
                } else {
                    self.record(&RayPre::new(&rays.ray(i)), b as u32)
                };
                out.is_hit() as u64
            })
            .sum::<u64>();
        let top = h.levels.last().map(|l| l.len() as u64).unwrap_or(0);
        crate::stats::report_counters(&c, self.cfg.mesh_culling && self.tree.is_none(), top, stats);
        if self.tree.is_some() {
            // An object tree over no triangles: its counters are reported, as zeros.
            crate::stats::object_counters(&c, stats);
        }
    }

    /// The dual traversal with the object tree ([`crate::dual`]): the rays gathered into
    /// leaf order, the hierarchy over them, (ray node, object node) pairs descended by the
    /// configured schedule, and the records laid out by leaf position.
    fn trace_dual(
        &self,
        tree: &ObjectTree,
        rays: &RayBatch,
        order: Vec<u32>,
        mode: TraceMode,
        hits: &mut [Hit],
        stats: &mut TraceStats,
    ) {
        let n = rays.len();
        let t0 = Instant::now();
        // The dual traversal reads rays in leaf order: the rays' fields are gathered into
        // that order once (the hash order scatters ray ids, so the hierarchy's build, the
        // final tests' lanes and the beams would each gather them again, missing the cache
        // on every ray), its best hits are laid out by leaf position, and the hierarchy's
        // leaves are numbered by position. Only the arrays in use are made (fresh memory
        // costs page faults on every trace).
        let batch = gather_leaves(rays, &order);
        let len = order.len() as u32;
        let h = build(
            &batch,
            (0..len).collect(),
            self.cfg.branching as usize,
            self.cfg.levels,
            self.cfg.union,
        );
        stats.time(crate::stats::HIERARCHY_CREATION, t0.elapsed().as_secs_f64());
        let leaf_rays = &order[..];
        let best: Vec<AtomicU64> = (0..leaf_rays.len())
            .into_par_iter()
            .map(|_| AtomicU64::new(u64::MAX))
            .collect();
        // The depth-first dual traversal does all of a ray's tests in one task, so it keeps
        // each hit's barycentrics with it, and the records need not test again.
        let keep_bary = self.cfg.schedule == Schedule::Depth;
        let bary: Vec<AtomicU64> = (0..if keep_bary { leaf_rays.len() } else { 0 })
            .into_par_iter()
            .map(|_| AtomicU64::new(0))
            .collect();
        // The rays' constants in leaf order, 8 lanes at a time (geom::tri8).
        let lanes = RayLanes::build(batch.len(), |p| RayPre::new(&batch.ray(p)));
        let trav = self.traversal(&h, &lanes, &best, keep_bary.then_some(&bary[..]));
        let mut c = Counters::default();
        let t1 = Instant::now();
        let inv_dir: Vec<Vec3> = batch.dir.par_iter().map(|d| d.recip()).collect();
        let side = RaySide {
            inv_dir: &inv_dir,
            org: &batch.org,
            t_min: &batch.t_min,
            t_max: &batch.t_max,
            kind: &batch.kind,
            any_hit: mode == TraceMode::Any,
        };
        trav.run_dual(
            self.cfg.schedule,
            tree,
            self.cfg.descent,
            self.bounds.diagonal(),
            &side,
            &mut c,
        );
        let total = t1.elapsed().as_secs_f64();
        stats.time(trace::TRAVERSAL, total - c.final_seconds);
        // The depth-first schedule interleaves the final tests with the pair tests (timing
        // each would cost more than many of them): its traversal phase holds both.
        if !keep_bary {
            stats.time(crate::stats::FINAL_TESTS, c.final_seconds);
        }
        // Best hits by leaf position, the rays' constants read back from the lanes in that
        // order (not regathered from the batch); rays outside the leaves (t_min ≥ t_max)
        // miss.
        if leaf_rays.len() < n {
            hits.par_iter_mut().for_each(|h| *h = Hit::MISS);
        }
        let out = SharedMut(hits.as_mut_ptr());
        stats.hits += leaf_rays
            .par_iter()
            .zip(&best)
            .enumerate()
            .with_min_len(1024)
            .map(|(p, (&r, b))| {
                let b = b.load(Ordering::Relaxed);
                let hit = if b == u64::MAX {
                    Hit::MISS
                } else if keep_bary {
                    let (u, v) = unpack_uv(bary[p].load(Ordering::Relaxed));
                    Hit {
                        tri: b as u32,
                        t: f32::from_bits((b >> 32) as u32),
                        u,
                        v,
                    }
                } else {
                    self.record(&lanes.pre(p), b as u32)
                };
                // SAFETY: every ray is at most one leaf, so each record is written by one
                // task; `hits` outlives the pass.
                unsafe { out.write(r as usize, hit) };
                hit.is_hit() as u64
            })
            .sum::<u64>();
        let top = h.levels.last().map(|l| l.len() as u64).unwrap_or(0);
        crate::stats::report_counters(&c, false, top, stats);
        crate::stats::object_counters(&c, stats);
    }

    /// The traversal's view of the scene and of one trace's hierarchy, lanes and results.
    fn traversal<'a>(
        &'a self,
        h: &'a crate::build::Hierarchy,
        lanes: &'a RayLanes,
        best: &'a [AtomicU64],
        bary: Option<&'a [AtomicU64]>,
    ) -> Traversal<'a> {
        Traversal {
            h,
            scene: SceneData {
                tris: &self.tris,
                tri_center: &self.tri_center,
                tri_radius: &self.tri_radius,
                mesh_first: &self.mesh_first,
                mesh_sphere: &self.mesh_sphere,
            },
            lanes,
            best,
            bary,
            test: self.cfg.node_test,
            mesh_culling: self.cfg.mesh_culling,
            budget: self.cfg.pair_budget,
        }
    }

    /// A winner's record, recomputed with the shared kernel (bit-identical to brute force).
    fn record(&self, pre: &RayPre, tri: u32) -> Hit {
        let [a, b, c] = self.tris[tri as usize];
        let h = intersect(pre, a, b, c).expect("the recorded hit repeats");
        Hit {
            tri,
            t: h.t,
            u: h.u,
            v: h.v,
        }
    }
}

impl Tracer for RshEngine {
    fn name(&self) -> &str {
        match self.cfg.method {
            Method::Crsh => "crsh",
            Method::Rah => "rah",
        }
    }

    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        assert_eq!(hits.len(), rays.len(), "one hit record per ray");
        let n = rays.len();
        stats.rays += n as u64;
        if n == 0 {
            return;
        }
        let grouping = match self.cfg.method {
            Method::Crsh => Grouping::Hash(self.cfg.hash),
            Method::Rah => Grouping::Screen,
        };
        let tree = self.tree.as_ref().filter(|_| !self.tris.is_empty());
        if tree.is_some() {
            stats.count(crate::stats::BUNDLED_BATCHES, 1);
        }
        let order = leaf_order(rays, grouping, &self.bounds, &self.cfg.hash_bits, stats);
        match tree {
            Some((tree, _)) => self.trace_dual(tree, rays, order, mode, hits, stats),
            None => self.trace_mesh_spheres(rays, order, hits, stats),
        }
    }

    fn structure_bytes(&self) -> Option<u64> {
        let spheres = std::mem::size_of_val(&self.tri_center[..])
            + std::mem::size_of_val(&self.tri_radius[..])
            + std::mem::size_of_val(&self.mesh_sphere[..])
            + std::mem::size_of_val(&self.mesh_first[..]);
        let tree = self.tree.as_ref().map_or(0, |(t, _)| t.bytes());
        Some((spheres + tree) as u64)
    }

    fn build_passes(&self) -> Vec<trace::PassTime> {
        match &self.tree {
            Some((_, secs)) => vec![trace::PassTime::new(accel::bvh::OBJECT_HIERARCHY, *secs)],
            None => Vec::new(),
        }
    }
}
