//! `rayspace bench`: the papers' evaluations, reproduced on this machine.
//!
//! - [`rsh`]: the thesis's chapter-4 tables (CRSH against RAH per configuration).
//! - [`gpu`]: the GPU backend against the CPU engines, phase by phase (thesis Tables 4.25–4.27).
//! - [`grid`]: the irregular-grid paper's Tables 1, 2, 3 and 5 against the peers.
//! - [`budget`]: the irregular-grid paper's Table 4 (AO samples per frame budget).
//!
//! This module holds what they share: the [`Spec`] of the ray-hierarchy benchmarks, the
//! recording of a render's ray batches, the scene list and the provenance line every report
//! starts with. [`charts`] draws their figures.

pub mod budget;
pub mod charts;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod grid;
pub mod rsh;
pub mod scale;

use anyhow::Result;
use render::whitted::RenderOptions;
use scene::{Geometry, LoadOptions};
use trace::Hit;

/// What the ray-hierarchy benchmarks ([`rsh`], [`gpu`]) run: scenes × configurations B/D.
pub struct Spec {
    pub scenes: Vec<String>,
    /// (branching, levels) pairs.
    pub configs: Vec<(u32, u32)>,
    pub width: u32,
    pub height: u32,
    pub bounces: u32,
}

/// Why a `B/D,...` list of configurations was refused.
#[derive(Debug, thiserror::Error)]
pub enum ConfigsError {
    /// A pair is not `B/D` with two numbers.
    #[error("'{0}' is not B/D (branching/levels)")]
    Syntax(String),
    /// A pair's branching or levels is out of range.
    #[error("'{pair}': {error}")]
    Option {
        /// The pair as written.
        pair: String,
        /// Why.
        error: trace::OptionError,
    },
}

/// Parse `B/D,B/D,...`; each pair is checked by [`::rsh::RshConfig::validate`].
pub fn parse_configs(s: &str) -> Result<Vec<(u32, u32)>, ConfigsError> {
    s.split(',')
        .map(|c| {
            let syntax = || ConfigsError::Syntax(c.to_string());
            let (b, d) = c.trim().split_once('/').ok_or_else(syntax)?;
            let b: u32 = b.parse().map_err(|_| syntax())?;
            let d: u32 = d.parse().map_err(|_| syntax())?;
            ::rsh::RshConfig {
                branching: b,
                levels: d,
                ..::rsh::RshConfig::crsh()
            }
            .validate()
            .map_err(|error| ConfigsError::Option {
                pair: c.to_string(),
                error,
            })?;
            Ok((b, d))
        })
        .collect()
}

/// The batches a render of `name` traces (answered by CPU CRSH, whose hits equal brute
/// force's), with the scene and its geometry.
pub type Recorded = (
    scene::Scene,
    Geometry,
    Vec<(trace::RayBatch, trace::TraceMode, Vec<Hit>)>,
);

/// Render `name` once with CRSH, recording every traced batch.
pub fn record(name: &str, width: u32, height: u32, bounces: u32) -> Result<Recorded> {
    let s = scene::load(name, &LoadOptions::default())?;
    let geo = Geometry::from_scene(&s);
    let opts = RenderOptions {
        width,
        height,
        bounces,
        spp: 1,
    };
    // The frame as every front end makes it (the runner), recording CRSH's batches.
    let f = crate::runner::Runner::new(
        crate::engines::Engine::Crsh,
        crate::engines::Config::Rsh(::rsh::RshConfig::crsh()),
        crate::engines::Backend::Cpu,
    )
    .record(true)
    .with_geometry(geo.clone())
    .frame(&s, None, 0, &opts, &())?;
    Ok((s, geo, f.batches))
}

/// The scenes of a benchmark: `--scenes a,b,...` as given (at least one name), or the
/// built-in `builtins` plus the shared scenes `real` by name (`sponza`: the benchmark view
/// of `bench/scenes/sponza.toml`) when the shared scenes are present.
pub fn scenes(arg: Option<&str>, builtins: &[&str], real: &[&str]) -> Result<Vec<String>> {
    Ok(match arg {
        Some(s) => {
            let v: Vec<String> = s
                .split(',')
                .map(|x| x.trim().to_string())
                .filter(|x| !x.is_empty())
                .collect();
            if v.is_empty() {
                anyhow::bail!("`scenes`='{s}': no scene named");
            }
            v
        }
        None => {
            let mut v: Vec<String> = builtins.iter().map(|s| s.to_string()).collect();
            if scene::scenes_dir().is_some() {
                // The shared scenes by name (`scene::SHARED`: the benchmark views are built
                // into the binary).
                v.extend(real.iter().map(|f| f.to_string()));
            }
            v
        }
    })
}

/// Machine, build and revision, recorded with every benchmark.
pub fn provenance() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    // The commit the binary was built from (see build.rs), not the checkout it runs in.
    let commit = env!("RAYSPACE_BUILD_COMMIT");
    // Which grid traversal kernel this CPU runs (decided at run time; the same hits either
    // way, not the same speed).
    let grid = if accel::grid::lanes::available() {
        "8 AVX2 lanes"
    } else {
        "scalar stream"
    };
    format!(
        "rayspace {} (commit {commit}, {} build{}), {cpu}, {} threads, grid traversal in {grid}",
        env!("CARGO_PKG_VERSION"),
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "optimised"
        },
        if cfg!(target_feature = "avx2") {
            ", avx2"
        } else {
            ""
        },
        rayon::current_num_threads()
    )
}
