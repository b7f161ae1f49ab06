//! CRSH's ray paths and object builders from the command line: every combination renders
//! the same image, the stats say which path each batch took, and `trace` reports the
//! paths' counters.

use std::path::PathBuf;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rayspace"))
}

fn tmp(tag: &str) -> PathBuf {
    testkit::temp_dir(&format!("paths-{tag}"))
}

fn ok(args: &[String]) -> String {
    let o = bin().args(args).output().unwrap();
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A counter of a `render --stats` JSON (an object under `trace`) or a `trace --json` one
/// (a list of name–value pairs), 0 when absent.
fn counter(json: &serde_json::Value, name: &str) -> u64 {
    if let Some(v) = json["trace"]["counters"][name].as_u64() {
        return v;
    }
    json["counters"]
        .as_array()
        .and_then(|a| a.iter().find(|p| p[0] == name))
        .and_then(|p| p[1].as_u64())
        .unwrap_or(0)
}

/// `render office` (reflections, refractions, shadows) with every ray path and builder, for
/// CRSH and RAH: one image whatever the path and builder, and the batches counted by path.
#[test]
fn every_path_and_builder_renders_the_same_image() {
    let d = tmp("render");
    let mut first: Option<Vec<u8>> = None;
    for engine in ["crsh", "rah"] {
        for path in ["", "packets", "single", "bundles", "auto"] {
            for builder in ["sah", "lbvh"] {
                let png = d.join(format!("{engine}-{path}-{builder}.png"));
                let json = d.join(format!("{engine}-{path}-{builder}.json"));
                let mut args: Vec<String> = [
                    "render",
                    "office",
                    "-W",
                    "48",
                    "-H",
                    "36",
                    "--engine",
                    engine,
                    "--object-builder",
                    builder,
                ]
                .iter()
                .map(|s| s.to_string())
                .collect();
                if !path.is_empty() {
                    args.extend(["--ray-path".into(), path.into()]);
                }
                args.extend(["--out".into(), png.display().to_string()]);
                args.extend(["--stats".into(), json.display().to_string()]);
                ok(&args);
                let img = std::fs::read(&png).unwrap();
                match &first {
                    None => first = Some(img),
                    Some(f) => assert!(*f == img, "{engine} {path} {builder}: another image"),
                }
                let stats: serde_json::Value =
                    serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
                let (single, packets, bundled) = (
                    counter(&stats, "single-ray batches"),
                    counter(&stats, "packet batches"),
                    counter(&stats, "bundled batches"),
                );
                let batches = single + packets + bundled;
                assert!(batches >= 3, "{engine} {path}: {stats}");
                // The default path: packets (or single rays) for CRSH, bundles for RAH.
                let want = match (path, engine) {
                    ("single", _) => (batches, 0, 0),
                    ("packets", _) | ("", "crsh") => (single, batches - single, 0),
                    ("bundles", _) | ("", "rah") => (0, 0, batches),
                    _ => (single, 0, bundled),
                };
                assert_eq!(
                    (single, packets, bundled),
                    want,
                    "{engine} {path} {builder}"
                );
                if matches!((path, engine), ("packets", _) | ("", "crsh")) {
                    assert!(
                        packets > 0,
                        "{engine} {path} {builder}: a view's batches as packets"
                    );
                }
                assert!(counter(&stats, "ray-box tests") > 0);
            }
        }
    }
}

/// `trace` on random rays takes the single-ray path under `auto` and says so; on shadow
/// rays of a view, the bundles.
#[test]
fn auto_takes_single_rays_for_random_rays() {
    let d = tmp("trace");
    for (kind, single, bundled) in [("random", 1, 0), ("shadow", 0, 1)] {
        let rays = d.join(format!("{kind}.rays"));
        let json = d.join(format!("{kind}.json"));
        let s = |x: &str| x.to_string();
        ok(&[
            s("rays"),
            s("office"),
            s("--kind"),
            s(kind),
            s("-W"),
            s("64"),
            s("-H"),
            s("48"),
            s("-o"),
            rays.display().to_string(),
        ]);
        let mut args = vec![s("trace"), rays.display().to_string()];
        args.extend(["--scene", "office", "-e", "crsh", "--ray-path", "auto"].map(s));
        if kind == "shadow" {
            args.push(s("--any-hit"));
        }
        args.extend([s("--json"), json.display().to_string()]);
        let out = ok(&args);
        let stats: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(
            counter(&stats, "single-ray batches"),
            single,
            "{kind}: {out}"
        );
        assert_eq!(counter(&stats, "bundled batches"), bundled, "{kind}: {out}");
    }
}

/// `trace` refuses, in one line and before tracing, the options its engine would not read:
/// the ray hierarchy's where CRSH traces single rays, any CRSH option with a grid.
#[test]
fn trace_refuses_options_that_do_nothing() {
    let d = tmp("refuse");
    let rays = d.join("s.rays");
    let s = |x: &str| x.to_string();
    ok(&[
        s("rays"),
        s("office"),
        s("--kind"),
        s("shadow"),
        s("-W"),
        s("16"),
        s("-H"),
        s("16"),
        s("-o"),
        rays.display().to_string(),
    ]);
    for (extra, needle) in [
        (
            &["-e", "crsh", "--levels", "4"][..],
            "--levels applies to the ray hierarchy",
        ),
        (
            &["-e", "grid", "--levels", "4"],
            "--levels does not apply to --engine grid",
        ),
        (
            &[
                "-e",
                "crsh",
                "--object-hierarchy",
                "mesh-spheres",
                "--ray-path",
                "single",
            ],
            "--ray-path applies to the object BVH",
        ),
    ] {
        let mut args = vec![
            s("trace"),
            rays.display().to_string(),
            s("--scene"),
            s("office"),
        ];
        args.extend(extra.iter().map(|x| s(x)));
        let o = bin().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    // With the bundles asked for, the ray hierarchy's options are read.
    let mut args = vec![
        s("trace"),
        rays.display().to_string(),
        s("--scene"),
        s("office"),
    ];
    args.extend(["-e", "crsh", "--ray-path", "bundles", "--levels", "3"].map(s));
    ok(&args);
}
