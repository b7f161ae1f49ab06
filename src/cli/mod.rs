//! The command line: `render`, `rays`, `trace` and `bench`. Each room holds one part:
//! [`args`] the grammar, [`render`] and [`frames`] the renderer's commands, [`trace`] the ray
//! files, [`bench`] the papers' evaluations, [`progress`] the progress display. Engines are
//! named and built by the library's registry (`rayspace::engines`).

/// `println!` that ignores a closed stdout (`rayspace … | head` must not panic).
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($t)*);
    }};
}

mod args;
mod bench;
mod frames;
mod progress;
mod render;
mod trace;

use anyhow::{bail, Result};
use args::{BenchCommand, Cli, Command};
use clap::Parser;

/// Parse the command line and run the command (`render` with its defaults when none).
pub fn run() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Some(Command::Render(a)) => render::cmd_render(&a),
        Some(Command::Rays(a)) => trace::cmd_rays(&a),
        Some(Command::Trace(a)) => trace::cmd_trace(&a),
        Some(Command::Bench { what }) => match what {
            BenchCommand::Rsh(a) => bench::cmd_bench_rsh(&a),
            BenchCommand::Grid(a) => bench::cmd_bench_grid(&a),
            BenchCommand::Gpu(a) => bench::cmd_bench_gpu(&a),
            BenchCommand::Budget(a) => bench::cmd_bench_budget(&a),
        },
        None => render::cmd_render(&args::defaults()),
    }
}

/// An output file's directory must exist (checked before any work is done).
fn check_out_dir(opt: &str, out: &std::path::Path) -> Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            bail!(
                "{opt} {}: directory {} does not exist",
                out.display(),
                dir.display()
            );
        }
    }
    Ok(())
}

/// An output directory must exist.
fn check_dir(opt: &str, d: &std::path::Path) -> Result<()> {
    if !d.is_dir() {
        bail!("{opt} {}: not a directory", d.display());
    }
    Ok(())
}
