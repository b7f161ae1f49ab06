//! The command line's grammar (clap): subcommands and their options. Option values that name
//! a library enum parse into it directly (`clap::ValueEnum` behind each crate's `clap`
//! feature), and defaults come from the library's own (`RshConfig::crsh()`,
//! `GridConfig::default()`), so nothing here restates the engines' choices.

use clap::{Args, Parser, Subcommand};
use rayspace::bench::Spec;
pub use rayspace::engines::Backend;
use rayspace::engines::{Engine, DEFAULT_ENGINE};
pub use rayspace::options::{EngineFlags, LoadArgs, LookArgs};
use render::raygen::Kind;
use render::whitted::{MAX_BOUNCES, MAX_SIDE};
use std::path::PathBuf;

/// The version and the optional features this binary was built with (`--version`).
fn version() -> &'static str {
    static V: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    V.get_or_init(|| {
        let features: Vec<&str> = [
            (cfg!(feature = "gpu"), "gpu"),
            (cfg!(feature = "view"), "view"),
            (cfg!(feature = "embree"), "embree"),
        ]
        .into_iter()
        .filter_map(|(on, f)| on.then_some(f))
        .collect();
        format!(
            "{} (features: {}; commit {})",
            env!("CARGO_PKG_VERSION"),
            if features.is_empty() {
                "none".to_string()
            } else {
                features.join(", ")
            },
            env!("RAYSPACE_BUILD_COMMIT")
        )
    })
}

#[derive(Parser)]
#[command(
    name = "rayspace",
    version = version(),
    about = "Ray tracing with ray-space hierarchies and irregular grids",
    max_term_width = 100,
    after_help = "Engines and their options: `rayspace engines`; the manual: README.md and docs/."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a scene: rasterized primary visibility, traced shadow/reflection/refraction rays.
    Render(RenderArgs),
    /// Write a ray file (primary, shadow, reflection, ambient-occlusion or random rays).
    Rays(RaysArgs),
    /// Trace a ray file with an engine: prints MRays/s and counters, writes the hits.
    Trace(TraceArgs),
    /// List every engine: what it runs, its paper, and its options with their defaults.
    Engines(EnginesArgs),
    /// Reproduce the papers' evaluation tables.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
    /// Render every scene with every engine and run the benchmarks; write one static HTML
    /// page (renders, difference images, the papers' tables beside ours, charts, scaling).
    Report(ReportCmdArgs),
    /// An interactive window: switch engine (e), backend (g), bounces (b/B), buffer (v);
    /// play (space) and scrub ([ ]) animations; drag to orbit, wheel to zoom, wasdqz to fly.
    View(ViewArgs),
}

#[derive(Args, Clone)]
pub struct ViewArgs {
    /// A built-in, shared or generated scene (hairball:100k), or an .obj, .gltf/.glb, .toml
    /// or BART .aff file.
    #[arg(default_value = "spheres")]
    pub scene: String,
    #[arg(long, value_enum, default_value_t = DEFAULT_ENGINE)]
    pub engine: Engine,
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    pub backend: Backend,
    #[arg(long, default_value_t = 512, value_parser = side())]
    pub width: u32,
    #[arg(long, default_value_t = 512, value_parser = side())]
    pub height: u32,
    #[arg(long, default_value_t = 3, value_parser = bounces())]
    pub bounces: u32,
    /// Camera: EX,EY,EZ,TX,TY,TZ[,FOV] (eye, target, vertical field of view in degrees).
    #[arg(
        long,
        value_name = "EX,EY,EZ,TX,TY,TZ[,FOV]",
        allow_hyphen_values = true
    )]
    pub viewpoint: Option<String>,
    /// Start at this time of an animated scene.
    #[arg(long)]
    pub time: Option<f32>,
    /// The buffer shown first (v cycles them).
    #[arg(long, default_value = "shaded", value_parser = ["shaded", "normals", "kinds", "tests"])]
    pub buffer: String,
    /// Render this many full frames, write the last one (as shown, read back from the GPU)
    /// to F.png and exit: the viewer without a person (tests, CI under Xvfb).
    #[arg(long, value_name = "F.png")]
    pub screenshot: Option<PathBuf>,
    /// Frames before the screenshot.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub frames: u32,
    /// Render the screenshot's frames at 1/N resolution, upscaled, as the moving view's
    /// previews are (measures their frame rate).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub scale: u32,
    /// Text overlay (default: on in the window, off in screenshots).
    #[arg(long, value_parser = rayspace::options::on_off())]
    pub overlay: Option<bool>,
    /// Most memory a frame may use, in MiB (default: 80 % of this machine's memory); a size
    /// whose memory model needs more is refused before the window opens.
    #[arg(long = "max-memory", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_memory: Option<u64>,
    /// The display interval previews aim at while the view moves (ms).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..=10000))]
    pub interval_ms: u64,
    /// Samples per pixel (antialiasing), as `render --spp`.
    #[arg(long, default_value_t = 1, value_parser = spp())]
    pub spp: u32,
    #[command(flatten)]
    pub load: LoadArgs,
    #[command(flatten)]
    pub look: LookArgs,
}

