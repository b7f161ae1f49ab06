//! The shared real scenes load with the expected triangle counts (skipped when absent).

use scene::{load, LoadOptions, MeshSplit};

fn check(rel: &str, split: MeshSplit, expect_tris: usize, expect_degenerate: usize) {
    let Some(dir) = testkit::scenes() else {
        return;
    };
    let path = dir.join(rel);
    if !path.exists() {
        testkit::skip("scenes", format!("{} not present", path.display()));
        return;
    }
    let s = load(
        path.to_str().unwrap(),
        &LoadOptions {
            split,
            ..Default::default()
        },
    )
    .unwrap();
    let n = s.triangle_count();
    eprintln!(
        "{rel}: {n} triangles, {} meshes, {} materials, {} degenerate skipped, loaded in {:.2} s",
        s.meshes.len(),
        s.materials.len(),
        s.report.degenerate_skipped,
        s.report.load_seconds
    );
    assert_eq!(n + s.report.degenerate_skipped, expect_tris, "{rel}");
    assert_eq!(s.report.degenerate_skipped, expect_degenerate, "{rel}");
    s.validate().unwrap();
}

#[test]
fn cornell_box() {
    check(
        "cornell-box/CornellBox-Original.obj",
        MeshSplit::Groups,
        36,
        0,
    );
}

#[test]
fn bunny() {
    check(
        "stanford-bunny/stanford-bunny.obj",
        MeshSplit::Groups,
        69_451,
        0,
    );
}

#[test]
fn sponza() {
    check("dabrovic-sponza/sponza.obj", MeshSplit::Groups, 66_454, 1);
}

#[test]
fn conference() {
    check(
        "conference/conference.obj",
        MeshSplit::Groups,
        331_179,
        53_627,
    );
}

#[test]
fn kitchen() {
    check(
        "bart-kitchen/kitchen.obj",
        MeshSplit::Materials,
        110_561,
        41,
    );
}

#[test]
fn museum() {
    check("bart-museum/museum5.obj", MeshSplit::Groups, 11_820, 0);
}
