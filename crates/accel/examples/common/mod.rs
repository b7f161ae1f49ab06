//! What the grid examples share: the scene named on the command line (a built-in name or a
//! file), with a one-line error, and the subdivision and merge rule arguments.

use accel::grid::{MergeRule, Subdivision};

/// The scene `spec` and its flattened geometry; exits with a one-line error when it cannot
/// be loaded.
pub fn load(spec: &str) -> (scene::Scene, scene::Geometry) {
    // As the `rayspace` binary: freed scratch is reused, not faulted in again per build.
    render::memory::keep_freed_memory();
    match scene::load(spec, &Default::default()) {
        Ok(s) => {
            let geo = scene::Geometry::from_scene(&s);
            (s, geo)
        }
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}

/// The subdivision rule named by `arg` (default: the paper's); exits on an unknown name.
#[allow(dead_code)] // grid_stages uses only `load`
pub fn subdivision(arg: Option<&String>) -> Subdivision {
    arg.map_or(Ok(Subdivision::Paper), |a| a.parse())
        .unwrap_or_else(|e| {
            eprintln!("error: {e}");
            std::process::exit(2);
        })
}

/// The merge rule named by `arg` (default: runs); exits on an unknown name.
#[allow(dead_code)] // grid_stages uses only `load`
pub fn merge_rule(arg: Option<&String>) -> MergeRule {
    arg.map_or(Ok(MergeRule::Runs), |a| a.parse())
        .unwrap_or_else(|e| {
            eprintln!("error: {e}");
            std::process::exit(2);
        })
}
