//! The rasterizer's tests: coverage without cracks, exact spans, perspective-correct
//! positions, clipping.

use super::*;
use scene::Camera;

fn quad_scene(tris: Vec<[Vec3; 3]>) -> Geometry {
    Geometry::soup(tris, Vec3::Z)
}

fn cam() -> Camera {
    Camera {
        eye: Vec3::new(0.0, 0.0, 5.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov: 40.0,
    }
}

/// Two triangles sharing a diagonal cover every pixel of their square exactly once: no
/// cracks, no double coverage (each covered pixel is written exactly once).
#[test]
fn shared_edges_no_cracks_no_overlap() {
    let a = Vec3::new(-1.0, -1.0, 0.0);
    let b = Vec3::new(1.0, -1.0, 0.0);
    let c = Vec3::new(1.0, 1.0, 0.0);
    let d = Vec3::new(-1.0, 1.0, 0.0);
    // A fan of 8 triangles around an off-centre point, all sharing edges.
    let m = Vec3::new(0.13, -0.07, 0.0);
    let e = Vec3::new(0.0, -1.0, 0.0);
    let f = Vec3::new(1.0, 0.0, 0.0);
    let g = Vec3::new(0.0, 1.0, 0.0);
    let h = Vec3::new(-1.0, 0.0, 0.0);
    let ring = [a, e, b, f, c, g, d, h];
    let tris: Vec<[Vec3; 3]> = (0..8).map(|i| [m, ring[i], ring[(i + 1) % 8]]).collect();
    let geo = quad_scene(tris);
    let view = View::new(&cam(), 97, 89);
    let (gb, st) = rasterize(&geo, &[Material::default()], &view, 1e-3);
    // Exactly one fragment per covered pixel: the fan has no overlaps.
    assert_eq!(st.fragments as usize, gb.covered());
    // Every pixel whose centre is strictly inside the square (by a margin) is covered.
    for y in 0..view.height {
        for x in 0..view.width {
            let r = view.primary_ray(x, y);
            let t = -r.org.z / r.dir.z;
            let p = r.at(t);
            let inside = p.x.abs() < 0.999 && p.y.abs() < 0.999;
            if inside {
                assert_ne!(
                    gb.tri[(y * view.width + x) as usize],
                    NO_HIT,
                    "crack at {x},{y}"
                );
            }
        }
    }
}

/// A row's span holds exactly the pixels whose three edge values pass, at every magnitude
/// the edge functions reach (up to 2^58, with steps up to 2^41).
#[test]
fn spans_are_exact() {
    let mut rng = geom::rng::Pcg32::new(7, 1);
    for case in 0..60_000 {
        let (eb, db) = [(20, 16), (40, 30), (58, 41), (12, 2)][case % 4];
        let mut r = |bits: u32| {
            let m = ((rng.next_u32() as u64) << 32 | rng.next_u32() as u64) >> (64 - bits);
            if rng.next_u32().is_multiple_of(2) {
                m as i64
            } else {
                -(m as i64)
            }
        };
        let mut e = [r(eb), r(eb), r(eb)];
        let d = [r(db), r(db), r(4)];
        // Values at the span's edges: e an exact multiple of d (plus or minus one).
        if case % 3 == 0 && d[0] != 0 {
            e[0] = d[0] * (case as i64 % 40 - 5) + (case as i64 % 3 - 1);
        }
        let last = [31, 0, 7][case % 3];
        let want: Vec<i64> = (0..=last)
            .filter(|&k| (0..3).all(|i| e[i] - k * d[i] >= 0))
            .collect();
        let got: Vec<i64> = span(e, d, last).map_or(Vec::new(), |(a, b)| (a..=b).collect());
        assert_eq!(got, want, "e {e:?} d {d:?} last {last}");
    }
}

/// Perspective-correct barycentrics reproduce the world point under the pixel centre.
#[test]
fn perspective_correct_positions() {
    let tris = vec![[
        Vec3::new(-2.0, -1.0, -3.0),
        Vec3::new(2.0, -1.0, 1.0),
        Vec3::new(0.0, 2.0, -1.0),
    ]];
    let geo = quad_scene(tris);
    let view = View::new(&cam(), 64, 64);
    let (gb, _) = rasterize(&geo, &[Material::default()], &view, 1e-3);
    let mut n = 0;
    for y in 0..64 {
        for x in 0..64 {
            let p = (y * 64 + x) as usize;
            if gb.tri[p] == NO_HIT {
                continue;
            }
            n += 1;
            // The G-buffer position lies on the pixel's primary ray.
            let r = view.primary_ray(x, y);
            let q = gb.position[p] - r.org;
            let off_ray = (q - r.dir * q.dot(r.dir)).length();
            assert!(off_ray < 2e-3, "pixel {x},{y}: {off_ray}");
        }
    }
    assert!(n > 300);
}

/// Geometry crossing the near plane and far outside the guard band is clipped, not lost.
#[test]
fn clipping_keeps_visible_parts() {
    // A huge floor under the camera, extending behind it and far to the sides.
    let s = 1e4;
    let tris = vec![
        [
            Vec3::new(-s, -1.0, s),
            Vec3::new(s, -1.0, s),
            Vec3::new(s, -1.0, -s),
        ],
        [
            Vec3::new(-s, -1.0, s),
            Vec3::new(s, -1.0, -s),
            Vec3::new(-s, -1.0, -s),
        ],
    ];
    let geo = quad_scene(tris);
    let cam = Camera {
        eye: Vec3::new(0.0, 0.0, 0.0),
        target: Vec3::new(0.0, -0.3, -1.0),
        up: Vec3::Y,
        vfov: 60.0,
    };
    let view = View::new(&cam, 80, 60);
    let (gb, st) = rasterize(&geo, &[Material::default()], &view, 1e-3);
    assert!(st.setup > 2, "the floor was clipped into several pieces");
    // Below the horizon every pixel sees the floor.
    for y in 0..60 {
        for x in 0..80 {
            let r = view.primary_ray(x, y);
            if r.dir.y < -0.01 {
                assert_ne!(gb.tri[(y * 80 + x) as usize], NO_HIT, "{x},{y}");
            }
        }
    }
}
