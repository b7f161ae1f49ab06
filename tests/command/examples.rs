//! The Rust front door's example (`examples/own_mesh.rs`, built by `cargo test` with the
//! tests): a mesh from arrays, an engine, a batch of rays: it prints "N rays, M hits", and
//! every engine answers with brute force's count.

use std::path::PathBuf;
use std::process::Command;

/// The example's binary, built beside this test's (`target/<profile>/examples`).
fn own_mesh() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let p = exe.parent()?.parent()?.join("examples").join("own_mesh");
    p.is_file().then_some(p)
}

#[test]
fn own_mesh_prints_its_rays_and_hits_for_every_engine() {
    let Some(bin) = own_mesh() else {
        testkit::skip(
            "examples",
            "examples/own_mesh was not built (run `cargo test`, which builds it)",
        );
        return;
    };
    let first_line = |engine: &str| {
        let out = Command::new(&bin).arg(engine).output().unwrap();
        assert!(
            out.status.success(),
            "{engine}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = String::from_utf8(out.stdout).unwrap();
        let line = text.lines().next().unwrap().to_string();
        assert!(
            text.contains("after moving the torus down by 0.5"),
            "{text}"
        );
        line
    };
    let brute = first_line("brute");
    assert!(brute.starts_with("65536 rays, "), "{brute}");
    let hits: u64 = brute["65536 rays, ".len()..]
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(hits > 10_000, "{brute}");
    for e in ["bvh", "crsh", "rah", "grid", "grid2l"] {
        let line = first_line(e);
        assert_eq!(line.replace(e, "brute"), brute, "{e}");
    }
    let out = Command::new(&bin).arg("bvhh").output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}
