//! The front door: a mesh from arrays, an engine, a batch of rays, the hits.
//!
//! `cargo run --release --example own_mesh [ENGINE]` builds a torus (vertex and face
//! arrays, as a program that owns its geometry holds them), builds an engine over it
//! (`bvh` unless named: any of `rayspace engines`), casts a 256 × 256 grid of parallel
//! rays down at it, prints "N rays, M hits" and where the nearest hit is, then moves the
//! torus, rebuilds the engine and traces again.

use rayspace::{Engine, Ray, Scene, SceneEngine, TraceMode, Vec3};
use std::process::ExitCode;

/// A torus of radii `big` and `small` in the xz-plane: (vertices, faces).
fn torus(big: f32, small: f32, rings: u32, sides: u32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut v = Vec::new();
    for i in 0..rings {
        let a = i as f32 / rings as f32 * std::f32::consts::TAU;
        for j in 0..sides {
            let b = j as f32 / sides as f32 * std::f32::consts::TAU;
            let r = big + small * b.cos();
            v.push([r * a.cos(), small * b.sin(), r * a.sin()]);
        }
    }
    let at = |i: u32, j: u32| (i % rings) * sides + j % sides;
    let mut f = Vec::new();
    for i in 0..rings {
        for j in 0..sides {
            let (p, q, r, s) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            f.push([p, r, q]);
            f.push([p, s, r]);
        }
    }
    (v, f)
}

/// A `side` × `side` grid of rays pointing down (−y) over the square [−2, 2]².
fn sensor(side: u32, height: f32) -> Vec<Ray> {
    let mut rays = Vec::with_capacity((side * side) as usize);
    for i in 0..side {
        for j in 0..side {
            let x = -2.0 + 4.0 * (i as f32 + 0.5) / side as f32;
            let z = -2.0 + 4.0 * (j as f32 + 0.5) / side as f32;
            rays.push(Ray::new(
                Vec3::new(x, height, z),
                Vec3::NEG_Y,
                0.0,
                f32::INFINITY,
            ));
        }
    }
    rays
}

fn run(engine: Engine) -> Result<(), Box<dyn std::error::Error>> {
    let (vertices, faces) = torus(1.2, 0.4, 48, 24);
    let mut scene = Scene::from_arrays(&vertices, &faces)?;
    let mut tracer = SceneEngine::new(&scene, engine, &[])?;
    let rays = sensor(256, 3.0);
    let hits = tracer.trace(&scene, &rays, TraceMode::Closest)?;
    let hit = hits.iter().filter(|h| h.is_hit()).count();
    println!(
        "{} rays, {hit} hits ({} triangles, engine {})",
        rays.len(),
        faces.len(),
        engine.name()
    );
    if let Some(h) = hits
        .iter()
        .filter(|h| h.is_hit())
        .min_by(|a, b| a.t.total_cmp(&b.t))
    {
        println!(
            "nearest: face {} at t = {} (point {}, normal {})",
            h.tri,
            h.t,
            tracer.point(h).expect("a hit"),
            tracer.normal(h).expect("a hit")
        );
    }
    // The torus sinks by 0.5: an engine built before must be rebuilt to see it.
    let moved: Vec<[f32; 3]> = vertices.iter().map(|p| [p[0], p[1] - 0.5, p[2]]).collect();
    scene.set_vertices(0, &moved)?;
    tracer.rebuild(&scene)?;
    let again = tracer.trace(&scene, &rays, TraceMode::Closest)?;
    let moved_by = again
        .iter()
        .zip(&hits)
        .find(|(a, b)| a.is_hit() && b.is_hit())
        .map(|(a, b)| a.t - b.t);
    println!(
        "after moving the torus down by 0.5: {} hits, the first {} farther",
        again.iter().filter(|h| h.is_hit()).count(),
        moved_by.unwrap_or(f32::NAN)
    );
    Ok(())
}

fn main() -> ExitCode {
    let name = std::env::args().nth(1).unwrap_or_else(|| "bvh".into());
    let engine = match Engine::parse(&name) {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    match run(engine) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
