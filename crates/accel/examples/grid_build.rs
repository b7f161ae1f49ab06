//! Build the irregular grid of a scene several times and print each pass's best time: the
//! profiling loop for the build (run it under `perf record` to see inside a pass).
//!
//! `cargo run --release -p accel --example grid_build -- SCENE [REPEATS] [paper|adaptive] [runs|pairs]`
//!
//! It also prints a hash of everything the build makes (voxel map, cell boxes, expanded boxes,
//! reference ranges and references), so a change meant to leave the grid alone can be
//! checked to build the same bytes.

mod common;

use accel::grid::{build_grid, GridConfig, MergeRule, Subdivision};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let spec = args.get(1).map(String::as_str).unwrap_or("cornell");
    let repeats: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10);
    let cfg = GridConfig {
        subdivision: common::rule(args.get(3), Subdivision::Paper),
        merge_rule: common::rule(args.get(4), MergeRule::Runs),
        ..Default::default()
    };
    let (s, geo) = common::load(spec);
    let mut best: Option<Vec<(String, f64)>> = None;
    let mut cells = 0;
    let mut shape = (0, 0, 0);
    let mut hash = 0u64;
    let mut best_total = f64::MAX;
    for _ in 0..repeats {
        let g = build_grid(&geo.tris, &cfg).unwrap();
        cells = g.cells();
        shape = (g.build.initial_cells, g.build.merge_rounds, g.refs.len());
        if hash == 0 {
            hash = structure_hash(&g); // the same bytes every time: hashed once
        }
        let p = g.build.passes();
        best_total = best_total.min(p.iter().map(|x| x.seconds).sum());
        best = Some(match best {
            None => p.iter().map(|x| (x.name(), x.seconds)).collect(),
            Some(b) => b
                .iter()
                .zip(p.iter())
                .map(|(a, b)| (a.0.clone(), a.1.min(b.seconds)))
                .collect::<Vec<_>>(),
        });
    }
    println!(
        "{}: {} triangles, {} initial cells, {} merge rounds, {} cells, {} references",
        s.name,
        geo.len(),
        shape.0,
        shape.1,
        cells,
        shape.2
    );
    println!("structure hash {hash:016x}");
    for (name, t) in best.unwrap() {
        println!("{name:>12} {:8.2} ms", t * 1e3);
    }
    println!("{:>12} {:8.2} ms", "total", best_total * 1e3);
}

/// FNV-1a over the grid's arrays, in a fixed order.
fn structure_hash(g: &accel::grid::Grid) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |v: u32| {
        for b in v.to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    for boxes in [&g.cell_min, &g.cell_max, &g.exp_min, &g.exp_max] {
        boxes.iter().flatten().for_each(|&v| eat(v));
    }
    for a in [&g.ref_first, &g.refs, &g.entries] {
        a.iter().for_each(|&v| eat(v));
    }
    h
}
