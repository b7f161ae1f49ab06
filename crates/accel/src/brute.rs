//! The brute-force engine: every ray against every triangle, parallel over rays.

use geom::tri::RayPre;
use geom::{intersect, Vec3};
use scene::Geometry;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

/// The memory model of the engine's build: the resident bytes it adds per triangle at its
/// peak (its copy of the triangles), over the measured 37–40 (`bench/results/2026-12-07-2core/
/// memory.txt`), checked against the memory limit before it is built.
pub const BUILD_BYTES_PER_TRIANGLE: u64 = 48;

/// Triangles in one flat array; nothing else.
pub struct BruteForce {
    tris: Vec<[Vec3; 3]>,
}

impl BruteForce {
    /// The engine over `geo`'s triangles (no build beyond a copy).
    pub fn new(geo: &Geometry) -> Self {
        BruteForce {
            tris: geo.tris.clone(),
        }
    }

    /// Closest hit (smallest t, ties to the smallest id) or any hit of one ray; returns the
    /// record and the number of triangle tests made.
    #[inline]
    pub fn trace_one(tris: &[[Vec3; 3]], ray: &geom::Ray, mode: TraceMode) -> (Hit, u64) {
        let mut pre = RayPre::new(ray);
        let mut best = Hit::MISS;
        for (i, t) in tris.iter().enumerate() {
            if let Some(h) = intersect(&pre, t[0], t[1], t[2]) {
                best = Hit {
                    tri: i as u32,
                    t: h.t,
                    u: h.u,
                    v: h.v,
                };
                if mode == TraceMode::Any {
                    return (best, i as u64 + 1);
                }
                // Later triangles must be strictly closer: ties keep the smaller id.
                pre.t_max = h.t;
            }
        }
        (best, tris.len() as u64)
    }
}

impl Tracer for BruteForce {
    fn structure_bytes(&self) -> Option<u64> {
        Some(0) // No structure: every ray tests every triangle.
    }

    fn name(&self) -> &str {
        "brute"
    }

    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        trace::trace_per_ray(rays, hits, stats, |ray| {
            Self::trace_one(&self.tris, ray, mode)
        });
    }
}
