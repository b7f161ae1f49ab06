//! `cargo run --release -p fuzz -- --minutes N`: fuzz every loader for N minutes in all
//! (split evenly), print the table of inputs and findings, and exit 1 on any finding.

use clap::Parser;
use std::path::PathBuf;

#[derive(Parser)]
#[command(about = "Fuzz rayspace's loaders (OBJ/MTL, glTF, GLB, TOML, AFF, ray and hit files)")]
struct Args {
    /// Minutes in all, split evenly over the loaders.
    #[arg(long, conflicts_with_all = ["seconds", "execs"])]
    minutes: Option<f64>,
    /// Seconds in all, split evenly over the loaders.
    #[arg(long, conflicts_with = "execs")]
    seconds: Option<f64>,
    /// Inputs per loader (deterministic for a given --seed and --threads).
    #[arg(long)]
    execs: Option<u64>,
    /// Loaders, comma-separated (obj, gltf, glb, toml, aff, rays, hits).
    #[arg(long, default_value = "obj,gltf,glb,toml,aff,rays,hits")]
    targets: String,
    /// Worker threads (default: the machine's cores).
    #[arg(long)]
    threads: Option<usize>,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where findings are saved.
    #[arg(long, default_value = "target/fuzz")]
    out: PathBuf,
    /// Also write the table here (markdown).
    #[arg(long)]
    report: Option<PathBuf>,
    /// Instead of fuzzing, load the findings saved under this directory again.
    #[arg(long)]
    replay: Option<PathBuf>,
}

fn main() {
    let a = Args::parse();
    if let Some(d) = &a.replay {
        match fuzz::replay(d) {
            Ok(v) => {
                let bad = v
                    .iter()
                    .filter(|(_, w)| w.starts_with("PANIC") || w.starts_with("WRONG"))
                    .count();
                for (p, w) in &v {
                    println!("{}: {w}", p.display());
                }
                println!("{} findings replayed, {bad} still fail", v.len());
                std::process::exit(i32::from(bad > 0));
            }
            Err(e) => {
                eprintln!("error: --replay {}: {e}", d.display());
                std::process::exit(1);
            }
        }
    }
    let targets: Vec<String> = a.targets.split(',').map(|s| s.trim().to_string()).collect();
    let total = a.minutes.map(|m| m * 60.0).or(a.seconds);
    let execs = if total.is_none() {
        Some(a.execs.unwrap_or(10_000))
    } else {
        None
    };
    if let Some(s) = total {
        if !(s.is_finite() && s > 0.0 && s <= 7.0 * 86400.0) {
            eprintln!("error: --minutes/--seconds: a duration between 0 and a week");
            std::process::exit(2);
        }
    }
    let cfg = fuzz::Config {
        seconds: total.map(|s| s / targets.len().max(1) as f64),
        execs,
        targets,
        threads: a
            .threads
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())),
        seed: a.seed,
        out: a.out,
        scenes: scene::scenes_dir(),
    };
    match fuzz::run(&cfg) {
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::exit(2);
        }
        Ok(reports) => {
            let t = fuzz::table(&reports);
            print!("{t}");
            if let Some(p) = &a.report {
                if let Err(e) = render::output::write_atomic(p, t.as_bytes()) {
                    eprintln!("error: --report {e}");
                    std::process::exit(1);
                }
            }
            let mut clean = true;
            for r in &reports {
                for f in &r.findings {
                    println!("{}: {f}", r.target);
                }
                clean &= r.clean();
            }
            if !clean {
                std::process::exit(1);
            }
        }
    }
}
