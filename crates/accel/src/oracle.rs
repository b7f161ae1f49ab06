//! The brute-force oracle as a test harness for any engine: record the batches a render
//! traces (answered by brute force), and check another engine against them.

use render::{Hit, RayBatch, TraceMode, TraceStats, Tracer};
use std::sync::Mutex;

/// A tracer that forwards to `inner` and keeps every batch it was given with the answers.
/// Wrapping brute force records the oracle's answers; wrapping another engine records the
/// exact rays a render traced (benchmarks replay them for every configuration).
pub struct Recorder<'a> {
    pub inner: &'a dyn Tracer,
    pub batches: Mutex<Vec<(RayBatch, TraceMode, Vec<Hit>)>>,
}

impl<'a> Recorder<'a> {
    pub fn new(inner: &'a dyn Tracer) -> Self {
        Recorder {
            inner,
            batches: Mutex::new(Vec::new()),
        }
    }

    /// The recorded (rays, mode, hits), in trace order.
    pub fn into_batches(self) -> Vec<(RayBatch, TraceMode, Vec<Hit>)> {
        self.batches.into_inner().unwrap_or_else(|e| e.into_inner())
    }
}

impl Tracer for Recorder<'_> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        self.inner.trace(rays, mode, hits, stats);
        self.batches
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push((rays.clone(), mode, hits.to_vec()));
    }
}

/// Trace `rays` with `engine` and panic (naming `what` and the ray) unless the result equals
/// `expect`: closest-hit records bit for bit (one shared kernel and tie rule), any-hit as
/// booleans.
pub fn assert_same_hits(
    engine: &dyn Tracer,
    rays: &RayBatch,
    mode: TraceMode,
    expect: &[Hit],
    what: &str,
) {
    let mut got = vec![Hit::MISS; rays.len()];
    engine.trace(rays, mode, &mut got, &mut TraceStats::default());
    for (i, (g, e)) in got.iter().zip(expect).enumerate() {
        match mode {
            TraceMode::Closest => assert_eq!(g, e, "{what}: ray {i} {:?}", rays.ray(i)),
            TraceMode::Any => {
                assert_eq!(g.is_hit(), e.is_hit(), "{what}: ray {i} {:?}", rays.ray(i))
            }
        }
    }
}

/// Render `scene` with brute force and return every batch the Whitted loop traced, with
/// brute force's answers: the reference other engines are checked against.
pub fn record_render(
    scene: &scene::Scene,
    geo: &scene::Geometry,
    width: u32,
    height: u32,
    bounces: u32,
) -> Vec<(RayBatch, TraceMode, Vec<Hit>)> {
    let bf = crate::BruteForce::new(geo);
    let rec = Recorder::new(&bf);
    render::whitted::render(
        scene,
        geo,
        &rec,
        &render::whitted::RenderOptions {
            width,
            height,
            bounces,
        },
        &(),
    );
    rec.into_batches()
}
