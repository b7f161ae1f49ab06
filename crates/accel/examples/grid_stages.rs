//! The irregular-grid paper's Table 1 and Table 2 on a scene: for primary rays at W×H from the
//! scene's camera, N_T (traversal steps) and N_I (triangle tests) per ray and MRays/s after
//! each build stage (initial two-level grid, + merge, + merge and expansion), build time per
//! stage and memory; brute force on every 64th ray of the same set, in the same run.
//!
//! `cargo run --release -p accel --example grid_stages -- SCENE [W H]`

mod common;

use accel::grid::{build_grid, GridConfig, GridEngine};
use accel::BruteForce;
use render::View;
use std::time::Instant;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let spec = args.get(1).map(String::as_str).unwrap_or("cornell");
    let w: u32 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1024);
    let h: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(1024);
    let (s, geo) = common::load(spec);
    let rays = View::new(&s.camera, w, h).primary_rays();
    println!(
        "{}: {} triangles, {}x{} primary rays",
        s.name,
        geo.len(),
        w,
        h
    );
    println!("| stage | cells | refs | N_T/ray | N_I/ray | MRays/s | build ms | memory (cells/refs/map) B |");
    println!("|---|---:|---:|---:|---:|---:|---:|---|");
    let stages = GridConfig::stages();
    let mut reference: Option<Vec<Hit>> = None;
    for (name, cfg) in stages {
        let t0 = Instant::now();
        let g = build_grid(&geo.tris, &cfg).unwrap();
        let build = t0.elapsed().as_secs_f64();
        let (mc, mr, mv) = g.memory();
        let (cells, refs) = (g.cells(), g.refs.len());
        let e = GridEngine {
            grid: g,
            ..GridEngine::new(&geo, &GridConfig::two_level()).unwrap()
        };
        let mut hits = vec![Hit::MISS; rays.len()];
        let mut st = TraceStats::default();
        // Best of three timed runs.
        let mut best = f64::MAX;
        for _ in 0..3 {
            st = TraceStats::default();
            let t = Instant::now();
            e.trace(&rays, TraceMode::Closest, &mut hits, &mut st);
            best = best.min(t.elapsed().as_secs_f64());
        }
        let n = rays.len() as f64;
        println!(
            "| {name} | {cells} | {refs} | {:.2} | {:.2} | {:.2} | {:.0} | {mc}/{mr}/{mv} |",
            st.counters[accel::grid::TRAVERSAL_STEPS] as f64 / n,
            st.ray_tri_tests as f64 / n,
            n / best / 1e6,
            build * 1e3
        );
        if let Some(r) = &reference {
            assert_eq!(r, &hits, "every stage returns the same hits");
        }
        reference = Some(hits);
    }
    // Brute force on a subsample of the same rays.
    let idx: Vec<usize> = (0..rays.len()).step_by(64).collect();
    let mut sub = RayBatch::default();
    for &i in &idx {
        sub.push(
            rays.ray(i),
            trace::RayKind::Primary,
            i as u32,
            0,
            geom::Vec3::ONE,
            0,
        );
    }
    let mut hits = vec![Hit::MISS; sub.len()];
    let t = Instant::now();
    BruteForce::new(&geo).trace(
        &sub,
        TraceMode::Closest,
        &mut hits,
        &mut TraceStats::default(),
    );
    let secs = t.elapsed().as_secs_f64();
    let r = reference.unwrap();
    assert!(
        idx.iter().zip(&hits).all(|(&i, h)| r[i] == *h),
        "the grid agrees with brute force"
    );
    println!(
        "| brute force (every 64th ray) | | | | {} | {:.4} | | |",
        geo.len(),
        sub.len() as f64 / secs / 1e6
    );
}
