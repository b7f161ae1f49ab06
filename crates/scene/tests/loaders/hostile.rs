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
    load_with(path, false)
}

/// [`load_quickly`], reading outside the scene's directory when `outside`.
fn load_with(path: &str, outside: bool) -> Result<scene::Scene, SceneError> {
    let t0 = Instant::now();
    let opts = LoadOptions {
        allow_outside_paths: outside,
        ..Default::default()
    };
    let r = load(path, &opts);
    assert!(
        t0.elapsed() < Duration::from_secs(20),
        "{path} took {:?}",
        t0.elapsed()
    );
    r
}

fn err_of(path: &str) -> String {
    err_with(path, false)
}

fn err_with(path: &str, outside: bool) -> String {
    match load_with(path, outside) {
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
    // Devices are outside the scene's directory; with that allowed, the reader still
    // refuses them. An OBJ whose material library is a device: loads with a note.
    let s = load_with(
        &write(&d, "m.obj", &format!("mtllib /dev/zero\n{TRI}")),
        true,
    )
    .unwrap();
    assert!(
        s.report
            .notes
            .iter()
            .any(|n| n.contains("/dev/zero") && n.contains("regular file")),
        "{:?}",
        s.report.notes
    );
    // An AFF include of a device.
    let e = err_with(&write(&d, "i.aff", "i 0 /dev/zero\n"), true);
    assert!(e.contains("/dev/zero") && e.contains("regular file"), "{e}");
    // A glTF buffer that is a device.
    let g = r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"/dev/zero"}]}"#;
    let e = err_with(&write(&d, "b.gltf", g), true);
    assert!(e.contains("regular file"), "{e}");
    // Inside the scene's directory, a FIFO is refused too.
    let fifo = d.join("pipe.mtl");
    let _ = std::fs::remove_file(&fifo);
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.map(|s| s.success()).unwrap_or(false) {
        let s = load_quickly(&write(&d, "f.obj", &format!("mtllib pipe.mtl\n{TRI}"))).unwrap();
        assert!(
            s.report.notes.iter().any(|n| n.contains("regular file")),
            "{:?}",
            s.report.notes
        );
    }
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
fn gltf_views_past_their_buffer_are_named() {
    // One triangle's positions (36 bytes) in a 36-byte buffer, read through a view that
    // claims 48 bytes (past the buffer's end), then through a 36-byte view by an accessor
    // of 4 vertices (past the view's end): each error names what runs past what (the first
    // used to read "no positions").
    let d = dir("views");
    let data =
        "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";
    for (name, view_len, count, needle) in [
        (
            "view.gltf",
            48,
            3,
            "runs past the end of buffer 0 (36 bytes)",
        ),
        (
            "accessor.gltf",
            36,
            4,
            "needs 48 bytes of buffer view 0, which has 36",
        ),
    ] {
        let g = format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":{count},"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
"bufferViews":[{{"buffer":0,"byteLength":{view_len}}}],
"buffers":[{{"byteLength":36,"uri":"{data}"}}]}}"#
        );
        let e = err_of(&write(&d, name, &g));
        assert!(
            e.contains(name) && e.contains("position accessor 0") && e.contains(needle),
            "{e}"
        );
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

