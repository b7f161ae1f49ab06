//! The options that build an engine and load a scene, as the command line spells them
//! (`--engine`'s family options, `--meshes`, ...): one clap grammar shared by the
//! `rayspace` command line and the Python bindings (whose keyword arguments are these
//! options' names with `_` for `-`), so both name, default and validate them alike.

use crate::engines::{Engine, EngineOptions};
use accel::grid::{GridConfig, MergeRule, Subdivision};
use clap::builder::TypedValueParser as _;
use clap::{Args, Parser};
use rsh::{
    Descent, HashBits, HashKind, NodeTest, ObjectBuilder, ObjectHierarchy, RayPath, RshConfig,
    Schedule, Union,
};
use scene::MeshSplit;

/// A command's options with every default, as if given no arguments.
pub fn defaults<T: Args + clap::FromArgMatches>() -> T {
    let m = T::augment_args(clap::Command::new("defaults"))
        .try_get_matches_from(["defaults"])
        .expect("every option has a default");
    T::from_arg_matches(&m).expect("defaults parse")
}

/// `on`/`off` as a boolean.
pub fn on_off() -> impl clap::builder::TypedValueParser<Value = bool> {
    clap::builder::PossibleValuesParser::new(["on", "off"]).map(|s| s == "on")
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
        .for_memory(::trace::memory::limit(max_mib))
    }
}

/// How a rendered scene is lit and exposed (`render`, `view`).
#[derive(Args, Clone, Debug, Default)]
pub struct LookArgs {
    /// Ambient fill, `on` or `off`: a grey ambient light reflected by every material's
    /// diffuse colour, so that no shadow is pure black (default: on for scenes whose lights
    /// are automatic — a bare OBJ or glTF, a TOML file without lights — and off for scene
    /// files with their own lights and the benchmark scenes, which keep the thesis's
    /// eq. 3.19).
    #[arg(long, value_parser = on_off(), help_heading = "Look")]
    pub fill: Option<bool>,
    /// Exposure in stops: every light, the ambient light, the background and emission
    /// scaled by 2^EV (e.g. -1 for a blown-out scene; -16 to 16).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_name = "EV", value_parser = exposure(), help_heading = "Look")]
    pub exposure: f32,
}

/// `--exposure`: a finite number of stops in -16..=16.
fn exposure() -> impl clap::builder::TypedValueParser<Value = f32> {
    clap::builder::StringValueParser::new().try_map(|s: String| match s.parse::<f32>() {
        Ok(v) if v.is_finite() && (-16.0..=16.0).contains(&v) => Ok(v),
        _ => Err(format!("'{s}' is not a number of stops in -16..=16")),
    })
}

impl LookArgs {
    /// `o` with the fill and exposure asked for.
    pub fn apply(&self, o: scene::LoadOptions) -> scene::LoadOptions {
        scene::LoadOptions {
            fill: self.fill,
            exposure: self.exposure,
            ..o
        }
    }
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
    /// How a merge pass cuts its chains of candidates into merges: `runs` (a cell absorbs
    /// its successors while the SAH cost still drops; fewer rounds) or `pairs` (even
    /// positions absorb their successor, the paper's §4.2).
    #[arg(long = "grid-merge-rule", value_enum, default_value_t = GridConfig::default().merge_rule)]
    pub merge_rule: MergeRule,
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
            merge_rule: self.merge_rule,
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
    /// spheres (the thesis), or a per-frame BVH descended together with it (default: bvh).
    #[arg(long = "object-hierarchy", value_enum)]
    pub objects: Option<ObjectHierarchy>,
    /// With `--object-hierarchy bvh`: which node of a surviving pair is expanded.
    #[arg(long, value_enum, default_value_t = RshConfig::crsh().descent)]
    pub descent: Descent,
    /// With `--object-hierarchy bvh`: take the pairs depth first per top ray node (fast on
    /// the CPU), or level by level in data-parallel steps (the GPU's shape; the GPU backend
    /// runs breadth only).
    #[arg(long, value_enum, default_value_t = RshConfig::crsh().schedule)]
    pub schedule: Schedule,
    /// With `--object-hierarchy bvh`: trace each batch as the ray hierarchy's bundles, as
    /// single rays through the object tree, or as its coherence says (default: auto for
    /// crsh, bundles for rah; on the GPU backend single for crsh, bundles for rah).
    #[arg(long = "ray-path", value_enum)]
    pub path: Option<RayPath>,
    /// With `--object-hierarchy bvh`: how the object tree is built per frame.
    #[arg(long = "object-builder", value_enum, default_value_t = RshConfig::crsh().builder)]
    pub builder: ObjectBuilder,
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
            schedule: self.schedule,
            builder: self.builder,
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
        path: r.path,
        grid: g.config(dynamic),
    }
}

/// An engine and its options (the bindings' `Engine(scene, name, **options)`).
#[derive(Parser, Clone, Debug)]
#[command(name = "engine", no_binary_name = true, disable_help_flag = true)]
pub struct EngineArgs {
    #[arg(long, value_enum, default_value_t = Engine::Crsh)]
    pub engine: Engine,
    #[command(flatten)]
    pub rsh: RshArgs,
    #[command(flatten)]
    pub grid: GridArgs,
}

impl EngineArgs {
    /// Parse `--option value` words (without a program name); the error is clap's first
    /// line (`error: invalid value 'x' for '--levels <LEVELS>': ...`).
    pub fn parse_words<I: IntoIterator<Item = String>>(words: I) -> anyhow::Result<EngineArgs> {
        EngineArgs::try_parse_from(words).map_err(|e| {
            let msg = e.to_string();
            anyhow::anyhow!(
                "{}",
                msg.lines()
                    .next()
                    .unwrap_or("bad engine option")
                    .trim_start_matches("error: ")
            )
        })
    }
}
