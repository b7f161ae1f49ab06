//! `rayspace report --quick`: the page, its files and its JSON agree, every engine's render
//! equals the reference's byte for byte, and bad `--out` paths get one-line errors. (The
//! page in a real browser is checked by `tests/browser/test_report.py` in CI.)

use rayspace::bench::charts::slug;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rayspace"))
}

/// Every `src="…"` and `href="…"` of the page that names a file of the report.
fn links(html: &str) -> Vec<String> {
    let mut v = Vec::new();
    for attr in ["src=\"", "href=\""] {
        for part in html.split(attr).skip(1) {
            let link = part.split('"').next().unwrap_or("");
            if !link.starts_with('#') && !link.starts_with("data:") {
                v.push(link.to_string());
            }
        }
    }
    v
}

/// The text of the element with `id` (a table cell: no nested markup).
fn cell<'a>(html: &'a str, id: &str) -> &'a str {
    let key = format!("id=\"{id}\">");
    let at = html
        .find(&key)
        .unwrap_or_else(|| panic!("no element {id} in the page"));
    let rest = &html[at + key.len()..];
    &rest[..rest.find('<').unwrap()]
}

#[test]
fn quick_report_is_complete_and_its_renders_agree() {
    let dir = testkit::temp_dir("report-quick");
    let out = dir.join("r");
    let o = bin()
        .args(["report", "--quick", "--scenes", "cornell", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();

    // Every file the page names exists and is not empty; charts are there (a font is
    // present wherever the tests run: CI's Debian has DejaVu) or the page says why not.
    let files = links(&html);
    assert!(files.iter().any(|f| f.ends_with(".svg")) || json["charts_note"].is_string());
    for f in &files {
        let p = out.join(f);
        let len = std::fs::metadata(&p)
            .unwrap_or_else(|e| panic!("{f}: {e}"))
            .len();
        assert!(len > 0, "{f} is empty");
    }

    // Renders: every engine (brute force is affordable on cornell at 128²) equals the
    // reference pixel for pixel, and the page shows the JSON's counts.
    let scenes = json["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 1);
    let s = &scenes[0];
    assert_eq!(s["reference"], "brute");
    let renders = s["renders"].as_array().unwrap();
    assert!(renders.len() >= 5, "{renders:?}");
    for r in renders {
        // Ours: identical pixels. Peers: within their tolerance (edge hits), here at most
        // 0.1 % of the pixels.
        let differing = r["differing_pixels"].as_u64().unwrap();
        if r["exact"] == true {
            assert_eq!(differing, 0, "{r}");
        } else {
            assert!(differing <= 128 * 128 / 1000, "{r}");
        }
        let id = format!(
            "render-{}-{}-tests",
            s["id"].as_str().unwrap(),
            slug(r["engine"].as_str().unwrap())
        );
        assert_eq!(cell(&html, &id), r["total_tests"].to_string());
        // Embree's kernel is a black box: its renders count no tests (a build with the
        // `embree` feature puts them in the report); every other engine counts its own.
        if !r["engine"].as_str().unwrap().starts_with("embree") {
            assert!(r["total_tests"].as_u64().unwrap() > 0, "{r}");
        }
    }
    let kinds: Vec<&str> = s["ray_kinds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|k| k["kind"].as_str().unwrap())
        .collect();
    assert!(
        kinds.contains(&"shadow") && kinds.contains(&"reflection"),
        "{kinds:?}"
    );

    // Thesis tables: 6 configurations × CRSH/RAH × two object sides; each shown.
    let rsh = json["rsh"].as_array().unwrap();
    assert_eq!(rsh.len(), 24);
    for r in rsh {
        let id = format!(
            "rsh-cornell-{}-{}-{}-{}-pct",
            r["engine"].as_str().unwrap(),
            r["objects"].as_str().unwrap(),
            r["branching"],
            r["levels"]
        );
        let shown: f64 = cell(&html, &id).parse().unwrap();
        let pct = r["percent_of_brute_force"].as_f64().unwrap();
        assert!(
            (shown - pct).abs() <= 0.0005 + 1e-9,
            "{id}: {shown} vs {pct}"
        );
        assert!(pct > 0.0 && pct < 100.0);
    }
    // The published thesis values sit beside ours (CORNELL 8/2: CRSH 8.83 %, RAH 12.01 %).
    assert!(html.contains("<td class=\"pub\">8.83</td>"));
    assert!(html.contains("<td class=\"pub\">12.01</td>"));

    // Grid tables 1, 2 and 5 were built; Table 3 has every engine on three ray kinds, none
    // disagreeing with the irregular grid.
    let builds = json["grid_builds"].as_array().unwrap();
    for t in ["1", "2", "5"] {
        assert!(builds.iter().any(|b| b["table"] == t), "table {t} missing");
    }
    for p in json["grid_perf"].as_array().unwrap() {
        assert_eq!(p["wrong"], 0, "{p}");
    }

    // Scaling: the counted brute-force tests grow linearly in pixels and triangles (the
    // fit is exact there: rays ∝ pixels, triangles × the same rays); engines' slopes shown.
    let slopes = json["scaling"]["slopes"].as_array().unwrap();
    let brute_pixels = slopes
        .iter()
        .find(|x| x["engine"] == "brute (counted)" && x["axis"] == "pixels")
        .unwrap();
    let k = brute_pixels["slope"].as_f64().unwrap();
    assert!(
        (k - 1.0).abs() < 0.1,
        "brute force tests vs pixels: slope {k}"
    );
    for x in slopes {
        let id = format!(
            "slope-{}-{}-{}",
            x["axis"].as_str().unwrap(),
            x["measure"].as_str().unwrap(),
            slug(x["engine"].as_str().unwrap())
        );
        let shown: f64 = cell(&html, &id).parse().unwrap();
        assert!((shown - x["slope"].as_f64().unwrap()).abs() <= 0.005 + 1e-9);
    }

    // Generated scenes (bench scale): two classes at two sizes, bvh, CRSH and the grid at
    // both, brute force at the smallest; no engine's hits disagree with the grid's, and the
    // page shows every row.
    let rows = json["generated"].as_array().unwrap();
    assert_eq!(rows.len(), 2 * (2 * 3 + 1), "{rows:?}");
    for x in rows {
        assert_eq!(x["wrong"], 0, "{x}");
        assert!(x["random_mrays"].as_f64().unwrap() > 0.0, "{x}");
        let id = format!(
            "generated-{}-{}-{}-wrong",
            slug(x["generator"].as_str().unwrap()),
            x["requested"],
            slug(x["engine"].as_str().unwrap())
        );
        assert_eq!(cell(&html, &id), "0");
    }
    assert!(!json["generated_slopes"].as_array().unwrap().is_empty());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn report_refuses_bad_out_paths_in_one_line() {
    let dir = testkit::temp_dir("report-bad");
    let file = dir.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    for (out, needle) in [
        (file.clone(), "not a directory"),
        (dir.join("missing/parent/r"), "does not exist"),
    ] {
        let o = bin()
            .args(["report", "--quick", "--scenes", "cornell", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains("--out") && err.contains(needle), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
    let o = bin()
        .args([
            "report",
            "--quick",
            "--scenes",
            "no-such-scene.obj",
            "--out",
        ])
        .arg(dir.join("r"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no-such-scene.obj") && !err.contains("panicked"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
