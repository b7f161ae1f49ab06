//! `rayspace report`: options in, [`rayspace::report`]'s page out, with a progress bar.

use super::args::ReportCmdArgs;
use super::progress::step_bar;
use anyhow::{bail, Result};
use rayspace::report::{self, Spec};

pub fn cmd_report(a: &ReportCmdArgs) -> Result<()> {
    // The directory may be new, but its parent must exist, and it must not be a file.
    if a.out.exists() && !a.out.is_dir() {
        bail!("--out {}: exists and is not a directory", a.out.display());
    }
    let parent = match a.out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    if !parent.is_dir() {
        bail!(
            "--out {}: its parent directory {} does not exist",
            a.out.display(),
            parent.display()
        );
    }
    let spec = Spec::new(a.scenes.as_deref(), a.quick, a.size, a.out.clone())?;
    let bar = step_bar(spec.steps());
    let r = report::run(&spec, &|m| bar.step(m))?;
    bar.0.finish_and_clear();
    if let Some(n) = &r.charts_note {
        eprintln!("warning: {n}");
    }
    say!(
        "wrote {} ({} scenes, {} thesis rows, {} grid rows, {} scaling points) in {:.1} s",
        a.out.join("index.html").display(),
        r.scenes.len(),
        r.rsh.len(),
        r.grid_perf.len() + r.grid_builds.len(),
        r.scaling.triangles.len() + r.scaling.pixels.len(),
        r.seconds
    );
    Ok(())
}
