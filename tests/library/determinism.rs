//! Two renders of the same input and configuration give identical pixels and counts.

use accel::BruteForce;
use render::whitted::{render, RenderOptions};
use scene::{builtin, Geometry};

#[test]
fn renders_are_bit_identical() {
    for name in ["cornell", "spheres", "office"] {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let engine = BruteForce::new(&geo);
        let opts = RenderOptions {
            width: 64,
            height: 48,
            bounces: 3,
            spp: 1,
        };
        let a = render(&s, &geo, &engine, &opts, &());
        let b = render(&s, &geo, &engine, &opts, &());
        let bytes = |p: &[geom::Vec3]| render::output::to_rgb8(p, 64, 48).into_raw();
        assert_eq!(bytes(&a.pixels), bytes(&b.pixels), "{name}: image bytes");
        assert_eq!(a.stats.trace, b.stats.trace, "{name}: counters");
        assert_eq!(a.stats.rays_traced(), b.stats.rays_traced());
    }
}

#[test]
fn cornell_spawns_every_ray_kind() {
    let s = builtin::cornell();
    let geo = Geometry::from_scene(&s);
    let out = render(
        &s,
        &geo,
        &BruteForce::new(&geo),
        &RenderOptions {
            width: 64,
            height: 64,
            bounces: 2,
            spp: 1,
        },
        &(),
    );
    let st = &out.stats;
    assert_eq!(
        st.covered_pixels,
        64 * 64,
        "the room is closed: every pixel is covered"
    );
    assert!(st.rays_shadow > 0 && st.rays_reflection > 0 && st.rays_refraction > 0);
    // Brute force tests every triangle for closest hits, and at most that for shadows.
    assert!(st.total_tests <= st.brute_force_tests);
    assert_eq!(st.brute_force_tests, st.rays_traced() * geo.len() as u64);
    // Shadow rays: one per covered pixel and light in each of the 3 generations' surfaces.
    assert!(st.rays_shadow >= st.covered_pixels);
}
