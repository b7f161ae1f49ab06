//! The `obvhs` peer: a BVH2 or CWBVH from the `obvhs` crate, traversed by its own code, with
//! our shared watertight kernel as the leaf intersection callback.

use geom::tri::RayPre;
use geom::{intersect, Vec3};
use glam::Vec3A;
use obvhs::ray::{Ray as ORay, RayHit as ORayHit};
use obvhs::triangle::Triangle as OTri;
use obvhs::BvhBuildParams;
use scene::Geometry;
use std::time::{Duration, Instant};
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

/// Which obvhs hierarchy to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BvhKind {
    /// Binary BVH (PLOC build, reinsertion optimisation, leaves collapsed).
    Bvh2,
    /// Compressed 8-wide BVH (Ylitie et al. 2017), obvhs's fastest CPU traversal.
    CwBvh,
}

enum Bvh {
    Two(obvhs::bvh2::Bvh2),
    Wide(obvhs::cwbvh::CwBvh),
}

/// A peer engine: obvhs's hierarchy over the scene's triangles.
pub struct ObvhsEngine {
    name: &'static str,
    tris: Vec<[Vec3; 3]>,
    bvh: Bvh,
    /// Wall time of the build (including obvhs's own pre-processing).
    pub build_seconds: f64,
}

impl ObvhsEngine {
    /// Build with obvhs's `medium_build` preset, the one its documentation recommends for
    /// static scenes traced many times.
    pub fn new(geo: &Geometry, kind: BvhKind) -> Self {
        let start = Instant::now();
        let otris: Vec<OTri> = geo
            .tris
            .iter()
            .map(|t| OTri {
                v0: Vec3A::from(t[0]),
                v1: Vec3A::from(t[1]),
                v2: Vec3A::from(t[2]),
            })
            .collect();
        let params = BvhBuildParams::medium_build();
        let mut core = Duration::default();
        let (name, bvh) = match kind {
            BvhKind::Bvh2 => (
                "obvhs-bvh2",
                Bvh::Two(obvhs::bvh2::builder::build_bvh2_from_tris(
                    &otris, params, &mut core,
                )),
            ),
            BvhKind::CwBvh => (
                "obvhs-cwbvh",
                Bvh::Wide(obvhs::cwbvh::builder::build_cwbvh_from_tris(
                    &otris, params, &mut core,
                )),
            ),
        };
        ObvhsEngine {
            name,
            tris: geo.tris.clone(),
            bvh,
            build_seconds: start.elapsed().as_secs_f64(),
        }
    }

    /// Bytes of the hierarchy (nodes and primitive indices; the triangles are not counted,
    /// as for our engines).
    pub fn memory_bytes(&self) -> usize {
        match &self.bvh {
            Bvh::Two(b) => {
                b.nodes.len() * std::mem::size_of::<obvhs::bvh2::node::Bvh2Node>()
                    + b.primitive_indices.len() * 4
            }
            Bvh::Wide(b) => {
                b.nodes.len() * std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>()
                    + b.primitive_indices.len() * 4
            }
        }
    }

    fn primitive_indices(&self) -> &[u32] {
        match &self.bvh {
            Bvh::Two(b) => &b.primitive_indices,
            Bvh::Wide(b) => &b.primitive_indices,
        }
    }

    /// One ray; returns the record and the number of triangle tests.
    fn trace_one(&self, ray: &geom::Ray, mode: TraceMode) -> (Hit, u64) {
        // NaN bounds compare false, so this is also true for them.
        let empty = ray.t_max.partial_cmp(&ray.t_min) != Some(std::cmp::Ordering::Greater);
        if empty || self.tris.is_empty() {
            return (Hit::MISS, 0);
        }
        let pre = RayPre::new(ray);
        // `+ 0.0` turns −0.0 components into +0.0: obvhs picks the CWBVH octant from
        // `d < 0` but inverts −0.0 to −∞-like values, so a −0.0 component makes the two
        // disagree and every box is missed. The ray is the same; our kernel gets the original.
        let oray = ORay::new(
            Vec3A::from(ray.org),
            Vec3A::from(ray.dir + Vec3::ZERO),
            ray.t_min,
            ray.t_max,
        );
        let indices = self.primitive_indices();
        let mut best = Hit::MISS;
        let mut tests = 0u64;
        // The callback keeps our tie rule (smallest t, then smallest id) in `best`; it tells
        // obvhs the hit's t so that obvhs shrinks its own interval and culls farther nodes.
        let mut leaf = |_: &ORay, id: usize| -> f32 {
            tests += 1;
            let tri = indices[id];
            let v = &self.tris[tri as usize];
            match intersect(&pre, v[0], v[1], v[2]) {
                Some(h) => {
                    if best.closer(h.t, tri) {
                        best = Hit {
                            tri,
                            t: h.t,
                            u: h.u,
                            v: h.v,
                        };
                    }
                    h.t
                }
                None => f32::INFINITY,
            }
        };
        match (&self.bvh, mode) {
            (Bvh::Two(b), TraceMode::Closest) => {
                b.ray_traverse(oray, &mut ORayHit::none(), &mut leaf);
            }
            (Bvh::Wide(b), TraceMode::Closest) => {
                b.ray_traverse(oray, &mut ORayHit::none(), &mut leaf);
            }
            (Bvh::Two(b), TraceMode::Any) => {
                b.ray_traverse_miss(oray, &mut leaf);
            }
            (Bvh::Wide(b), TraceMode::Any) => {
                b.ray_traverse_miss(oray, &mut leaf);
            }
        }
        (best, tests)
    }
}

impl Tracer for ObvhsEngine {
    fn structure_bytes(&self) -> Option<u64> {
        Some(self.memory_bytes() as u64)
    }

    fn name(&self) -> &str {
        self.name
    }

    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        trace::trace_per_ray(rays, hits, stats, |ray| self.trace_one(ray, mode));
    }
}
