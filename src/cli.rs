//! Command-line interface.

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use render::whitted::{render, Progress, RenderOptions, MAX_BOUNCES, MAX_SIDE};
use render::Tracer;
use scene::{Geometry, LoadOptions, MeshSplit};
use serde::Serialize;
use std::path::PathBuf;
use std::time::{Duration, Instant};

#[derive(Parser)]
#[command(
    name = "rayspace",
    version,
    about = "Ray tracing with ray-space hierarchies and irregular grids"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene: rasterized primary visibility, traced shadow/reflection/refraction rays.
    Render(RenderArgs),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Engine {
    /// Every ray against every triangle (the oracle).
    Brute,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Split {
    Groups,
    Materials,
    Single,
}

#[derive(Args, Clone)]
struct RenderArgs {
    /// A built-in scene (cornell, spheres, soup, stadium, office), or an .obj, .gltf/.glb or .toml file.
    #[arg(default_value = "cornell")]
    scene: String,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    height: u32,
    /// Whitted recursion depth: reflection/refraction generations after the rasterized one.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Tracing engine.
    #[arg(long, value_enum, default_value_t = Engine::Brute)]
    engine: Engine,
    /// How OBJ files are cut into meshes (the unit of bounding-sphere culling).
    #[arg(long, value_enum, default_value_t = Split::Groups)]
    meshes: Split,
    /// Output PNG.
    #[arg(long, default_value = "rayspace.png")]
    out: PathBuf,
    /// Also write the statistics as JSON to this file.
    #[arg(long)]
    stats: Option<PathBuf>,
}

impl Default for RenderArgs {
    fn default() -> Self {
        RenderArgs {
            scene: "cornell".into(),
            width: 512,
            height: 512,
            bounces: 3,
            engine: Engine::Brute,
            meshes: Split::Groups,
            out: PathBuf::from("rayspace.png"),
            stats: None,
        }
    }
}

pub fn make_engine(engine: Engine, geo: &Geometry) -> Box<dyn Tracer> {
    match engine {
        Engine::Brute => Box::new(accel::BruteForce::new(geo)),
    }
}

struct Bar(ProgressBar);

impl Progress for Bar {
    fn stage(&self, name: &str) {
        self.0.set_message(name.to_string());
    }
}

fn progress_bar() -> Bar {
    // Drawn only when stderr is a terminal (indicatif hides it otherwise).
    let pb = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    pb.set_style(ProgressStyle::with_template("{spinner} [{elapsed}] {msg}").unwrap());
    pb.enable_steady_tick(Duration::from_millis(120));
    Bar(pb)
}

#[derive(Serialize)]
struct StatsFile<'a> {
    #[serde(flatten)]
    render: &'a render::RenderStats,
    load_seconds: f64,
    degenerate_skipped: usize,
    raster_setup_triangles: u64,
    raster_fragments: u64,
}

fn cmd_render(a: &RenderArgs) -> Result<()> {
    let split = match a.meshes {
        Split::Groups => MeshSplit::Groups,
        Split::Materials => MeshSplit::Materials,
        Split::Single => MeshSplit::Single,
    };
    if let Some(dir) = a.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            bail!(
                "--out {}: directory {} does not exist",
                a.out.display(),
                dir.display()
            );
        }
    }
    let t0 = Instant::now();
    let scene = scene::load(&a.scene, &LoadOptions { split })?;
    let geo = Geometry::from_scene(&scene);
    let load_s = t0.elapsed().as_secs_f64();
    let r = &scene.report;
    println!(
        "loaded {} in {:.2} s: {} triangles, {} meshes, {} materials, {} lights{}{}",
        scene.name,
        load_s,
        geo.len(),
        geo.mesh_count(),
        scene.materials.len(),
        scene.lights.len(),
        if r.degenerate_skipped > 0 {
            format!(", {} degenerate triangles skipped", r.degenerate_skipped)
        } else {
            String::new()
        },
        if r.notes.is_empty() {
            String::new()
        } else {
            format!(" ({})", r.notes.join("; "))
        },
    );
    let t1 = Instant::now();
    let engine = make_engine(a.engine, &geo);
    let build_s = t1.elapsed().as_secs_f64();
    let bar = progress_bar();
    let opts = RenderOptions {
        width: a.width,
        height: a.height,
        bounces: a.bounces,
    };
    let mut out = render(&scene, &geo, engine.as_ref(), &opts, &bar);
    bar.0.finish_and_clear();
    out.stats.phases.insert(0, ("engine build".into(), build_s));
    render::output::write_png(&out.pixels, a.width, a.height, &a.out)
        .map_err(anyhow::Error::msg)
        .context("--out")?;
    println!("{}", out.stats.table());
    println!("wrote {}", a.out.display());
    if let Some(p) = &a.stats {
        let f = StatsFile {
            render: &out.stats,
            load_seconds: load_s,
            degenerate_skipped: r.degenerate_skipped,
            raster_setup_triangles: out.raster.setup,
            raster_fragments: out.raster.fragments,
        };
        let json = serde_json::to_string_pretty(&f)?;
        std::fs::write(p, json).with_context(|| format!("--stats {}", p.display()))?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

pub fn run() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Some(Command::Render(a)) => cmd_render(&a),
        None => cmd_render(&RenderArgs::default()),
    }
}