#[derive(Args, Clone)]
pub struct EnginesArgs {
    /// As JSON: `{"engines": [{"name", "summary", "gpu", "options": {NAME: default}, "gpu_options": {...}}]}`
    /// (option names as the command line spells them, without the dashes).
    #[arg(long)]
    pub json: bool,
}

#[derive(Args, Clone)]
pub struct ReportCmdArgs {
    /// Output directory (made if missing): index.html, report.json, img/, charts/.
    #[arg(short = 'o', long, default_value = "report")]
    pub out: PathBuf,
    /// The small version (under a minute on 2 cores): built-in scenes at 128², one timing
    /// run, short scaling series.
    #[arg(long)]
    pub quick: bool,
    /// Scenes, comma-separated, for the renders and both benchmarks (default: built-ins,
    /// plus Sponza, Conference and Kitchen when the shared scenes are present and not
    /// --quick).
    #[arg(long)]
    pub scenes: Option<String>,
    /// Image side in pixels of the renders and benchmarks (default 512; --quick 128).
    #[arg(long, value_parser = side())]
    pub size: Option<u32>,
}

#[derive(Subcommand)]
pub enum BenchCommand {
    /// The thesis's chapter-4 tables: CRSH and RAH per configuration on the same rays
    /// (charts: intersections per hierarchy level, like the thesis's Figures 4.7–4.23).
    #[command(mut_arg("scenes", |a| a.help("Scenes, comma-separated: built-in or shared names (sponza, conference, kitchen, museum) or files [default: cornell, office, and sponza when the shared scenes are present]")))]
    Rsh(BenchRshArgs),
    /// The GPU backend against the CPU engines on the same rays, phase by phase (CRSH, RAH;
    /// the irregular grid's traversal on primary, AO and random rays), with the agreement
    /// of hits and counters checked in the same run.
    #[command(mut_arg("scenes", |a| a.help("Scenes, comma-separated: built-in or shared names (sponza, conference, kitchen, museum) or files [default: cornell, and sponza when the shared scenes are present]")))]
    Gpu(BenchGpuArgs),
    /// The irregular-grid paper's Tables 1, 2, 3 and 5: our grids against the peers
    /// (obvhs; Embree with `--features embree`) on the same rays (charts: MRays/s by ray
    /// kind and engine).
    #[command(mut_arg("scenes", |a| a.help("Scenes, comma-separated: built-in or shared names (sponza, conference, kitchen, museum) or files [default: cornell, office, stadium, and sponza, conference, kitchen when the shared scenes are present]")))]
    Grid(BenchGridArgs),
    /// The irregular-grid paper's Table 4: AO samples per pixel that fit in a frame budget
    /// on an animated scene, per-frame rebuild included.
    Budget(BenchBudgetArgs),
    /// Every engine on generated scenes (hairball, city, nested) from thousands to millions
    /// of triangles: build time, structure bytes per triangle, MRays/s, tests per ray, a
    /// render's whole-process peak memory, and each measure's log-log slope.
    Scale(BenchScaleArgs),
}

