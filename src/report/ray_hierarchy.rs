//! "When does a ray-space hierarchy pay?": per scene and ray kind, CRSH's and RAH's ray
//! hierarchies (thesis §3.2: rays hashed, sorted and bundled into sphere-cone nodes; RAH:
//! the screen-space pyramid of Roger et al. 2007) against `bvh`, the same object tree
//! walked by packets and single rays without any ray hierarchy, on the same rays.
//!
//! The rays are those a CRSH render traces (`bench::record`: shadow rays and the
//! reflection and refraction generations), split by kind, each kind traced by every engine
//! in the batches the render made. A row gives the tests of each kind (the ray hierarchy's
//! node tests, single rays' ray–box tests, exact ray–triangle tests), the ray side's time
//! (CRSH/RAH: hash, trim, compress, sort, decompress or screen order, hierarchy creation:
//! the phases their stats mark as build), the traversal's and the total. CRSH against RAH
//! over the same object tree is what the hash and sort buy over screen order, with and
//! without their cost. Beside it the thesis's own claim (Tables 4.4–4.24: CRSH makes fewer
//! tests than RAH with mesh spheres), from the report's chapter-4 rows.

use crate::bench;
use crate::engines::{config, Backend, Engine};
use anyhow::{ensure, Result};
use serde::Serialize;
use std::time::Instant;
use trace::{Hit, RayBatch, RayKind, TraceMode, TraceStats, RAY_BOX_TESTS};

/// The section's figures (`report.json`'s `ray_hierarchy`).
#[derive(Clone, Debug, Default, Serialize)]
pub struct RayHierarchy {
    /// One row per scene, ray kind and engine.
    pub rows: Vec<PayRow>,
    /// The thesis's claim per scene: CRSH's and RAH's tests with mesh spheres.
    pub claim: Vec<Claim>,
}

/// One engine on one kind of one scene's rays.
#[derive(Clone, Debug, Serialize)]
pub struct PayRow {
    pub scene: String,
    /// `shadow`, `reflection` or `refraction`.
    pub kind: String,
    pub engine: String,
    /// The object side: `bvh` (the per-frame object tree) for all three here.
    pub objects: String,
    pub rays: u64,
    /// Every test (the three below).
    pub tests: u64,
    /// Ray-hierarchy node tests (sphere and cone against an object node or a triangle).
    pub node_tests: u64,
    /// Single rays' slab tests against object nodes.
    pub ray_box_tests: u64,
    /// Exact ray–triangle tests.
    pub ray_tri_tests: u64,
    /// The ray side: the hierarchy's build phases (0 for `bvh`).
    pub ray_side_ms: f64,
    /// The traversal and final tests (total less the ray side).
    pub trace_ms: f64,
    pub total_ms: f64,
    /// Total per ray.
    pub ns_per_ray: f64,
    /// Records that differ from brute force's (the recorded CRSH render's): 0.
    pub wrong: u64,
}

/// The thesis's claim on one scene, from the chapter-4 rows (mesh spheres).
#[derive(Clone, Debug, Serialize)]
pub struct Claim {
    pub scene: String,
    /// The configuration compared (B × D).
    pub config: String,
    pub crsh_tests: u64,
    pub rah_tests: u64,
    /// CRSH makes fewer tests than RAH.
    pub holds: bool,
}

/// The engines compared: the ray hierarchies over the object tree and `bvh`.
const ENGINES: [Engine; 3] = [Engine::Crsh, Engine::Rah, Engine::Bvh];