#[test]
fn references_outside_the_scene_directory_are_refused() {
    let d = dir("outside");
    let inner = d.join("scene");
    std::fs::create_dir_all(&inner).unwrap();
    // A file beside the scene's directory, which the references below try to reach.
    write(&d, "secret.obj", TRI);
    std::fs::write(d.join("secret.bin"), [0u8; 36]).unwrap();
    std::fs::write(d.join("secret.mtl"), "newmtl m\nKd 1 0 0\n").unwrap();
    write(&d, "secret.aff", "p 3\n0 0 0\n1 0 0\n0 1 0\n");
    let gltf = |uri: &str| {
        format!(
            r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":36,"uri":"{uri}"}}],
            "bufferViews":[{{"buffer":0,"byteLength":36}}],
            "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
            "min":[0,0,0],"max":[0,0,0]}}],
            "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
            "nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#
        )
    };
    let secret = d.join("secret.bin");
    let cases = [
        ("g1.gltf", gltf("../secret.bin")),
        ("g2.gltf", gltf(secret.to_str().unwrap())),
        ("g3.gltf", gltf(&format!("file://{}", secret.display()))),
        ("g4.gltf", gltf("/etc/passwd")),
        ("o1.obj", format!("mtllib ../secret.mtl\n{TRI}")),
        ("o2.obj", format!("mtllib /etc/passwd\n{TRI}")),
        (
            "t1.toml",
            "[[meshes]]\nfile = \"../secret.obj\"\n".to_string(),
        ),
        (
            "t2.toml",
            format!(
                "[[meshes]]\nfile = \"{}\"\n",
                d.join("secret.obj").display()
            ),
        ),
        (
            "t3.toml",
            format!(
                "[[meshes]]\nfile = \"scenes:{}{}\"\n",
                "../".repeat(32),
                d.join("secret.obj")
                    .display()
                    .to_string()
                    .trim_start_matches('/')
            ),
        ),
        ("a1.aff", "i 0 ../secret.aff\n".to_string()),
        ("a2.aff", "i 0 /etc/passwd\n".to_string()),
    ];
    for (name, text) in &cases {
        let p = write(&inner, name, text);
        let e = err_of(&p);
        assert!(
            e.contains("outside the scene's directory") && e.contains("`allow_outside_paths`")
                || (*name == "t3.toml" && scene::scenes_dir().is_none()),
            "{name}: {e}"
        );
        assert!(
            e.contains(name),
            "{name}: the error names the referring file: {e}"
        );
        // Never the target's content (an AFF include used to print /etc/passwd's first line).
        assert!(!e.contains("root:"), "{name}: {e}");
    }
    // The user can allow it; then the files beside the scene load.
    for name in [
        "g1.gltf", "g2.gltf", "g3.gltf", "o1.obj", "t1.toml", "t2.toml", "a1.aff",
    ] {
        let p = inner.join(name);
        let s = load_with(p.to_str().unwrap(), true);
        match (name, s) {
            // The glTF's three zero vertices make a degenerate triangle: loaded and emptied.
            (n, Err(e)) if n.starts_with('g') => {
                assert!(e.to_string().contains("no triangles"), "{name}: {e}")
            }
            (_, Err(e)) => panic!("{name}: {e}"),
            (_, Ok(s)) => assert_eq!(s.triangle_count(), 1, "{name}"),
        }
    }
    // A malformed escape in a buffer URI is an error, not a panic in the glTF crate.
    let e = err_of(&write(&inner, "g5.gltf", &gltf("%FF%FE.bin")));
    assert!(e.contains("malformed URI"), "{e}");
    let e = err_of(&write(&inner, "g6.gltf", &gltf("http://example.com/x.bin")));
    assert!(e.contains("unsupported URI scheme"), "{e}");
}

