//! The command line: `render`, `rays`, `trace`, `engines`, `bench`, `report` and `view`.
//! Each room holds one part: [`args`] the grammar, [`render`] and [`frames`] the renderer's
//! commands, [`trace`] the ray files, [`engines`] the engines and their options, [`bench`]
//! the papers' evaluations, [`report`] the HTML report of them all, [`view`] the interactive
//! window, [`progress`] the progress display. Engines are named, configured and built by
//! the library's registry (`rayspace::engines`).

/// `println!` that ignores a closed stdout (`rayspace … | head` must not panic).
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($t)*);
    }};
}

mod args;
mod bench;
mod check;
mod engines;
mod frames;
pub mod oom;
mod progress;
mod render;
mod report;
pub mod signals;
pub mod spell;
mod trace;
mod view;

use anyhow::{bail, Result};
use args::{BenchCommand, Cli, Command};

/// A command-line usage error (exit status 2), as one line.
#[derive(Debug)]
pub struct UsageError(pub String);

impl std::fmt::Display for UsageError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for UsageError {}

/// clap's message (3–7 lines: the error, context, usage, a hint) as one line: the error and
/// its context lines, without the usage and the help hint.
fn one_line(e: &clap::Error) -> String {
    if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        let args: Vec<String> = std::env::args().skip(1).collect();
        return format!(
            "'rayspace {}' needs a subcommand; see 'rayspace {} --help'",
            args.join(" "),
            args.join(" ")
        );
    }
    let text = e.render().to_string();
    text.lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information")
        })
        .map(|l| l.strip_prefix("error: ").unwrap_or(l))
        .collect::<Vec<_>>()
        .join("; ")
}

/// Parse the command line and run the command (`render` with its defaults when none).
/// `--help` and `--version` print and exit here; a usage error is a [`UsageError`].
pub fn run() -> Result<()> {
    use clap::{CommandFactory, FromArgMatches};
    let parsed = Cli::command()
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m).map(|c| (c, m)));
    let cli = match parsed {
        Ok((c, _)) => c,
        Err(e) if !e.use_stderr() => e.exit(),
        Err(e) => return Err(UsageError(one_line(&e)).into()),
    };
    // A scenes folder named by the environment that is not one is said, once.
    if let Some(d) = std::env::var_os("RAYSPACE_SCENES") {
        if !std::path::Path::new(&d).is_dir() {
            eprintln!(
                "warning: RAYSPACE_SCENES={}: not a folder; the shared scenes (sponza, kitchen, ...) are not available",
                printable(&d.to_string_lossy())
            );
        }
    }
    match cli.command {
        Some(Command::Render(a)) => render::cmd_render(&a),
        Some(Command::Rays(a)) => trace::cmd_rays(&a),
        Some(Command::Trace(a)) => trace::cmd_trace(&a),
        Some(Command::Engines(a)) => engines::cmd_engines(&a),
        Some(Command::Bench { what }) => match what {
            BenchCommand::Rsh(a) => bench::cmd_bench_rsh(&a),
            BenchCommand::Grid(a) => bench::cmd_bench_grid(&a),
            BenchCommand::Gpu(a) => bench::cmd_bench_gpu(&a),
            BenchCommand::Budget(a) => bench::cmd_bench_budget(&a),
            BenchCommand::Scale(a) => bench::cmd_bench_scale(&a),
        },
        Some(Command::Report(a)) => report::cmd_report(&a),
        Some(Command::View(a)) => view::cmd_view(&a),
        None => render::cmd_render(&rayspace::options::defaults()),
    }
}

/// An output file must be writable before any work is done: its directory exists, it is
/// not a directory or a special file (`render::output::check_output`).
/// Load a scene, printing the loader's warnings (suspicious content loaded anyway, each
/// naming file:line) as `warning:` lines on stderr.
fn load_scene(spec: &str, opts: &scene::LoadOptions) -> Result<scene::Scene> {
    let mut s = scene::load(spec, opts).map_err(|e| -> anyhow::Error {
        // A bare name that names no scene is a usage error (with the nearest name); a
        // path to a missing file stays an error of the file (status 1).
        let bare = !spec.contains(['/', '\\']) && std::path::Path::new(spec).extension().is_none();
        match e {
            scene::SceneError::UnknownScene { .. } if bare => UsageError(e.to_string()).into(),
            e => e.into(),
        }
    })?;
    for w in &s.report.warnings {
        eprintln!("warning: {}", printable(&spell::flags_in(&w.to_string())));
    }
    // The name comes from the file: every line that prints it prints it escaped.
    s.name = printable(&s.name);
    Ok(s)
}

