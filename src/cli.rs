//! Command-line interface.

/// `println!` that ignores a closed stdout (`rayspace … | head` must not panic).
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($t)*);
    }};
}

use anyhow::{bail, Context, Result};
use clap::builder::TypedValueParser as _;
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
enum BenchCommand {
    /// The thesis's chapter-4 tables: CRSH and RAH per configuration on the same rays.
    Rsh(BenchRshArgs),
    /// The GPU backend against the CPU engines on the same rays, phase by phase, with the
    /// agreement of hits and counters checked in the same run.
    Gpu(BenchGpuArgs),
    /// The irregular-grid paper's Tables 1, 2, 3 and 5: our grids against the peers
    /// (obvhs; Embree with `--features embree`) on the same rays.
    Grid(BenchGridArgs),
    /// The irregular-grid paper's Table 4: AO samples per pixel that fit in a frame budget
    /// on an animated scene, per-frame rebuild included.
    Budget(BenchBudgetArgs),
}

#[derive(Args, Clone)]
struct BenchBudgetArgs {
    /// An animated scene (a BART .aff file); a static scene is measured as one still.
    scene: String,
    /// Frame budgets in milliseconds, comma-separated.
    #[arg(long, default_value = "100,50,33")]
    ms: String,
    /// Engines, comma-separated (crsh, rah, grid, grid2l, obvhs-cwbvh, obvhs-bvh2, embree,
    /// embree-stream, brute).
    #[arg(long, default_value = "grid,grid2l,obvhs-cwbvh")]
    engines: String,
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    height: u32,
    /// Instants of the animation measured (spread over its interval); times are averaged.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=1000))]
    frames: u32,
    /// Also write the rows as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
}

#[derive(Args, Clone)]
struct BenchGridArgs {
    /// Scenes, comma-separated (default: cornell, office, stadium, and Sponza, Conference
    /// and Kitchen when the shared scenes are present).
    #[arg(long)]
    scenes: Option<String>,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    height: u32,
    /// Ambient-occlusion rays per pixel.
    #[arg(long = "ao-spp", default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=64))]
    ao_spp: u32,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Timed runs per engine and ray kind (the best is reported).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeats: u32,
    /// Also write every row as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Also write Table 3's rows (engine × ray kind) as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Also write the grid builds of Tables 1, 2 and 5 as CSV.
    #[arg(long = "grids-csv")]
    grids_csv: Option<PathBuf>,
    /// Also write the markdown report to this file.
    #[arg(long)]
    md: Option<PathBuf>,
    /// Write charts (PNG and SVG) into this directory: MRays/s by ray kind and engine.
    #[arg(long)]
    charts: Option<PathBuf>,
}

#[derive(Args, Clone)]
struct BenchRshArgs {
    /// Scenes, comma-separated (default: cornell, office, and Sponza when the shared scenes
    /// are present).
    #[arg(long)]
    scenes: Option<String>,
    /// Configurations B/D (branching/levels), comma-separated.
    #[arg(long, default_value = "8/2,8/3,8/4,16/2,16/3,16/4")]
    configs: String,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    height: u32,
    /// Reflection/refraction generations (the thesis's tables use shadows + 1 bounce).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Also write the rows (with every counter) as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Also write the summary rows as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Also write the markdown report to this file.
    #[arg(long)]
    md: Option<PathBuf>,
    /// Write charts (PNG and SVG) into this directory: intersections per hierarchy level by
    /// configuration (like the thesis's Figures 4.7–4.23).
    #[arg(long)]
    charts: Option<PathBuf>,
}

#[derive(Args, Clone)]
struct BenchGpuArgs {
    /// Scenes, comma-separated (default: cornell, and Sponza when the shared scenes are
    /// present).
    #[arg(long)]
    scenes: Option<String>,
    /// Configurations B/D (branching/levels), comma-separated.
    #[arg(long, default_value = "8/2")]
    configs: String,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    height: u32,
    /// Reflection/refraction generations (0: shadow rays of the rasterized surfaces only).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=MAX_BOUNCES as i64))]
    bounces: u32,
    /// Also run RAH.
    #[arg(long)]
    rah: bool,
    /// Also write the markdown report to this file.
    #[arg(long)]
    md: Option<PathBuf>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum RayKindArg {
    Primary,
    Shadow,
    Reflection,
    Ao,
    Random,
}

#[derive(Args, Clone)]
struct RaysArgs {
    /// A built-in scene, an .obj, .gltf/.glb or .toml file.
    scene: String,
    #[arg(long, value_enum, default_value_t = RayKindArg::Primary)]
    kind: RayKindArg,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    width: u32,
    #[arg(long, default_value_t = 512, value_parser = clap::value_parser!(u32).range(1..=MAX_SIDE as i64))]
    height: u32,
    /// Rays per pixel (ao, random).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1024))]
    spp: u32,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Length of ambient-occlusion rays (default: 10 % of the scene's box diagonal).
    #[arg(long = "ao-distance", allow_negative_numbers = true)]
    ao_distance: Option<f32>,
    /// Camera override: EX,EY,EZ,TX,TY,TZ[,FOV] (eye, target, vertical field of view in degrees).
    #[arg(long)]
    viewpoint: Option<String>,
    #[arg(long, value_enum, default_value_t = Split::Groups)]
    meshes: Split,
    /// Output ray file.
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args, Clone)]
struct TraceArgs {
    /// Ray file (rayspace format, or hagrid's headerless 6 × f32 per ray).
    rays: PathBuf,
    /// The scene the rays were made for.
    #[arg(long)]
    scene: String,
    #[arg(long, value_enum, default_value_t = Engine::Crsh)]
    engine: Engine,
    #[command(flatten)]
    rsh: RshArgs,
    #[command(flatten)]
    grid: GridArgs,
    /// Any-hit (occlusion) queries instead of closest hit.
    #[arg(long = "any-hit")]
    any_hit: bool,
    #[arg(long, value_enum, default_value_t = Split::Groups)]
    meshes: Split,
    /// Output hit file.
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Engine {
    /// Coherent ray-space hierarchy (hashed, sorted rays; mesh culling).
    Crsh,
    /// Roger et al.'s ray hierarchy (screen-ordered rays).
    Rah,
    /// Every ray against every triangle (the oracle).
    Brute,
    /// Irregular grid (Pérard-Gayot et al. 2017).
    Grid,
    /// Two-level grid (the irregular grid's initial cells, Kalojanov et al. 2011).
    Grid2l,
    /// Peer: obvhs's compressed 8-wide BVH (our triangle kernel at the leaves).
    ObvhsCwbvh,
    /// Peer: obvhs's binary BVH (our triangle kernel at the leaves).
    ObvhsBvh2,
    /// Peer: Embree 3, one `rtcIntersect1`/`rtcOccluded1` per ray (needs `--features embree`).
    Embree,
    /// Peer: Embree 3's stream API, `rtcIntersect1M` (needs `--features embree`).
    EmbreeStream,
}

/// Options of the irregular grid (paper defaults).
#[derive(Args, Clone, Debug)]
struct GridArgs {
    /// Top-level density λ₁.
    #[arg(long = "grid-top-density", default_value_t = 0.12)]
    top_density: f32,
    /// Second-level (octree) density λ₂.
    #[arg(long = "grid-leaf-density", default_value_t = 2.4)]
    leaf_density: f32,
    /// Merging stops when a round keeps at least this fraction of the cells.
    #[arg(long = "grid-alpha", default_value_t = 0.995)]
    alpha: f32,
    /// Cell merging (grid only).
    #[arg(long = "grid-merge", value_enum, default_value_t = OnOff::On)]
    merge: OnOff,
    /// Cell expansion passes (grid only; default 3 for a still, 1 per frame of an animation
    /// as in the paper's dynamic scenes).
    #[arg(long = "grid-expansion", value_parser = clap::value_parser!(u32).range(0..=16))]
    expansion: Option<u32>,
    /// Set by the frame loop: use the dynamic-scene default of 1 expansion pass.
    #[arg(skip)]
    dynamic: bool,
    /// Largest octree depth per top-level cell.
    #[arg(long = "grid-max-depth", default_value_t = 10, value_parser = clap::value_parser!(u32).range(0..=12))]
    max_depth: u32,
    /// Which octree nodes split: `paper` (one depth per top cell from its count, §4.1) or
    /// `adaptive` (also every deeper node whose own count calls for it, up to the max depth).
    #[arg(long = "grid-subdivision", default_value = "paper",
          value_parser = clap::builder::PossibleValuesParser::new(accel::grid::Subdivision::NAMES)
              .map(|s| s.parse::<accel::grid::Subdivision>().expect("one of the possible values")))]
    subdivision: accel::grid::Subdivision,
}

