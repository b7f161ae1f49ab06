//! The command line's grammar (clap): subcommands and their options. Option values that name
//! a library enum parse into it directly (`clap::ValueEnum` behind each crate's `clap`
//! feature), and defaults come from the library's own (`RshConfig::crsh()`,
//! `GridConfig::default()`), so nothing here restates the engines' choices.

use accel::grid::{GridConfig, Subdivision};
use clap::builder::TypedValueParser as _;
use clap::{Args, Parser, Subcommand, ValueEnum};
use rayspace::bench::Spec;
use rayspace::engines::{Engine, EngineOptions};
use render::raygen::Kind;
use render::whitted::{MAX_BOUNCES, MAX_SIDE};
use rsh::{Descent, HashBits, HashKind, NodeTest, ObjectHierarchy, RshConfig, Union};
use scene::MeshSplit;
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "rayspace",
    version,
    about = "Ray tracing with ray-space hierarchies and irregular grids"
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
    /// Reproduce the papers' evaluation tables.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
}

#[derive(Subcommand)]
pub enum BenchCommand {
    /// The thesis's chapter-4 tables: CRSH and RAH per configuration on the same rays.
    Rsh(BenchRshArgs),
    /// The GPU backend against the CPU engines on the same rays, phase by phase (CRSH, RAH;
    /// the irregular grid's traversal on primary, AO and random rays), with the agreement
    /// of hits and counters checked in the same run.
    Gpu(BenchGpuArgs),
    /// The irregular-grid paper's Tables 1, 2, 3 and 5: our grids against the peers
    /// (obvhs; Embree with `--features embree`) on the same rays.
    Grid(BenchGridArgs),
    /// The irregular-grid paper's Table 4: AO samples per pixel that fit in a frame budget
    /// on an animated scene, per-frame rebuild included.
    Budget(BenchBudgetArgs),
}

/// A command's options with every default, as if given no arguments.
pub fn defaults<T: Args + clap::FromArgMatches>() -> T {
    let m = T::augment_args(clap::Command::new("defaults"))
        .try_get_matches_from(["defaults"])
        .expect("every option has a default");
    T::from_arg_matches(&m).expect("defaults parse")
}

/// `on`/`off` as a boolean.
fn on_off() -> impl clap::builder::TypedValueParser<Value = bool> {
    clap::builder::PossibleValuesParser::new(["on", "off"]).map(|s| s == "on")
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
    /// Write charts (PNG and SVG) into this directory (`bench grid`: MRays/s by ray kind and
    /// engine; `bench rsh`: intersections per hierarchy level by configuration, like the
    /// thesis's Figures 4.7–4.23).
    #[arg(long)]
    pub charts: Option<PathBuf>,
}

