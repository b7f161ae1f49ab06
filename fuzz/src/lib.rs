//! Fuzzing every rayspace loader on stable Rust (issue 14): OBJ/MTL, glTF and GLB, TOML
//! scenes, BART AFF, ray files and hit files.
//!
//! No compiler instrumentation is needed: inputs come from structure-aware mutations
//! ([`mutate`]) of seeds ([`targets`]): small valid files covering each format, the hostile
//! inputs the issue lists, and pieces of the real scenes. Inputs a loader accepts join that
//! worker's pool, so mutations build on structure that parses. Each input is written to a
//! worker's own directory (with its companion files: MTL, buffer, include, mesh) and loaded
//! through the public entry point, as a user's file would be.
//!
//! Findings, each saved with its files under the output directory:
//! - a **panic** (caught per input);
//! - a **hang**: one input running over [`HANG_SECONDS`] (a watchdog saves it and ends the
//!   run, since a hung thread cannot be stopped);
//! - an **allocation over the cap** ([`alloc::SOFT_CAP`] on the loading thread; beyond
//!   [`alloc::HARD_CAP`] anywhere the request is refused and the run aborts with the inputs
//!   in flight saved);
//! - a **wrong result**: a scene that loads but is not finite at some time of its animation,
//!   or a ray file that reads but fails its own validation.
//!
//! `cargo run --release -p fuzz -- --minutes N` runs long; the crate's test runs a fixed,
//! seeded number of inputs per loader in CI.

pub mod alloc;
pub mod mutate;
pub mod targets;

use mutate::Rng;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};
use targets::{Outcome, Target};

/// An input that runs longer than this is a hang.
pub const HANG_SECONDS: u64 = 10;

/// How long and where to fuzz.
#[derive(Clone, Debug)]
pub struct Config {
    /// Targets by name ([`targets::NAMES`]).
    pub targets: Vec<String>,
    /// Inputs per target (each worker runs its share), or …
    pub execs: Option<u64>,
    /// … seconds per target.
    pub seconds: Option<f64>,
    /// Worker threads.
    pub threads: usize,
    /// Seed of the mutations (worker w uses seed + w).
    pub seed: u64,
    /// Where findings and the workers' directories go.
    pub out: PathBuf,
    /// The shared scenes, whose pieces seed the text formats.
    pub scenes: Option<PathBuf>,
}

/// One target's run.
#[derive(Clone, Debug, Default)]
pub struct Report {
    /// The target.
    pub target: String,
    /// Inputs loaded.
    pub execs: u64,
    /// Loaded without error.
    pub accepted: u64,
    /// Refused with an error.
    pub rejected: u64,
    /// Panics.
    pub panics: u64,
    /// Loads that returned a wrong result.
    pub wrong: u64,
    /// Inputs that allocated more than the cap at once.
    pub over_cap: u64,
    /// Largest single allocation seen (any thread), bytes.
    pub largest_alloc: usize,
    /// Peak live heap during the run, bytes.
    pub peak_heap: usize,
    /// Slowest input, seconds.
    pub slowest: f64,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Where each finding was saved, with what it was.
    pub findings: Vec<String>,
}

impl Report {
    /// Whether the run found nothing.
    pub fn clean(&self) -> bool {
        self.panics + self.wrong + self.over_cap == 0
    }
}

/// The reports as a markdown table.
pub fn table(reports: &[Report]) -> String {
    let mut s = String::from(
        "| loader | inputs | accepted | refused | panics | wrong | over cap | largest alloc | peak heap | slowest | inputs/s |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in reports {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {:.1} MiB | {:.1} MiB | {:.3} s | {:.0} |\n",
            r.target,
            r.execs,
            r.accepted,
            r.rejected,
            r.panics,
            r.wrong,
            r.over_cap,
            r.largest_alloc as f64 / (1 << 20) as f64,
            r.peak_heap as f64 / (1 << 20) as f64,
            r.slowest,
            r.execs as f64 / r.seconds.max(1e-9),
        );
    }
    s
}

/// What the watchdog and the breach hook need: each worker's directory and input start.
struct Flight {
    dirs: Vec<PathBuf>,
    started_ms: Vec<AtomicU64>,
    out: PathBuf,
    target: String,
}

static FLIGHT: Mutex<Option<Arc<Flight>>> = Mutex::new(None);
static EPOCH: OnceLock<Instant> = OnceLock::new();

fn now_ms() -> u64 {
    EPOCH.get_or_init(Instant::now).elapsed().as_millis() as u64 + 1
}

