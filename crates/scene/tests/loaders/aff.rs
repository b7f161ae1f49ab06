//! The BART AFF loader and the animation it carries: entities, includes, transform groups,
//! keyframe tracks, animated triangles, the camera path, and the errors for bad files.

use geom::Vec3;
use proptest::prelude::*;
use scene::{load, Geometry, LoadOptions, SceneError};
use std::path::{Path, PathBuf};

fn dir(tag: &str) -> PathBuf {
    testkit::temp_dir(&format!("aff-{tag}"))
}

fn write(d: &Path, name: &str, text: &str) -> PathBuf {
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn load_aff(p: &Path) -> Result<scene::Scene, SceneError> {
    load(p.to_str().unwrap(), &LoadOptions::default())
}

/// A small animated scene: a static group, an animated group (4 translation keys, 4 rotation
/// keys, 4 non-uniform scale keys), an included mesh with normals and texture coordinates,
/// a cone, animated triangles and a camera track.
const TOP: &str = "% test scene
b 0.1 0.2 0.3
v
from 0 1 -5
at 0 1 0
up 0 1 0
angle 45
hither 0.01
resolution 64 48
l 0 4 0 1 1 1
l 1 4 0
fm 0.1 0.1 0.1  0.5 0.4 0.3  0.2 0.2 0.2  20 0 0
p 4
 -5 0 -5
  5 0 -5
  5 0  5
 -5 0  5
xs 2 2 2  0 1 0 90  1 0 0
{
  i 0 part.aff
}
x spinner
{
  c 0 0 0 1  0 2 0 0.5
}
tpa 2
 0
 0 0 0  0 1 0
 1 0 0  0 1 0
 0 0 1  0 1 0
 10
 0 3 0  0 1 0
 1 3 0  0 1 0
 0 3 1  0 1 0
a 0 10 11
k spinner
{
  transl 4
  -1  0 0 0  0 0 0
   0  0 0 0  0 0 0
  10  4 0 0  0 0 0
  11  4 0 0  0 0 0
  rot 4
  -1  0 1 0 0  0 0 0
   0  0 1 0 0  0 0 0
  10  0 1 0 180  0 0 0
  11  0 1 0 180  0 0 0
  scale 4
  -1  1 1 1  0 0 0
   0  1 1 1  0 0 0
  10  3 1 0.5  0 0 0
  11  3 1 0.5  0 0 0
}
k camera
{
  transl 4
  -1  0 1 -5  0 0 0
   0  0 1 -5  0 0 0
  10  0 1 -9  0 0 0
  11  0 1 -9  0 0 0
}
";

const PART: &str = "m
 vertices 4
  0 0 0
  1 0 0
  1 1 0
  0 1 0
 normals 1
  0 0 1
 texturecoords 4 wood.ppm
  0 0
  1 0
  1 1
  0 1
 triangles 2
  0 1 2  0 0 0  0 1 2
  0 2 3  0 0 0  0 2 3
";

/// The test scene, written once per process: tests run in parallel, and one test
/// rewriting the files while another reads them made the reader see an empty file.
fn scene_dir() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let d = dir("ok");
        write(&d, "part.aff", PART);
        write(&d, "top.aff", TOP);
        d
    })
    .clone()
}

#[test]
fn entities_groups_and_counts() {
    let d = scene_dir();
    let s = load_aff(&d.join("top.aff")).unwrap();
    // Loose polygon (2) + included mesh (2) + cone wall (64) + one animated triangle.
    assert_eq!(
        s.triangle_count(),
        2 + 2 + 64 + 1,
        "{:?}",
        s.meshes
            .iter()
            .map(|m| (&m.name, m.triangles.len()))
            .collect::<Vec<_>>()
    );
    assert_eq!(s.lights.len(), 2);
    assert_eq!(s.background, Vec3::new(0.1, 0.2, 0.3));
    let a = s.animation.as_ref().expect("animated");
    assert_eq!((a.start, a.end, a.frames), (0.0, 10.0, 11));
    // The included mesh sits under xs: scale 2, 90° about y, then +1 in x.
    let part = s
        .meshes
        .iter()
        .position(|m| m.name.contains("part"))
        .unwrap();
    let m = a.mesh_transform(part, 0.0).unwrap();
    let p = m.transform_point3(Vec3::new(1.0, 0.0, 0.0));
    assert!((p - Vec3::new(1.0, 0.0, -2.0)).length() < 1e-5, "{p}");
}

