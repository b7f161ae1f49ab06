//! `rayspace bench budget`: the irregular-grid paper's Table 4 — how many ambient-occlusion
//! samples per pixel each engine fits in a frame-time budget on an animated scene, with the
//! per-frame rebuild and the primary rays inside the budget.
//!
//! Per frame (a few instants of the animation): update the scene, build the engine, trace one
//! primary ray per pixel (closest hit), then one AO ray per pixel (any hit, from the
//! rasterized surfaces, as `rays --kind ao`). The AO samples that fit are
//! ⌊(budget − build − primary) / AO time per sample⌋, from the mean times over the frames.

use anyhow::Result;
use render::raygen::{generate, Kind, Options};
use render::View;
use scene::{Geometry, Scene};
use serde::Serialize;
use std::time::Instant;
use trace::{Hit, TraceMode, TraceStats, Tracer};

#[derive(Serialize, Clone, Debug)]
pub struct BudgetRow {
    pub scene: String,
    pub engine: String,
    pub frames: u32,
    pub build_ms: f64,
    pub primary_ms: f64,
    pub ao_ms_per_spp: f64,
    /// (budget ms, samples per pixel that fit).
    pub spp: Vec<(f64, u64)>,
}

/// Builds an engine for one frame's geometry.
pub type BuildFn = dyn Fn(&Geometry) -> Result<Box<dyn Tracer>>;

/// An engine's name and how to build it.
pub type Builder<'a> = (&'a str, &'a BuildFn);

/// Measure every engine on `frames` instants of `scene`.
pub fn run(
    scene: &Scene,
    engines: &[Builder],
    width: u32,
    height: u32,
    frames: u32,
    budgets_ms: &[f64],
    progress: &dyn Fn(&str),
) -> Result<Vec<BudgetRow>> {
    let times = match &scene.animation {
        Some(a) => a.frame_times(frames),
        None => vec![0.0; frames as usize],
    };
    // Per engine: summed build, primary and AO seconds. The frame's scene, geometry and rays
    // are made once and traced by every engine.
    let mut sums = vec![(0.0f64, 0.0f64, 0.0f64); engines.len()];
    for (i, &t) in times.iter().enumerate() {
        let s = scene.at_time(t);
        let geo = Geometry::from_scene(&s);
        let primary = View::new(&s.camera, width, height).primary_rays();
        let ao_rays = generate(
            &s,
            &geo,
            Kind::Ao,
            &Options {
                width,
                height,
                spp: 1,
                seed: i as u64 + 1,
                ao_distance: None,
            },
        );
        // AO rays start only where a surface was rasterized; a sample is one ray per pixel,
        // so scale to the full pixel count.
        let per_pixel = ((width * height) as f64 / ao_rays.len().max(1) as f64).max(1.0);
        for ((name, build), (b, p, ao)) in engines.iter().zip(sums.iter_mut()) {
            progress(&format!("{name}: frame {i} (t = {t:.2})"));
            let t0 = Instant::now();
            let e = build(&geo)?;
            *b += t0.elapsed().as_secs_f64();
            let mut hits = vec![Hit::MISS; primary.len()];
            let t1 = Instant::now();
            e.trace(
                &primary,
                TraceMode::Closest,
                &mut hits,
                &mut TraceStats::default(),
            );
            *p += t1.elapsed().as_secs_f64();
            let mut hits = vec![Hit::MISS; ao_rays.len()];
            let t2 = Instant::now();
            e.trace(
                &ao_rays,
                TraceMode::Any,
                &mut hits,
                &mut TraceStats::default(),
            );
            *ao += t2.elapsed().as_secs_f64() * per_pixel;
        }
    }
    let mut rows = Vec::new();
    for ((name, _), &(b, p, ao)) in engines.iter().zip(&sums) {
        let n = times.len().max(1) as f64;
        let (b, p, ao) = (b / n * 1e3, p / n * 1e3, ao / n * 1e3);
        let spp = budgets_ms
            .iter()
            .map(|&ms| {
                let left = ms - b - p;
                (
                    ms,
                    if left > 0.0 && ao > 0.0 {
                        (left / ao).floor() as u64
                    } else {
                        0
                    },
                )
            })
            .collect();
        rows.push(BudgetRow {
            scene: scene.name.clone(),
            engine: name.to_string(),
            frames,
            build_ms: b,
            primary_ms: p,
            ao_ms_per_spp: ao,
            spp,
        });
    }
    Ok(rows)
}

pub fn markdown(rows: &[BudgetRow], width: u32, height: u32) -> String {
    let budgets: Vec<f64> = rows
        .first()
        .map(|r| r.spp.iter().map(|x| x.0).collect())
        .unwrap_or_default();
    // Each engine as run: its name and every option's value (a frame's defaults).
    let as_run: Vec<String> = rows
        .iter()
        .filter_map(|r| crate::engines::Engine::parse(&r.engine).ok())
        .map(|e| {
            let cfg = crate::engines::config::defaults(e, crate::engines::Backend::Cpu, true);
            format!("`{}`", crate::engines::config::describe(e, &cfg))
        })
        .collect();
    let mut md = format!(
        "As run: {}.\n\n| engine | build ms | primary ms | AO ms per spp ({width}×{height}) |{}\n|---|---:|---:|---:|{}\n",
        as_run.join(", "),
        budgets.iter().map(|b| format!(" AO spp in {b} ms |")).collect::<String>(),
        "---:|".repeat(budgets.len())
    );
    for r in rows {
        md += &format!(
            "| {} | {:.1} | {:.1} | {:.1} |{}\n",
            r.engine,
            r.build_ms,
            r.primary_ms,
            r.ao_ms_per_spp,
            r.spp
                .iter()
                .map(|x| format!(" {} |", x.1))
                .collect::<String>()
        );
    }
    md
}
