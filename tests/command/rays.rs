//! Ray files from the command line: `rays` writes them, `trace` reads them back, and every
//! engine returns the same hits on them.

use super::common::{bin, fails, tmp, words};

/// `rays` then `trace` with every engine: the closest-hit files are byte-identical, and
/// any-hit runs agree on which rays are occluded.
#[test]
fn ray_files_and_identical_hits_across_engines() {
    let d = tmp("rays");
    for (kind, extra) in [
        ("primary", vec![]),
        ("shadow", vec![]),
        ("ao", vec!["--spp", "2"]),
        ("random", vec![]),
    ] {
        let rays = d.join(format!("{kind}.rays"));
        let mut args = vec![
            "rays",
            "spheres",
            "--kind",
            kind,
            "--width",
            "24",
            "--height",
            "20",
            "--out",
            rays.to_str().unwrap(),
        ];
        args.extend(extra);
        let out = bin().args(&args).output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let mut files = Vec::new();
        for engine in ["brute", "crsh", "rah", "grid", "grid2l"] {
            for any in [false, true] {
                let hits = d.join(format!("{kind}-{engine}-{any}.hits"));
                let mut a = vec![
                    "trace",
                    rays.to_str().unwrap(),
                    "--scene",
                    "spheres",
                    "--engine",
                    engine,
                    "--out",
                    hits.to_str().unwrap(),
                ];
                if any {
                    a.push("--any-hit");
                }
                // CRSH's closest hits are traced three times over in one process (the
                // frames of --repeat): the file must be the single run's.
                let repeat = engine == "crsh" && !any;
                if repeat {
                    a.extend(["--repeat", "3"]);
                }
                let out = bin().args(&a).output().unwrap();
                assert!(
                    out.status.success(),
                    "{kind} {engine}: {}",
                    String::from_utf8_lossy(&out.stderr)
                );
                let text = String::from_utf8_lossy(&out.stdout);
                assert!(text.contains("MRays/s"));
                if repeat {
                    assert!(text.contains("(medians of 3 runs)"), "{text}");
                    let runs = text
                        .lines()
                        .find(|l| l.starts_with("runs (build+trace ms): "));
                    let listed = runs.and_then(|l| l.split(": ").nth(1));
                    assert_eq!(listed.map(|l| l.split(", ").count()), Some(3), "{text}");
                    // The engine's phases, medians over the runs: CRSH builds its object
                    // tree and traverses it (single rays by default: nothing is hashed).
                    let phases = text
                        .lines()
                        .find(|l| l.starts_with("phases (ms, medians): "));
                    assert!(
                        phases.is_some_and(
                            |l| l.contains("object hierarchy ") && l.contains("traversal ")
                        ),
                        "{text}"
                    );
                }
                let (h, _) = render::rayfile::read_hits(&hits).unwrap();
                files.push((engine, any, std::fs::read(&hits).unwrap(), h));
            }
        }
        let closest: Vec<_> = files.iter().filter(|f| !f.1).collect();
        for f in &closest[1..] {
            assert!(
                f.2 == closest[0].2,
                "{kind}: {} closest-hit file differs from brute force",
                f.0
            );
        }
        let any: Vec<_> = files.iter().filter(|f| f.1).collect();
        for f in &any[1..] {
            assert!(
                f.3.iter()
                    .zip(&any[0].3)
                    .all(|(a, b)| a.is_hit() == b.is_hit()),
                "{kind}: {} any-hit occlusion differs",
                f.0
            );
        }
    }
    // Same seed, same bytes.
    let (a, b) = (d.join("a.rays"), d.join("b.rays"));
    for p in [&a, &b] {
        assert!(bin()
            .args([
                "rays",
                "cornell",
                "--kind",
                "ao",
                "--width",
                "8",
                "--height",
                "8",
                "--seed",
                "5",
                "--out",
                p.to_str().unwrap()
            ])
            .status()
            .unwrap()
            .success());
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    // Bad ray files and options.
    let junk = d.join("junk.rays");
    std::fs::write(&junk, b"hello").unwrap();
    fails(
        &["trace", junk.to_str().unwrap(), "--scene", "cornell"],
        &["junk.rays"],
    );
    fails(
        &words(&format!(
            "rays cornell --viewpoint 1,2,3 --out {}",
            a.display()
        )),
        &["--viewpoint"],
    );
    fails(
        &words(&format!(
            "rays cornell --kind ao --ao-distance -1 --out {}",
            a.display()
        )),
        &["--ao-distance"],
    );
}