#[derive(Args, Clone)]
pub struct BenchScaleArgs {
    /// Generators, comma-separated (hairball, city, nested).
    #[arg(long, default_value = "hairball,city,nested")]
    pub generators: String,
    /// Sizes in triangles, comma-separated (10000, 250k, 2M).
    #[arg(long, default_value = "10k,30k,100k,300k,1M")]
    pub sizes: String,
    /// Engines, comma-separated [default: crsh, rah, grid, grid2l, obvhs-cwbvh, embree with
    /// `--features embree`, then brute].
    #[arg(long)]
    pub engines: Option<String>,
    /// Brute force runs up to this many triangles (it stays the oracle where it runs).
    #[arg(long = "brute-max", default_value_t = 20_000)]
    pub brute_max: u64,
    #[arg(long, default_value_t = 256, value_parser = side())]
    pub width: u32,
    #[arg(long, default_value_t = 256, value_parser = side())]
    pub height: u32,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Timed runs per engine and ray kind (the best is reported).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeats: u32,
    /// Skip the peak-memory renders (one child process per engine and size).
    #[arg(long = "no-peak")]
    pub no_peak: bool,
    #[command(flatten)]
    pub out: ReportArgs,
}

/// Image side in pixels: 1..=`MAX_SIDE`.
fn side() -> clap::builder::RangedI64ValueParser<u32> {
    clap::value_parser!(u32).range(1..=MAX_SIDE as i64)
}

/// Reflection/refraction generations: 0..=`MAX_BOUNCES`.
fn bounces() -> clap::builder::RangedI64ValueParser<u32> {
    clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64)
}