/// `s` with its control characters escaped (`\x1b`, `\t`), so that text that came from a
/// file or the environment cannot move the cursor, clear the screen or retitle the
/// terminal when it is printed.
pub fn printable(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '\t' => out.push_str("\\t"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            c if c.is_control() => out.push_str(&format!("\\x{:02x}", c as u32)),
            c => out.push(c),
        }
    }
    out
}

fn check_out_dir(opt: &str, out: &std::path::Path) -> Result<()> {
    ::render::output::check_output(out).map_err(|e| anyhow::anyhow!("{opt} {e}"))
}

/// The file a path names, for comparing paths: its folder resolved (links and `..`), then
/// its name (an output need not exist yet; an existing output that is a link is replaced,
/// not written through, so the link itself is the file).
fn file_key(p: &std::path::Path) -> std::path::PathBuf {
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let dir = dir
        .canonicalize()
        .unwrap_or_else(|_| std::path::absolute(&dir).unwrap_or(dir));
    match p.file_name() {
        Some(n) => dir.join(n),
        None => dir,
    }
}

/// No output may be another output of the same command (`--json x --csv x`: one would be
/// lost) or a file the command reads (`inputs`: the scene file and everything it includes,
/// ray files, ...): refused with one line naming both, a usage error.
fn check_outputs(
    outputs: &[(&str, &std::path::Path)],
    inputs: &[&std::path::Path],
) -> Result<(), UsageError> {
    for (i, (a, pa)) in outputs.iter().enumerate() {
        let ka = file_key(pa);
        for (b, pb) in &outputs[..i] {
            if file_key(pb) == ka {
                return Err(UsageError(format!(
                    "{b} and {a} name the same file {}: one would be lost; give each its own",
                    pa.display()
                )));
            }
        }
        for input in inputs {
            let read = input.canonicalize().unwrap_or_else(|_| file_key(input));
            if read == ka || pa.canonicalize().is_ok_and(|c| c == read) {
                return Err(UsageError(format!(
                    "{a} {}: is an input of this command (it reads {}); refusing to overwrite it",
                    pa.display(),
                    input.display()
                )));
            }
        }
    }
    Ok(())
}

/// Write an output file atomically (`render::output::write_atomic`); the error names the
/// option and the file.
fn write_out(opt: &str, path: &std::path::Path, bytes: impl AsRef<[u8]>) -> Result<()> {
    ::render::output::write_atomic(path, bytes.as_ref()).map_err(|e| anyhow::anyhow!("{opt} {e}"))
}

/// The memory a command may use: `--max-memory` (MiB) when given, else 80 % of the
/// smaller of the machine's memory and the process's address-space limit.
fn memory_limit(max_mib: Option<u64>) -> u64 {
    ::trace::memory::limit(max_mib)
}

/// Refuse work whose memory model needs more than the limit, naming the options.
fn check_memory(what: &str, opts: &str, need: u64, max_mib: Option<u64>) -> Result<()> {
    let limit = memory_limit(max_mib);
    if need > limit {
        let gib = ::trace::memory::gib;
        bail!(
            "{opts}: {what} needs about {}, more than the {} allowed (--max-memory, default 80 % of this machine's memory); lower {opts} or raise --max-memory",
            gib(need),
            gib(limit)
        );
    }
    Ok(())
}

/// `--viewpoint EX,EY,EZ,TX,TY,TZ[,FOV]`: the scene seen from there at every time (an
/// animation's camera track no longer moves it); a viewpoint that makes no usable view (NaN
/// or overflowing rays) is refused, naming the option.
fn set_viewpoint(scene: &mut scene::Scene, v: &str) -> Result<()> {
    let cam =
        scene::Camera::from_viewpoint(v).map_err(|e| UsageError(format!("--viewpoint {e}")))?;
    scene
        .set_camera(cam)
        .map_err(|e| anyhow::anyhow!("--viewpoint {v}: {e}"))
}

/// The program and what it holds already (`held` bytes: its code, the rays read, the
/// render's buffers) must leave room under the limit for any scene at all.
fn check_held(held: u64, max_mib: Option<u64>) -> Result<()> {
    let limit = memory_limit(max_mib);
    if held >= limit {
        let gib = ::trace::memory::gib;
        bail!(
            "--max-memory: the program and its buffers take {} before the scene loads, more than the {} allowed; raise --max-memory",
            gib(held),
            gib(limit)
        );
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
