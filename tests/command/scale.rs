//! `bench scale`: every engine on generated scenes, with hits checked and memory measured.

use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rayspace"))
}

#[test]
fn bench_scale_writes_rows_slopes_and_peaks() {
    let dir = testkit::temp_dir("scale");
    let csv = dir.join("s.csv");
    let json = dir.join("s.json");
    let o = bin()
        .args([
            "bench",
            "scale",
            "--generators",
            "city,hairball",
            "--sizes",
            "2k,6k",
        ])
        .args([
            "--engines",
            "grid,crsh,obvhs-cwbvh,brute",
            "--brute-max",
            "3000",
        ])
        .args(["--width", "24", "--height", "16", "--repeats", "1"])
        .arg("--csv")
        .arg(&csv)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("### Slopes"), "{stdout}");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // 2 generators × 2 sizes × 3 engines, and brute force only at 2k.
    assert_eq!(rows.len(), 2 * 2 * 3 + 2, "{text}");
    for r in &rows {
        assert_eq!(r[col("wrong")], "0", "{r:?}: hits agree with the grid's");
        let peak: u64 = r[col("peak_rss_bytes")].parse().unwrap();
        assert!(peak > 1 << 20, "{r:?}: a render's peak memory");
        // The build's resident growth holds at least the structure it made.
        let build: u64 = r[col("build_peak_bytes")].parse().unwrap();
        let structure: u64 = r[col("structure_bytes")].parse().unwrap_or(0);
        assert!(build > 0 && build >= structure, "{r:?}: the build's peak");
        let tris: u64 = r[col("triangles")].parse().unwrap();
        let want: u64 = r[col("requested")].parse().unwrap();
        assert!(tris.abs_diff(want) * 10 < want, "{r:?}: the generated size");
        if r[col("engine")] == "grid" {
            let b: f64 = r[col("structure_bytes_per_triangle")].parse().unwrap();
            assert!(b > 10.0, "{r:?}: the grid's structure");
        }
    }
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(!j["slopes"].as_array().unwrap().is_empty());

    let bad = bin()
        .args(["bench", "scale", "--generators", "forest"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(1));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("--generators") && err.contains("hairball"),
        "{err}"
    );
    let bad = bin()
        .args(["bench", "scale", "--sizes", "2G"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && err.contains("--sizes"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
