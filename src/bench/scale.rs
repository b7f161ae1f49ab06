//! `rayspace bench scale`: every engine on generated scenes from thousands to millions of
//! triangles (`scene::generate`: the irregular-grid paper's scene classes, §6), so that a
//! structure whose build or memory grows faster than its input shows as a slope above 1.
//!
//! Per generator and size, in one process and on the same rays: each engine's build time,
//! its structure's bytes per triangle (`Tracer::structure_bytes`), MRays/s on primary,
//! shadow (any hit) and random rays (best of `repeats`), and tests per ray where the engine
//! counts them; each engine's hits checked against the irregular grid's (itself equal to
//! brute force's, by the test suite) with [`accel::oracle::Agreement`]. A caller may add the
//! whole-process peak memory of a `render` of the same scene with each engine, measured in a
//! child process (the only place a peak belongs to one engine). The slope of each measure
//! against the triangle count is fitted on a log–log scale (1: linear growth).

use super::charts;
use crate::engines::{self, Config, Engine};
use accel::oracle::Agreement;
use anyhow::Result;
use render::raygen::{generate, Kind, Options};
use scene::{Geometry, LoadOptions};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

/// What to run.
pub struct Spec {
    /// Generators (`scene::generate::NAMES`).
    pub generators: Vec<String>,
    /// Triangle counts.
    pub sizes: Vec<u64>,
    pub engines: Vec<Engine>,
    pub width: u32,
    pub height: u32,
    pub seed: u64,
    pub repeats: u32,
    /// Brute force runs only up to this many triangles.
    pub brute_max: u64,
}

/// One engine on one generated scene.
#[derive(Serialize, Clone, Debug)]
pub struct Row {
    pub generator: String,
    /// The size asked for, and the triangles generated.
    pub requested: u64,
    pub triangles: u64,
    pub engine: String,
    pub build_ms: f64,
    /// The engine's structure (`None`: the engine cannot say).
    pub structure_bytes: Option<u64>,
    pub structure_bytes_per_triangle: Option<f64>,
    /// The scene model the engines are built from (`scene::Geometry`), per triangle.
    pub geometry_bytes_per_triangle: f64,
    pub primary_mrays: f64,
    pub shadow_mrays: f64,
    pub random_mrays: f64,
    /// Tests per ray (primary, random) where the engine counts them all.
    pub primary_tests_per_ray: Option<f64>,
    pub random_tests_per_ray: Option<f64>,
    /// Records that disagree with the irregular grid's beyond the peers' stated tolerance.
    pub wrong: u64,
    /// Whole-process peak of `render SCENE -e ENGINE -b 0` at the same size (a child
    /// process), where measured.
    pub peak_rss_bytes: Option<u64>,
    /// The resident memory the engine's build added at its peak in that render
    /// (`render --stats`' `build_peak_bytes`), where measured.
    pub build_peak_bytes: Option<u64>,
}

/// What a render of one engine in a child process says of its memory.
#[derive(Clone, Copy, Debug, Default)]
pub struct Peaks {
    /// The whole process's peak.
    pub process: Option<u64>,
    /// What the engine's build added at its peak.
    pub build: Option<u64>,
}

/// A fitted exponent: `measure` ∝ triangles^slope for one engine on one generator.
#[derive(Serialize, Clone, Debug)]
pub struct Slope {
    pub generator: String,
    pub engine: String,
    pub measure: String,
    pub slope: f64,
}

/// Engines whose tests per ray are every test they make (see `report::counts_tests`).
fn counts_tests(e: Engine) -> bool {
    matches!(
        e,
        Engine::Bvh | Engine::Crsh | Engine::Rah | Engine::Grid | Engine::Grid2l | Engine::Brute
    )
}

