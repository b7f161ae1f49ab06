//! Shared test support for the rayspace crates (a dev-dependency only, never built into the
//! library): proptest strategies, random scenes and ray batches, small closed meshes,
//! scratch directories and the skip rule. The generators are deterministic in their seed, so
//! a property-test failure reproduces with `PROPTEST_RNG_SEED`.

#![warn(missing_docs)]

use geom::{Pcg32, Ray, Vec3};
use proptest::prelude::*;
use scene::{builtin, Geometry};
use std::path::PathBuf;
use trace::{RayBatch, RayKind};

/// Points uniform in the cube [−r, r)³.
pub fn v3(r: f32) -> impl Strategy<Value = Vec3> {
    (-r..r, -r..r, -r..r).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// An icosahedron scaled by `scale` and moved by `offset`, as a triangle soup: a closed mesh
/// whose every edge and vertex is shared (watertightness tests).
pub fn icosahedron(scale: f32, offset: Vec3) -> Vec<[Vec3; 3]> {
    let (v, f) = geom::polyhedra::icosahedron();
    let v = v.map(|p| p * scale + offset);
    f.iter().map(|i| i.map(|k| v[k as usize])).collect()
}

/// A fresh scratch directory for one test (`tag` names it; the process id keeps parallel
/// test runs apart). Emptied first: process ids come round again (32,768 of them on Linux
/// by default), and a directory an earlier run left under the same id would hold its
/// outputs, which tests that check a refused command wrote nothing would find.
pub fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rayspace-{tag}-{}", std::process::id()));
    match std::fs::remove_dir_all(&d) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            panic!("cannot clear {}: {e}", d.display())
        }
        _ => {}
    }
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A test that cannot run here for want of `need` (`gpu`: a GPU driver; `scenes`: the shared
/// real scenes; `display`: an X server; `avx2`: the CPU of the grid's 8-lane kernel): prints
/// one `SKIPPED: why` line straight to the terminal (the test harness hides a passing test's
/// captured output), and the caller returns. A skipped test is not
/// a passed test: where `need` is listed in `RAYSPACE_REQUIRE` (comma-separated; `.ci/run`
/// sets it), it panics instead, so CI fails rather than reporting "ok".
pub fn skip(need: &str, why: impl std::fmt::Display) {
    if required(need) {
        panic!("RAYSPACE_REQUIRE lists '{need}', but this test cannot run: {why}");
    }
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr(), "SKIPPED: {why}");
}

/// Whether `RAYSPACE_REQUIRE` lists `need` (or `all`).
pub fn required(need: &str) -> bool {
    std::env::var("RAYSPACE_REQUIRE")
        .unwrap_or_default()
        .split(',')
        .map(str::trim)
        .any(|r| r == need || r == "all")
}

/// The shared real scenes' directory, or `None` after skipping (see [`skip`]). A
/// `RAYSPACE_SCENES` that names no directory is a mistake, not a reason to skip: it panics.
pub fn scenes() -> Option<PathBuf> {
    if let Ok(v) = std::env::var("RAYSPACE_SCENES") {
        assert!(
            std::path::Path::new(&v).is_dir(),
            "RAYSPACE_SCENES={v} is not a directory"
        );
    }
    let d = scene::scenes_dir();
    if d.is_none() {
        skip(
            "scenes",
            "no shared scenes (set RAYSPACE_SCENES or provide ../shared/scenes)",
        );
    }
    d
}

/// `Ok(v)` as `Some(v)`; an error skips the test for want of `need` (see [`skip`]).
pub fn or_skip<T, E: std::fmt::Display>(r: Result<T, E>, need: &str) -> Option<T> {
    r.map_err(|e| skip(need, format!("no {need}: {e}"))).ok()
}

/// A random case for the grids' property tests: a soup (with degenerate triangles) in one
/// mesh; rays from inside and outside the grid, axis-parallel, with ±0.0 components, aimed
/// at vertices and cell boundaries.
pub fn grid_case(seed: u64, ntri: usize, nray: usize) -> (Geometry, RayBatch) {
    let mut rng = Pcg32::new(seed, 9);
    let mut tris: Vec<[Vec3; 3]> = (0..ntri)
        .map(|_| {
            let c = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let s = rng.range(0.01, 0.4);
            [0, 1, 2].map(|_| c + rng.unit_vector() * s)
        })
        .collect();
    // Degenerate triangles: a point and a segment.
    tris.push([Vec3::splat(0.1); 3]);
    tris.push([Vec3::ZERO, Vec3::ZERO, Vec3::X]);
    let mut b = RayBatch::default();
    for i in 0..nray {
        let org = match i % 4 {
            0 => Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            ),
            1 => rng.unit_vector() * rng.range(2.0, 5.0),
            // On a grid-friendly plane (cell boundaries are often at such coordinates).
            2 => Vec3::new(0.0, rng.range(-1.0, 1.0), 0.5),
            _ => Vec3::new(rng.range(-1.0, 1.0), -0.0, rng.range(-1.0, 1.0)),
        };
        let dir = match i % 7 {
            0 => [Vec3::X, -Vec3::Y, Vec3::Z, -Vec3::X][i % 4],
            1 => Vec3::new(-0.0, 1.0, 0.0),
            2 => Vec3::new(
                std::f32::consts::FRAC_1_SQRT_2,
                -0.0,
                std::f32::consts::FRAC_1_SQRT_2,
            ),
            3 => {
                // Aimed at a vertex.
                let t = tris[rng.below(ntri as u32) as usize];
                (t[rng.below(3) as usize] - org).normalize_or(Vec3::X)
            }
            _ => rng.unit_vector(),
        };
        let t_max = if i % 5 == 0 {
            rng.range(0.0, 4.0)
        } else {
            f32::INFINITY
        };
        b.push(
            Ray::new(org, dir, 0.0, t_max),
            RayKind::Reflection,
            i as u32,
            0,
            Vec3::ONE,
            0,
        );
    }
    (Geometry::soup(tris, Vec3::Y), b)
}