/// Copy a worker's current files to `out/<name>`; the path.
fn save(dir: &Path, out: &Path, name: &str) -> PathBuf {
    let to = out.join(name);
    let _ = std::fs::create_dir_all(&to);
    if let Ok(r) = std::fs::read_dir(dir) {
        for e in r.flatten() {
            let _ = std::fs::copy(e.path(), to.join(e.file_name()));
        }
    }
    to
}

/// Save every input in flight (the hard cap's and the watchdog's last act).
fn save_in_flight(why: &str) {
    let f = FLIGHT.lock().ok().and_then(|g| g.clone());
    if let Some(f) = f {
        for (w, d) in f.dirs.iter().enumerate() {
            if f.started_ms[w].load(Relaxed) != 0 {
                let p = save(d, &f.out, &format!("{}-{why}-worker{w}", f.target));
                eprintln!(
                    "fuzz: {why}: {} input in flight saved to {}",
                    f.target,
                    p.display()
                );
            }
        }
    }
}

fn breach(size: usize) {
    eprintln!(
        "fuzz: an allocation of {size} bytes (over the {} hard cap) was refused",
        alloc::HARD_CAP
    );
    save_in_flight("hard-cap");
}

thread_local! {
    static LAST_PANIC: std::cell::RefCell<String> = const { std::cell::RefCell::new(String::new()) };
}

/// Fuzz every configured target in turn; the reports, one per target.
pub fn run(cfg: &Config) -> anyhow::Result<Vec<Report>> {
    let all = targets::all(cfg.scenes.as_deref());
    for t in &cfg.targets {
        anyhow::ensure!(
            targets::NAMES.contains(&t.as_str()),
            "--targets: unknown loader '{t}' (known: {})",
            targets::NAMES.join(", ")
        );
    }
    anyhow::ensure!(
        cfg.execs.is_some() || cfg.seconds.is_some(),
        "give a number of inputs or a duration"
    );
    std::fs::create_dir_all(&cfg.out)?;
    alloc::on_breach(breach);
    // Quiet panics: they are counted and saved, not printed as they happen.
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .to_string()
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ");
        LAST_PANIC.with(|p| *p.borrow_mut() = msg);
    }));
    let mut reports = Vec::new();
    for t in all
        .iter()
        .filter(|t| cfg.targets.iter().any(|n| n == t.name))
    {
        reports.push(run_target(t, cfg)?);
    }
    std::panic::set_hook(prev);
    Ok(reports)
}

fn run_target(t: &Target, cfg: &Config) -> anyhow::Result<Report> {
    let threads = cfg.threads.max(1);
    let work = cfg.out.join("work").join(t.name);
    let dirs: Vec<PathBuf> = (0..threads).map(|w| work.join(format!("w{w}"))).collect();
    for d in &dirs {
        let _ = std::fs::remove_dir_all(d);
        std::fs::create_dir_all(d)?;
    }
    let flight = Arc::new(Flight {
        dirs: dirs.clone(),
        started_ms: (0..threads).map(|_| AtomicU64::new(0)).collect(),
        out: cfg.out.clone(),
        target: t.name.to_string(),
    });
    *FLIGHT.lock().unwrap() = Some(flight.clone());
    let done = Arc::new(AtomicBool::new(false));
    let watchdog = {
        let (flight, done) = (flight.clone(), done.clone());
        std::thread::spawn(move || {
            while !done.load(Relaxed) {
                std::thread::sleep(Duration::from_millis(100));
                let now = now_ms();
                if flight.started_ms.iter().any(|s| {
                    let s = s.load(Relaxed);
                    s != 0 && now - s > HANG_SECONDS * 1000
                }) {
                    eprintln!(
                        "fuzz: an input of {} ran over {HANG_SECONDS} s",
                        flight.target
                    );
                    save_in_flight("hang");
                    std::process::exit(3);
                }
            }
        })
    };
    alloc::take_largest();
    alloc::take_peak();
    let t0 = Instant::now();
    let per_worker = cfg.execs.map(|n| n.div_ceil(threads as u64));
    let deadline = cfg.seconds.map(|s| t0 + Duration::from_secs_f64(s));
    let parts: Vec<Report> = std::thread::scope(|sc| {
        let hs: Vec<_> = (0..threads)
            .map(|w| {
                let (flight, dir) = (&flight, &dirs[w]);
                sc.spawn(move || worker(t, w, cfg, dir, flight, per_worker, deadline))
            })
            .collect();
        hs.into_iter().map(|h| h.join().expect("worker")).collect()
    });
    done.store(true, Relaxed);
    let _ = watchdog.join();
    let mut r = Report {
        target: t.name.to_string(),
        seconds: t0.elapsed().as_secs_f64(),
        largest_alloc: alloc::take_largest(),
        peak_heap: alloc::take_peak(),
        ..Default::default()
    };
    for p in parts {
        r.execs += p.execs;
        r.accepted += p.accepted;
        r.rejected += p.rejected;
        r.panics += p.panics;
        r.wrong += p.wrong;
        r.over_cap += p.over_cap;
        r.slowest = r.slowest.max(p.slowest);
        r.findings.extend(p.findings);
    }
    if r.clean() {
        let _ = std::fs::remove_dir_all(&work);
    }
    Ok(r)
}