/// Best seconds of `repeats` traces, with the stats of the last.
fn timed(
    e: &dyn Tracer,
    rays: &RayBatch,
    mode: TraceMode,
    repeats: u32,
    hits: &mut [Hit],
) -> (f64, TraceStats) {
    let mut best = f64::INFINITY;
    let mut stats = TraceStats::default();
    for _ in 0..repeats.max(1) {
        stats = TraceStats::default();
        let t = Instant::now();
        e.trace(rays, mode, hits, &mut stats);
        best = best.min(t.elapsed().as_secs_f64());
    }
    (best, stats)
}

/// Steps `progress` is called with per (generator, size): the load, then each engine.
pub fn steps(spec: &Spec) -> u64 {
    (spec.generators.len() * spec.sizes.len() * (1 + spec.engines.len())) as u64
}

/// Run the sweep. `peak(scene, engine)` measures a render's whole-process and build peaks
/// (or says `None`); `progress` is told each step.
pub fn run(
    spec: &Spec,
    peak: &dyn Fn(&str, Engine) -> Result<Peaks>,
    progress: &dyn Fn(&str),
) -> Result<(Vec<Row>, Vec<Slope>)> {
    let mut rows = Vec::new();
    for g in &spec.generators {
        for &n in &spec.sizes {
            let name = format!("{g}:{n}:{}", spec.seed);
            progress(&format!("{name}: generating"));
            let s = scene::load(&name, &LoadOptions::default())?;
            let geo = Geometry::from_scene(&s);
            let geo_bytes = geometry_bytes(&geo) as f64 / geo.len() as f64;
            let opts = Options {
                width: spec.width,
                height: spec.height,
                spp: 1,
                seed: spec.seed,
                ao_distance: None,
            };
            let kinds = [
                (Kind::Primary, TraceMode::Closest),
                (Kind::Shadow, TraceMode::Any),
                (Kind::Random, TraceMode::Closest),
            ];
            let rays: Vec<RayBatch> = kinds
                .iter()
                .map(|(k, _)| generate(&s, &geo, *k, &opts))
                .collect();
            // The reference records: the irregular grid's (brute force's, by the tests).
            let reference = engines::build(Engine::Grid, &Config::of(Engine::Grid), &geo)?.tracer;
            let expect: Vec<Vec<Hit>> = rays
                .iter()
                .zip(&kinds)
                .map(|(r, (_, mode))| {
                    let mut h = vec![Hit::MISS; r.len()];
                    reference.trace(r, *mode, &mut h, &mut TraceStats::default());
                    h
                })
                .collect();
            drop(reference);
            for &e in &spec.engines {
                progress(&format!("{name}: {}", e.name()));
                if e == Engine::Brute && geo.len() as u64 > spec.brute_max {
                    continue;
                }
                let t = Instant::now();
                let built = engines::build(e, &Config::of(e), &geo)?;
                let build_ms = t.elapsed().as_secs_f64() * 1e3;
                let tracer = built.tracer;
                let mut mrays = [0.0; 3];
                let mut tests = [None; 3];
                let mut wrong = 0;
                for (i, (r, (_, mode))) in rays.iter().zip(&kinds).enumerate() {
                    let mut hits = vec![Hit::MISS; r.len()];
                    let (secs, st) = timed(tracer.as_ref(), r, *mode, spec.repeats, &mut hits);
                    mrays[i] = r.len() as f64 / secs.max(1e-9) / 1e6;
                    if counts_tests(e) && !r.is_empty() {
                        tests[i] = Some(st.total_tests() as f64 / r.len() as f64);
                    }
                    let floor = if e.is_peer() { 1e-4 } else { 0.0 };
                    let mut a = Agreement::default();
                    a.check(&geo.tris, r, *mode, &expect[i], &hits, floor);
                    wrong += a.wrong;
                }
                let structure = tracer.structure_bytes();
                drop(tracer);
                let peaks = peak(&name, e)?;
                rows.push(Row {
                    generator: g.clone(),
                    requested: n,
                    triangles: geo.len() as u64,
                    engine: e.name().to_string(),
                    build_ms,
                    structure_bytes: structure,
                    structure_bytes_per_triangle: structure.map(|b| b as f64 / geo.len() as f64),
                    geometry_bytes_per_triangle: geo_bytes,
                    primary_mrays: mrays[0],
                    shadow_mrays: mrays[1],
                    random_mrays: mrays[2],
                    primary_tests_per_ray: tests[0],
                    random_tests_per_ray: tests[2],
                    wrong,
                    peak_rss_bytes: peaks.process,
                    build_peak_bytes: peaks.build,
                });
            }
        }
    }
    let slopes = slopes(spec, &rows);
    Ok((rows, slopes))
}