/// The section for `scenes` at `side`² with `bounces` generations, the best of `repeats`
/// runs per row; `thesis` the report's chapter-4 rows.
pub fn run(
    scenes: &[String],
    side: u32,
    bounces: u32,
    repeats: u32,
    thesis: &[bench::rsh::Row],
    progress: &dyn Fn(&str),
) -> Result<RayHierarchy> {
    let mut out = RayHierarchy::default();
    for name in scenes {
        progress(&format!("{name}: when a ray hierarchy pays"));
        let (s, geo, batches) = bench::record(name, side, side, bounces)?;
        for kind in [RayKind::Shadow, RayKind::Reflection, RayKind::Refraction] {
            let parts = of_kind(&batches, kind);
            let rays: u64 = parts.iter().map(|p| p.0.len() as u64).sum();
            if rays == 0 {
                continue;
            }
            for e in ENGINES {
                let tracer =
                    crate::engines::build(e, &config::defaults(e, Backend::Cpu, false), &geo)?
                        .tracer;
                let mut best: Option<(f64, TraceStats)> = None;
                let mut wrong = 0;
                for _ in 0..repeats.max(1) {
                    let mut st = TraceStats::default();
                    let t0 = Instant::now();
                    let mut got = Vec::with_capacity(parts.len());
                    for (b, mode, _) in &parts {
                        let mut h = vec![Hit::MISS; b.len()];
                        tracer.trace(b, *mode, &mut h, &mut st);
                        got.push(h);
                    }
                    let secs = t0.elapsed().as_secs_f64();
                    wrong = parts
                        .iter()
                        .zip(&got)
                        .map(|((_, mode, want), h)| differing(*mode, want, h))
                        .sum();
                    if best.as_ref().is_none_or(|b| secs < b.0) {
                        best = Some((secs, st));
                    }
                }
                let (secs, st) = best.expect("one run");
                ensure!(
                    wrong == 0,
                    "{}: {} {} rays: {wrong} records differ from brute force's",
                    s.name,
                    e.name(),
                    kind.name()
                );
                let side_s: f64 = st
                    .phases
                    .iter()
                    .filter(|(p, _)| p.is_build())
                    .fold(0.0, |a, (_, t)| a + t);
                let ray_box = st.counters.get(RAY_BOX_TESTS).unwrap_or(0);
                out.rows.push(PayRow {
                    scene: s.name.clone(),
                    kind: kind.name().to_string(),
                    engine: e.name().to_string(),
                    objects: "bvh".into(),
                    rays,
                    tests: st.total_tests(),
                    node_tests: st.node_tri_tests,
                    ray_box_tests: ray_box,
                    ray_tri_tests: st.ray_tri_tests,
                    ray_side_ms: side_s * 1e3,
                    trace_ms: (secs - side_s).max(0.0) * 1e3,
                    total_ms: secs * 1e3,
                    ns_per_ray: secs * 1e9 / rays as f64,
                    wrong,
                });
            }
        }
        drop(geo);
    }
    out.claim = claim(thesis);
    Ok(out)
}

/// The recorded batches' rays of `kind`, each batch's part with its mode and records (the
/// batches keep their image width: RAH orders its rays by pixel).
fn of_kind(
    batches: &[(RayBatch, TraceMode, Vec<Hit>)],
    kind: RayKind,
) -> Vec<(RayBatch, TraceMode, Vec<Hit>)> {
    batches
        .iter()
        .filter_map(|(b, mode, hits)| {
            let mut part = RayBatch::with_capacity(b.len());
            part.width = b.width;
            let mut want = Vec::new();
            for i in (0..b.len()).filter(|&i| b.kind[i] == kind as u8) {
                part.push(
                    b.ray(i),
                    kind,
                    b.pixel[i],
                    b.light[i],
                    b.throughput[i],
                    b.depth[i],
                );
                want.push(hits[i]);
            }
            (!part.is_empty()).then_some((part, *mode, want))
        })
        .collect()
}

/// Records of `got` that are not `want`'s: closest hits bit for bit, any hits as hit or
/// miss.
fn differing(mode: TraceMode, want: &[Hit], got: &[Hit]) -> u64 {
    want.iter()
        .zip(got)
        .filter(|(a, b)| match mode {
            TraceMode::Any => a.is_hit() != b.is_hit(),
            TraceMode::Closest => {
                a.tri != b.tri
                    || a.t.to_bits() != b.t.to_bits()
                    || a.u.to_bits() != b.u.to_bits()
                    || a.v.to_bits() != b.v.to_bits()
            }
        })
        .count() as u64
}

/// Per scene of the chapter-4 rows, CRSH's and RAH's tests with mesh spheres at the
/// thesis's default configuration (8 × 3; else the first both ran).
fn claim(thesis: &[bench::rsh::Row]) -> Vec<Claim> {
    let mut scenes: Vec<&str> = thesis.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    scenes
        .into_iter()
        .filter_map(|sc| {
            let of = |e: &str, b: u32, d: u32| {
                thesis.iter().find(|r| {
                    r.scene == sc
                        && r.engine == e
                        && r.objects == "mesh-spheres"
                        && r.branching == b
                        && r.levels == d
                })
            };
            let configs = thesis
                .iter()
                .filter(|r| r.scene == sc)
                .map(|r| (r.branching, r.levels));
            let (b, d) = std::iter::once((8, 3))
                .chain(configs)
                .find(|&(b, d)| of("crsh", b, d).is_some() && of("rah", b, d).is_some())?;
            let (c, r) = (of("crsh", b, d)?, of("rah", b, d)?);
            Some(Claim {
                scene: sc.to_string(),
                config: format!("{b} × {d}"),
                crsh_tests: c.total_tests,
                rah_tests: r.total_tests,
                holds: c.total_tests < r.total_tests,
            })
        })
        .collect()
}