/// The scenes and image size of a benchmark.
#[derive(Args, Clone)]
pub struct SceneArgs {
    /// Scenes, comma-separated (default: the built-in scenes the benchmark reports on, and
    /// the real scenes of its paper when the shared scenes are present: `bench rsh` cornell,
    /// office, Sponza; `bench gpu` cornell, Sponza; `bench grid` cornell, office, stadium,
    /// Sponza, Conference, Kitchen).
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

/// How a scene file is loaded.
#[derive(Args, Clone, Debug)]
pub struct LoadArgs {
    /// How OBJ files are cut into meshes (the unit of bounding-sphere culling).
    #[arg(long, value_enum, default_value_t = MeshSplit::Groups)]
    pub meshes: MeshSplit,
    /// Read files the scene references (OBJ mtllib, glTF buffers, TOML meshes, AFF
    /// includes) even where they resolve outside the scene's directory and the scenes
    /// directory.
    #[arg(long = "allow-outside-paths")]
    pub allow_outside_paths: bool,
}

impl LoadArgs {
    /// The loader's options, with a triangle budget from the memory limit (`--max-memory`
    /// in MiB where the command has it): a scene whose model alone would exceed it stops
    /// while it loads.
    pub fn options(&self, max_mib: Option<u64>) -> scene::LoadOptions {
        scene::LoadOptions {
            split: self.meshes,
            allow_outside_paths: self.allow_outside_paths,
            ..Default::default()
        }
        .for_memory(::render::memory::limit(max_mib))
    }
}

#[derive(Args, Clone)]
pub struct RaysArgs {
    /// A built-in scene, an .obj, .gltf/.glb or .toml file.
    pub scene: String,
    #[arg(long, value_enum, default_value_t = Kind::Primary)]
    pub kind: Kind,
    #[arg(long, default_value_t = 512, value_parser = side())]
    pub width: u32,
    #[arg(long, default_value_t = 512, value_parser = side())]
    pub height: u32,
    /// Rays per pixel (ao, random).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub spp: u32,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Length of ambient-occlusion rays (default: 10 % of the scene's box diagonal).
    #[arg(long = "ao-distance", allow_negative_numbers = true)]
    pub ao_distance: Option<f32>,
    /// Camera override: EX,EY,EZ,TX,TY,TZ[,FOV] (eye, target, vertical field of view in degrees).
    #[arg(long)]
    pub viewpoint: Option<String>,
    #[command(flatten)]
    pub load: LoadArgs,
    /// Output ray file.
    #[arg(long)]
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
    #[arg(long, value_enum, default_value_t = Engine::Crsh)]
    pub engine: Engine,
    #[command(flatten)]
    pub rsh: RshArgs,
    #[command(flatten)]
    pub grid: GridArgs,
    /// Any-hit (occlusion) queries instead of closest hit.
    #[arg(long = "any-hit")]
    pub any_hit: bool,
    #[command(flatten)]
    pub load: LoadArgs,
    /// Output hit file.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Options of the irregular grid (defaults: the paper's, `GridConfig::default()`).
#[derive(Args, Clone, Debug)]
pub struct GridArgs {
    /// Top-level density λ₁.
    #[arg(long = "grid-top-density", default_value_t = GridConfig::default().top_density)]
    pub top_density: f32,
    /// Second-level (octree) density λ₂.
    #[arg(long = "grid-leaf-density", default_value_t = GridConfig::default().leaf_density)]
    pub leaf_density: f32,
    /// Merging stops when a round keeps at least this fraction of the cells.
    #[arg(long = "grid-alpha", default_value_t = GridConfig::default().alpha)]
    pub alpha: f32,
    /// Cell merging, `on` or `off` (grid only; default on).
    #[arg(long = "grid-merge", value_parser = on_off())]
    pub merge: Option<bool>,
    /// Cell expansion passes (grid only; default 3 for a still, 1 per frame of an animation
    /// as in the paper's dynamic scenes).
    #[arg(long = "grid-expansion")]
    pub expansion: Option<u32>,
    /// Largest octree depth per top-level cell.
    #[arg(long = "grid-max-depth", default_value_t = GridConfig::default().max_depth)]
    pub max_depth: u32,
    /// Which octree nodes split: `paper` (one depth per top cell from its count, §4.1) or
    /// `adaptive` (also every deeper node whose own count calls for it, up to the max depth).
    #[arg(long = "grid-subdivision", value_enum, default_value_t = GridConfig::default().subdivision)]
    pub subdivision: Subdivision,
}

impl GridArgs {
    /// The grid's configuration; `dynamic` (a frame of an animation) defaults to one
    /// expansion pass, as the paper's dynamic scenes use.
    pub fn config(&self, dynamic: bool) -> GridConfig {
        let d = GridConfig::default();
        GridConfig {
            top_density: self.top_density,
            leaf_density: self.leaf_density,
            alpha: self.alpha,
            merge: self.merge.unwrap_or(d.merge),
            expansion_passes: self.expansion.unwrap_or(if dynamic {
                1
            } else {
                d.expansion_passes
            }),
            max_depth: self.max_depth,
            subdivision: self.subdivision,
            empty_only: d.empty_only,
            max_bytes: d.max_bytes,
        }
    }
}

/// Options of the ray-space hierarchies, CRSH and RAH (defaults: `RshConfig::crsh()`).
#[derive(Args, Clone, Debug)]
pub struct RshArgs {
    /// Children per hierarchy node (2..=64).
    #[arg(long, default_value_t = RshConfig::crsh().branching)]
    pub branching: u32,
    /// Hierarchy levels above the leaves (0..=16; 0: up to one root per ray kind).
    #[arg(long, default_value_t = RshConfig::crsh().levels)]
    pub levels: u32,
    /// CRSH ray hash.
    #[arg(long, value_enum, default_value_t = RshConfig::crsh().hash)]
    pub hash: HashKind,
    /// Bit budgets of the 32-bit thesis hash: LIGHT,SHADOW_DIR,ORIGIN,DIR (bits for the light
    /// index, per angle of shadow directions, per axis of origins, per angle of other rays).
    #[arg(long = "hash-bits", default_value_t = RshConfig::crsh().hash_bits)]
    pub hash_bits: HashBits,
    /// Sphere and cone union formulas.
    #[arg(long, value_enum, default_value_t = RshConfig::crsh().union)]
    pub union: Union,
    /// Node-triangle test.
    #[arg(long = "node-test", value_enum, default_value_t = RshConfig::crsh().node_test)]
    pub node_test: NodeTest,
    /// Cull by per-mesh bounding spheres at the top level, `on` or `off` (default: on for
    /// crsh, off for rah).
    #[arg(long = "mesh-culling", value_parser = on_off())]
    pub mesh_culling: Option<bool>,
    /// Most (node, triangle) pairs per buffer (1024..=2^31); larger levels are processed in
    /// batches.
    #[arg(long = "pair-budget", default_value_t = RshConfig::crsh().pair_budget)]
    pub pair_budget: usize,
    /// What the traversal pushes through the ray hierarchy: every triangle behind per-mesh
    /// spheres (the thesis), or a per-frame BVH descended together with it (default: bvh on
    /// the CPU; the GPU backend has mesh-spheres only).
    #[arg(long = "object-hierarchy", value_enum)]
    pub objects: Option<ObjectHierarchy>,
    /// With `--object-hierarchy bvh`: which node of a surviving pair is expanded.
    #[arg(long, value_enum, default_value_t = RshConfig::crsh().descent)]
    pub descent: Descent,
}

impl RshArgs {
    /// The options as a configuration (CRSH's method; `EngineOptions::rsh_config` sets the
    /// method and its mesh-culling default).
    fn base(&self) -> RshConfig {
        RshConfig {
            branching: self.branching,
            levels: self.levels,
            hash: self.hash,
            hash_bits: self.hash_bits,
            union: self.union,
            node_test: self.node_test,
            pair_budget: self.pair_budget,
            descent: self.descent,
            ..RshConfig::crsh()
        }
    }
}

/// The engine options the ray-hierarchy and grid arguments describe (`dynamic`: a frame of
/// an animation, see [`GridArgs::config`]).
pub fn engine_options(r: &RshArgs, g: &GridArgs, dynamic: bool) -> EngineOptions {
    EngineOptions {
        rsh: r.base(),
        mesh_culling: r.mesh_culling,
        objects: r.objects,
        grid: g.config(dynamic),
    }
}

/// Where a render runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    Cpu,
    Gpu,
}

#[derive(Args, Clone)]
pub struct RenderArgs {
    /// A built-in scene (cornell, spheres, soup, stadium, office), or an .obj, .gltf/.glb or .toml file.
    #[arg(default_value = "cornell")]
    pub scene: String,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512, value_parser = side())]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512, value_parser = side())]
    pub height: u32,
    /// Whitted recursion depth: reflection/refraction generations after the rasterized one.
    #[arg(long, default_value_t = 3, value_parser = bounces())]
    pub bounces: u32,
    /// Tracing engine.
    #[arg(long, value_enum, default_value_t = Engine::Crsh)]
    pub engine: Engine,
    /// Where the render runs: `gpu` rasterizes the G-buffer with a render pipeline and runs
    /// CRSH/RAH (or the grid's traversal, on a grid the CPU builds), secondary-ray
    /// generation and shading as compute kernels (wgpu).
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    pub backend: Backend,
    #[command(flatten)]
    pub rsh: RshArgs,
    #[command(flatten)]
    pub grid: GridArgs,
    #[command(flatten)]
    pub load: LoadArgs,
    /// Output PNG.
    #[arg(long, default_value = "rayspace.png")]
    pub out: PathBuf,
    /// Also write the statistics as JSON to this file.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Render one instant of an animated scene (seconds, in the scene's time).
    #[arg(long, conflicts_with = "frames", allow_hyphen_values = true)]
    pub time: Option<f32>,
    /// Render N frames of an animated scene; `--out` then needs a `%0Nd`-style frame number
    /// (e.g. frames/%04d.png). Engines are rebuilt every frame.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub frames: Option<u32>,
    /// Frames per second (default: spread the frames over the scene's animation interval).
    #[arg(long, allow_hyphen_values = true)]
    pub fps: Option<f32>,
    /// With --frames: per-frame statistics (build and trace times, rays, tests) as CSV.
    #[arg(long = "frame-csv")]
    pub frame_csv: Option<PathBuf>,
    /// With --frames: also assemble the frames into this animated GIF.
    #[arg(long)]
    pub gif: Option<PathBuf>,
    /// Most memory the render may use, in MiB (default: 80 % of this machine's memory);
    /// a size whose memory model needs more is refused before anything is allocated.
    #[arg(long = "max-memory", value_parser = clap::value_parser!(u64).range(1..))]
    pub max_memory: Option<u64>,
}
