//! `rayspace`: render scenes with the hybrid rasterizer + ray tracer and compare engines.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    trace::memory::keep_freed_memory();
    match cli::run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line, naming the file/line/option at fault; usage errors exit with 2.
            // Library messages name options by keyword; the CLI spells them as its flags.
            let msg = cli::spell::flags_in(&format!("{e:#}"));
            eprintln!("error: {}", msg.replace('\n', " "));
            if e.is::<cli::UsageError>() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
