//! Hostile input to the loaders (issue 14): each case ends in a clear error naming the file,
//! or loads as it should, quickly; never a panic, an unbounded read or a hang.

use scene::{load, LoadOptions, SceneError};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn dir(tag: &str) -> PathBuf {
    testkit::temp_dir(&format!("hostile-{tag}"))
}

fn write(d: &Path, name: &str, text: &str) -> String {
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

/// Load `path`, within a generous time bound (the hangs this guards against never end).
fn load_quickly(path: &str) -> Result<scene::Scene, SceneError> {
    let t0 = Instant::now();
    let r = load(path, &LoadOptions::default());
    assert!(
        t0.elapsed() < Duration::from_secs(20),
        "{path} took {:?}",
        t0.elapsed()
    );
    r
}

fn err_of(path: &str) -> String {
    match load_quickly(path) {
        Ok(_) => panic!("{path} loaded"),
        Err(e) => e.to_string(),
    }
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

#[test]
fn a_byte_order_mark_is_not_part_of_the_first_line() {
    let d = dir("bom");
    let plain = load_quickly(&write(&d, "plain.obj", TRI)).unwrap();
    let bom = load_quickly(&write(&d, "bom.obj", &format!("\u{feff}{TRI}"))).unwrap();
    assert_eq!(bom.triangle_count(), 1);
    assert_eq!(bom.meshes[0].positions, plain.meshes[0].positions);
}

#[cfg(unix)]
#[test]
fn special_files_are_never_read() {
    let d = dir("special");
    // An OBJ whose material library is a device: loads with a note, the read refused.
    let s = load_quickly(&write(&d, "m.obj", &format!("mtllib /dev/zero\n{TRI}"))).unwrap();
    assert!(
        s.report
            .notes
            .iter()
            .any(|n| n.contains("/dev/zero") && n.contains("regular file")),
        "{:?}",
        s.report.notes
    );
    // An AFF include of a device.
    let e = err_of(&write(&d, "i.aff", "i 0 /dev/zero\n"));
    assert!(e.contains("/dev/zero") && e.contains("regular file"), "{e}");
    // A glTF buffer that is a device.
    let g = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"/dev/zero"}]}"#;
    let e = err_of(&write(&d, "b.gltf", g));
    assert!(e.contains("regular file"), "{e}");
    // A scene "file" that is a directory.
    let sub = d.join("dir.obj");
    std::fs::create_dir_all(&sub).unwrap();
    let e = err_of(sub.to_str().unwrap());
    assert!(e.contains("dir.obj"), "{e}");
}

#[test]
fn aff_include_fan_out_is_bounded() {
    // 31 files each including the next one twice: 2^31 loads before the bound.
    let d = dir("fanout");
    for i in 0..31 {
        let next = format!("f{}.aff", i + 1);
        write(
            &d,
            &format!("f{i}.aff"),
            &format!("i 0 {next}\ni 0 {next}\n"),
        );
    }
    write(&d, "f31.aff", "p 3 0 0 0 1 0 0 0 1 0\n");
    let e = err_of(d.join("f0.aff").to_str().unwrap());
    assert!(e.contains("file loads"), "{e}");
}

#[test]
fn gltf_node_cycles_are_errors() {
    let d = dir("cycle");
    for (name, nodes) in [
        ("self.gltf", r#"[{"children":[0]}]"#),
        ("pair.gltf", r#"[{"children":[1]},{"children":[0]}]"#),
    ] {
        let g = format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":{nodes}}}"#
        );
        let e = err_of(&write(&d, name, &g));
        assert!(e.contains(name) && e.contains("cycle"), "{e}");
    }
}

#[test]
fn out_of_range_material_values_are_errors() {
    let d = dir("materials");
    for (mtl, needle) in [
        ("Ns -5", "Ns"),
        ("Tf nan", "Tf"),
        ("Kd 0.5 -1 0.5", "Kd"),
        ("d 7", "d 7"),
    ] {
        write(&d, "m.mtl", &format!("newmtl m\nKd 0.5 0.5 0.5\n{mtl}\n"));
        let obj = write(&d, "m.obj", &format!("mtllib m.mtl\nusemtl m\n{TRI}"));
        let e = err_of(&obj);
        assert!(e.contains("m.obj") && e.contains(needle), "{mtl}: {e}");
    }
    write(&d, "tri.obj", TRI);
    for (m, needle) in [
        ("transparency = -5", "transparency"),
        ("transparency = 0.5, ior = 1e-30", "index of refraction"),
        ("shininess = -1", "shininess"),
        ("diffuse = [0.5, nan, 0.5]", "diffuse"),
    ] {
        let t = write(
            &d,
            "s.toml",
            &format!("[[meshes]]\nfile = \"tri.obj\"\nmaterial = {{ {m} }}\n"),
        );
        let e = err_of(&t);
        assert!(e.contains("s.toml") && e.contains(needle), "{m}: {e}");
    }
}

#[test]
fn aff_static_transforms_apply_without_animation() {
    // The same triangle, once plain and once inside an `xs` group translated by (5, 0, 0):
    // the second must be moved (it used to be ignored in a file without animation).
    let d = dir("xs");
    let tri = "p 3 0 0 0 1 0 0 0 1 0\n";
    let plain = load_quickly(&write(&d, "plain.aff", tri)).unwrap();
    let moved = load_quickly(&write(
        &d,
        "moved.aff",
        &format!("xs 1 1 1 0 1 0 0 5 0 0 {{\n{tri}}}\n"),
    ))
    .unwrap();
    let (a, b) = (
        scene::Geometry::from_scene(&plain),
        scene::Geometry::from_scene(&moved),
    );
    assert_eq!(a.tris.len(), 1);
    assert_eq!(b.tris.len(), 1);
    for k in 0..3 {
        assert_eq!(b.tris[0][k], a.tris[0][k] + geom::Vec3::new(5.0, 0.0, 0.0));
    }
    assert!(moved.animation.is_none());
}
