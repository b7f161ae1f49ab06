//! `rayspace`: render scenes with the hybrid rasterizer + ray tracer and compare engines.

mod cli;

use std::process::ExitCode;

/// An allocation the system refuses ends the command with one line and status 1.
#[global_allocator]
static ALLOCATOR: cli::oom::Guarded = cli::oom::Guarded;

fn main() -> ExitCode {
    // Mesa's Vulkan drivers print two lines when XDG_RUNTIME_DIR is unset or not a folder;
    // the GPU backend keeps nothing there, so the system's temporary folder serves. (Set
    // before any other thread starts.)
    if std::env::var_os("XDG_RUNTIME_DIR").is_none_or(|d| !std::path::Path::new(&d).is_dir()) {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    cli::signals::install();
    trace::memory::keep_freed_memory();
    match cli::run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(_) if render::output::stopping() => {
            // An interrupt is ending the command (its handler removes the temporaries, says
            // so and exits with 128 + the signal): an output refused because of it is not
            // another error to report.
            loop {
                std::thread::park();
            }
        }
        Err(e) => {
            // One line, naming the file/line/option at fault; usage errors exit with 2.
            // Library messages name options by keyword; the CLI spells them as its flags.
            let msg = cli::spell::flags_in(&format!("{e:#}"));
            eprintln!("error: {}", cli::printable(&msg.replace('\n', " ")));
            if e.is::<cli::UsageError>() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
