//! `rayspace`: render scenes with the hybrid rasterizer + ray tracer and compare engines.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    trace::memory::keep_freed_memory();
    match cli::run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line, naming the file/line/option at fault; usage errors exit with 2.
            eprintln!("error: {}", format!("{e:#}").replace('\n', " "));
            if e.is::<cli::UsageError>() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