#[test]
fn tracks_pass_through_their_keys_and_clamp() {
    let d = scene_dir();
    let s = load_aff(&d.join("top.aff")).unwrap();
    let a = s.animation.as_ref().unwrap();
    let spin = a.tracks.iter().find(|t| t.name == "spinner").unwrap();
    for (t, x, deg, sc) in [
        (0.0f32, 0.0f32, 0.0f32, Vec3::ONE),
        (10.0, 4.0, 180.0, Vec3::new(3.0, 1.0, 0.5)),
    ] {
        let (tr, r, s) = spin.trs(t);
        assert!((tr - Vec3::new(x, 0.0, 0.0)).length() < 1e-5, "t {t}: {tr}");
        assert!((s - sc).length() < 1e-5, "t {t}: {s}");
        let want = geom::Quat::from_axis_angle(Vec3::Y, deg.to_radians());
        assert!(r.dot(want).abs() > 1.0 - 1e-5, "t {t}: {r:?}");
    }
    // Clamped outside the keyed interval [key 1, key n−2].
    assert_eq!(spin.trs(-5.0).0, spin.trs(0.0).0);
    assert_eq!(spin.trs(50.0).0, spin.trs(10.0).0);
    // In between, monotone here (TCB 0 on these keys).
    let xs: Vec<f32> = (0..=10).map(|i| spin.trs(i as f32).0.x).collect();
    assert!(xs.windows(2).all(|w| w[1] >= w[0] - 1e-6), "{xs:?}");
    // The camera follows its path: eye at the keys, looking at the original target
    // direction (no rotation keys).
    assert!((s.at_time(10.0).camera.eye - Vec3::new(0.0, 1.0, -9.0)).length() < 1e-5);
    assert!((s.at_time(0.0).camera.eye - Vec3::new(0.0, 1.0, -5.0)).length() < 1e-5);
    // Animated triangles move linearly between their keys.
    let tpa = s
        .meshes
        .iter()
        .position(|m| m.name.contains("animated"))
        .unwrap();
    let y = |t: f32| s.at_time(t).meshes[tpa].positions[0].y;
    assert!(
        (y(0.0) - 0.0).abs() < 1e-6 && (y(5.0) - 1.5).abs() < 1e-5 && (y(10.0) - 3.0).abs() < 1e-6
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Per frame the culling spheres are the precomputed object-space spheres moved by the
    /// mesh transform (non-uniform scale keys included; animated triangles bounded over all
    /// their keys), never recomputed: they must still contain every world vertex.
    #[test]
    fn updated_spheres_contain_every_vertex(t in -2.0f32..12.0) {
        let d = scene_dir();
        let s = load_aff(&d.join("top.aff")).unwrap().at_time(t);
        let g = Geometry::from_scene(&s);
        for m in 0..g.mesh_count() {
            let sp = g.mesh_sphere[m];
            for tri in &g.tris[g.mesh_first[m] as usize..g.mesh_first[m + 1] as usize] {
                for v in tri {
                    prop_assert!((*v - sp.center).length() <= sp.radius * (1.0 + 1e-5) + 1e-5,
                        "t {} mesh {} vertex {} outside {:?}", t, m, v, sp);
                }
            }
        }
    }
}

#[test]
fn spheres_are_transformed_not_recomputed() {
    let d = scene_dir();
    let s = load_aff(&d.join("top.aff")).unwrap();
    let a = s.animation.as_ref().unwrap();
    let s10 = s.at_time(10.0);
    let g = Geometry::from_scene(&s10);
    for m in 0..g.mesh_count() {
        let want = a.local_spheres[m].transformed(&s10.meshes[m].transform);
        assert_eq!(g.mesh_sphere[m], want);
        assert_eq!(g.mesh_local_sphere[m], a.local_spheres[m]);
    }
}

fn fails(name: &str, text: &str, needles: &[&str]) {
    let d = dir(name);
    write(&d, "part.aff", PART);
    let p = write(&d, "top.aff", text);
    let e = load_aff(&p).expect_err(name).to_string();
    for n in needles {
        assert!(e.contains(n), "{name}: '{e}' lacks '{n}'");
    }
}

#[test]
fn bad_files_name_file_and_line() {
    fails(
        "truncated",
        "p 4\n 0 0 0\n 1 0 0\n",
        &["top.aff:", "end of file", "polygon vertex"],
    );
    fails(
        "nan",
        "p 3\n 0 0 0\n 1 nan 0\n 0 1 0\n",
        &["top.aff:3", "not finite"],
    );
    fails(
        "word",
        "p 3\n 0 0 0\n 1 x 0\n 0 1 0\n",
        &["top.aff:3", "found 'x'"],
    );
    fails(
        "unknown",
        "p 3\n 0 0 0\n 1 0 0\n 0 1 0\nzz 1 2\n",
        &["top.aff:5", "unknown AFF entity 'zz'"],
    );
    fails(
        "include",
        "i 0 nothere.aff\n",
        &["top.aff:1", "nothere.aff", "does not exist"],
    );
    fails(
        "brace",
        "xs 1 1 1 0 1 0 0 0 0 0\n{\np 3\n 0 0 0\n 1 0 0\n 0 1 0\n",
        &["top.aff", "unclosed"],
    );
    fails("close", "}\n", &["top.aff:1", "without a matching"]);
    // Key times that go back are BART data as published (issue 14): loaded, with a warning
    // naming file and line, not refused.
    let d = dir("keys");
    let p = write(
        &d,
        "top.aff",
        "p 3\n 0 0 0\n 1 0 0\n 0 1 0\nk a\n{\n transl 2\n 1 0 0 0 0 0 0\n 0 0 0 0 0 0 0\n}\n",
    );
    let w = load_aff(&p).unwrap().report.warnings;
    assert!(
        w.len() == 1 && w[0].contains("top.aff:5") && w[0].contains("comes after"),
        "{w:?}"
    );
    fails(
        "index",
        "m\n vertices 3\n 0 0 0\n 1 0 0\n 0 1 0\n triangles 1\n 0 1 7\n",
        &["top.aff:7", "out of range"],
    );
    fails("empty", "% nothing\n", &["no triangles"]);
    fails("cycle", "i 0 top.aff\n", &["nested deeper"]);
    fails("count", "p 99999999999\n", &["top.aff:1", "count"]);
}