/// BART's reference evaluation of a position track (`kbsplpos.c`: one cubic per key pair
/// 1‥n−2 in file order, `ComputeIAndU` picks the first whose end time exceeds t), restated
/// independently in f64 for the test.
fn bart_reference_position(keys: &[(f64, f64)], t: f64) -> f64 {
    let n = keys.len();
    let polys = n - 3;
    let poly = |i: usize| {
        let (i0, i1, i2, i3) = (i, i + 1, i + 2, i + 3);
        let dp = keys[i2].1 - keys[i1].1;
        let adj0 = 2.0 * (keys[i2].0 - keys[i1].0) / (keys[i2].0 - keys[i0].0);
        let adj1 = 2.0 * (keys[i2].0 - keys[i1].0) / (keys[i3].0 - keys[i1].0);
        // Tension, continuity and bias are 0 here: every multiplier is 0.5·adj.
        let tout = 0.5 * adj0 * dp + 0.5 * adj0 * (keys[i1].1 - keys[i0].1);
        let tin = 0.5 * adj1 * (keys[i3].1 - keys[i2].1) + 0.5 * adj1 * dp;
        let c = [
            keys[i1].1,
            tout,
            3.0 * dp - 2.0 * tout - tin,
            -2.0 * dp + tout + tin,
        ];
        (c, keys[i1].0, keys[i2].0)
    };
    let (i, u) = if poly(0).1 < t {
        if t < poly(polys - 1).2 {
            let i = (0..polys).find(|&i| t < poly(i).2).unwrap();
            let (_, lo, hi) = poly(i);
            (i, (t - lo) / (hi - lo))
        } else {
            (polys - 1, 1.0)
        }
    } else {
        (0, 0.0)
    };
    let (c, _, _) = poly(i);
    c[0] + u * (c[1] + u * (c[2] + u * c[3]))
}

#[test]
fn bart_tracks_whose_times_go_back_load_with_a_warning_and_evaluate_as_bart_does() {
    let d = dir("backwards");
    // Times 0 … 4, then back to 2.5, with a repeated key, as in published BART files.
    let keys = [
        (0.0, 0.0),
        (1.0, 1.0),
        (2.0, 4.0),
        (3.0, 2.0),
        (4.0, 5.0),
        (2.5, -1.0),
        (2.5, 3.0),
        (3.5, 0.5),
        (5.0, 2.0),
        (6.0, 6.0),
    ];
    let mut track = format!("k mover\n{{\ntransl {}\n", keys.len());
    for (t, x) in keys {
        track += &format!("{t} {x} 0 0 0 0 0\n");
    }
    track += "}\n";
    let aff = format!(
        "a 0 6 25\nv\nfrom 0 0 10\nat 0 0 0\nup 0 1 0\nangle 45\nhither 1\nresolution 64 64\n\
         l 0 5 5\n\n{track}x mover\n{{\np 3\n0 0 0\n1 0 0\n0 1 0\n}}\n"
    );
    let p = write(&d, "back.aff", &aff);
    let s = load_quickly(&p).unwrap();
    let w = &s.report.warnings;
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains("back.aff:11:") && w[0].contains("mover") && w[0].contains("'transl'"),
        "the warning names file:line and the track: {w:?}"
    );
    let anim = s.animation.as_ref().unwrap();
    let tr = anim.tracks.iter().find(|t| t.name == "mover").unwrap();
    for k in 0..=120 {
        let t = -0.5 + 7.0 * k as f64 / 120.0;
        let ours = tr.trs(t as f32).0.x as f64;
        let bart = bart_reference_position(&keys, t);
        assert!(
            (ours - bart).abs() <= 1e-4 * (1.0 + bart.abs()),
            "t = {t}: ours {ours}, BART's {bart}"
        );
    }
    // A sorted track gives no warning.
    let sorted = aff
        .replace("2.5 -1", "4.2 -1")
        .replace("2.5 3", "4.4 3")
        .replace("3.5 0.5", "4.6 0.5");
    let s = load_quickly(&write(&d, "sorted.aff", &sorted)).unwrap();
    assert!(s.report.warnings.is_empty(), "{:?}", s.report.warnings);
}