/// Bytes of the scene model the engines read (triangles, normals, materials, meshes).
fn geometry_bytes(g: &Geometry) -> usize {
    use std::mem::size_of_val;
    size_of_val(&g.tris[..])
        + size_of_val(&g.normals[..])
        + size_of_val(&g.material[..])
        + size_of_val(&g.mesh[..])
        + size_of_val(&g.mesh_first[..])
        + size_of_val(&g.mesh_local_sphere[..])
        + size_of_val(&g.mesh_sphere[..])
}

/// The measures whose growth with the triangle count is fitted.
const MEASURES: [&str; 4] = [
    "build_ms",
    "structure_bytes",
    "random_tests_per_ray",
    "random_ns_per_ray",
];

fn measure(r: &Row, m: &str) -> Option<f64> {
    match m {
        "build_ms" => Some(r.build_ms),
        "structure_bytes" => r.structure_bytes.map(|b| b as f64),
        "random_tests_per_ray" => r.random_tests_per_ray,
        _ => Some(1e3 / r.random_mrays.max(1e-12)),
    }
}

fn slopes(spec: &Spec, rows: &[Row]) -> Vec<Slope> {
    let mut out = Vec::new();
    for g in &spec.generators {
        for e in &spec.engines {
            for m in MEASURES {
                let pts: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| &r.generator == g && r.engine == e.name())
                    .filter_map(|r| measure(r, m).map(|y| (r.triangles as f64, y)))
                    .collect();
                if let Some(k) = charts::loglog_slope(&pts) {
                    out.push(Slope {
                        generator: g.clone(),
                        engine: e.name().to_string(),
                        measure: m.to_string(),
                        slope: k,
                    });
                }
            }
        }
    }
    out
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("n/a".into(), |v| format!("{v:.digits$}"))
}

