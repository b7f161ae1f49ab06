//! Helpers shared by the command tests of `cli.rs` and `gpu.rs`.

use std::path::PathBuf;
use std::process::Command;

pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rayspace"))
}

pub fn tmp(tag: &str) -> PathBuf {
    testkit::temp_dir(&format!("cli-{tag}"))
}

/// A command line's words (test paths have no spaces).
pub fn words(line: &str) -> Vec<&str> {
    line.split_whitespace().collect()
}

/// Run the binary and require success (stderr in the message otherwise).
pub fn ok(args: &[&str]) -> std::process::Output {
    let o = bin().args(args).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// Run with `args`; expect failure with a one-line message containing every `needle`.
pub fn fails(args: &[&str], needles: &[&str]) {
    let out = bin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} should fail");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: '{n}' not in: {err}");
    }
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{args:?}: one line expected: {err}");
}