/// Inputs the fuzzer (`fuzz/`) found, each once a panic or an abort in a third-party parser.
#[test]
fn fuzzer_findings_are_clear_errors() {
    let d = dir("fuzzed");
    // A GLB whose header claims 3 GB: `gltf::Gltf::open` allocated that much.
    let mut glb = b"glTF".to_vec();
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&0xbf80_0000u32.to_le_bytes());
    glb.extend_from_slice(&0xbf80_0000u32.to_le_bytes());
    glb.extend_from_slice(b"JSON{}");
    let p = d.join("huge.glb");
    std::fs::write(&p, &glb).unwrap();
    let e = err_of(p.to_str().unwrap());
    assert!(e.contains("huge.glb") && e.contains("glTF"), "{e}");
    // An MTL colour with two numbers: tobj unwrapped it.
    write(&d, "short.mtl", "newmtl red\nKa 0.5 0\nKd 1 0 0\n");
    let e = err_of(&write(&d, "short.obj", &format!("mtllib short.mtl\n{TRI}")));
    assert!(
        e.contains("short.mtl:2") && e.contains("Ka needs three numbers"),
        "{e}"
    );
    // A POSITION accessor that does not exist: gltf-json's validation indexed past the list.
    let g = r#"{"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":7}}]}],
        "nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]}"#;
    let e = err_of(&write(&d, "pos.gltf", g));
    assert!(e.contains("POSITION accessor 7 does not exist"), "{e}");
    // Float indices: the gltf crate's index reader reached `unreachable!`.
    let g = r#"{"asset":{"version":"2.0"},
        "buffers":[{"byteLength":48,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAAAAAAAgD8AAABA"}],
        "bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":12}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                     {"bufferView":1,"componentType":5126,"count":3,"type":"SCALAR"}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
        "nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]}"#;
    let e = err_of(&write(&d, "fidx.gltf", g));
    assert!(e.contains("not unsigned scalars"), "{e}");
}

#[test]
fn a_material_library_named_thousands_of_times_is_read_once() {
    // Found by fuzzing: 5,000 `mtllib` lines naming one 90 KB library took 7 s.
    let d = dir("mtllib-repeat");
    let mtl: String = (0..2000)
        .map(|i| format!("newmtl m{i}\nKd 0.5 0.5 0.5\n"))
        .collect();
    write(&d, "big.mtl", &mtl);
    let obj = format!("{}usemtl m7\n{TRI}", "mtllib big.mtl\n".repeat(5000));
    let t0 = Instant::now();
    let s = load_quickly(&write(&d, "many.obj", &obj)).unwrap();
    assert!(t0.elapsed() < Duration::from_secs(3), "{:?}", t0.elapsed());
    assert!(s.materials.iter().any(|m| m.name == "m7"));
    assert!(s.materials.len() <= 2001, "{} materials", s.materials.len());
}

#[test]
fn non_finite_animation_keys_are_errors() {
    // Found by fuzzing: a NaN rotation key loaded and made every later frame NaN.
    let d = dir("nan-keys");
    let toml = "[[meshes]]\nshape = \"sphere\"\n[meshes.animation]\nkeys = [\n\
                { t = 0, rotate = [0, 0, 0] },\n{ t = 2, rotate = [0, 180, -nan] },\n]\n";
    let e = err_of(&write(&d, "nan.toml", toml));
    assert!(
        e.contains("nan.toml") && e.contains("rotation key 2 is not finite"),
        "{e}"
    );
    let toml = "[[meshes]]\nshape = \"sphere\"\n[meshes.animation]\nkeys = [\n\
                { t = 0, translate = [0, 0, 0] },\n{ t = inf, translate = [1, 0, 0] },\n]\n";
    let e = err_of(&write(&d, "inf.toml", toml));
    assert!(e.contains("is not finite"), "{e}");
}

#[test]
fn animation_intervals_near_the_f32_limit_give_finite_frames() {
    // Found by fuzzing: `end = 3e38` made the last frame's time infinite (and its geometry
    // NaN); an interval whose length overflows is an error.
    let d = dir("long-interval");
    let toml = |start: &str, end: &str| {
        format!(
            "[[meshes]]\nshape = \"box\"\n[meshes.animation]\nloop = true\nkeys = [\n\
             {{ t = 0, translate = [0, 0, 0] }},\n{{ t = 2, translate = [1, 0, 0] }},\n]\n\
             [animation]\nstart = {start}\nend = {end}\n"
        )
    };
    let s = load_quickly(&write(&d, "long.toml", &toml("0", "3e38"))).unwrap();
    let a = s.animation.as_ref().unwrap();
    for t in a.frame_times(3) {
        assert!(t.is_finite(), "{t}");
        let g = scene::Geometry::from_scene(&s.at_time(t));
        assert!(g.tris.iter().flatten().all(|v| v.is_finite()), "t = {t}");
    }
    let e = err_of(&write(&d, "over.toml", &toml("-3e38", "3e38")));
    assert!(e.contains("must be finite"), "{e}");
}

