//! What the grid examples share: the scene named on the command line (a built-in name or a
//! file), with a one-line error, and the subdivision rule argument.

use accel::grid::Subdivision;

/// The scene `spec` and its flattened geometry; exits with a one-line error when it cannot
/// be loaded.
pub fn load(spec: &str) -> (scene::Scene, scene::Geometry) {
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

/// `adaptive` → adaptive subdivision; anything else (or nothing) → the paper's rule.
#[allow(dead_code)] // grid_stages uses only `load`
pub fn subdivision(arg: Option<&String>) -> Subdivision {
    match arg.map(String::as_str) {
        Some("adaptive") => Subdivision::Adaptive,
        _ => Subdivision::Paper,
    }
}
