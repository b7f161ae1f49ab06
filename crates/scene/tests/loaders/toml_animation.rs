//! Keyframed rigid motion and OBJ-sequence vertex animation in TOML scene files.

use geom::Vec3;
use proptest::prelude::*;
use scene::{load, Geometry, LoadOptions};
use std::path::{Path, PathBuf};

fn dir(tag: &str) -> PathBuf {
    testkit::temp_dir(&format!("tanim-{tag}"))
}

fn tri_obj(y: f32) -> String {
    format!("v 0 {y} 0\nv 1 {y} 0\nv 0 {y} 1\nf 1 2 3\n")
}

fn setup(tag: &str) -> PathBuf {
    let d = dir(tag);
    for (i, y) in [0.0f32, 1.0, 4.0].iter().enumerate() {
        std::fs::write(d.join(format!("seq{i:02}.obj")), tri_obj(*y)).unwrap();
    }
    std::fs::write(
        d.join("s.toml"),
        r#"
[camera]
eye = [0, 2, 8]
target = [0, 0, 0]
[[meshes]]
name = "mover"
shape = "box"
scale = [1, 2, 0.5]
[meshes.animation]
loop = true
keys = [
  { t = 0, translate = [0, 0, 0] },
  { t = 2, translate = [4, 0, 0], rotate = [0, 90, 0], scale = [2, 1, 1] },
]
[[meshes]]
name = "wave"
sequence = "seq%02d.obj"
frames = 3
fps = 2
"#,
    )
    .unwrap();
    d
}

fn load_at(p: &Path) -> scene::Scene {
    load(p.to_str().unwrap(), &LoadOptions::default()).unwrap()
}

#[test]
fn keys_loop_and_sequences_interpolate() {
    let d = setup("ok");
    let s = load_at(&d.join("s.toml"));
    let a = s.animation.as_ref().expect("animated");
    assert_eq!((a.start, a.end), (0.0, 2.0), "interval from the keys");
    let mover = s
        .meshes
        .iter()
        .position(|m| m.name.starts_with("mover"))
        .unwrap();
    let centre = |t: f32| {
        s.at_time(t).meshes[mover]
            .transform
            .transform_point3(Vec3::ZERO)
    };
    assert!((centre(1.0) - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-5);
    assert!(
        (centre(3.0) - centre(1.0)).length() < 1e-5,
        "loops with period 2"
    );
    // The static placement (scale [1, 2, 0.5]) applies before the animation.
    let top = s.at_time(0.0).meshes[mover]
        .transform
        .transform_point3(Vec3::Y);
    assert!((top - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-5, "{top}");
    let wave = s
        .meshes
        .iter()
        .position(|m| m.name.starts_with("wave"))
        .unwrap();
    let y = |t: f32| s.at_time(t).meshes[wave].positions[0].y;
    // Frames at t = 0, 0.5, 1 (fps 2): y = 0, 1, 4; linear in between, clamped after.
    assert!((y(0.25) - 0.5).abs() < 1e-6 && (y(0.75) - 2.5).abs() < 1e-6 && y(9.0) == 4.0);
}

#[test]
fn bad_animation_entries_are_errors() {
    let d = setup("bad");
    let cases = [
        ("keys = []", "increasing"),
        ("keys = [{ t = 1 }, { t = 0 }]", "increasing"),
        ("keys = [{ t = 0, scale = -1 }]", "positive"),
    ];
    for (keys, needle) in cases {
        let p = d.join("b.toml");
        std::fs::write(
            &p,
            format!("[[meshes]]\nshape = \"box\"\n[meshes.animation]\n{keys}\n"),
        )
        .unwrap();
        let e = load(p.to_str().unwrap(), &LoadOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("meshes[0]") && e.contains(needle), "{keys}: {e}");
    }
    std::fs::write(
        d.join("seq02.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 0 1\nv 1 1 1\nf 1 2 3\nf 2 3 4\n",
    )
    .unwrap();
    let e = load(d.join("s.toml").to_str().unwrap(), &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("seq02.obj") && e.contains("topology"), "{e}");
    let p = d.join("c.toml");
    std::fs::write(&p, "[[meshes]]\nsequence = \"nothere%d.obj\"\nframes = 2\n").unwrap();
    let e = load(p.to_str().unwrap(), &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("nothere0.obj"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// The culling spheres (precomputed, moved by the transform, bounding every sequence
    /// frame) contain every world vertex at any time.
    #[test]
    fn spheres_contain_vertices_at_any_time(t in -1.0f32..7.0) {
        let d = setup("prop");
        let s = load_at(&d.join("s.toml")).at_time(t);
        let g = Geometry::from_scene(&s);
        for m in 0..g.mesh_count() {
            let sp = g.mesh_sphere[m];
            for tri in &g.tris[g.mesh_first[m] as usize..g.mesh_first[m + 1] as usize] {
                for v in tri {
                    prop_assert!((*v - sp.center).length() <= sp.radius * (1.0 + 1e-5) + 1e-5);
                }
            }
        }
    }
}
