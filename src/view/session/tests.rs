//! The viewer's session without a window: a full frame is the render, previews, buffers,
//! controls and animation.

use super::*;

fn session(engine: Engine) -> Session {
    let s = scene::builtin::cornell();
    Session::new(s, engine, Backend::Cpu, 64, 48, 2, None).unwrap()
}

/// An untouched view's frame is `render`'s image of the scene camera, byte for byte.
#[test]
fn a_full_frame_is_the_render() {
    let mut s = session(Engine::Grid);
    let rgb = s.frame(1).unwrap();
    let scene = scene::builtin::cornell();
    let geo = scene::Geometry::from_scene(&scene);
    let t = engines::build(Engine::Grid, &Config::of(Engine::Grid), &geo).unwrap();
    let out = render(
        &scene,
        &geo,
        t.tracer.as_ref(),
        &RenderOptions {
            width: 64,
            height: 48,
            bounces: 2,
            spp: 1,
        },
        &(),
    );
    assert_eq!(rgb, render::output::to_rgb8(&out.pixels, 64, 48).into_raw());
    assert_eq!(s.last.rays, out.stats.rays_traced());
    assert!(s.last.build_seconds > 0.0);
    // The engine is reused while nothing changes.
    s.frame(1).unwrap();
    assert_eq!(s.last.build_seconds, 0.0);
    assert!(s.overlay()[0].contains("grid"));
}

/// A preview is the low-resolution frame upscaled: every pixel block is one colour.
#[test]
fn previews_are_low_resolution_frames_upscaled() {
    let mut s = session(Engine::Crsh);
    let rgb = s.frame(4).unwrap();
    assert_eq!(rgb.len(), 64 * 48 * 3);
    assert_eq!(s.last.scale, 4);
    for y in (0..48).step_by(4) {
        for x in (0..64).step_by(4) {
            let at = |dx: usize, dy: usize| {
                let i = ((y + dy) * 64 + x + dx) * 3;
                [rgb[i], rgb[i + 1], rgb[i + 2]]
            };
            assert_eq!(at(0, 0), at(3, 3));
        }
    }
}

#[test]
fn buffers_show_what_they_say() {
    let mut s = session(Engine::Grid);
    s.buffer = Buffer::Normals;
    let n = s.frame(1).unwrap();
    assert!(n.iter().any(|&c| c != 0));
    s.buffer = Buffer::Kinds;
    let k = s.frame(1).unwrap();
    // Cornell's walls are mirrors: shadow (red) and reflection (green) rays everywhere.
    assert!(k.chunks_exact(3).any(|p| p[0] > 0) && k.chunks_exact(3).any(|p| p[1] > 0));
    s.buffer = Buffer::Tests;
    let t = s.frame(1).unwrap();
    assert!(t.chunks_exact(3).any(|p| p[0] > 0));
    assert!(s.last.note.is_none(), "the grid's tests are its own");
    // CRSH's tests are shared by nodes: the heat map says it shows the grid's.
    s.engine = Engine::Crsh;
    s.frame(1).unwrap();
    assert!(s.last.note.as_deref().is_some_and(|n| n.contains("grid")));
    s.cycle_buffer();
    assert_eq!(s.buffer, Buffer::Shaded);
}

#[test]
fn controls_change_the_view_and_the_engine() {
    let mut s = session(Engine::Crsh);
    let before = s.frame(1).unwrap();
    let cam = s.camera();
    s.orbit_by(0.3, 0.1);
    assert_ne!(s.camera().eye, cam.eye);
    assert_eq!(s.camera().target, cam.target);
    s.dolly(0.5);
    s.fly(0.1, 0.0, 0.0);
    assert_ne!(s.frame(1).unwrap(), before);
    s.cycle_engine();
    assert_eq!(s.engine, Engine::Rah);
    s.set_bounces(99);
    assert_eq!(s.bounces, render::whitted::MAX_BOUNCES);
    // On the GPU backend the cycle skips engines that do not run there.
    s.engine = Engine::Grid2l;
    s.backend = Backend::Gpu;
    s.cycle_engine();
    assert_eq!(s.engine, Engine::Bvh);
    s.backend = Backend::Cpu;
    s.engine = Engine::ObvhsCwbvh;
    s.toggle_backend();
    assert_eq!((s.backend, s.engine), (Backend::Gpu, Engine::Grid));
    assert!(Session::new(
        scene::builtin::cornell(),
        Engine::Brute,
        Backend::Gpu,
        8,
        8,
        1,
        None
    )
    .is_err());
}

/// Playing and scrubbing an animation moves the geometry and rebuilds the engine
/// every frame (the papers' dynamic scenes); time stays inside the interval.
#[test]
fn animation_rebuilds_per_frame() {
    let d = testkit::temp_dir("view-anim");
    let p = d.join("s.toml");
    std::fs::write(
        &p,
        r#"
[camera]
eye = [0, 2, 8]
target = [0, 0, 0]
[[lights]]
position = [2, 5, 4]
[[meshes]]
name = "floor"
shape = "box"
scale = [6, 0.1, 6]
translate = [0, -1, 0]
[[meshes]]
name = "mover"
shape = "box"
[meshes.animation]
keys = [
  { t = 0, translate = [-2, 0, 0] },
  { t = 2, translate = [2, 0, 0] },
]
"#,
    )
    .unwrap();
    let sc = scene::load(p.to_str().unwrap(), &scene::LoadOptions::default()).unwrap();
    let mut s = Session::new(sc, Engine::Grid, Backend::Cpu, 48, 32, 1, None).unwrap();
    assert!(s.animated());
    assert_eq!(s.time, 0.0);
    let a = s.frame(1).unwrap();
    s.set_time(1.0);
    let b = s.frame(1).unwrap();
    assert!(s.last.build_seconds > 0.0, "rebuilt after the time moved");
    assert_ne!(a, b, "the box moved");
    s.set_time(99.0);
    assert_eq!(s.time, 2.0, "clamped while paused");
    s.playing = true;
    s.set_time(2.5);
    assert!(
        (s.time - 0.5).abs() < 1e-5,
        "wraps while playing: {}",
        s.time
    );
    assert!(s.overlay().iter().any(|l| l.contains("playing")));
    // On the GPU backend the engine is rebuilt on the device it has: the same frame
    // (and so the same device and compiled kernels) across the animation's frames.
    #[cfg(feature = "gpu")]
    {
        let sc = scene::load(p.to_str().unwrap(), &scene::LoadOptions::default()).unwrap();
        let made = Session::new(sc, Engine::Grid, Backend::Gpu, 48, 32, 1, None)
            .and_then(|mut g| g.frame(1).map(|a| (g, a)));
        match made {
            Err(e) => testkit::skip("gpu", e.to_string()),
            Ok((mut g, a)) => {
                let frame_box = |g: &Session| {
                    g.runner
                        .as_ref()
                        .and_then(|r| r.gpu_frame_address())
                        .expect("a GPU frame is built")
                };
                let first = frame_box(&g);
                g.set_time(1.0);
                let b = g.frame(1).unwrap();
                assert!(g.last.build_seconds > 0.0, "rebuilt after the time moved");
                assert_eq!(frame_box(&g), first, "the same device and kernels");
                assert_ne!(a, b, "the box moved on the GPU too");
                let c = g.frame(1).unwrap();
                assert_eq!(g.last.build_seconds, 0.0, "nothing moved: nothing rebuilt");
                assert_eq!(b, c);
            }
        }
    }
    std::fs::remove_dir_all(&d).ok();
}
