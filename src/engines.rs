//! The engine registry: every tracer this build can name, and the one function that builds
//! it. The CLI's `render`, `rays`/`trace` and frame loop, the benchmarks and the bindings all
//! build engines here, so an engine is named, configured and validated in one place.
//!
//! Engines: CRSH (Reis 2015, §3.2) and RAH (Roger et al. 2007) from `rsh`; the irregular grid
//! (Pérard-Gayot et al. 2017) and its two-level baseline, brute force (the oracle) and the
//! peers from `accel`.

use accel::grid::{GridConfig, GridError};
use rsh::{Method, ObjectBuilder, ObjectHierarchy, RayPath, RshConfig, RshError};
use scene::Geometry;
use trace::{NameError, OptionError, Tracer};

/// Why an engine was not built.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// An option out of range (CRSH/RAH's, or a grid option given to another engine).
    #[error(transparent)]
    Option(#[from] OptionError),
    /// A grid engine refused its options, its input or its size.
    #[error("`engine` {engine}: {error}")]
    Grid {
        /// `grid` or `grid2l`.
        engine: &'static str,
        /// Why.
        error: GridError,
    },
    /// CRSH or RAH refused its input.
    #[error(transparent)]
    Rsh(#[from] RshError),
    /// Embree refused the scene.
    #[cfg(feature = "embree")]
    #[error(transparent)]
    Embree(#[from] accel::peers::EmbreeError),
    /// An Embree engine asked of a build without the peer.
    #[error("`engine` {0}: this build has no Embree peer; install Embree 3 (Debian: libembree-dev) and build with `cargo build --release --features embree`")]
    NoEmbree(&'static str),
}

/// An engine, as the command line names it (`--engine`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
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

impl Engine {
    /// Every engine by its name, in the order the command line lists them.
    pub const NAMES: [(&'static str, Engine); 9] = [
        ("crsh", Engine::Crsh),
        ("rah", Engine::Rah),
        ("brute", Engine::Brute),
        ("grid", Engine::Grid),
        ("grid2l", Engine::Grid2l),
        ("obvhs-cwbvh", Engine::ObvhsCwbvh),
        ("obvhs-bvh2", Engine::ObvhsBvh2),
        ("embree", Engine::Embree),
        ("embree-stream", Engine::EmbreeStream),
    ];

    /// The engine's name (`grid2l`, `obvhs-cwbvh`, ...).
    pub fn name(self) -> &'static str {
        Self::NAMES
            .iter()
            .find(|(_, e)| *e == self)
            .map(|(n, _)| *n)
            .expect("every engine is named")
    }

    /// The engine named `name` (case-insensitive, surrounding spaces ignored).
    pub fn parse(name: &str) -> Result<Engine, NameError> {
        trace::by_name(&name.trim().to_ascii_lowercase(), "engine", &Self::NAMES)
    }

    /// Every engine worth comparing except brute force: ours, then the peers this build has
    /// (the viewer cycles through them, `bench scale` runs them).
    pub fn all_but_brute() -> Vec<Engine> {
        let mut v = vec![
            Engine::Crsh,
            Engine::Rah,
            Engine::Grid,
            Engine::Grid2l,
            Engine::ObvhsCwbvh,
        ];
        if cfg!(feature = "embree") {
            v.push(Engine::Embree);
        }
        v
    }

    /// A peer (obvhs, Embree): equal to brute force within the peers' stated tolerance,
    /// not bit for bit.
    pub fn is_peer(self) -> bool {
        matches!(
            self,
            Engine::ObvhsCwbvh | Engine::ObvhsBvh2 | Engine::Embree | Engine::EmbreeStream
        )
    }

    /// CRSH's and RAH's method; `None` for the other engines.
    pub fn rsh_method(self) -> Option<Method> {
        match self {
            Engine::Crsh => Some(Method::Crsh),
            Engine::Rah => Some(Method::Rah),
            _ => None,
        }
    }

    /// Whether the engine option `keyword` (a name of `keywords::KEYWORDS`) changes what
    /// this engine does: CRSH's and RAH's options for them (RAH orders rays by screen
    /// position, so CRSH's hash is not its), the grid's for the grids (the two-level grid
    /// stops before merging and expansion), none for the others.
    pub fn takes(self, keyword: &str) -> bool {
        let grid = keyword.starts_with("grid_");
        match self {
            Engine::Crsh => !grid,
            Engine::Rah => !grid && !matches!(keyword, "hash" | "hash_bits"),
            Engine::Grid => grid,
            Engine::Grid2l => {
                grid && !matches!(
                    keyword,
                    "grid_alpha" | "grid_merge" | "grid_merge_rule" | "grid_expansion"
                )
            }
            _ => false,
        }
    }

    /// Whether the engine runs on the GPU backend.
    pub fn has_gpu(self) -> bool {
        matches!(
            self,
            Engine::Crsh | Engine::Rah | Engine::Grid | Engine::Grid2l
        )
    }

    /// The engines that run on the GPU backend, by name.
    pub fn gpu_names() -> Vec<&'static str> {
        Self::NAMES
            .iter()
            .filter(|(_, e)| e.has_gpu())
            .map(|(n, _)| *n)
            .collect()
    }
}

/// How a method's batches go over the object tree unless `--ray-path` says otherwise.
pub fn method_default_path(method: Method) -> RayPath {
    match method {
        Method::Crsh => RshConfig::crsh().path,
        Method::Rah => RshConfig::rah().path,
    }
}

/// How a method's batches go over the object tree on the GPU backend unless `--ray-path`
/// says otherwise: the CPU's default as a device takes it ([`RayPath::on_device`]).
pub fn gpu_default_path(method: Method) -> RayPath {
    method_default_path(method).on_device()
}

/// The object side CRSH and RAH use on the CPU unless `--object-hierarchy` says otherwise.
pub const DEFAULT_OBJECTS: ObjectHierarchy = ObjectHierarchy::Bvh;

/// The object hierarchy the GPU backend gives `method` when none is asked for: the BVH, as
/// on the CPU (CRSH's single rays walk it; RAH's bundles descend it with the dual
/// traversal, level by level).
pub fn gpu_default_objects(_method: Method) -> ObjectHierarchy {
    ObjectHierarchy::Bvh
}

/// The object hierarchy `method` runs with: the one asked for, else the backend's default
/// (the CPU's [`DEFAULT_OBJECTS`]; on the GPU [`gpu_default_objects`]).
pub fn objects_for(method: Method, asked: Option<ObjectHierarchy>, gpu: bool) -> ObjectHierarchy {
    match (asked, gpu) {
        (Some(o), _) => o,
        (None, true) => gpu_default_objects(method),
        (None, false) => DEFAULT_OBJECTS,
    }
}

/// [`objects_for`] of `engine` by name (`bvh`, `mesh-spheres`), for the stats; `None` for
/// engines that are not ray-space hierarchies.
pub fn object_hierarchy_name(
    engine: Engine,
    asked: Option<ObjectHierarchy>,
    gpu: bool,
) -> Option<&'static str> {
    Some(match objects_for(engine.rsh_method()?, asked, gpu) {
        ObjectHierarchy::Bvh => "bvh",
        ObjectHierarchy::MeshSpheres => "mesh-spheres",
    })
}

/// What engines are built with: the options of every family, each engine taking its own.
#[derive(Clone, Debug)]
pub struct EngineOptions {
    /// CRSH/RAH options. `method` comes from the engine, and so does `mesh_culling` unless
    /// [`EngineOptions::mesh_culling`] overrides it (CRSH culls by default, RAH does not).
    pub rsh: RshConfig,
    /// Mesh-sphere culling for CRSH and RAH alike (`None`: each method's default).
    pub mesh_culling: Option<bool>,
    /// The object side of CRSH and RAH (`None`: [`DEFAULT_OBJECTS`] on the CPU,
    /// [`gpu_default_objects`] on the GPU).
    pub objects: Option<ObjectHierarchy>,
    /// How CRSH and RAH trace a batch over the object tree (`None`: each method's default,
    /// auto for CRSH, bundles for RAH).
    pub path: Option<RayPath>,
    /// Irregular-grid options (`grid2l` turns merging and expansion off).
    pub grid: GridConfig,
}

impl Default for EngineOptions {
    fn default() -> Self {
        EngineOptions {
            rsh: RshConfig::crsh(),
            mesh_culling: None,
            objects: None,
            path: None,
            grid: GridConfig::default(),
        }
    }
}

impl EngineOptions {
    /// The configuration of CRSH or RAH.
    pub fn rsh_config(&self, method: Method) -> RshConfig {
        let base = match method {
            Method::Crsh => RshConfig::crsh(),
            Method::Rah => RshConfig::rah(),
        };
        RshConfig {
            method,
            mesh_culling: self.mesh_culling.unwrap_or(base.mesh_culling),
            objects: self.objects.unwrap_or(DEFAULT_OBJECTS),
            path: self.path.unwrap_or(base.path),
            ..self.rsh.clone()
        }
    }

    /// [`EngineOptions::rsh_config`] for the GPU backend: the object side defaults to
    /// [`gpu_default_objects`], the path to [`gpu_default_path`], the object tree is the
    /// LBVH (the device's builder) and the dual traversal goes level by level (the device's
    /// schedule).
    pub fn gpu_rsh_config(&self, method: Method) -> RshConfig {
        RshConfig {
            objects: objects_for(method, self.objects, true),
            builder: ObjectBuilder::Lbvh,
            path: self.path.unwrap_or(gpu_default_path(method)),
            schedule: rsh::Schedule::Breadth,
            ..self.rsh_config(method)
        }
    }

    /// The configuration of `grid` or `grid2l` (initial cells only).
    pub fn grid_config(&self, two_level: bool) -> GridConfig {
        if two_level {
            GridConfig {
                merge: false,
                expansion_passes: 0,
                ..self.grid.clone()
            }
        } else {
            self.grid.clone()
        }
    }

    /// Check every option (whichever engine uses it: a bad value is an error even where
    /// `engine` ignores it); errors name the option.
    pub fn validate(&self, engine: Engine) -> Result<(), EngineError> {
        self.rsh_config(engine.rsh_method().unwrap_or(Method::Crsh))
            .validate()?;
        self.grid.validate().map_err(|e| {
            if matches!(engine, Engine::Grid | Engine::Grid2l) {
                EngineError::Grid {
                    engine: engine.name(),
                    error: e.into(),
                }
            } else {
                e.into()
            }
        })
    }
}

/// A built engine, with a one-line description of what was built where the engine has one
/// (the grids: cells, references, memory, build passes).
pub struct Built {
    /// The engine (`Send`, so that a binding may own it on any thread).
    pub tracer: Box<dyn Tracer + Send>,
    pub report: Option<String>,
}

/// Build `engine` over `geo`.
pub fn build(engine: Engine, opts: &EngineOptions, geo: &Geometry) -> Result<Built, EngineError> {
    opts.validate(engine)?;
    let mut report = None;
    let tracer: Box<dyn Tracer + Send> = match engine {
        Engine::Grid | Engine::Grid2l => {
            let two_level = engine == Engine::Grid2l;
            let g = accel::GridEngine::new(geo, &opts.grid_config(two_level)).map_err(|e| {
                EngineError::Grid {
                    engine: engine.name(),
                    error: e,
                }
            })?;
            let (c, r, v) = g.grid.memory();
            let b = &g.grid.build;
            report = Some(format!(
                "{}: {} cells (initial {}), {} references, top grid {:?}, virtual grid {:?}; memory cells {} B, references {} B, voxel map {} B; build ms: references {:.1}, octrees {:.1}, voxel map {:.1}, merge {:.1} ({} rounds), expansion {:.1}",
                if two_level { "two-level grid" } else { "irregular grid" },
                g.grid.cells(), b.initial_cells, g.grid.refs.len(), g.grid.top_dims, g.grid.dims, c, r, v,
                b.top_refs_seconds * 1e3, b.octree_seconds * 1e3, b.voxel_map_seconds * 1e3, b.merge_seconds * 1e3, b.merge_rounds, b.expand_seconds * 1e3
            ));
            Box::new(g)
        }
        Engine::Brute => Box::new(accel::BruteForce::new(geo)),
        Engine::ObvhsCwbvh => Box::new(accel::peers::ObvhsEngine::new(
            geo,
            accel::peers::BvhKind::CwBvh,
        )),
        Engine::ObvhsBvh2 => Box::new(accel::peers::ObvhsEngine::new(
            geo,
            accel::peers::BvhKind::Bvh2,
        )),
        Engine::Embree | Engine::EmbreeStream => embree(engine, geo)?,
        Engine::Crsh | Engine::Rah => {
            let m = engine.rsh_method().expect("a ray-space hierarchy");
            Box::new(rsh::RshEngine::new(geo, opts.rsh_config(m))?)
        }
    };
    Ok(Built { tracer, report })
}

#[cfg(feature = "embree")]
fn embree(engine: Engine, geo: &Geometry) -> Result<Box<dyn Tracer + Send>, EngineError> {
    let mode = if engine == Engine::Embree {
        accel::peers::EmbreeMode::Single
    } else {
        accel::peers::EmbreeMode::Stream
    };
    Ok(Box::new(accel::peers::EmbreeEngine::new(geo, mode)?))
}

#[cfg(not(feature = "embree"))]
fn embree(engine: Engine, _geo: &Geometry) -> Result<Box<dyn Tracer + Send>, EngineError> {
    Err(EngineError::NoEmbree(engine.name()))
}

/// The obvhs version this binary is built with (for benchmark provenance).
pub const OBVHS_VERSION: &str = "0.4";
