//! The `bvh` engine: an object tree (a binary BVH over the triangles, one triangle per leaf,
//! collapsed into 8-wide nodes) built every frame, walked by packets of 16 neighbouring rays
//! or by single rays. No ray hierarchy: no hashing, sorting or bundling of rays.
//!
//! - [`objects`]: the tree and its builders (binned SAH, Wald 2007; Karras's LBVH, 2012),
//!   with the records each walk reads. The ray hierarchy's dual traversal (`rsh::dual`,
//!   the thesis's future work, §5.1) descends the same tree with its bundles.
//! - [`single`]: one ray at a time through the 8-wide nodes (Wald et al. 2008, "Getting rid
//!   of packets"), scalar, AVX2 and AVX-512 builds with the same bits.
//! - [`packet`]: 16 consecutive rays walking the nodes together (Wald et al. 2001's packets,
//!   in vector lanes).
//!
//! Per batch the engine measures whether its rays are neighbours ([`locality`]: rays made
//! pixel by pixel towards a light, short AO rays from neighbouring points) and sends them as
//! packets, else as single rays ([`RayPath`]), and counts which in its stats. Every hit is
//! the shared kernel's ([`geom::intersect`]), so records equal brute force's bit for bit.

pub mod objects;
pub mod packet;
pub mod single;

pub use objects::{ObjectBuilder, ObjectTree};

use geom::{Aabb, Vec3};
use scene::Geometry;
use std::time::Instant;
use trace::options::{name_of, named, Kind, OnGpu, Spec, Value};
use trace::{Counter, Hit, RayBatch, TraceMode, TraceStats, Tracer};

/// How the engine walks a batch through the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayPath {
    /// Batches of neighbouring rays ([`locality`]) in packets of 16 consecutive rays
    /// walking the tree together ([`packet`]), other batches as single rays (Sponza's 512²
    /// shadow rays in about half the single rays' time, its AO rays in 0.7–0.8 of it).
    Packets,
    /// Every batch as single rays ([`single`]; the GPU backend's only walk: a device's
    /// threads walk neighbouring rays side by side on their own).
    Single,
}

impl RayPath {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, RayPath); 2] =
        [("packets", RayPath::Packets), ("single", RayPath::Single)];

    /// The value's name (as options spell it).
    pub fn name(self) -> &'static str {
        match self {
            RayPath::Packets => "packets",
            RayPath::Single => "single",
        }
    }
}

/// The `bvh` engine's configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct BvhConfig {
    /// How the tree is built per frame.
    pub builder: ObjectBuilder,
    /// How a batch walks it.
    pub path: RayPath,
}

impl Default for BvhConfig {
    /// The CPU's fastest: the SAH tree, packets for neighbouring rays.
    fn default() -> Self {
        BvhConfig {
            builder: ObjectBuilder::Sah,
            path: RayPath::Packets,
        }
    }
}

/// Every option of the `bvh` engine (`object_builder` is also the ray hierarchy's, whose
/// dual traversal descends the same tree).
pub const OPTIONS: &[Spec<BvhConfig>] = &[
    Spec {
        name: "object_builder",
        kind: Kind::Choice(&[
            (
                "sah",
                "binned SAH, top down (Wald 2007): fewer node visits per ray",
            ),
            (
                "lbvh",
                "linear BVH over Morton codes (Karras 2012): the fastest build",
            ),
        ]),
        doc: "how the tree is built per frame",
        engines: None,
        requires: None,
        gpu: OnGpu::Only("lbvh"),
        get: |c| Value::Str(name_of(&ObjectBuilder::NAMES, c.builder).into()),
        set: |c, v| {
            c.builder = named(&ObjectBuilder::NAMES, v)?;
            Ok(())
        },
    },
    Spec {
        name: "ray_path",
        kind: Kind::Choice(&[
            (
                "packets",
                "packets of 16 rays for batches of neighbouring rays, single rays for others",
            ),
            ("single", "every ray alone"),
        ]),
        doc: "how a batch walks the tree",
        engines: None,
        requires: None,
        gpu: OnGpu::Only("single"),
        get: |c| Value::Str(c.path.name().into()),
        set: |c, v| {
            c.path = named(&RayPath::NAMES, v)?;
            Ok(())
        },
    },
];

