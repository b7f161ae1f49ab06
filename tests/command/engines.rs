//! `rayspace engines`: every engine with its options and defaults, from the engines' own
//! declarations; a render with each engine's defaults runs with exactly those values (its
//! `--stats` `engine_config`), and its stats show the algorithm the name promises.

use crate::common::{bin, ok, tmp, words};

/// The `engines --json` list.
fn engines_json() -> serde_json::Value {
    let o = ok(&["engines", "--json"]);
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn every_engine_renders_with_the_defaults_engines_lists() {
    let d = tmp("engines");
    let list = engines_json();
    let engines = list["engines"].as_array().unwrap();
    assert_eq!(
        engines.iter().filter(|e| e["default"] == true).count(),
        1,
        "one default engine"
    );
    let crsh = engines.iter().find(|e| e["name"] == "crsh").unwrap();
    for (k, v) in [("branching", 8), ("levels", 2)] {
        assert_eq!(crsh["options"][k], v, "{k}");
    }
    assert_eq!(crsh["gpu_options"]["schedule"], "breadth");
    let with_embree = cfg!(feature = "embree");
    for e in engines {
        let name = e["name"].as_str().unwrap();
        if name.starts_with("embree") && !with_embree {
            continue;
        }
        let json = d.join(format!("{name}.json"));
        ok(&words(&format!(
            "render cornell -W 24 -H 16 -e {name} --out {} --stats {}",
            d.join(format!("{name}.png")).display(),
            json.display()
        )));
        let stats: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(stats["engine"], name);
        assert_eq!(
            stats["engine_config"], e["options"],
            "{name}: engine_config"
        );
        let c = &stats["trace"]["counters"];
        let phases = &stats["trace"]["phases"];
        match name {
            // The thesis's pipeline: hashed, sorted, bundled.
            "crsh" => {
                for p in ["hash", "sort", "hierarchy creation"] {
                    assert!(phases[p].as_f64().is_some_and(|t| t > 0.0), "crsh: {p}");
                }
                assert!(c["top nodes"].as_u64().unwrap() > 0);
                assert!(c["chunks"].as_u64().unwrap() > 0);
            }
            "rah" => {
                assert!(phases["screen order"].as_f64().is_some());
                assert!(c["top nodes"].as_u64().unwrap() > 0);
            }
            // The object-tree walk: no ray hierarchy at all.
            "bvh" => {
                assert!(stats["trace"].get("levels").is_none());
                assert_eq!(stats["trace"]["node_tri_tests"], 0);
                assert!(phases.get("hash").is_none() && c.get("top nodes").is_none());
                assert!(c["packet batches"].as_u64().unwrap() > 0);
            }
            _ => {}
        }
    }
    // The text listing names the same engines and options.
    let o = ok(&["engines"]);
    let text = String::from_utf8_lossy(&o.stdout);
    for want in [
        "bvh (default)",
        "--branching 8",
        "--ray-path packets (GPU: single)",
    ] {
        assert!(text.contains(want), "{want} not in: {text}");
    }
    assert!(!bin()
        .args(["engines", "--bogus"])
        .status()
        .unwrap()
        .success());
}

/// The thesis's own configurations of its own engine run, and every one renders brute
/// force's image byte for byte.
#[test]
fn crsh_takes_the_thesis_configurations_and_renders_brute_forces_image() {
    let d = tmp("thesis");
    let render = |tag: &str, args: &str| {
        let png = d.join(format!("{tag}.png"));
        ok(&words(&format!(
            "render office -W 40 -H 30 {args} --out {}",
            png.display()
        )));
        std::fs::read(png).unwrap()
    };
    let brute = render("brute", "-e brute");
    for (k, args) in [
        "-e crsh --branching 8 --levels 2",
        "-e crsh --branching 16 --levels 3",
        "-e crsh --object-hierarchy bvh --schedule breadth",
        "-e crsh --object-hierarchy mesh-spheres --branching 8 --levels 2",
        "-e rah --branching 4 --levels 0",
    ]
    .into_iter()
    .enumerate()
    {
        assert!(
            render(&format!("c{k}"), args) == brute,
            "{args}: another image"
        );
    }
}
