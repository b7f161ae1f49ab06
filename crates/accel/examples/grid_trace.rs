//! Trace the bench's three ray kinds (512² primary, 2-spp AO any-hit, random) through the
//! irregular grid of a scene and print MRays/s (best of N), N_T and N_I: the profiling loop
//! for traversal (run it under `perf record`). Hits are checked against the first run.
//!
//! `cargo run --release -p accel --example grid_trace -- SCENE [REPEATS] [paper|adaptive] [runs|pairs]`

mod common;

use accel::grid::{GridConfig, GridEngine, MergeRule, Subdivision};
use render::raygen::{generate, Kind, Options};
use render::View;
use std::time::Instant;
use trace::{Hit, TraceMode, TraceStats, Tracer};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let spec = args.get(1).map(String::as_str).unwrap_or("cornell");
    let repeats: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let (s, geo) = common::load(spec);
    let opts = Options {
        width: 512,
        height: 512,
        spp: 2,
        seed: 1,
        ao_distance: None,
    };
    let kinds = [
        (
            "primary",
            View::new(&s.camera, 512, 512).primary_rays(),
            TraceMode::Closest,
        ),
        ("ao", generate(&s, &geo, Kind::Ao, &opts), TraceMode::Any),
        (
            "random",
            generate(&s, &geo, Kind::Random, &Options { spp: 1, ..opts }),
            TraceMode::Closest,
        ),
    ];
    let cfg = GridConfig {
        subdivision: common::rule(args.get(3), Subdivision::Paper),
        merge_rule: common::rule(args.get(4), MergeRule::Runs),
        ..Default::default()
    };
    let e = GridEngine::new(&geo, &cfg).unwrap();
    println!(
        "{}: {} triangles, {} cells",
        s.name,
        geo.len(),
        e.grid.cells()
    );
    for (name, rays, mode) in &kinds {
        let mut best = f64::MAX;
        let mut first: Option<Vec<Hit>> = None;
        let mut st = TraceStats::default();
        for _ in 0..repeats {
            let mut hits = vec![Hit::MISS; rays.len()];
            st = TraceStats::default();
            let t = Instant::now();
            e.trace(rays, *mode, &mut hits, &mut st);
            best = best.min(t.elapsed().as_secs_f64());
            match &first {
                Some(f) => assert_eq!(f, &hits, "runs agree"),
                None => first = Some(hits),
            }
        }
        let n = rays.len() as f64;
        println!(
            "{name:>8}: {:7.2} MRays/s  N_T {:6.2}  N_I {:6.2}",
            n / best / 1e6,
            st.counters.get(accel::grid::TRAVERSAL_STEPS).unwrap_or(0) as f64 / n,
            st.ray_tri_tests as f64 / n
        );
    }
}
