//! The rasterizer agrees with brute-force primary rays: the same triangle id for ≥ 99.9 % of
//! the pixels either of them covers, on every built-in scene.

use accel::BruteForce;
use geom::NO_HIT;
use render::raster::{default_near, rasterize};
use render::whitted::trace_primary;
use render::View;
use scene::{builtin, Geometry};

fn agreement(name: &str, w: u32, h: u32) -> (usize, usize) {
    let s = builtin::by_name(name).unwrap();
    let geo = Geometry::from_scene(&s);
    let view = View::new(&s.camera, w, h);
    let (gb, _) = rasterize(&geo, &s.materials, &view, default_near(&geo));
    let (_, hits, _) = trace_primary(&view, &BruteForce::new(&geo));
    let mut covered = 0;
    let mut same = 0;
    for (p, hit) in hits.iter().enumerate() {
        let r = gb.tri[p];
        if r == NO_HIT && !hit.is_hit() {
            continue;
        }
        covered += 1;
        if r == hit.tri {
            same += 1;
        }
    }
    (same, covered)
}

#[test]
fn rasterizer_matches_primary_rays_on_builtin_scenes() {
    for name in builtin::NAMES {
        for (w, h) in [(160, 120), (97, 131)] {
            let (same, covered) = agreement(name, w, h);
            let frac = same as f64 / covered as f64;
            eprintln!("{name} {w}x{h}: {same}/{covered} = {:.5}", frac);
            assert!(covered > 1000, "{name}: the camera sees the scene");
            assert!(
                frac >= 0.999,
                "{name} {w}x{h}: only {:.4} % agree",
                100.0 * frac
            );
        }
    }
}
