//! What a user sees first: the named real scenes look right at their named view (at most
//! 10 % of pixels pure black, 5 % clipped white, at 256²; the benchmarks keep the thesis's
//! lighting), a camera can be given on the command line (`--viewpoint`, the same image as
//! the same camera in a scene file, negative numbers included), and a mistyped scene name
//! gets the nearest name and status 2.

use crate::common::{bin, ok, tmp, words};

/// The shares of pure black (every channel < 8/255) and clipped (every channel ≥ 250/255)
/// pixels of a PNG, in percent.
fn black_and_clipped(png: &std::path::Path) -> (f64, f64) {
    let img = image::open(png).unwrap().to_rgb8();
    let n = (img.width() * img.height()) as f64;
    let black = img.pixels().filter(|p| p.0.iter().all(|&c| c < 8)).count() as f64;
    let clipped = img
        .pixels()
        .filter(|p| p.0.iter().all(|&c| c >= 250))
        .count() as f64;
    (100.0 * black / n, 100.0 * clipped / n)
}

#[test]
fn named_scenes_look_right_by_default() {
    if testkit::scenes().is_none() {
        return; // said by testkit (SKIPPED, or a failure where the scenes are required)
    }
    let d = tmp("looks");
    for name in ["sponza", "museum", "conference", "kitchen"] {
        let png = d.join(format!("{name}.png"));
        ok(&words(&format!(
            "render {name} -W 256 -H 256 --out {}",
            png.display()
        )));
        let (black, clipped) = black_and_clipped(&png);
        assert!(black <= 10.0, "{name}: {black:.1} % pure black");
        assert!(clipped <= 5.0, "{name}: {clipped:.1} % clipped");
    }
}

#[test]
fn a_viewpoint_is_the_same_camera_as_a_scene_files() {
    let d = tmp("viewpoint");
    let body = "[[lights]]\nposition = [0, 5, 2]\n[[meshes]]\nbuiltin = \"office\"\n";
    let with_camera = d.join("camera.toml");
    std::fs::write(
        &with_camera,
        format!("[camera]\neye = [-1.5, 1.6, 3.0]\ntarget = [0.5, 0.8, -1.0]\nfov = 55\n{body}"),
    )
    .unwrap();
    let without = d.join("plain.toml");
    std::fs::write(&without, body).unwrap();
    let (a, b) = (d.join("a.png"), d.join("b.png"));
    ok(&words(&format!(
        "render {} -W 48 -H 40 --out {}",
        with_camera.display(),
        a.display()
    )));
    ok(&words(&format!(
        "render {} -W 48 -H 40 --viewpoint -1.5,1.6,3,0.5,0.8,-1,55 --out {}",
        without.display(),
        b.display()
    )));
    assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap());
    ok(&words(&format!(
        "rays office --viewpoint -10,3,1,0,1,0 -W 8 -H 8 -o {}",
        d.join("r.rays").display()
    )));
    let out = bin()
        .args(words("render office --viewpoint 1,2,3 -W 8 -H 8"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--viewpoint"));
}

#[test]
fn mistyped_scene_names_get_the_nearest_and_status_2() {
    for (name, nearest) in [
        ("offce", "office"),
        ("sponsa", "sponza"),
        ("hairbal:2k", "hairball"),
    ] {
        let out = bin()
            .args(["render", name, "-W", "8", "-H", "8"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.contains(&format!("did you mean '{nearest}'?")),
            "{name}: {err}"
        );
    }
    // A missing file is the file's error, status 1.
    let out = bin()
        .args(["render", "/no/such/scene.obj"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
}