/// The memory model of the engine's build: the resident bytes it adds per triangle at its
/// peak (the tree, its 8-wide nodes and triangle blocks, the builders' scratch), above the
/// measured 199–205 of both builders on hairball and city scenes
/// (`bench/results/2026-12-07-2core/memory.txt`), checked against the memory limit before
/// the build.
pub const BUILD_BYTES_PER_TRIANGLE: u64 = 230;

/// Why a `bvh` engine cannot be built.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum BvhError {
    /// More triangles than the tree's 31-bit node ids hold.
    #[error("{0} triangles exceed the object tree's 2^31")]
    TooManyTriangles(usize),
}

/// The engine: the scene's triangles and their tree, built once per frame.
pub struct BvhEngine {
    cfg: BvhConfig,
    tris: Vec<[Vec3; 3]>,
    bounds: Aabb,
    tree: ObjectTree,
    /// Seconds the tree's build took.
    build_secs: f64,
}

impl BvhEngine {
    /// The engine over `geo`: the tree built with the configured builder, holding the
    /// records the single rays and packets read (no sphere bounds: those are the dual
    /// traversal's).
    pub fn new(geo: &Geometry, cfg: BvhConfig) -> Result<Self, BvhError> {
        if geo.tris.len() >= objects::LEAF as usize {
            return Err(BvhError::TooManyTriangles(geo.tris.len()));
        }
        let t0 = Instant::now();
        let parts = objects::Parts {
            dual: false,
            single: true,
        };
        let tree = objects::build(&geo.tris, &geo.mesh_first, None, cfg.builder, parts);
        Ok(BvhEngine {
            cfg,
            tris: geo.tris.clone(),
            bounds: geo.bounds,
            tree,
            build_secs: t0.elapsed().as_secs_f64(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &BvhConfig {
        &self.cfg
    }

    /// The tree.
    pub fn tree(&self) -> &ObjectTree {
        &self.tree
    }
}

/// Trace calls whose rays went through the tree in packets of neighbouring rays.
pub const PACKET_BATCHES: Counter = Counter::sum("packet batches");
/// Trace calls whose rays went one by one through the tree.
pub const SINGLE_RAY_BATCHES: Counter = Counter::sum("single-ray batches");
/// Ray–box tests that passed (of [`trace::RAY_BOX_TESTS`]).
pub const RAY_BOX_PASSES: Counter = Counter::sum("ray-box passes");
/// The object tree's build, every frame.
pub const OBJECT_HIERARCHY: trace::BuildPass = trace::BuildPass::new("object hierarchy");

/// A single-ray or packet walk's counts into `stats` (the CPU engine and its GPU twin report
/// them alike): hits, ray–triangle tests, ray–box tests and their passes.
pub fn report(c: &single::SingleCounts, stats: &mut TraceStats) {
    stats.hits += c.hits;
    stats.ray_tri_tests += c.final_tests.iter().sum::<u64>();
    stats.count(trace::RAY_BOX_TESTS, c.box_tests);
    stats.count(RAY_BOX_PASSES, c.box_passes);
}

impl Tracer for BvhEngine {
    fn name(&self) -> &str {
        "bvh"
    }

    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        assert_eq!(hits.len(), rays.len(), "one hit record per ray");
        stats.rays += rays.len() as u64;
        if rays.is_empty() {
            return;
        }
        if self.tris.is_empty() {
            hits.iter_mut().for_each(|h| *h = Hit::MISS);
            return;
        }
        let packets = self.cfg.path == RayPath::Packets
            && locality(rays, self.bounds.extent().length()) >= COHERENT_SHARE;
        stats.count(SINGLE_RAY_BATCHES, !packets as u64);
        stats.count(PACKET_BATCHES, packets as u64);
        let t0 = Instant::now();
        let isa = single::Isa::best();
        let c = if packets {
            packet::trace(&self.tree, &self.tris, rays, mode, hits, isa)
        } else {
            single::trace(&self.tree, &self.tris, rays, mode, hits, isa)
        };
        stats.time(trace::TRAVERSAL, t0.elapsed().as_secs_f64());
        report(&c, stats);
    }

    fn structure_bytes(&self) -> Option<u64> {
        Some(self.tree.bytes() as u64)
    }

    fn build_passes(&self) -> Vec<trace::PassTime> {
        vec![trace::PassTime::new(OBJECT_HIERARCHY, self.build_secs)]
    }
}

/// Rays sampled by [`locality`] (evenly spaced over the batch).
const SAMPLES: usize = 4096;
/// How many following rays of the batch a sampled ray looks among for a neighbour.
const NEIGHBOURS: usize = 8;
/// A batch goes as packets when at least this share of its sampled rays has a neighbour.
pub const COHERENT_SHARE: f32 = 0.5;
/// Segments near each other for [`locality`]: within this share of the scene's diagonal.
const LOCAL: f32 = 0.25;

/// The share of a batch's rays (a deterministic sample of at most 4096, evenly spaced) whose
/// segment runs near the segment of one of the 8 rays that follow it in the batch: the
/// distance of their origins plus their common length (the shorter t_max times the
/// direction's length, capped at the scene's diagonal `diag`) times the distance of their
/// unit directions, within a quarter of `diag`. Neighbouring rays whose segments stay close
/// walk mostly the same nodes, which is what a packet ([`packet`]) needs: rays made pixel by
/// pixel towards a light or a mirror have it (near-parallel and long), and so do
/// ambient-occlusion rays (random directions, but short and from neighbouring points); rays
/// scattered from anywhere do not. On the bench scenes' 512² batches
/// (`bench/results/2026-12-03d-2core/`): shadow rays 0.998–1, AO rays 0.995–1, random rays
/// 0.002–0.003. It costs a few microseconds.
pub fn locality(rays: &RayBatch, diag: f32) -> f32 {
    let n = rays.len();
    if n < 2 {
        return 1.0;
    }
    let samples = n.min(SAMPLES);
    let reach = LOCAL * diag;
    let mut near = 0usize;
    for s in 0..samples {
        let i = s * n / samples;
        let (o, d) = (rays.org[i], rays.dir[i]);
        let (u, len) = (d.normalize_or_zero(), d.length());
        let end = (i + 1 + NEIGHBOURS).min(n);
        near += (i + 1..end).any(|j| {
            let l = (rays.t_max[i].min(rays.t_max[j]) * len).min(diag);
            let gap = o.distance(rays.org[j]) + l * u.distance(rays.dir[j].normalize_or_zero());
            gap <= reach
        }) as usize;
    }
    near as f32 / samples as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::{Pcg32, Ray};
    use trace::RayKind;

    /// Rays from points 0.001 apart along x, directions from `dir`, t_max `t`.
    fn batch(n: usize, t: f32, mut dir: impl FnMut(usize) -> Vec3) -> RayBatch {
        let mut b = RayBatch::with_capacity(n);
        for i in 0..n {
            let o = Vec3::new(i as f32 * 1e-3, 0.0, 0.0);
            b.push(
                Ray::new(o, dir(i), 0.0, t),
                RayKind::Shadow,
                i as u32,
                0,
                Vec3::ONE,
                0,
            );
        }
        b
    }

    /// Packets for rays towards one point and for short rays in random directions from
    /// neighbouring points; single rays for long rays in random directions.
    #[test]
    fn locality_tells_neighbouring_segments() {
        let mut rng = Pcg32::new(5, 9);
        let mut random = move |_| {
            let mut f = || 2.0 * rng.next_f32() - 1.0;
            Vec3::new(f(), f(), f()).normalize_or(Vec3::Z)
        };
        let diag = 10.0;
        let light = Vec3::new(3.0, 8.0, 2.0);
        let shadows = batch(3000, 1.0, |i| light - Vec3::new(i as f32 * 1e-3, 0.0, 0.0));
        assert!(locality(&shadows, diag) >= 0.99);
        let ao = batch(3000, 0.05 * diag, &mut random);
        assert!(locality(&ao, diag) >= 0.99);
        let far = batch(3000, f32::INFINITY, &mut random);
        let l = locality(&far, diag);
        assert!(l < COHERENT_SHARE / 2.0, "{l}");
    }
}