fn worker(
    t: &Target,
    w: usize,
    cfg: &Config,
    dir: &Path,
    flight: &Flight,
    execs: Option<u64>,
    deadline: Option<Instant>,
) -> Report {
    let mut rng = Rng::new(
        cfg.seed
            .wrapping_add(w as u64)
            .wrapping_mul(0x2545_f491_4f6c_dd1d),
    );
    let mut pool: Vec<Vec<Vec<u8>>> = t.seeds.clone();
    let nseeds = pool.len();
    let mut r = Report::default();
    let main = dir.join(t.files[0].0);
    loop {
        if execs.is_some_and(|n| r.execs >= n) || deadline.is_some_and(|d| Instant::now() >= d) {
            break;
        }
        // Mutate a pooled input: mostly its loaded file, sometimes a companion.
        let mut input = pool[rng.below(pool.len())].clone();
        let f = if t.files.len() > 1 && rng.one_in(5) {
            1 + rng.below(t.files.len() - 1)
        } else {
            0
        };
        let others: Vec<&[u8]> = t.seeds.iter().map(|s| s[f].as_slice()).collect();
        mutate::mutate(&mut rng, &mut input[f], t.files[f].1, &others);
        for ((name, _), bytes) in t.files.iter().zip(&input) {
            if std::fs::write(dir.join(name), bytes).is_err() {
                continue;
            }
        }
        alloc::take_thread_largest();
        flight.started_ms[w].store(now_ms(), Relaxed);
        let t1 = Instant::now();
        let out = std::panic::catch_unwind(|| (t.load)(&main));
        let dt = t1.elapsed().as_secs_f64();
        flight.started_ms[w].store(0, Relaxed);
        let big = alloc::take_thread_largest();
        r.execs += 1;
        r.slowest = r.slowest.max(dt);
        let mut finding = |kind: &str, what: String| {
            let p = save(
                dir,
                &cfg.out,
                &format!("{}-{kind}-w{w}-{}", t.name, r.execs),
            );
            r.findings.push(format!("{kind}: {what} ({})", p.display()));
        };
        match out {
            Err(_) => {
                let msg = LAST_PANIC.with(|p| p.borrow().clone());
                finding("panic", msg);
                r.panics += 1;
            }
            Ok(Outcome::Wrong(msg)) => {
                finding("wrong", msg);
                r.wrong += 1;
            }
            Ok(Outcome::Rejected) => r.rejected += 1,
            Ok(Outcome::Accepted) => {
                r.accepted += 1;
                // Inputs that load are kept to build on (the seeds stay).
                if pool.len() < nseeds + 256 {
                    pool.push(input);
                } else {
                    let i = nseeds + rng.below(256);
                    pool[i] = input;
                }
            }
        }
        if big > alloc::SOFT_CAP {
            finding("over-cap", format!("one allocation of {big} bytes"));
            r.over_cap += 1;
        }
    }
    r
}

/// Load the saved findings under `dir` again (each a directory named `<loader>-<kind>-…`
/// holding the files), as the fuzzer did: the outcome of each, or the panic's message.
pub fn replay(dir: &Path) -> anyhow::Result<Vec<(PathBuf, String)>> {
    let all = targets::all(None);
    let mut out = Vec::new();
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)?
        .flatten()
        .map(|e| e.path())
        .collect();
    entries.sort();
    for p in entries.into_iter().filter(|p| p.is_dir()) {
        let name = p
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let Some(t) = all
            .iter()
            .find(|t| name.starts_with(&format!("{}-", t.name)))
        else {
            continue;
        };
        let main = p.join(t.files[0].0);
        if !main.exists() {
            continue;
        }
        let what = match std::panic::catch_unwind(|| (t.load)(&main)) {
            Ok(Outcome::Accepted) => "loads".to_string(),
            Ok(Outcome::Rejected) => "refused with an error".to_string(),
            Ok(Outcome::Wrong(w)) => format!("WRONG: {w}"),
            Err(_) => "PANIC".to_string(),
        };
        out.push((p, what));
    }
    Ok(out)
}
