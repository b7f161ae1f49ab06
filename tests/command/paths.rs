//! The engines over the object tree from the command line (`bvh`'s ray paths, `crsh` and
//! `rah`'s ray hierarchy, both builders): every combination renders the same image, the
//! stats say what ran, and `trace` reports the paths' counters.

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

/// `render office` (reflections, refractions, shadows) with every engine that walks the
/// object tree, every builder and, for `bvh`, every ray path: one image whatever the engine,
/// path and builder; `bvh` counts its batches by path and has no ray hierarchy, `crsh` and
/// `rah` bundle every batch and show the thesis's phases.
#[test]
fn every_path_and_builder_renders_the_same_image() {
    let d = tmp("render");
    let mut first: Option<Vec<u8>> = None;
    let runs = [
        ("bvh", ""),
        ("bvh", "packets"),
        ("bvh", "single"),
        ("crsh", ""),
        ("rah", ""),
    ];
    for (engine, path) in runs {
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
            let what = format!("{engine} {path} {builder}");
            match (engine, path) {
                ("bvh", "single") => {
                    assert_eq!((single, packets, bundled), (batches, 0, 0), "{what}")
                }
                ("bvh", _) => {
                    assert_eq!(bundled, 0, "{what}");
                    assert!(packets > 0, "{what}: a view's batches as packets");
                }
                _ => assert_eq!((single, packets, bundled), (0, 0, batches), "{what}"),
            }
            let phases = &stats["trace"]["phases"];
            if engine == "bvh" {
                assert!(
                    stats["trace"].get("levels").is_none(),
                    "{what}: no ray hierarchy"
                );
                assert_eq!(counter(&stats, "top nodes"), 0, "{what}");
            } else {
                for p in ["hierarchy creation", "traversal"] {
                    assert!(phases[p].as_f64().is_some_and(|t| t > 0.0), "{what}: {p}");
                }
                assert!(counter(&stats, "top nodes") > 0, "{what}");
            }
            assert!(counter(&stats, "ray-box tests") > 0);
        }
    }
}

/// `trace` on random rays: `bvh` takes single rays and says so; on shadow rays of a view,
/// packets; `crsh` bundles either.
#[test]
fn bvh_takes_packets_for_neighbouring_rays() {
    let d = tmp("trace");
    for (kind, single, packets) in [("random", 1, 0), ("shadow", 0, 1)] {
        let rays = d.join(format!("{kind}.rays"));
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
        for engine in ["bvh", "crsh"] {
            let json = d.join(format!("{kind}-{engine}.json"));
            let mut args = vec![s("trace"), rays.display().to_string()];
            args.extend(["--scene", "office", "-e", engine].map(s));
            if kind == "shadow" {
                args.push(s("--any-hit"));
            }
            args.extend([s("--json"), json.display().to_string()]);
            let out = ok(&args);
            let stats: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
            let got = (
                counter(&stats, "single-ray batches"),
                counter(&stats, "packet batches"),
                counter(&stats, "bundled batches"),
            );
            let want = if engine == "bvh" {
                (single, packets, 0)
            } else {
                (0, 0, 1)
            };
            assert_eq!(got, want, "{kind} {engine}: {out}");
        }
    }
}

/// `trace` refuses, in one line and before tracing, the options its engine would not read:
/// a ray-hierarchy option with `bvh` or a grid, `bvh`'s path with CRSH, the object tree's
/// with the mesh spheres.
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
    let trace_with = |extra: &[&str]| {
        let mut args = vec![
            s("trace"),
            rays.display().to_string(),
            s("--scene"),
            s("office"),
        ];
        args.extend(extra.iter().map(|x| s(x)));
        args
    };
    for (extra, needle) in [
        (
            &["-e", "bvh", "--levels", "4"][..],
            "--levels does not apply to --engine bvh (it is an option of crsh, rah)",
        ),
        (
            &["-e", "grid", "--levels", "4"],
            "--levels does not apply to --engine grid",
        ),
        (
            &["-e", "crsh", "--ray-path", "single"],
            "--ray-path does not apply to --engine crsh (it is an option of bvh)",
        ),
        (
            &[
                "-e",
                "crsh",
                "--object-hierarchy",
                "mesh-spheres",
                "--descent",
                "size",
            ],
            "--descent applies with --object-hierarchy bvh",
        ),
    ] {
        let args = trace_with(extra);
        let o = bin().args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    // The thesis's own configurations of its own engine run.
    for extra in [
        &["-e", "crsh", "--branching", "8", "--levels", "2"][..],
        &["-e", "crsh", "--branching", "16", "--levels", "3"],
        &[
            "-e",
            "crsh",
            "--object-hierarchy",
            "bvh",
            "--schedule",
            "breadth",
        ],
        &["-e", "rah", "--branching", "4", "--levels", "0"],
    ] {
        ok(&trace_with(extra));
    }
}
