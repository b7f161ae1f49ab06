//! The object tree's builders side by side (issue 43): per scene, each builder's median
//! build time over 11 builds (the whole `objects::build`: boxes, tree and the single-ray
//! path's records, or the dual traversal's as well) and the surface-area metric of its
//! single-ray tree (expected nodes and triangle tests per ray).
//!
//! `cargo run --profile ci -p accel --example object_trees -- SCENE...` (scene files or
//! built-in names; default: the bench Sponza).

use accel::bvh::objects::{build, ObjectBuilder, Parts};
use scene::{Geometry, LoadOptions};
use std::time::Instant;

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    if args.is_empty() {
        args.push(
            concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../bench/scenes/sponza.toml"
            )
            .into(),
        );
    }
    println!(
        "| scene | triangles | builder | records | build ms (median of 11) | nodes/ray | triangles/ray |"
    );
    println!("|---|---:|---|---|---:|---:|---:|");
    for a in &args {
        let s = match scene::load(a, &LoadOptions::default()) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{a}: {e}");
                std::process::exit(1);
            }
        };
        let geo = Geometry::from_scene(&s);
        for (name, b, parts, pname) in ObjectBuilder::NAMES.into_iter().flat_map(|(n, b)| {
            [
                (
                    n,
                    b,
                    Parts {
                        dual: false,
                        single: true,
                    },
                    "single",
                ),
                (n, b, Parts::ALL, "both"),
            ]
        }) {
            let mut ms: Vec<f64> = (0..11)
                .map(|_| {
                    let t0 = Instant::now();
                    std::hint::black_box(build(
                        &geo.tris,
                        &geo.mesh_first,
                        Some(&geo.mesh_sphere),
                        b,
                        parts,
                    ));
                    t0.elapsed().as_secs_f64() * 1e3
                })
                .collect();
            ms.sort_by(f64::total_cmp);
            let t = build(&geo.tris, &geo.mesh_first, Some(&geo.mesh_sphere), b, parts);
            let (nodes, tris) = t.sah_metric();
            println!(
                "| {} | {} | {name} | {pname} | {:.1} | {nodes:.2} | {tris:.2} |",
                s.name,
                geo.tris.len(),
                ms[5]
            );
        }
    }
}