#[test]
fn declared_counts_do_not_reserve_what_the_file_cannot_hold() {
    // Found by fuzzing: `m vertices 49551616` in a 440-byte file reserved 567 MiB before
    // reading the first vertex. The count now fails where the file's tokens run out.
    let d = dir("counts");
    let e = err_of(&write(
        &d,
        "m.aff",
        "m\n vertices 49551616\n 0 0 0\n 1 0 0\n 0 1 0\n triangles 1\n 0 1 2\n",
    ));
    assert!(e.contains("m.aff:") && e.contains("mesh vertex"), "{e}");
}

/// Load `path` with a budget of `n` triangles.
fn err_with_budget(path: &str, n: u64) -> String {
    let opts = LoadOptions {
        max_triangles: n,
        ..Default::default()
    };
    match load(path, &opts) {
        Ok(s) => panic!("{path} loaded ({} triangles)", s.triangle_count()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn scenes_that_outgrow_the_triangle_budget_stop_while_loading() {
    let d = dir("budget");
    // AFF: 6,000 sphere lines (about a thousand triangles each) made 354–512 MiB allocations from a
    // 100 KB file (found by fuzzing); the load stops at the sphere that passes the budget.
    let mut aff = String::from("v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 1 resolution 8 8\n");
    for i in 0..6000 {
        aff += &format!("s {i} 0 0 0.5\n");
    }
    let p = write(&d, "spheres.aff", &aff);
    let per_sphere = load(&p, &LoadOptions::default()).unwrap().triangle_count() / 6000;
    let e = err_with_budget(&p, 100_000);
    // Sphere k is on line k + 1; the first that passes the budget names its line.
    let line = 100_000 / per_sphere + 2;
    assert!(
        e.contains(&format!(
            "spheres.aff:{line}: the scene grows past 100000 triangles"
        )) && e.contains("`max_memory`"),
        "{e}"
    );
    // OBJ: counted as the faces are validated, before the parser allocates anything; a
    // quad is two triangles.
    let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n");
    for _ in 0..10 {
        obj += "f 1 2 3 4\n";
    }
    let p = write(&d, "quads.obj", &obj);
    assert!(err_with_budget(&p, 19).contains("quads.obj:14:"));
    assert!(load(
        &p,
        &LoadOptions {
            max_triangles: 20,
            ..Default::default()
        }
    )
    .is_ok());
    // glTF: one triangle instanced by 1,000 nodes is 1,000 triangles.
    let nodes = vec![r#"{"mesh":0}"#; 1000].join(",");
    let ids = (0..1000)
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(",");
    let g = format!(
        r#"{{"asset":{{"version":"2.0"}},
        "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "nodes":[{nodes}],"scenes":[{{"nodes":[{ids}]}}]}}"#
    );
    let p = write(&d, "instanced.gltf", &g);
    assert!(err_with_budget(&p, 999).contains("instanced.gltf: the scene grows past 999"));
    assert_eq!(
        load(&p, &LoadOptions::default()).unwrap().triangle_count(),
        1000
    );
    // TOML: entries within the budget each, over it together.
    write(&d, "one.obj", &obj);
    let t = "[[meshes]]\nfile = \"one.obj\"\n[[meshes]]\nfile = \"one.obj\"\n";
    let p = write(&d, "two.toml", t);
    assert!(err_with_budget(&p, 30).contains("two.toml: the scene grows past 30"));
    // The memory form: 96 bytes a triangle.
    assert_eq!(
        LoadOptions::default().for_memory(96 * 1000).max_triangles,
        1000
    );
}
