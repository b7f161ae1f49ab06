//! `rayspace bench rsh` and `bench grid` from the command line: their tables, JSON and charts.

use super::common::{fails, ok, tmp, words};

#[test]
fn bench_rsh_writes_tables() {
    let d = tmp("bench");
    let (csv, json) = (d.join("b.csv"), d.join("b.json"));
    let out = ok(&words(&format!(
        "bench rsh --scenes cornell --configs 8/2,4/0 --width 32 --height 32 --csv {} --json {}",
        csv.display(),
        json.display()
    )));
    let md = String::from_utf8_lossy(&out.stdout);
    assert!(
        md.contains("| 8/2 |") && md.contains("| 4/0 |") && md.contains("phase times"),
        "{md}"
    );
    let csv = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(
        csv.lines().count(),
        1 + 8,
        "header + 2 configs × 2 engines × (mesh spheres, bvh)"
    );
    assert!(csv.lines().any(|l| l.contains(",bvh,")), "{csv}");
    assert!(md.contains("CRSH+BVH"), "{md}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    for row in v.as_array().unwrap() {
        assert!(row["total_tests"].as_u64().unwrap() <= row["brute_force_tests"].as_u64().unwrap());
    }
    fails(&["bench", "rsh", "--configs", "8-2"], &["--configs"]);
    fails(&["bench", "rsh", "--configs", "1/2"], &["--configs"]);
}

#[test]
fn bench_grid_writes_tables_and_charts() {
    let d = tmp("bench-grid");
    let (csv, grids, json) = (d.join("t3.csv"), d.join("g.csv"), d.join("g.json"));
    let charts = d.join("charts");
    std::fs::create_dir_all(&charts).unwrap();
    let out = ok(&words(&format!("bench grid --scenes cornell --width 24 --height 16 --repeats 1 --csv {} --grids-csv {} --json {} --charts {}", csv.display(), grids.display(), json.display(), charts.display())));
    let md = String::from_utf8_lossy(&out.stdout);
    for t in [
        "Table 1",
        "Table 2",
        "Table 3",
        "Table 5",
        "obvhs-cwbvh",
        "grid2l",
    ] {
        assert!(md.contains(t), "{t} missing:\n{md}");
    }
    // 3 ray kinds × (2 grids + bvh + 2 obvhs [+ 2 Embree]).
    let engines = if cfg!(feature = "embree") { 7 } else { 5 };
    let t3 = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(t3.lines().count(), 1 + 3 * engines, "{t3}");
    // Every engine agreed with the irregular grid (the `wrong` column).
    for line in t3.lines().skip(1) {
        assert_eq!(line.split(',').nth(11), Some("0"), "{line}");
    }
    // Table 1: 5 stages (initial; merge and merge + expansion by pairs and by runs), Table
    // 2: 3 densities × 2 structures, Table 5: 5 variants (with the macro regions), each with
    // its build passes' times.
    let g = std::fs::read_to_string(&grids).unwrap();
    assert_eq!(g.lines().count(), 1 + 5 + 6 + 5, "{g}");
    assert!(g.lines().next().unwrap().ends_with(
        "top_refs_seconds,octrees_seconds,cells_seconds,merge_seconds,expansion_seconds"
    ));
    assert!(g.contains("macro regions (Devillers)"), "{g}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["table3"].as_array().unwrap().len(), 3 * engines);
    // Charts need a TrueType font; without one the command says so and still succeeds.
    let png = charts.join("grid-mrays-cornell.png");
    if png.exists() {
        assert!(std::fs::metadata(&png).unwrap().len() > 1000);
        assert!(charts.join("grid-mrays-cornell.svg").exists());
    } else {
        eprintln!(
            "no chart written (no font?): {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    fails(
        &["bench", "grid", "--charts", "/nonexistent/dir"],
        &["--charts", "not a directory"],
    );
    fails(&["bench", "grid", "--ao-spp", "0"], &["--ao-spp"]);
    // Values that used to be accepted with a meaningless result.
    fails(
        &["bench", "budget", "cornell", "--ms", "1e30"],
        &["--ms", "1e30"],
    );
    fails(
        &["bench", "rsh", "--scenes", ","],
        &["--scenes", "no scene"],
    );
    fails(
        &["bench", "grid", "--scenes", " , "],
        &["--scenes", "no scene"],
    );
}
