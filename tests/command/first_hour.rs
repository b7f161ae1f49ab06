//! A newcomer's first hour, as the command line answers it: real scenes that look right,
//! antialiasing, options refused before anything loads, outputs that go where a user
//! expects, ray files that know their scene, words a user reads.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rayspace"))
}

fn tmp(tag: &str) -> PathBuf {
    testkit::temp_dir(&format!("first-{tag}"))
}

fn run(dir: &Path, args: &[&str]) -> Output {
    bin().current_dir(dir).args(args).output().unwrap()
}

fn ok(dir: &Path, args: &[&str]) -> String {
    let o = run(dir, args);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The image's (distinct colours, most common colour's share, pure black's share).
fn colours(png: &Path) -> (usize, f64, f64) {
    let img = image::open(png).unwrap().to_rgb8();
    let n = (img.width() * img.height()) as f64;
    let mut count = std::collections::HashMap::new();
    for p in img.pixels() {
        *count.entry(p.0).or_insert(0u32) += 1;
    }
    let top = *count.values().max().unwrap() as f64 / n;
    let black = *count.get(&[0, 0, 0]).unwrap_or(&0) as f64 / n;
    (count.len(), top, black)
}

/// `render sponza.obj` and `conference.obj` with the automatic camera and light: the
/// camera stands inside, the geometry covers at least 80 % of the pixels, no colour takes
/// more than 30 % of them, and at most 10 % are pure black.
#[test]
fn real_scenes_look_right_from_their_automatic_camera() {
    let Some(scenes) = testkit::scenes() else {
        return;
    };
    let d = tmp("real");
    for rel in ["dabrovic-sponza/sponza.obj", "conference/conference.obj"] {
        let path = scenes.join(rel);
        let json = d.join("s.json");
        let out = ok(
            &d,
            &[
                "render",
                path.to_str().unwrap(),
                "-W",
                "128",
                "-H",
                "128",
                "-b",
                "1",
                "-e",
                "grid",
                "--stats",
                json.to_str().unwrap(),
            ],
        );
        assert!(out.contains("automatic camera inside"), "{rel}: {out}");
        let stem = Path::new(rel).file_stem().unwrap().to_str().unwrap();
        let png = d.join(format!("{stem}.png"));
        assert!(out.contains(&format!("wrote {stem}.png")), "{out}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let covered = v["covered_pixels"].as_u64().unwrap() as f64 / (128.0 * 128.0);
        let (_, top, black) = colours(&png);
        assert!(covered >= 0.8, "{rel}: covered {covered}");
        assert!(top <= 0.3, "{rel}: most common colour {top}");
        assert!(black <= 0.1, "{rel}: pure black {black}");
    }
    // The shared scenes by name: the benchmark views and BART's animations.
    let out = ok(
        &d,
        &[
            "render", "sponza", "-W", "16", "-H", "16", "-b", "0", "-o", "n.png",
        ],
    );
    assert!(out.contains("66453 triangles"), "{out}");
    let out = ok(&d, &["render", "museum", "-W", "16", "-H", "16", "-b", "0"]);
    assert!(out.contains("wrote museum.png"), "{out}");
    std::fs::remove_dir_all(&d).ok();
}

/// `--fill` and `--exposure`: the fill lifts the shadows of a scene with its own lights
/// when asked, and an exposure of −1 darkens the image.
#[test]
fn fill_and_exposure() {
    let d = tmp("look");
    let sum = |p: &Path| -> u64 {
        image::open(p)
            .unwrap()
            .to_rgb8()
            .pixels()
            .map(|p| p.0.iter().map(|&c| c as u64).sum::<u64>())
            .sum()
    };
    let base = ["render", "cornell", "-W", "32", "-H", "32", "-b", "1"];
    let render = |name: &str, extra: &[&str]| -> u64 {
        let mut args = base.to_vec();
        args.extend_from_slice(&["-o", name]);
        args.extend_from_slice(extra);
        ok(&d, &args);
        sum(&d.join(name))
    };
    let plain = render("a.png", &[]);
    assert!(render("b.png", &["--fill", "on"]) > plain);
    assert!(render("c.png", &["--exposure", "-1"]) < plain);
    assert_eq!(
        render("d.png", &["--fill", "off", "--exposure", "0"]),
        plain
    );
    let o = run(&d, &["render", "cornell", "--exposure", "99"]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&d).ok();
}

/// `--spp 4` smooths the edges (more distinct colours) and its stats count every sample's
/// rays; `--spp 1` is the unjittered image.
#[test]
fn antialiasing() {
    let d = tmp("spp");
    let common = ["render", "spheres", "-W", "96", "-H", "96", "-b", "1"];
    let mut one = common.to_vec();
    one.extend_from_slice(&["-o", "1.png", "--stats", "1.json"]);
    ok(&d, &one);
    let mut four = common.to_vec();
    four.extend_from_slice(&["-o", "4.png", "--stats", "4.json", "--spp", "4"]);
    ok(&d, &four);
    let (c1, _, _) = colours(&d.join("1.png"));
    let (c4, _, _) = colours(&d.join("4.png"));
    assert!(c4 > c1, "spp 4: {c4} colours, spp 1: {c1}");
    let json = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(d.join(f)).unwrap()).unwrap()
    };
    let (j1, j4) = (json("1.json"), json("4.json"));
    assert_eq!((j1["spp"].as_u64(), j4["spp"].as_u64()), (Some(1), Some(4)));
    assert!(j4["rays_shadow"].as_u64() > j1["rays_shadow"].as_u64().map(|r| 3 * r));
    let mut again = common.to_vec();
    again.extend_from_slice(&["-o", "4b.png", "--spp", "4"]);
    ok(&d, &again);
    assert_eq!(
        std::fs::read(d.join("4.png")).unwrap(),
        std::fs::read(d.join("4b.png")).unwrap(),
        "deterministic"
    );
    std::fs::remove_dir_all(&d).ok();
}

