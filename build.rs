//! Build script: the commit this binary is built from, for the benchmarks' provenance line
//! (`RAYSPACE_BUILD_COMMIT`: the short hash, with `+modified` when tracked sources differ
//! from it, or `unknown` outside a git checkout). Reading git at run time would describe
//! whatever checkout the binary happens to run in, not the binary.

use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let o = Command::new("git").args(args).output().ok()?;
    o.status
        .success()
        .then(|| String::from_utf8_lossy(&o.stdout).trim().to_string())
}

fn main() {
    // A commit or a change to the index (git add, commit, checkout) reruns this script; so
    // does a change to the sources it checks (cargo scans these folders).
    // (A path that does not exist would rerun it on every build, so only existing ones.)
    for p in [
        ".git/HEAD",
        ".git/index",
        ".git/refs/heads",
        ".git/packed-refs",
        "src",
        "crates",
        "Cargo.toml",
        "Cargo.lock",
    ] {
        if std::path::Path::new(p).exists() {
            println!("cargo:rerun-if-changed={p}");
        }
    }
    let commit = match git(&["rev-parse", "--short", "HEAD"]) {
        Some(c) => {
            let dirty = git(&[
                "status",
                "--porcelain",
                "--untracked-files=no",
                "--",
                "src",
                "crates",
                "Cargo.toml",
                "Cargo.lock",
            ])
            .is_some_and(|s| !s.is_empty());
            if dirty {
                format!("{c}+modified")
            } else {
                c
            }
        }
        None => "unknown".into(),
    };
    println!("cargo:rustc-env=RAYSPACE_BUILD_COMMIT={commit}");
}