#[derive(Args, Clone)]
pub struct BenchBudgetArgs {
    /// An animated scene (a BART .aff file); a static scene is measured as one still.
    pub scene: String,
    #[command(flatten)]
    pub load: LoadArgs,
    /// Frame budgets in milliseconds, comma-separated.
    #[arg(long, default_value = "100,50,33")]
    pub ms: String,
    /// Engines, comma-separated (crsh, rah, grid, grid2l, obvhs-cwbvh, obvhs-bvh2, embree,
    /// embree-stream, brute).
    #[arg(long, default_value = "grid,grid2l,obvhs-cwbvh")]
    pub engines: String,
    #[arg(long, default_value_t = 1024, value_parser = side())]
    pub width: u32,
    #[arg(long, default_value_t = 1024, value_parser = side())]
    pub height: u32,
    /// Instants of the animation measured (spread over its interval); times are averaged.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub frames: u32,
    /// Also write the rows as CSV.
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

#[derive(Args, Clone)]
pub struct BenchGridArgs {
    #[command(flatten)]
    pub spec: SceneArgs,
    /// Ambient-occlusion rays per pixel.
    #[arg(long = "ao-spp", default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub ao_spp: u32,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Timed runs per engine and ray kind (the best is reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeats: u32,
    /// Also write the grid builds of Tables 1, 2 and 5 as CSV.
    #[arg(long = "grids-csv")]
    pub grids_csv: Option<PathBuf>,
    #[command(flatten)]
    pub out: ReportArgs,
}

/// Where a benchmark's report goes besides stdout.
#[derive(Args, Clone)]
pub struct ReportArgs {
    /// Also write every row (with every counter) as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Also write the main table's rows as CSV (`bench grid`: Table 3, engine × ray kind).
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Also write the markdown report to this file.
    #[arg(long)]
    pub md: Option<PathBuf>,
    /// Write the benchmark's charts (PNG and SVG) into this directory.
    #[arg(long)]
    pub charts: Option<PathBuf>,
}

/// The scenes and image size of a benchmark.
#[derive(Args, Clone)]
pub struct SceneArgs {
    /// Scenes, comma-separated (each benchmark says its default).
    #[arg(long)]
    pub scenes: Option<String>,
    #[arg(long, default_value_t = 512, value_parser = side())]
    pub width: u32,
    #[arg(long, default_value_t = 512, value_parser = side())]
    pub height: u32,
}

impl SceneArgs {
    /// The benchmark's spec with the scenes to run (see `bench::scenes`).
    pub fn spec(&self, scenes: Vec<String>, configs: Vec<(u32, u32)>, bounces: u32) -> Spec {
        Spec {
            scenes,
            configs,
            width: self.width,
            height: self.height,
            bounces,
        }
    }
}

#[derive(Args, Clone)]
pub struct BenchRshArgs {
    #[command(flatten)]
    pub spec: SceneArgs,
    /// Configurations B/D (branching/levels), comma-separated.
    #[arg(long, default_value = "8/2,8/3,8/4,16/2,16/3,16/4")]
    pub configs: String,
    /// Reflection/refraction generations (the thesis's tables use shadows + 1 bounce).
    #[arg(long, default_value_t = 1, value_parser = bounces())]
    pub bounces: u32,
    #[command(flatten)]
    pub out: ReportArgs,
}

#[derive(Args, Clone)]
pub struct BenchGpuArgs {
    #[command(flatten)]
    pub spec: SceneArgs,
    /// Configurations B/D (branching/levels), comma-separated.
    #[arg(long, default_value = "8/2")]
    pub configs: String,
    /// Reflection/refraction generations (0: shadow rays of the rasterized surfaces only).
    #[arg(long, default_value_t = 0, value_parser = bounces())]
    pub bounces: u32,
    /// Also run RAH.
    #[arg(long)]
    pub rah: bool,
    /// Only the irregular grid (no recording render, G-buffer or CRSH/RAH).
    #[arg(long, conflicts_with = "rah")]
    pub grid_only: bool,
    /// Also write the markdown report to this file.
    #[arg(long)]
    pub md: Option<PathBuf>,
}

#[derive(Args, Clone)]
pub struct RaysArgs {
    /// A built-in, shared or generated scene (hairball:100k), or an .obj, .gltf/.glb, .toml
    /// or BART .aff file.
    pub scene: String,
    #[arg(long, value_enum, default_value_t = Kind::Primary)]
    pub kind: Kind,
    #[arg(short = 'W', long, default_value_t = 512, value_parser = side())]
    pub width: u32,
    #[arg(short = 'H', long, default_value_t = 512, value_parser = side())]
    pub height: u32,
    /// Rays per pixel (ao, random).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub spp: u32,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Length of ambient-occlusion rays (default: 10 % of the scene's box diagonal).
    #[arg(long = "ao-distance", allow_negative_numbers = true)]
    pub ao_distance: Option<f32>,
    /// Camera: EX,EY,EZ,TX,TY,TZ[,FOV] (eye, target, vertical field of view in degrees)
    #[arg(
        long,
        value_name = "EX,EY,EZ,TX,TY,TZ[,FOV]",
        allow_hyphen_values = true
    )]
    pub viewpoint: Option<String>,
    #[command(flatten)]
    pub load: LoadArgs,
    /// Output ray file.
    #[arg(short = 'o', long)]
    pub out: PathBuf,
    /// Most memory the command may use, in MiB (default: 80 % of this machine's memory).
    #[arg(long = "max-memory", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_memory: Option<u64>,
}

#[derive(Args, Clone)]
pub struct TraceArgs {
    /// Ray file (rayspace format, or hagrid's headerless 6 × f32 per ray).
    pub rays: PathBuf,
    /// The scene the rays were made for.
    #[arg(long)]
    pub scene: String,
    #[arg(short = 'e', long, value_enum, default_value_t = DEFAULT_ENGINE)]
    pub engine: Engine,
    #[command(flatten)]
    pub options: EngineFlags,
    /// Any-hit (occlusion) queries instead of closest hit.
    #[arg(long = "any-hit")]
    pub any_hit: bool,
    /// Build and trace this many times in one process, as the frames of a dynamic scene
    /// (the engine rebuilt each time, the process's memory warm after the first); the times
    /// printed are the medians, with every run's listed (1 to 1000).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeat: u32,
    #[command(flatten)]
    pub load: LoadArgs,
    /// Output hit file.
    #[arg(short = 'o', long)]
    pub out: Option<PathBuf>,
    /// Also write the summary (rays, build and trace times, MRays/s, hits, tests, the
    /// engine's counters and phases) as JSON.
    #[arg(long, value_name = "F.json")]
    pub json: Option<PathBuf>,
    /// Read the ray file as this layout (default: rayspace's when it has the header,
    /// else hagrid's headerless rays, with a notice).
    #[arg(long, value_enum)]
    pub format: Option<render::rayfile::RayFormat>,
    /// Most memory the command may use, in MiB (default: 80 % of this machine's memory).
    #[arg(long = "max-memory", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_memory: Option<u64>,
}