/// Options that do not apply are refused with one line and status 2 before the scene is
/// read (the scene named here does not exist: a load would say so with status 1).
#[test]
fn options_that_do_not_apply_are_refused_before_loading() {
    let d = tmp("refuse");
    for (args, needle) in [
        (&["--gif", "a.gif"][..], "--gif needs --frames"),
        (&["--fps", "24"], "--fps needs --frames"),
        (&["--frame-csv", "a.csv"], "--frame-csv needs --frames"),
        (
            &["--engine", "grid", "--levels", "4"],
            "--levels does not apply to --engine grid",
        ),
        (
            &["--engine", "grid2l", "--grid-merge", "off"],
            "--grid-merge does not apply",
        ),
        (
            &["--grid-alpha", "0.9"],
            "--grid-alpha does not apply to --engine bvh (it is an option of grid)",
        ),
        (
            &["--engine", "rah", "--hash", "morton64"],
            "--hash does not apply to --engine rah",
        ),
        (
            &["--engine", "brute", "--branching", "4"],
            "--branching does not apply",
        ),
        (&["--backend", "gpu", "--engine", "brute"], "no GPU path"),
        (
            &["--backend", "gpu", "--object-builder", "sah"],
            "--object-builder sah: the GPU backend takes only lbvh",
        ),
        (
            &[
                "--engine",
                "crsh",
                "--object-hierarchy",
                "mesh-spheres",
                "--schedule",
                "breadth",
            ],
            "--schedule applies with --object-hierarchy bvh",
        ),
        (
            &["--engine", "crsh", "--ray-path", "single"],
            "--ray-path does not apply to --engine crsh (it is an option of bvh)",
        ),
        (
            &["--schedule", "breadth"],
            "--schedule does not apply to --engine bvh (it is an option of crsh, rah)",
        ),
        (
            &["--levels", "4"],
            "--levels does not apply to --engine bvh",
        ),
        (
            &["--engine", "bvh", "--descent", "size"],
            "--descent does not apply to --engine bvh",
        ),
        (
            &["--engine", "grid", "--object-builder", "lbvh"],
            "--object-builder does not apply to --engine grid",
        ),
        (&["--out", "x.jpg"], "must end in .png"),
        (&["--stats", "s.txt"], "must end in .json"),
        (&["--frames", "2", "--gif", "a.png"], "must end in .gif"),
        (&["--frames", "2", "--out", "x.png"], "frame number pattern"),
        (&["--levels", "99"], "--levels"),
    ] {
        let mut a = vec!["render", "no-such-scene.obj"];
        a.extend_from_slice(args);
        let o = run(&d, &a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{a:?}: {err}");
        assert!(err.contains(needle), "{a:?}: '{needle}' not in {err}");
        assert_eq!(err.lines().count(), 1, "{a:?}: {err}");
    }
    // Defaults adapt: grid options given to a grid are fine, and a missing file alone
    // stays status 1.
    let o = run(
        &d,
        &[
            "render",
            "no-such-scene.obj",
            "--engine",
            "grid",
            "--grid-alpha",
            "0.9",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    std::fs::remove_dir_all(&d).ok();
}

/// `--gif` alone makes the GIF (the frames live in a temporary folder), `--out` with a new
/// folder makes it, and `--stats` with `--frames` writes every frame's statistics.
#[test]
fn animation_workflow() {
    let d = tmp("anim");
    let anim = d.join("anim.toml");
    std::fs::write(
        &anim,
        "[camera]\neye = [0, 2, 8]\ntarget = [0, 0, 0]\n[[meshes]]\nshape = \"plane\"\nscale = 5\n[[meshes]]\nshape = \"box\"\n[meshes.animation]\nkeys = [{ t = 0 }, { t = 1, translate = [2, 1, 0] }]\n",
    )
    .unwrap();
    let a = anim.to_str().unwrap();
    let small = ["-W", "24", "-H", "16", "-b", "1"];
    let mut args = vec!["render", a, "--frames", "2", "--gif", "k.gif"];
    args.extend_from_slice(&small);
    let out = ok(&d, &args);
    assert!(out.contains("wrote k.gif"), "{out}");
    assert!(std::fs::metadata(d.join("k.gif")).unwrap().len() > 100);
    let left: Vec<_> = std::fs::read_dir(&d).unwrap().flatten().collect();
    assert_eq!(left.len(), 2, "only the scene and the GIF: {left:?}");
    let mut args = vec![
        "render",
        a,
        "--frames",
        "2",
        "--out",
        "new/dir/%04d.png",
        "--stats",
        "more/s.json",
    ];
    args.extend_from_slice(&small);
    args.extend_from_slice(&["--frame-csv", "f.csv"]);
    ok(&d, &args);
    assert!(d.join("new/dir/0000.png").exists() && d.join("new/dir/0001.png").exists());
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("more/s.json")).unwrap()).unwrap();
    assert_eq!(v.as_array().map(|a| a.len()), Some(2));
    // Every frame's phases: the JSON's four figures and the CSV's last four columns, which
    // fit inside the render's time (they are its parts).
    for f in v.as_array().unwrap() {
        for k in ["raster_ms", "ray_creation_ms", "trace_ms", "shading_ms"] {
            assert!(f[k].as_f64().is_some_and(|x| x >= 0.0), "{k}: {f}");
        }
    }
    let csv = std::fs::read_to_string(d.join("f.csv")).unwrap();
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert!(head.starts_with(&[
        "frame",
        "time",
        "triangles",
        "update_ms",
        "build_ms",
        "render_ms"
    ]));
    assert!(head.ends_with(&["raster_ms", "ray_creation_ms", "trace_ms", "shading_ms"]));
    for line in lines {
        let x: Vec<f64> = line.split(',').map(|c| c.parse().unwrap()).collect();
        let parts: f64 = x[x.len() - 4..].iter().sum();
        assert!(
            parts > 0.0 && parts <= x[5] + 0.01,
            "{parts} ms of phases in a {} ms render",
            x[5]
        );
    }
    // Without --out: a folder named after the scene.
    let mut args = vec!["render", a, "--frames", "2"];
    args.extend_from_slice(&small);
    ok(&d, &args);
    assert!(d.join("anim/0001.png").exists());
    std::fs::remove_dir_all(&d).ok();
}

/// Ray files say which scene their rays were made for, `trace` warns on another scene,
/// reads a headerless file as hagrid's with a notice, `--format` forces either, and
/// `--json` writes the summary.
#[test]
fn ray_files_know_their_scene() {
    let d = tmp("rays");
    ok(
        &d,
        &[
            "rays", "cornell", "--kind", "shadow", "-W", "8", "-H", "8", "-o", "c.rays",
        ],
    );
    let o = run(
        &d,
        &["trace", "c.rays", "--scene", "cornell", "--json", "t.json"],
    );
    assert!(o.status.success());
    assert!(!String::from_utf8_lossy(&o.stderr).contains("warning"));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("t.json")).unwrap()).unwrap();
    assert_eq!(v["rays"].as_u64(), Some(64));
    assert_eq!(v["mode"], "closest hit");
    assert!(v["total_tests"].as_u64().unwrap() > 0);
    let o = run(&d, &["trace", "c.rays", "--scene", "office"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && err.contains("warning: c.rays was made for scene 'cornell'"),
        "{err}"
    );
    // 240 bytes without the header: ten hagrid rays, said so; refused as rayspace's.
    let mut bytes = Vec::new();
    for i in 0..10 {
        for v in [0.1 * i as f32, 0.5, 3.0, 0.0, 0.0, -1.0] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    std::fs::write(d.join("h.bin"), &bytes).unwrap();
    let o = run(&d, &["trace", "h.bin", "--scene", "cornell"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && err.contains("notice: h.bin has no rayspace header"),
        "{err}"
    );
    let o = run(
        &d,
        &[
            "trace", "h.bin", "--scene", "cornell", "--format", "rayspace",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    let o = run(
        &d,
        &["trace", "h.bin", "--scene", "cornell", "--format", "hagrid"],
    );
    assert!(o.status.success() && o.stderr.is_empty());
    std::fs::remove_dir_all(&d).ok();
}

/// What the user reads: `--version` lists the features, `--help` is grouped with short
/// flags and no rustdoc links, `trace` and `rays` say kinds and modes in words.
#[test]
fn output_in_the_users_words() {
    let d = tmp("words");
    let v = ok(&d, &["--version"]);
    assert!(v.contains("features:"), "{v}");
    assert_eq!(v.contains("embree"), cfg!(feature = "embree"), "{v}");
    let help = ok(&d, &["render", "--help"]);
    for want in [
        "-o, --out",
        "-e, --engine",
        "-W, --width",
        "-H, --height",
        "--spp",
        "Animation:",
        "Ray hierarchy (--engine crsh, rah):",
        "BVH (--engine bvh):",
    ] {
        assert!(help.contains(want), "'{want}' not in render --help");
    }
    for never in ["[`", "Kitchen's", "crate::"] {
        assert!(!help.contains(never), "'{never}' in render --help");
    }
    let out = ok(
        &d,
        &[
            "rays", "cornell", "--kind", "shadow", "-W", "4", "-H", "4", "-o", "r.rays",
        ],
    );
    assert!(out.contains("wrote 16 shadow rays of cornell"), "{out}");
    let out = ok(&d, &["trace", "r.rays", "--scene", "cornell", "--any-hit"]);
    assert!(out.contains("(any hit)") && !out.contains("(Any)"), "{out}");
    let grid = ok(&d, &["bench", "grid", "--help"]);
    assert!(
        grid.contains("stadium") && !grid.contains("bench rsh"),
        "{grid}"
    );
    std::fs::remove_dir_all(&d).ok();
}
