//! The tracing trait every engine implements, so engines can be swapped and compared on
//! identical rays.

use crate::batch::{Hit, RayBatch};
use crate::stats::{PassTime, TraceStats};

/// What a trace call asks for each ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceMode {
    /// Nearest hit in (t_min, t_max): reflection, refraction, primary rays.
    Closest,
    /// Any hit in (t_min, t_max): shadow rays (occlusion only).
    Any,
}

/// An engine: traces batches of rays against the scene it was built for. Every engine
/// returns brute force's records (closest hit: same triangle, same t bits), so engines are
/// swapped and compared on identical rays.
pub trait Tracer: Sync {
    /// Engine name as used on the command line.
    fn name(&self) -> &str;

    /// Trace every ray of `rays`, writing one record per ray into `hits`
    /// (`hits.len() == rays.len()`), and add this call's counters to `stats`.
    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats);

    /// The engine's build passes with their times, for engines built once before tracing
    /// (reported beside the "engine build" phase); empty for the others.
    fn build_passes(&self) -> Vec<PassTime> {
        Vec::new()
    }

    /// Bytes of the engine's acceleration structure, as built: what traversal reads besides
    /// the triangles (every engine keeps its own copy of those, 36 bytes each, not counted
    /// here). `None` where the engine cannot say (a library's opaque structure).
    fn structure_bytes(&self) -> Option<u64> {
        None
    }
}

/// The per-ray engines' whole `trace`: `one(ray)` answers one ray with its record and the
/// number of ray–triangle tests it made; rays run in parallel, and the counters (rays, tests,
/// hits) are added to `stats`.
pub fn trace_per_ray(
    rays: &RayBatch,
    hits: &mut [Hit],
    stats: &mut TraceStats,
    one: impl Fn(&geom::Ray) -> (Hit, u64) + Sync,
) {
    use rayon::prelude::*;
    assert_eq!(hits.len(), rays.len(), "one hit record per ray");
    let tests: u64 = hits
        .par_iter_mut()
        .enumerate()
        .with_min_len(64)
        .map(|(i, out)| {
            let (h, n) = one(&rays.ray(i));
            *out = h;
            n
        })
        .sum();
    stats.rays += rays.len() as u64;
    stats.ray_tri_tests += tests;
    stats.hits += hits.iter().filter(|h| h.is_hit()).count() as u64;
}