#[derive(Args, Clone)]
pub struct RenderArgs {
    /// Built-in (spheres, cornell, office, ...), shared (sponza, kitchen, ...), generated
    /// (hairball:2M) or a file (.obj .gltf .glb .toml .aff)
    #[arg(default_value = "spheres")]
    pub scene: String,
    /// Image width in pixels.
    #[arg(short = 'W', long, default_value_t = 512, value_parser = side(), help_heading = "Image")]
    pub width: u32,
    /// Image height in pixels.
    #[arg(short = 'H', long, default_value_t = 512, value_parser = side(), help_heading = "Image")]
    pub height: u32,
    /// Whitted depth: reflection/refraction generations
    #[arg(short = 'b', long, default_value_t = 3, value_parser = bounces(), help_heading = "Image")]
    pub bounces: u32,
    /// Camera: eye, target, vertical field of view in degrees [default: the scene's]
    #[arg(
        long,
        value_name = "EX,EY,EZ,TX,TY,TZ[,FOV]",
        allow_hyphen_values = true,
        help_heading = "Image"
    )]
    pub viewpoint: Option<String>,
    /// Samples per pixel, jittered views averaged (1: the pixel centres)
    #[arg(short = 's', long, default_value_t = 1, value_parser = spp(), help_heading = "Image")]
    pub spp: u32,
    /// Output PNG [default: SCENE.png; with --frames SCENE/%04d.png]
    #[arg(short = 'o', long, value_name = "F.png", help_heading = "Output")]
    pub out: Option<PathBuf>,
    /// Also write the statistics as JSON (with --frames: every frame's)
    #[arg(long, value_name = "F.json", help_heading = "Output")]
    pub stats: Option<PathBuf>,
    /// bvh, crsh, rah, grid, grid2l, brute or a peer (`rayspace engines`)
    #[arg(short = 'e', long, value_enum, value_name = "NAME", hide_possible_values = true, default_value_t = DEFAULT_ENGINE, help_heading = "Engine")]
    pub engine: Engine,
    /// gpu: rasterize, trace and shade as wgpu kernels
    #[arg(long, value_enum, value_name = "cpu|gpu", hide_possible_values = true, default_value_t = Backend::Cpu, help_heading = "Engine")]
    pub backend: Backend,
    #[command(flatten, next_help_heading = "Animation")]
    pub anim: AnimArgs,
    #[command(flatten, next_help_heading = "Look")]
    pub look: LookArgs,
    #[command(flatten, next_help_heading = "Scene loading")]
    pub load: LoadArgs,
    /// Most memory in MiB; more is refused before allocating [default: 80 % of the machine]
    #[arg(long = "max-memory", value_name = "MIB", value_parser = clap::value_parser!(u64).range(1..), help_heading = "Scene loading")]
    pub max_memory: Option<u64>,
    #[command(flatten)]
    pub options: EngineFlags,
}

/// An animated scene's time or frames.
#[derive(Args, Clone)]
pub struct AnimArgs {
    /// One instant of an animated scene (seconds)
    #[arg(
        short = 't',
        long,
        value_name = "T",
        conflicts_with = "frames",
        allow_hyphen_values = true
    )]
    pub time: Option<f32>,
    /// N frames of an animation, the engine rebuilt per frame
    #[arg(short = 'n', long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub frames: Option<u32>,
    /// Frames per second [default: the frames spread over the animation]
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    pub fps: Option<f32>,
    /// Per-frame statistics (update, build, phases, rays, tests) as CSV
    #[arg(long = "frame-csv", value_name = "F.csv")]
    pub frame_csv: Option<PathBuf>,
    /// Also an animated GIF of the frames (alone: no PNGs kept)
    #[arg(long, value_name = "F.gif")]
    pub gif: Option<PathBuf>,
}

/// Samples per pixel: 1..=`MAX_SPP`.
fn spp() -> clap::builder::RangedI64ValueParser<u32> {
    clap::value_parser!(u32).range(1..=render::whitted::MAX_SPP as i64)
}
