//! The shared real scenes load and render (skipped with a message when absent).

use accel::BruteForce;
use render::whitted::{render, RenderOptions};
use scene::{load, scenes_dir, Geometry, LoadOptions};

#[test]
fn real_scenes_render() {
    let Some(dir) = scenes_dir() else {
        eprintln!("skipped: no shared scenes (set RAYSPACE_SCENES or provide ../shared/scenes)");
        return;
    };
    for rel in [
        "cornell-box/CornellBox-Original.obj",
        "stanford-bunny/stanford-bunny.obj",
        "dabrovic-sponza/sponza.obj",
        "conference/conference.obj",
        "bart-kitchen/kitchen.obj",
        "bart-museum/museum5.obj",
    ] {
        let path = dir.join(rel);
        if !path.exists() {
            eprintln!("skipped: {} not present", path.display());
            continue;
        }
        let t0 = std::time::Instant::now();
        let s = load(path.to_str().unwrap(), &LoadOptions::default()).unwrap();
        let geo = Geometry::from_scene(&s);
        let load_s = t0.elapsed().as_secs_f64();
        let out = render(
            &s,
            &geo,
            &BruteForce::new(&geo),
            &RenderOptions {
                width: 24,
                height: 24,
                bounces: 1,
            },
            &(),
        );
        eprintln!(
            "{rel}: {} triangles, load {:.2} s, {} rays traced",
            geo.len(),
            load_s,
            out.stats.rays_traced()
        );
        assert!(
            out.stats.covered_pixels > 24 * 24 / 20,
            "{rel}: the automatic camera sees the model"
        );
    }
}