/// A random case for the ray hierarchies' property tests: the `soup` built-in with a
/// degenerate triangle; rays of the three secondary kinds from inside and outside, some
/// axis-parallel, some bounded, on two lights.
pub fn soup_case(seed: u64, ntri: usize, nray: usize) -> (Geometry, RayBatch) {
    let mut rng = Pcg32::new(seed, 1);
    let mut s = builtin::soup(ntri, seed);
    // A few degenerate (zero-area) triangles must not disturb any engine.
    if let Some(m) = s.meshes.first_mut() {
        let p = m.positions[0];
        m.positions.extend_from_slice(&[p, p, p + Vec3::X]);
        m.normals.extend_from_slice(&[Vec3::Y; 3]);
        let b = m.positions.len() as u32 - 3;
        m.triangles.push([b, b + 1, b + 2]);
        m.materials.push(0);
    }
    let geo = Geometry::from_scene(&s);
    let mut batch = RayBatch::default();
    for i in 0..nray {
        let inside = rng.next_f32() < 0.5;
        let org = if inside {
            Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
        } else {
            rng.unit_vector() * rng.range(2.0, 6.0)
        };
        let mut dir = if inside || rng.next_f32() < 0.3 {
            rng.unit_vector()
        } else {
            (-org + rng.unit_vector() * 0.8).normalize()
        };
        if i % 17 == 0 {
            dir = [Vec3::X, -Vec3::Y, Vec3::new(-0.0, 0.0, 1.0)][i % 3];
        }
        let kind = [RayKind::Shadow, RayKind::Reflection, RayKind::Refraction][i % 3];
        let t_max = if rng.next_f32() < 0.3 {
            rng.range(0.0, 3.0)
        } else {
            f32::INFINITY
        };
        batch.push(
            Ray::new(org, dir, 0.0, t_max),
            kind,
            i as u32,
            (i % 2) as u32,
            Vec3::ONE,
            0,
        );
    }
    batch.width = 37;
    (geo, batch)
}

/// Random rays in clusters (so the hierarchy has coherent and incoherent nodes), of mixed
/// kinds, some with bounded length.
pub fn clustered_batch(seed: u64, n: usize) -> RayBatch {
    let mut rng = Pcg32::new(seed, 77);
    let mut b = RayBatch::default();
    let mut c = Vec3::ZERO;
    let mut d = Vec3::X;
    for i in 0..n {
        if i % 13 == 0 {
            c = rng.unit_vector() * rng.range(0.0, 10.0);
            d = rng.unit_vector();
        }
        let org = c + rng.unit_vector() * rng.range(0.0, 0.5);
        let dir = (d + rng.unit_vector() * rng.range(0.0, 1.5)).normalize_or(d);
        let kind = [RayKind::Shadow, RayKind::Reflection, RayKind::Refraction][(i / 40) % 3];
        let t_max = if kind == RayKind::Shadow {
            rng.range(0.1, 20.0)
        } else {
            f32::INFINITY
        };
        b.push(
            Ray::new(org, dir, 0.0, t_max),
            kind,
            i as u32,
            0,
            Vec3::ONE,
            0,
        );
    }
    b
}

/// Render `scene` with brute force and return every batch the Whitted loop traced, with
/// brute force's answers: the reference other engines are checked against.
pub fn record_render(
    scene: &scene::Scene,
    geo: &scene::Geometry,
    width: u32,
    height: u32,
    bounces: u32,
) -> Vec<(RayBatch, trace::TraceMode, Vec<trace::Hit>)> {
    let bf = accel::BruteForce::new(geo);
    let rec = accel::oracle::Recorder::new(&bf);
    render::whitted::render(
        scene,
        geo,
        &rec,
        &render::whitted::RenderOptions {
            width,
            height,
            bounces,
            spp: 1,
        },
        &(),
    );
    rec.into_batches()
}
