//! `rayspace view`: the window's screenshot (read back from the GPU after the draw) equals
//! `render` of the same view, on the CPU backend byte for byte and on the GPU backend too
//! (both are the same GPU frame). Needs a display: `$DISPLAY`, or `xvfb-run` (CI installs
//! Xvfb; `RAYSPACE_REQUIRE=display` makes a missing one a failure), and a Vulkan driver
//! that presents to it (lavapipe in CI). The session without a window is tested in
//! `src/view` (frames equal renders, buffers, controls).

#![cfg(feature = "view")]

use std::path::Path;
use std::process::Command;

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_rayspace")
}

/// A command that reaches a display: as is when `$DISPLAY` is set, else under `xvfb-run`;
/// `None` after skipping when neither is there.
fn with_display(args: &[&str]) -> Option<Command> {
    if std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty()) {
        let mut c = Command::new(bin());
        c.args(args);
        return Some(c);
    }
    let xvfb = ["/usr/bin/xvfb-run", "/usr/local/bin/xvfb-run"]
        .into_iter()
        .find(|p| Path::new(p).exists());
    let Some(xvfb) = xvfb else {
        testkit::skip(
            "display",
            "no display for the viewer (DISPLAY unset, no xvfb-run; Debian: apt-get install xvfb)",
        );
        return None;
    };
    let mut c = Command::new(xvfb);
    c.args(["-a", "-s", "-screen 0 1024x768x24", bin()])
        .args(args);
    Some(c)
}

fn rgb(p: &Path) -> image::RgbImage {
    image::open(p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .to_rgb8()
}

#[test]
fn screenshots_equal_renders_of_the_same_view() {
    let dir = testkit::temp_dir("view");
    let size = ["--width", "160", "--height", "120", "--bounces", "2"];
    for (backend, engine) in [("cpu", "grid"), ("cpu", "crsh"), ("gpu", "grid")] {
        let shot = dir.join(format!("shot-{backend}-{engine}.png"));
        let want = dir.join(format!("render-{backend}-{engine}.png"));
        let mut args = vec!["view", "cornell", "--engine", engine, "--backend", backend];
        args.extend(size);
        args.extend(["--frames", "3", "--screenshot", shot.to_str().unwrap()]);
        let Some(mut c) = with_display(&args) else {
            return;
        };
        let o = c.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{err}");
        if !o.status.success() {
            // Only a missing driver may stop it, said in one line.
            assert!(
                err.contains("no GPU adapter")
                    || err.contains("cannot show a window")
                    || err.contains("no GPU"),
                "{err}"
            );
            testkit::skip("gpu", err.trim());
            return;
        }
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(
            out.contains("3 frames in") && out.contains("frames/s"),
            "{out}"
        );
        let mut r = vec![
            "render",
            "cornell",
            "--engine",
            engine,
            "--backend",
            backend,
        ];
        r.extend(size);
        r.extend(["--out", want.to_str().unwrap()]);
        let o = Command::new(bin()).args(&r).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (a, b) = (rgb(&shot), rgb(&want));
        assert_eq!(a.dimensions(), (160, 120));
        let differing = a.pixels().zip(b.pixels()).filter(|(x, y)| x != y).count();
        assert_eq!(
            differing, 0,
            "{backend} {engine}: {differing} pixels differ between the screenshot and render"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn view_refuses_bad_options_in_one_line() {
    for (args, needle) in [
        (
            &["view", "cornell", "--backend", "gpu", "--engine", "brute"][..],
            "--backend gpu",
        ),
        (&["view", "no-such-scene.obj"], "no-such-scene.obj"),
        (&["view", "cornell", "--width", "0"], "--width"),
        (&["view", "cornell", "--buffer", "depth"], "--buffer"),
        (
            &["view", "cornell", "--width", "16384", "--height", "16384"],
            "--width/--height",
        ),
    ] {
        let o = Command::new(bin()).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            err.contains(needle) && !err.contains("panicked"),
            "{args:?}: {err}"
        );
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    }
}