impl Default for GridArgs {
    fn default() -> Self {
        GridArgs {
            top_density: 0.12,
            leaf_density: 2.4,
            alpha: 0.995,
            merge: OnOff::On,
            expansion: None,
            dynamic: false,
            max_depth: 10,
            subdivision: accel::grid::Subdivision::Paper,
        }
    }
}

impl GridArgs {
    fn config(&self, two_level: bool) -> accel::GridConfig {
        accel::GridConfig {
            top_density: self.top_density,
            leaf_density: self.leaf_density,
            alpha: self.alpha,
            merge: !two_level && self.merge == OnOff::On,
            expansion_passes: match (two_level, self.expansion) {
                (true, _) => 0,
                (false, Some(n)) => n,
                (false, None) => {
                    if self.dynamic {
                        1
                    } else {
                        3
                    }
                }
            },
            max_depth: self.max_depth,
            subdivision: self.subdivision,
            empty_only: false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum HashArg {
    /// The thesis's typed 32-bit hash.
    Thesis,
    /// 64-bit 5-D Morton code of origin and direction.
    Morton64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum UnionArg {
    Exact,
    Thesis,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum NodeTestArg {
    Rah,
    Exact,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum OnOff {
    On,
    Off,
}

/// Options of the ray-space hierarchies (CRSH, RAH).
#[derive(Args, Clone, Debug)]
struct RshArgs {
    /// Children per hierarchy node.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(2..=64))]
    branching: u32,
    /// Hierarchy levels above the leaves (0: up to one root per ray kind).
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(0..=16))]
    levels: u32,
    /// CRSH ray hash.
    #[arg(long, value_enum, default_value_t = HashArg::Thesis)]
    hash: HashArg,
    /// Bit budgets of the 32-bit thesis hash: LIGHT,SHADOW_DIR,ORIGIN,DIR (bits for the light
    /// index, per angle of shadow directions, per axis of origins, per angle of other rays).
    #[arg(long = "hash-bits", default_value = "4,13,5,7", value_parser = parse_hash_bits)]
    hash_bits: rsh::HashBits,
    /// Sphere and cone union formulas.
    #[arg(long, value_enum, default_value_t = UnionArg::Exact)]
    union: UnionArg,
    /// Node-triangle test.
    #[arg(long = "node-test", value_enum, default_value_t = NodeTestArg::Rah)]
    node_test: NodeTestArg,
    /// Cull by per-mesh bounding spheres at the top level (default: on for crsh, off for rah).
    #[arg(long = "mesh-culling", value_enum)]
    mesh_culling: Option<OnOff>,
    /// Most (node, triangle) pairs per buffer; larger levels are processed in batches.
    #[arg(long = "pair-budget", default_value_t = rsh::engine::DEFAULT_PAIR_BUDGET as u64, value_parser = clap::value_parser!(u64).range(1024..=(1u64 << 31)))]
    pair_budget: u64,
}

impl Default for RshArgs {
    fn default() -> Self {
        RshArgs {
            branching: 8,
            levels: 2,
            hash: HashArg::Thesis,
            hash_bits: rsh::HashBits::default(),
            union: UnionArg::Exact,
            node_test: NodeTestArg::Rah,
            mesh_culling: None,
            pair_budget: rsh::engine::DEFAULT_PAIR_BUDGET as u64,
        }
    }
}

impl RshArgs {
    fn config(&self, method: rsh::Method) -> rsh::RshConfig {
        let base = match method {
            rsh::Method::Crsh => rsh::RshConfig::crsh(),
            rsh::Method::Rah => rsh::RshConfig::rah(),
        };
        rsh::RshConfig {
            branching: self.branching,
            levels: self.levels,
            hash: match self.hash {
                HashArg::Thesis => rsh::HashKind::Thesis,
                HashArg::Morton64 => rsh::HashKind::Morton64,
            },
            hash_bits: self.hash_bits,
            union: match self.union {
                UnionArg::Exact => rsh::Union::Exact,
                UnionArg::Thesis => rsh::Union::Thesis,
            },
            node_test: match self.node_test {
                NodeTestArg::Rah => rsh::NodeTest::Rah,
                NodeTestArg::Exact => rsh::NodeTest::Exact,
            },
            mesh_culling: self
                .mesh_culling
                .map(|m| m == OnOff::On)
                .unwrap_or(base.mesh_culling),
            pair_budget: self.pair_budget as usize,
            ..base
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Split {
    Groups,
    Materials,
    Single,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum Backend {
    Cpu,
    Gpu,
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
    #[arg(long, value_enum, default_value_t = Engine::Crsh)]
    engine: Engine,
    /// Where the render runs: `gpu` rasterizes the G-buffer with a render pipeline and runs
    /// CRSH/RAH, secondary-ray generation and shading as compute kernels (wgpu).
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    backend: Backend,
    #[command(flatten)]
    rsh: RshArgs,
    #[command(flatten)]
    grid: GridArgs,
    /// How OBJ files are cut into meshes (the unit of bounding-sphere culling).
    #[arg(long, value_enum, default_value_t = Split::Groups)]
    meshes: Split,
    /// Output PNG.
    #[arg(long, default_value = "rayspace.png")]
    out: PathBuf,
    /// Also write the statistics as JSON to this file.
    #[arg(long)]
    stats: Option<PathBuf>,
    /// Render one instant of an animated scene (seconds, in the scene's time).
    #[arg(long, conflicts_with = "frames", allow_hyphen_values = true)]
    time: Option<f32>,
    /// Render N frames of an animated scene; `--out` then needs a `%0Nd`-style frame number
    /// (e.g. frames/%04d.png). Engines are rebuilt every frame.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: Option<u32>,
    /// Frames per second (default: spread the frames over the scene's animation interval).
    #[arg(long, allow_hyphen_values = true)]
    fps: Option<f32>,
    /// With --frames: per-frame statistics (build and trace times, rays, tests) as CSV.
    #[arg(long = "frame-csv")]
    frame_csv: Option<PathBuf>,
    /// With --frames: also assemble the frames into this animated GIF.
    #[arg(long)]
    gif: Option<PathBuf>,
}

impl Default for RenderArgs {
    fn default() -> Self {
        RenderArgs {
            scene: "cornell".into(),
            width: 512,
            height: 512,
            bounces: 3,
            engine: Engine::Crsh,
            backend: Backend::Cpu,
            rsh: RshArgs::default(),
            grid: GridArgs::default(),
            meshes: Split::Groups,
            out: PathBuf::from("rayspace.png"),
            stats: None,
            time: None,
            frames: None,
            fps: None,
            frame_csv: None,
            gif: None,
        }
    }
}

fn parse_hash_bits(s: &str) -> Result<rsh::HashBits, String> {
    let v: Vec<u32> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<u32>()
                .map_err(|_| format!("'{x}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    let [light, shadow_dir, origin, dir] = v[..] else {
        return Err(format!(
            "expected 4 comma-separated numbers, got {}",
            v.len()
        ));
    };
    let b = rsh::HashBits {
        light,
        shadow_dir,
        origin,
        dir,
    };
    b.validate()?;
    Ok(b)
}

fn make_engine(
    engine: Engine,
    rsh_args: &RshArgs,
    grid_args: &GridArgs,
    geo: &Geometry,
) -> Result<Box<dyn Tracer>> {
    make_engine_opt(engine, rsh_args, grid_args, geo, true)
}

/// [`make_engine`], with or without the build report (the frame loop builds one engine per
/// frame and stays quiet).
fn make_engine_opt(
    engine: Engine,
    rsh_args: &RshArgs,
    grid_args: &GridArgs,
    geo: &Geometry,
    verbose: bool,
) -> Result<Box<dyn Tracer>> {
    Ok(match engine {
        Engine::Grid | Engine::Grid2l => {
            let g = accel::GridEngine::new(geo, &grid_args.config(engine == Engine::Grid2l))
                .map_err(|e| {
                    anyhow::anyhow!(
                        "--engine {}: {e}",
                        if engine == Engine::Grid {
                            "grid"
                        } else {
                            "grid2l"
                        }
                    )
                })?;
            let (c, r, v) = g.grid.memory();
            let b = &g.grid.build;
            if verbose {
                say!(
                "{}: {} cells (initial {}), {} references, top grid {:?}, virtual grid {:?}; memory cells {} B, references {} B, voxel map {} B; build ms: references {:.1}, octrees {:.1}, voxel map {:.1}, merge {:.1} ({} rounds), expansion {:.1}",
                if engine == Engine::Grid { "irregular grid" } else { "two-level grid" },
                g.grid.cells(), b.initial_cells, g.grid.refs.len(), g.grid.top_dims, g.grid.dims, c, r, v,
                b.top_refs_seconds * 1e3, b.octree_seconds * 1e3, b.voxel_map_seconds * 1e3, b.merge_seconds * 1e3, b.merge_rounds, b.expand_seconds * 1e3
            );
            }
            Box::new(g)
        }
        Engine::Brute => Box::new(accel::BruteForce::new(geo)),
        Engine::ObvhsCwbvh | Engine::ObvhsBvh2 => {
            let kind = if engine == Engine::ObvhsCwbvh {
                accel::peers::BvhKind::CwBvh
            } else {
                accel::peers::BvhKind::Bvh2
            };
            Box::new(accel::peers::ObvhsEngine::new(geo, kind))
        }
        Engine::Embree | Engine::EmbreeStream => embree_engine(engine, geo)?,
        Engine::Crsh => Box::new(
            rsh::RshEngine::new(geo, rsh_args.config(rsh::Method::Crsh))
                .map_err(anyhow::Error::msg)?,
        ),
        Engine::Rah => Box::new(
            rsh::RshEngine::new(geo, rsh_args.config(rsh::Method::Rah))
                .map_err(anyhow::Error::msg)?,
        ),
    })
}

#[cfg(feature = "embree")]
fn embree_engine(engine: Engine, geo: &Geometry) -> Result<Box<dyn Tracer>> {
    let mode = if engine == Engine::Embree {
        accel::peers::EmbreeMode::Single
    } else {
        accel::peers::EmbreeMode::Stream
    };
    Ok(Box::new(
        accel::peers::EmbreeEngine::new(geo, mode).map_err(anyhow::Error::msg)?,
    ))
}

#[cfg(not(feature = "embree"))]
fn embree_engine(engine: Engine, _geo: &Geometry) -> Result<Box<dyn Tracer>> {
    let name = if engine == Engine::Embree {
        "embree"
    } else {
        "embree-stream"
    };
    anyhow::bail!(
        "--engine {name}: this build has no Embree peer; install Embree 3 (Debian: libembree-dev) and build with `cargo build --release --features embree`"
    )
}

struct Bar(ProgressBar);

impl Progress for Bar {
    fn stage(&self, name: &str) {
        self.0.set_message(name.to_string());
    }
}

/// A bar over `n` steps; `Bar::stage` advances it.
fn step_bar(n: u64) -> Bar {
    let pb = ProgressBar::with_draw_target(Some(n), ProgressDrawTarget::stderr());
    pb.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} [{elapsed}, eta {eta}] {msg}").unwrap(),
    );
    pb.enable_steady_tick(Duration::from_millis(200));
    Bar(pb)
}

impl Bar {
    fn step(&self, name: &str) {
        if self.0.position() < self.0.length().unwrap_or(0) && !self.0.message().is_empty() {
            self.0.inc(1);
        }
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
    /// GPU seconds per phase from timestamp queries (`--backend gpu`; empty otherwise).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    gpu_phase_seconds: Vec<(String, f64)>,
}

fn split(s: Split) -> MeshSplit {
    match s {
        Split::Groups => MeshSplit::Groups,
        Split::Materials => MeshSplit::Materials,
        Split::Single => MeshSplit::Single,
    }
}

fn check_out_dir(opt: &str, out: &std::path::Path) -> Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            bail!(
                "{opt} {}: directory {} does not exist",
                out.display(),
                dir.display()
            );
        }
    }
    Ok(())
}

fn parse_viewpoint(s: &str) -> Result<scene::Camera> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| {
            anyhow::anyhow!("--viewpoint '{s}': expected numbers EX,EY,EZ,TX,TY,TZ[,FOV]")
        })?;
    if !(v.len() == 6 || v.len() == 7) || v.iter().any(|x| !x.is_finite()) {
        bail!("--viewpoint '{s}': expected 6 or 7 finite numbers EX,EY,EZ,TX,TY,TZ[,FOV]");
    }
    Ok(scene::Camera {
        eye: geom::Vec3::new(v[0], v[1], v[2]),
        target: geom::Vec3::new(v[3], v[4], v[5]),
        up: geom::Vec3::Y,
        vfov: v.get(6).copied().unwrap_or(45.0),
    })
}

fn cmd_rays(a: &RaysArgs) -> Result<()> {
    check_out_dir("--out", &a.out)?;
    let mut scene = scene::load(
        &a.scene,
        &LoadOptions {
            split: split(a.meshes),
        },
    )?;
    if let Some(v) = &a.viewpoint {
        scene.camera = parse_viewpoint(v)?;
        scene
            .validate()
            .map_err(|e| anyhow::anyhow!("--viewpoint: {e}"))?;
    }
    if let Some(d) = a.ao_distance {
        if !(d.is_finite() && d > 0.0) {
            bail!("--ao-distance {d}: must be positive and finite");
        }
    }
    let geo = Geometry::from_scene(&scene);
    use render::raygen::{generate, Kind, Options};
    let kind = match a.kind {
        RayKindArg::Primary => Kind::Primary,
        RayKindArg::Shadow => Kind::Shadow,
        RayKindArg::Reflection => Kind::Reflection,
        RayKindArg::Ao => Kind::Ao,
        RayKindArg::Random => Kind::Random,
    };
    let n = a.width as u64 * a.height as u64 * a.spp as u64;
    if n > 1 << 28 {
        bail!("--width × --height × --spp = {n} rays is more than 2^28");
    }
    let rays = generate(
        &scene,
        &geo,
        kind,
        &Options {
            width: a.width,
            height: a.height,
            spp: a.spp,
            seed: a.seed,
            ao_distance: a.ao_distance,
        },
    );
    render::rayfile::write_rays(&a.out, &rays).map_err(anyhow::Error::msg)?;
    say!(
        "wrote {} {:?} rays of {} to {}",
        rays.len(),
        a.kind,
        scene.name,
        a.out.display()
    );
    Ok(())
}

fn cmd_trace(a: &TraceArgs) -> Result<()> {
    if let Some(o) = &a.out {
        check_out_dir("--out", o)?;
    }
    let rays = render::rayfile::read_rays(&a.rays, render::RayKind::Primary)
        .map_err(anyhow::Error::msg)?;
    let scene = scene::load(
        &a.scene,
        &LoadOptions {
            split: split(a.meshes),
        },
    )?;
    let geo = Geometry::from_scene(&scene);
    let t0 = Instant::now();
    let engine = make_engine(a.engine, &a.rsh, &a.grid, &geo)?;
    let build = t0.elapsed().as_secs_f64();
    let mode = if a.any_hit {
        render::TraceMode::Any
    } else {
        render::TraceMode::Closest
    };
    let mut hits = vec![render::Hit::MISS; rays.len()];
    let mut st = render::TraceStats::default();
    let t1 = Instant::now();
    engine.trace(&rays, mode, &mut hits, &mut st);
    let secs = t1.elapsed().as_secs_f64();
    let n = rays.len().max(1) as f64;
    say!(
        "{} rays, {} triangles, engine {} ({:?}): build {:.1} ms, trace {:.1} ms, {:.3} MRays/s",
        rays.len(),
        geo.len(),
        engine.name(),
        mode,
        build * 1e3,
        secs * 1e3,
        n / secs.max(1e-12) / 1e6
    );
    say!("hits {}, ray-triangle tests {} ({:.2}/ray), node-triangle tests {}, total tests {} ({:.4} % of brute force)", st.hits, st.ray_tri_tests, st.ray_tri_tests as f64 / n, st.node_tri_tests, st.total_tests(), 100.0 * st.total_tests() as f64 / (n * geo.len() as f64));
    for (k, v) in &st.counters {
        say!(
            "  {k}: {v}{}",
            if k == "traversal steps" {
                format!(" ({:.2}/ray)", *v as f64 / n)
            } else {
                String::new()
            }
        );
    }
    if let Some(o) = &a.out {
        render::rayfile::write_hits(o, &hits, mode).map_err(anyhow::Error::msg)?;
        say!("wrote {}", o.display());
    }
    Ok(())
}

/// Machine, build and revision, recorded with every benchmark.
fn provenance() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into());
    // A build from modified sources is not that commit: say so (results and docs written
    // while a benchmark runs do not count).
    let dirty = std::process::Command::new("git")
        .args([
            "status",
            "--porcelain",
            "--untracked-files=no",
            "--",
            "src",
            "crates",
            "Cargo.toml",
            "Cargo.lock",
        ])
        .output()
        .ok()
        .filter(|o| o.status.success() && !o.stdout.is_empty())
        .is_some();
    let commit = if dirty {
        format!("{commit}+modified")
    } else {
        commit
    };
    format!(
        "rayspace {} (commit {commit}, {} build{}), {cpu}, {} threads",
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

#[cfg(feature = "gpu")]
fn cmd_bench_gpu(a: &BenchGpuArgs) -> Result<()> {
    if let Some(p) = &a.md {
        check_out_dir("--md", p)?;
    }
    let configs =
        crate::bench::parse_configs(&a.configs).map_err(|e| anyhow::anyhow!("--configs: {e}"))?;
    let scenes = bench_scenes(a.scenes.as_deref(), &["cornell"], &["sponza"]);
    let per = 1 + configs.len() as u64 * if a.rah { 2 } else { 1 };
    let bar = step_bar(scenes.len() as u64 * per);
    let spec = crate::bench_gpu::Spec {
        scenes,
        configs,
        width: a.width,
        height: a.height,
        bounces: a.bounces,
        rah: a.rah,
    };
    let md = crate::bench_gpu::run(&spec, &|m| bar.step(m))?;
    bar.0.finish_and_clear();
    let report = format!("# rayspace bench gpu\n\n{}\n{md}", provenance());
    say!("{report}");
    if let Some(p) = &a.md {
        std::fs::write(p, &report).with_context(|| format!("--md {}", p.display()))?;
        say!("wrote {}", p.display());
    }
    Ok(())
}

#[cfg(not(feature = "gpu"))]
fn cmd_bench_gpu(_a: &BenchGpuArgs) -> Result<()> {
    bail!("bench gpu: this build has no GPU backend; build with `cargo build --release --features gpu`")
}

fn cmd_bench_rsh(a: &BenchRshArgs) -> Result<()> {
    for p in [&a.json, &a.csv, &a.md].into_iter().flatten() {
        check_out_dir("--json/--csv/--md", p)?;
    }
    let configs =
        crate::bench::parse_configs(&a.configs).map_err(|e| anyhow::anyhow!("--configs: {e}"))?;
    let scenes = bench_scenes(a.scenes.as_deref(), &["cornell", "office"], &["sponza"]);
    if let Some(d) = &a.charts {
        check_dir("--charts", d)?;
    }
    let bar = step_bar(scenes.len() as u64 * (1 + 2 * configs.len() as u64));
    let spec = crate::bench::Spec {
        scenes,
        configs,
        width: a.width,
        height: a.height,
        bounces: a.bounces,
    };
    let (rows, md) = crate::bench::run(&spec, &|m| bar.step(m))?;
    bar.0.finish_and_clear();
    if let Some(d) = &a.charts {
        report_charts(crate::bench::charts(&rows, d));
    }
    let report = format!(
        "# rayspace bench rsh

{}
{md}",
        provenance()
    );
    say!("{report}");
    if let Some(p) = &a.md {
        std::fs::write(p, &report).with_context(|| format!("--md {}", p.display()))?;
    }
    if let Some(p) = &a.json {
        std::fs::write(p, serde_json::to_string_pretty(&rows)?)
            .with_context(|| format!("--json {}", p.display()))?;
    }
    if let Some(p) = &a.csv {
        std::fs::write(p, crate::bench::csv(&rows))
            .with_context(|| format!("--csv {}", p.display()))?;
    }
    Ok(())
}

/// The scenes of a benchmark: `--scenes a,b,...` as given, or the built-in `builtins` plus
/// each `bench/scenes/<real>.toml` when the shared scenes are present.
fn bench_scenes(arg: Option<&str>, builtins: &[&str], real: &[&str]) -> Vec<String> {
    match arg {
        Some(s) => s
            .split(',')
            .map(|x| x.trim().to_string())
            .filter(|x| !x.is_empty())
            .collect(),
        None => {
            let mut v: Vec<String> = builtins.iter().map(|s| s.to_string()).collect();
            if scene::scenes_dir().is_some() {
                for f in real {
                    let p = format!("{}/bench/scenes/{f}.toml", env!("CARGO_MANIFEST_DIR"));
                    if std::path::Path::new(&p).exists() {
                        v.push(p);
                    }
                }
            }
            v
        }
    }
}

/// Report the chart files, or why there are none: the tables are written either way, so a
/// missing font only costs the pictures.
fn report_charts(charts: Result<Vec<PathBuf>>) {
    match charts {
        Ok(files) => files.iter().for_each(|f| say!("wrote {}", f.display())),
        Err(e) => eprintln!("warning: charts not written: {e:#}"),
    }
}

fn check_dir(opt: &str, d: &std::path::Path) -> Result<()> {
    if !d.is_dir() {
        bail!("{opt} {}: not a directory", d.display());
    }
    Ok(())
}

fn cmd_bench_grid(a: &BenchGridArgs) -> Result<()> {
    for p in [&a.json, &a.csv, &a.grids_csv, &a.md].into_iter().flatten() {
        check_out_dir("--json/--csv/--grids-csv/--md", p)?;
    }
    if let Some(d) = &a.charts {
        check_dir("--charts", d)?;
    }
    let scenes = bench_scenes(
        a.scenes.as_deref(),
        &["cornell", "office", "stadium"],
        &["sponza", "conference", "kitchen"],
    );
    let bar = step_bar(scenes.len() as u64 * crate::bench_grid::STEPS_PER_SCENE);
    let spec = crate::bench_grid::Spec {
        scenes,
        width: a.width,
        height: a.height,
        ao_spp: a.ao_spp,
        seed: a.seed,
        repeats: a.repeats,
    };
    let rep = crate::bench_grid::run(&spec, &|m| bar.step(m))?;
    bar.0.finish_and_clear();
    let report = format!(
        "# rayspace bench grid

{}; peers: obvhs {}{}
{}",
        provenance(),
        OBVHS_VERSION,
        if accel::peers::HAS_EMBREE {
            ", Embree 3 (system library, `embree` crate 0.3.8)"
        } else {
            "; Embree not in this build (`--features embree`)"
        },
        rep.markdown
    );
    say!("{report}");
    if let Some(p) = &a.md {
        std::fs::write(p, &report).with_context(|| format!("--md {}", p.display()))?;
    }
    if let Some(p) = &a.json {
        let v = serde_json::json!({ "table3": rep.perf, "grids": rep.grids });
        std::fs::write(p, serde_json::to_string_pretty(&v)?)
            .with_context(|| format!("--json {}", p.display()))?;
    }
    if let Some(p) = &a.csv {
        std::fs::write(p, crate::bench_grid::perf_csv(&rep.perf))
            .with_context(|| format!("--csv {}", p.display()))?;
    }
    if let Some(p) = &a.grids_csv {
        std::fs::write(p, crate::bench_grid::grid_csv(&rep.grids))
            .with_context(|| format!("--grids-csv {}", p.display()))?;
    }
    if let Some(d) = &a.charts {
        report_charts(crate::bench_grid::charts(&rep.perf, d));
    }
    Ok(())
}

fn cmd_bench_budget(a: &BenchBudgetArgs) -> Result<()> {
    if let Some(p) = &a.csv {
        check_out_dir("--csv", p)?;
    }
    let budgets: Vec<f64> =
        a.ms.split(',')
            .map(|x| match x.trim().parse::<f64>() {
                Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
                _ => Err(anyhow::anyhow!(
                    "--ms: '{x}' is not a positive number of milliseconds"
                )),
            })
            .collect::<Result<_>>()?;
    let engines: Vec<Engine> = a
        .engines
        .split(',')
        .map(|x| {
            Engine::from_str(x.trim(), true)
                .map_err(|_| anyhow::anyhow!("--engines: unknown engine '{}'", x.trim()))
        })
        .collect::<Result<_>>()?;
    let scene = scene::load(&a.scene, &LoadOptions::default())?;
    let grid = GridArgs {
        dynamic: true,
        ..GridArgs::default()
    };
    let rsh = RshArgs::default();
    let closures: Vec<(String, Box<crate::bench_budget::BuildFn>)> = engines
        .iter()
        .map(|&e| {
            let (g, r) = (grid.clone(), rsh.clone());
            let name = e
                .to_possible_value()
                .map(|v| v.get_name().to_string())
                .unwrap_or_default();
            let f: Box<crate::bench_budget::BuildFn> =
                Box::new(move |geo: &Geometry| make_engine_opt(e, &r, &g, geo, false));
            (name, f)
        })
        .collect();
    let builders: Vec<crate::bench_budget::Builder> = closures
        .iter()
        .map(|(n, f)| (n.as_str(), f.as_ref()))
        .collect();
    let bar = step_bar(engines.len() as u64 * a.frames as u64);
    let rows = crate::bench_budget::run(
        &scene,
        &builders,
        a.width,
        a.height,
        a.frames,
        &budgets,
        &|m| bar.step(m),
    )?;
    bar.0.finish_and_clear();
    say!(
        "# rayspace bench budget\n\n{}\n\n{} — {} frames, build and primary rays inside the budget; AO rays are any-hit, one per pixel per sample\n\n{}",
        provenance(),
        scene.name,
        a.frames,
        crate::bench_budget::markdown(&rows, a.width, a.height)
    );
    if let Some(p) = &a.csv {
        let mut csv =
            String::from("scene,engine,frames,build_ms,primary_ms,ao_ms_per_spp,budget_ms,spp\n");
        for r in &rows {
            for (b, n) in &r.spp {
                csv += &format!(
                    "{},{},{},{:.3},{:.3},{:.3},{},{}\n",
                    r.scene, r.engine, r.frames, r.build_ms, r.primary_ms, r.ao_ms_per_spp, b, n
                );
            }
        }
        std::fs::write(p, csv).with_context(|| format!("--csv {}", p.display()))?;
    }
    Ok(())
}

/// The obvhs version this binary is built with (for benchmark provenance).
const OBVHS_VERSION: &str = "0.4";

fn cmd_render(a: &RenderArgs) -> Result<()> {
    let split = split(a.meshes);
    check_out_dir("--out", &a.out)?;
    let t0 = Instant::now();
    let scene = scene::load(&a.scene, &LoadOptions { split })?;
    let geo = Geometry::from_scene(&scene);
    let load_s = t0.elapsed().as_secs_f64();
    let r = scene.report.clone();
    say!(
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
    if a.backend == Backend::Gpu {
        if a.frames.is_some() {
            bail!("--backend gpu renders one frame; --frames runs on the CPU backend only");
        }
        if !matches!(a.engine, Engine::Crsh | Engine::Rah) {
            bail!(
                "--backend gpu: only --engine crsh and --engine rah run on the GPU (not {:?})",
                a.engine
            );
        }
    }
    if let Some(n) = a.frames {
        return render_frames(a, &scene, n);
    }
    let (scene, geo) = match a.time {
        Some(t) => {
            if !t.is_finite() {
                bail!("--time {t}: not a finite time");
            }
            if scene.animation.is_none() {
                bail!("--time: {} is not animated", scene.name);
            }
            let s = scene.at_time(t);
            let g = Geometry::from_scene(&s);
            (s, g)
        }
        None => (scene, geo),
    };
    let opts = RenderOptions {
        width: a.width,
        height: a.height,
        bounces: a.bounces,
    };
    let t1 = Instant::now();
    let (mut out, build_s, gpu_phases, gpu_timer) = if a.backend == Backend::Gpu {
        render_on_gpu(a, &scene, &geo, &opts, t1)?
    } else {
        let engine = make_engine(a.engine, &a.rsh, &a.grid, &geo)?;
        let build_s = t1.elapsed().as_secs_f64();
        let bar = progress_bar();
        let mut out = render(&scene, &geo, engine.as_ref(), &opts, &bar);
        bar.0.finish_and_clear();
        // The build's passes, indented under "engine build" in the table and in the JSON.
        for (k, (p, t)) in engine.build_passes().into_iter().enumerate() {
            out.stats.phases.insert(k, (format!("  build: {p}"), t));
        }
        (out, build_s, Vec::new(), "")
    };
    out.stats.phases.insert(0, ("engine build".into(), build_s));
    render::output::write_png(&out.pixels, a.width, a.height, &a.out)
        .map_err(anyhow::Error::msg)
        .context("--out")?;
    say!("{}", out.stats.table());
    if !gpu_phases.is_empty() {
        say!("GPU time per phase ({}):", gpu_timer);
        for (p, t) in &gpu_phases {
            say!("  {p:<20} {:>10.3} ms", t * 1e3);
        }
    }
    say!("wrote {}", a.out.display());
    if let Some(p) = &a.stats {
        let f = StatsFile {
            render: &out.stats,
            load_seconds: load_s,
            degenerate_skipped: r.degenerate_skipped,
            raster_setup_triangles: out.raster.setup,
            raster_fragments: out.raster.fragments,
            gpu_phase_seconds: gpu_phases.clone(),
        };
        let json = serde_json::to_string_pretty(&f)?;
        std::fs::write(p, json).with_context(|| format!("--stats {}", p.display()))?;
        say!("wrote {}", p.display());
    }
    Ok(())
}

/// Rendered image, engine set-up seconds and GPU seconds per phase.
type GpuRender = (
    render::whitted::Rendered,
    f64,
    Vec<(String, f64)>,
    &'static str,
);

/// `render --backend gpu`: the G-buffer from the GPU's render pipeline, CRSH/RAH, secondary
/// ray generation and shading as compute kernels; the Whitted loop's sequencing, the surface
/// records between generations and the pixel accumulation on the CPU.
#[cfg(feature = "gpu")]
fn render_on_gpu(
    a: &RenderArgs,
    scene: &scene::Scene,
    geo: &Geometry,
    opts: &RenderOptions,
    t1: Instant,
) -> Result<GpuRender> {
    let g = gpu::Gpu::new().map_err(|e| anyhow::anyhow!("--backend gpu: {e}"))?;
    say!("GPU: {}", g.describe());
    let timer = match g.timer {
        gpu::device::PhaseTimer::Timestamps => "timestamp queries",
        gpu::device::PhaseTimer::WallClock => {
            "wall clock, waiting at every phase boundary: this adapter has no timestamp queries that time kernels"
        }
    };
    let method = if a.engine == Engine::Rah {
        rsh::Method::Rah
    } else {
        rsh::Method::Crsh
    };
    let engine = gpu::GpuRsh::new(g, geo, a.rsh.config(method))
        .map_err(|e| anyhow::anyhow!("--backend gpu: {e}"))?;
    let raster = gpu::GpuRaster::new(engine.gpu(), geo, &scene.materials)
        .map_err(|e| anyhow::anyhow!("--backend gpu: {e}"))?;
    raster
        .check_size(opts.width, opts.height)
        .map_err(|e| anyhow::anyhow!("--width/--height with --backend gpu: {e}"))?;
    let build_s = t1.elapsed().as_secs_f64();
    let bar = progress_bar();
    let stages = gpu::GpuStages::new(engine.gpu(), engine.kernels());
    let out = render::whitted::render_with(
        scene,
        geo,
        &engine,
        opts,
        &bar,
        &|v, n| raster.rasterize(v, n),
        &stages,
    );
    bar.0.finish_and_clear();
    let mut phases: Vec<(String, f64)> = Vec::new();
    if let Some(t) = raster.last_gpu_seconds.get() {
        phases.push(("rasterize".into(), t));
    }
    phases.extend(
        engine
            .take_times()
            .into_iter()
            .map(|(p, t)| (p.to_string(), t)),
    );
    phases.extend(
        stages
            .times
            .borrow()
            .iter()
            .map(|(p, t)| (p.to_string(), *t)),
    );
    Ok((out, build_s, phases, timer))
}

#[cfg(not(feature = "gpu"))]
fn render_on_gpu(
    _a: &RenderArgs,
    _scene: &scene::Scene,
    _geo: &Geometry,
    _opts: &RenderOptions,
    _t1: Instant,
) -> Result<GpuRender> {
    bail!("--backend gpu: this build has no GPU backend; build with `cargo build --release --features gpu`")
}

/// `path` with its `%0Nd` (or `%d`) replaced by `frame`.
fn frame_path(pattern: &std::path::Path, frame: u32) -> Result<PathBuf> {
    let s = pattern.to_string_lossy();
    let Some(i) = s.find('%') else {
        bail!("--out {s}: with --frames the name needs a frame number pattern such as %04d");
    };
    let rest = &s[i + 1..];
    let Some(d) = rest.find('d') else {
        bail!("--out {s}: expected %d or %0Nd");
    };
    let spec = &rest[..d];
    let width: usize = if spec.is_empty() {
        0
    } else {
        match spec.strip_prefix('0').unwrap_or(spec).parse() {
            Ok(w) if w <= 12 => w,
            _ => bail!("--out {s}: bad frame number pattern %{spec}d"),
        }
    };
    Ok(PathBuf::from(format!(
        "{}{:0width$}{}",
        &s[..i],
        frame,
        &rest[d + 1..]
    )))
}

/// One frame's record for `--frame-csv`.
#[derive(Serialize)]
struct FrameRow {
    frame: u32,
    time: f32,
    triangles: usize,
    update_ms: f64,
    build_ms: f64,
    trace_ms: f64,
    rays: u64,
    total_tests: u64,
    /// Engine phases inside the render (ms): for CRSH/RAH the per-frame ray-hierarchy build
    /// (hash … hierarchy creation) and its traversal, in [`ENGINE_PHASES`] order.
    phases_ms: Vec<f64>,
}

/// The engine phases `--frame-csv` reports (ray-space hierarchies; absent phases are 0).
const ENGINE_PHASES: [&str; 9] = [
    "hash",
    "trim",
    "compress",
    "sort",
    "decompress",
    "screen order",
    "hierarchy creation",
    "traversal",
    "final tests",
];

/// The per-frame pipeline: update transforms (and the meshes' culling spheres, by transform),
/// rebuild the engine, render; build and trace times apart.
fn render_frames(a: &RenderArgs, scene: &scene::Scene, n: u32) -> Result<()> {
    let Some(anim) = &scene.animation else {
        bail!(
            "--frames: {} is not animated (BART .aff files and TOML scenes with keyframes are)",
            scene.name
        );
    };
    frame_path(&a.out, 0)?;
    if let Some(d) = frame_path(&a.out, 0)?
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
    {
        check_dir("--out", d)?;
    }
    for p in [&a.frame_csv, &a.gif].into_iter().flatten() {
        check_out_dir("--frame-csv/--gif", p)?;
    }
    let times: Vec<f32> = match a.fps {
        Some(f) if f.is_finite() && f > 0.0 => (0..n).map(|i| anim.start + i as f32 / f).collect(),
        Some(f) => bail!("--fps {f}: must be a positive number"),
        None => anim.frame_times(n),
    };
    let bar = step_bar(n as u64);
    let grid = GridArgs {
        dynamic: true,
        ..a.grid.clone()
    };
    let opts = RenderOptions {
        width: a.width,
        height: a.height,
        bounces: a.bounces,
    };
    let mut rows = Vec::new();
    let mut gif_frames = Vec::new();
    for (i, &t) in times.iter().enumerate() {
        bar.step(&format!("frame {i} (t = {t:.3})"));
        let t0 = Instant::now();
        let s = scene.at_time(t);
        let geo = Geometry::from_scene(&s);
        let update_s = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let engine = make_engine_opt(a.engine, &a.rsh, &grid, &geo, false)?;
        let build_s = t1.elapsed().as_secs_f64();
        let t2 = Instant::now();
        let out = render(&s, &geo, engine.as_ref(), &opts, &());
        let trace_s = t2.elapsed().as_secs_f64();
        let path = frame_path(&a.out, i as u32)?;
        render::output::write_png(&out.pixels, a.width, a.height, &path)
            .map_err(anyhow::Error::msg)
            .context("--out")?;
        if a.gif.is_some() {
            gif_frames.push(out.pixels.clone());
        }
        rows.push(FrameRow {
            frame: i as u32,
            time: t,
            triangles: geo.len(),
            update_ms: update_s * 1e3,
            build_ms: build_s * 1e3,
            trace_ms: trace_s * 1e3,
            rays: out.stats.rays_traced(),
            total_tests: out.stats.trace.total_tests(),
            phases_ms: ENGINE_PHASES
                .iter()
                .map(|p| out.stats.trace.phases.get(*p).copied().unwrap_or(0.0) * 1e3)
                .collect(),
        });
    }
    bar.0.finish_and_clear();
    let mean = |f: &dyn Fn(&FrameRow) -> f64| rows.iter().map(f).sum::<f64>() / rows.len() as f64;
    say!(
        "{} frames of {} ({}×{}, engine {:?}): mean per frame update {:.1} ms, build {:.1} ms, render {:.1} ms{}",
        rows.len(),
        scene.name,
        a.width,
        a.height,
        a.engine,
        mean(&|r| r.update_ms),
        mean(&|r| r.build_ms),
        mean(&|r| r.trace_ms),
        {
            // Ray-space hierarchies build their structure inside the render, per batch.
            let h = mean(&|r| r.phases_ms[..7].iter().sum());
            if h > 0.0 {
                format!(
                    " (of which ray-hierarchy build {h:.1} ms, traversal and final tests {:.1} ms)",
                    mean(&|r| r.phases_ms[7..].iter().sum())
                )
            } else {
                String::new()
            }
        }
    );
    say!(
        "wrote {} … {}",
        frame_path(&a.out, 0)?.display(),
        frame_path(&a.out, n - 1)?.display()
    );
    if let Some(p) = &a.frame_csv {
        let mut csv =
            String::from("frame,time,triangles,update_ms,build_ms,render_ms,rays,total_tests");
        for p in ENGINE_PHASES {
            csv += &format!(",{}_ms", p.replace(' ', "_"));
        }
        csv += "\n";
        for r in &rows {
            csv += &format!(
                "{},{},{},{:.3},{:.3},{:.3},{},{}",
                r.frame,
                r.time,
                r.triangles,
                r.update_ms,
                r.build_ms,
                r.trace_ms,
                r.rays,
                r.total_tests
            );
            for p in &r.phases_ms {
                csv += &format!(",{p:.3}");
            }
            csv += "\n";
        }
        std::fs::write(p, csv).with_context(|| format!("--frame-csv {}", p.display()))?;
        say!("wrote {}", p.display());
    }
    if let Some(p) = &a.gif {
        let delay_ms = a.fps.map_or(100.0, |f| 1000.0 / f) as u32;
        render::output::write_gif(&gif_frames, a.width, a.height, delay_ms, p)
            .map_err(anyhow::Error::msg)
            .context("--gif")?;
        say!("wrote {}", p.display());
    }
    Ok(())
}

pub fn run() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Some(Command::Render(a)) => cmd_render(&a),
        Some(Command::Rays(a)) => cmd_rays(&a),
        Some(Command::Trace(a)) => cmd_trace(&a),
        Some(Command::Bench {
            what: BenchCommand::Rsh(a),
        }) => cmd_bench_rsh(&a),
        Some(Command::Bench {
            what: BenchCommand::Grid(a),
        }) => cmd_bench_grid(&a),
        Some(Command::Bench {
            what: BenchCommand::Gpu(a),
        }) => cmd_bench_gpu(&a),
        Some(Command::Bench {
            what: BenchCommand::Budget(a),
        }) => cmd_bench_budget(&a),
        None => cmd_render(&RenderArgs::default()),
    }
}
