//! `rayspace`: render scenes with the hybrid rasterizer + ray tracer and compare engines.

mod bench;
mod bench_budget;
#[cfg(feature = "gpu")]
mod bench_gpu;
mod bench_grid;
mod charts;
mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    match cli::run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line, naming the file/line/option at fault.
            eprintln!("error: {}", format!("{e:#}").replace('\n', " "));
            ExitCode::FAILURE
        }
    }
}
