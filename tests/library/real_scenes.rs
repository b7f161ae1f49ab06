//! The shared real scenes load and render (skipped with a message when absent).

use accel::BruteForce;
use render::whitted::{render, RenderOptions};
use scene::{load, Geometry, LoadOptions};

#[test]
fn real_scenes_render() {
    let Some(dir) = testkit::scenes() else {
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
            testkit::skip("scenes", format!("{} not present", path.display()));
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
                spp: 1,
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

/// On the real scenes' ray files (primary, shadow, ambient occlusion; written and read back
/// through the RSRAYS format), every rayspace engine returns brute force's records bit for
/// bit, and every peer agrees within `accel::oracle::Agreement`'s rule.
#[test]
fn engines_and_peers_agree_on_real_scene_ray_files() {
    use render::rayfile::{read_rays, write_rays};
    use render::raygen::{generate, Kind, Options};
    use trace::{Hit, RayKind, TraceMode, TraceStats, Tracer};

    let Some(dir) = testkit::scenes() else {
        return;
    };
    let tmp = testkit::temp_dir("real");
    for rel in [
        "dabrovic-sponza/sponza.obj",
        "bart-kitchen/kitchen.obj",
        "conference/conference.obj",
    ] {
        let path = dir.join(rel);
        if !path.exists() {
            testkit::skip("scenes", format!("{} not present", path.display()));
            continue;
        }
        let s = load(path.to_str().unwrap(), &LoadOptions::default()).unwrap();
        let geo = Geometry::from_scene(&s);
        let (ours, peers) = (crate::roster::ours(&geo), crate::roster::peers(&geo));
        let opts = Options {
            width: 32,
            height: 24,
            spp: 1,
            seed: 5,
            ao_distance: None,
        };
        for (kind, name, mode) in [
            (Kind::Primary, "primary", TraceMode::Closest),
            (Kind::Shadow, "shadow", TraceMode::Any),
            (Kind::Ao, "ao", TraceMode::Closest),
            (Kind::Ao, "ao-any", TraceMode::Any),
        ] {
            let file = tmp.join(format!("{name}.rays"));
            write_rays(&file, &generate(&s, &geo, kind, &opts)).unwrap();
            let rays = read_rays(&file, RayKind::Reflection).unwrap();
            let mut expect = vec![Hit::MISS; rays.len()];
            BruteForce::new(&geo).trace(&rays, mode, &mut expect, &mut TraceStats::default());
            let what = format!("{rel} {name}");
            crate::roster::check(&geo, &ours, &peers, &rays, mode, &expect, &what);
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
}

/// BART Museum and Kitchen from their AFF files: triangle counts as in the OBJ snapshots,
/// the camera on its keyframed path, geometry that moves, and at several animation times
/// every engine's hits equal brute force's on the animated scene.
#[test]
fn bart_animations_load_animate_and_match_brute_force() {
    use accel::oracle::assert_same_hits;
    use testkit::record_render;
    let Some(dir) = testkit::scenes() else {
        return;
    };
    for (rel, tris, times, key) in [
        (
            "bart-museum/aff/museum5.aff",
            11_820,
            [-1.0f32, 1.7, 4.2],
            // camera transl key at t = 0.5
            (0.5f32, geom::Vec3::new(3.0, 2.4, -1.0)),
        ),
        (
            "bart-kitchen/aff/kitchen.aff",
            110_520,
            [0.0, 6.0, 14.0],
            (5.0, geom::Vec3::new(3.5, 0.2, 0.1)),
        ),
    ] {
        let path = dir.join(rel);
        if !path.exists() {
            testkit::skip("scenes", format!("{} not present", path.display()));
            continue;
        }
        let s = load(path.to_str().unwrap(), &LoadOptions::default()).unwrap();
        assert_eq!(s.triangle_count(), tris, "{rel}");
        let a = s.animation.as_ref().expect("animated");
        assert!(a.camera.is_some(), "{rel}: camera track");
        let eye = s.at_time(key.0).camera.eye;
        assert!(
            (eye - key.1).length() < 1e-4,
            "{rel}: camera at t={} is {eye}",
            key.0
        );
        let g0 = Geometry::from_scene(&s.at_time(times[0]));
        let g2 = Geometry::from_scene(&s.at_time(times[2]));
        assert_ne!(g0.tris, g2.tris, "{rel}: something moves");
        for &t in &times {
            let st = s.at_time(t);
            let geo = Geometry::from_scene(&st);
            let mut batches = record_render(&st, &geo, 20, 16, 1);
            // The renderer rasterizes primary visibility; trace the primary rays too.
            let prim = render::View::new(&st.camera, 20, 16).primary_rays();
            let mut ph = vec![trace::Hit::MISS; prim.len()];
            trace::Tracer::trace(
                &BruteForce::new(&geo),
                &prim,
                trace::TraceMode::Closest,
                &mut ph,
                &mut Default::default(),
            );
            batches.push((prim, trace::TraceMode::Closest, ph));
            let engines: Vec<Box<dyn trace::Tracer>> = vec![
                Box::new(
                    accel::GridEngine::new(
                        &geo,
                        &accel::GridConfig {
                            expansion_passes: 1,
                            ..Default::default()
                        },
                    )
                    .unwrap(),
                ),
                Box::new(rsh::RshEngine::new(&geo, rsh::RshConfig::crsh()).unwrap()),
                Box::new(rsh::RshEngine::new(&geo, rsh::RshConfig::rah()).unwrap()),
            ];
            for e in &engines {
                for (i, (rays, mode, hits)) in batches.iter().enumerate() {
                    assert_same_hits(
                        e.as_ref(),
                        rays,
                        *mode,
                        hits,
                        &format!("{rel} t={t} {} batch {i}", e.name()),
                    );
                }
            }
            eprintln!(
                "{rel} t={t}: {} batches, engines agree with brute force",
                batches.len()
            );
        }
    }
}
