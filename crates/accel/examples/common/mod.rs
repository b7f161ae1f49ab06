//! What the grid examples share: the scene named on the command line (a built-in name or a
//! file), with a one-line error, and the subdivision and merge rule arguments.

/// The scene `spec` and its flattened geometry; exits with a one-line error when it cannot
/// be loaded.
pub fn load(spec: &str) -> (scene::Scene, scene::Geometry) {
    // As the `rayspace` binary: freed scratch is reused, not faulted in again per build.
    trace::memory::keep_freed_memory();
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

/// The rule named by `arg` (`default` without one); exits on an unknown name.
#[allow(dead_code)] // grid_stages uses only `load`
pub fn rule<T: std::str::FromStr<Err = trace::NameError>>(arg: Option<&String>, default: T) -> T {
    arg.map_or(Ok(default), |a| a.parse()).unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2);
    })
}