/// The markdown tables: one row per (generator, size, engine), then the slopes.
pub fn markdown(rows: &[Row], slopes: &[Slope]) -> String {
    let mut md = String::from(
        "| scene | triangles | engine | build ms | structure B/tri | peak MB (render) | build peak MB | primary MRays/s | shadow MRays/s | random MRays/s | tests/ray primary | tests/ray random | wrong |\n|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        md += &format!(
            "| {} | {} | {} | {:.1} | {} | {} | {} | {:.2} | {:.2} | {:.2} | {} | {} | {} |\n",
            r.generator,
            r.triangles,
            r.engine,
            r.build_ms,
            opt(r.structure_bytes_per_triangle, 1),
            opt(r.peak_rss_bytes.map(|b| b as f64 / 1e6), 0),
            opt(r.build_peak_bytes.map(|b| b as f64 / 1e6), 0),
            r.primary_mrays,
            r.shadow_mrays,
            r.random_mrays,
            opt(r.primary_tests_per_ray, 1),
            opt(r.random_tests_per_ray, 1),
            r.wrong
        );
    }
    // Each engine as run: its name and every option's value (its defaults).
    let mut seen: Vec<&str> = Vec::new();
    for r in rows {
        if !seen.contains(&r.engine.as_str()) {
            seen.push(&r.engine);
        }
    }
    let as_run: Vec<String> = seen
        .iter()
        .filter_map(|n| Engine::parse(n).ok())
        .map(|e| format!("`{}`", crate::engines::config::describe(e, &Config::of(e))))
        .collect();
    md += &format!("\nAs run: {}.\n", as_run.join(", "));
    if let Some(r) = rows.first() {
        md += &format!(
            "\nThe scene model (`Geometry`) takes {:.0} bytes per triangle; every engine also keeps its own copy of the triangles (36 bytes each), not in its structure's bytes.\n",
            r.geometry_bytes_per_triangle
        );
    }
    md += "\n### Slopes: measure ∝ triangles^k (least squares on log–log; 1 is linear)\n\n| scene | engine | build ms | structure bytes | random tests/ray | random ns/ray |\n|---|---|---:|---:|---:|---:|\n";
    let mut keys: Vec<(&str, &str)> = slopes
        .iter()
        .map(|s| (s.generator.as_str(), s.engine.as_str()))
        .collect();
    keys.dedup();
    for (g, e) in keys {
        let k = |m: &str| {
            opt(
                slopes
                    .iter()
                    .find(|s| s.generator == g && s.engine == e && s.measure == m)
                    .map(|s| s.slope),
                2,
            )
        };
        md += &format!(
            "| {g} | {e} | {} | {} | {} | {} |\n",
            k(MEASURES[0]),
            k(MEASURES[1]),
            k(MEASURES[2]),
            k(MEASURES[3])
        );
    }
    md
}

/// The rows as CSV.
pub fn csv(rows: &[Row]) -> String {
    let f = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.4}"));
    let mut s = String::from("generator,requested,triangles,engine,build_ms,structure_bytes,structure_bytes_per_triangle,geometry_bytes_per_triangle,primary_mrays,shadow_mrays,random_mrays,primary_tests_per_ray,random_tests_per_ray,wrong,peak_rss_bytes,build_peak_bytes\n");
    for r in rows {
        s += &format!(
            "{},{},{},{},{:.3},{},{},{:.1},{:.4},{:.4},{:.4},{},{},{},{},{}\n",
            r.generator,
            r.requested,
            r.triangles,
            r.engine,
            r.build_ms,
            r.structure_bytes.map_or(String::new(), |b| b.to_string()),
            f(r.structure_bytes_per_triangle),
            r.geometry_bytes_per_triangle,
            r.primary_mrays,
            r.shadow_mrays,
            r.random_mrays,
            f(r.primary_tests_per_ray),
            f(r.random_tests_per_ray),
            r.wrong,
            r.peak_rss_bytes.map_or(String::new(), |b| b.to_string()),
            r.build_peak_bytes.map_or(String::new(), |b| b.to_string()),
        );
    }
    s
}

/// Log–log charts per generator: build ms and random ns per ray against triangles.
pub fn charts(spec: &Spec, rows: &[Row], dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for g in &spec.generators {
        for (m, title, y) in [
            ("build_ms", "build", "build ms"),
            ("random_ns_per_ray", "random rays", "ns per ray"),
        ] {
            let series: Vec<(String, Vec<(f64, f64)>)> = spec
                .engines
                .iter()
                .map(|e| {
                    let p = rows
                        .iter()
                        .filter(|r| &r.generator == g && r.engine == e.name())
                        .filter_map(|r| measure(r, m).map(|v| (r.triangles as f64, v)))
                        .collect();
                    (e.name().to_string(), p)
                })
                .filter(|(_, p): &(String, Vec<(f64, f64)>)| !p.is_empty())
                .collect();
            let t = format!("{g}: {title}");
            files.extend(charts::loglog_lines(
                &dir.join(format!("scale-{}-{m}", charts::slug(g))),
                &charts::Lines {
                    title: &t,
                    x_label: "triangles",
                    y_label: y,
                    series: &series,
                },
            )?);
        }
    }
    Ok(files)
}
