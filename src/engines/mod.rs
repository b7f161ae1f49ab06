//! The engine registry: every tracer this build can name, what each runs, its options (from
//! the engines' own declarations, [`config`]) and the one function that builds it. The
//! command line's `render`, `rays`/`trace`, frames and `engines`, the benchmarks, the report,
//! the viewer and the Python bindings all name, configure and build engines here.
//!
//! An engine's name is the algorithm it runs:
//! - `bvh`: an object tree built every frame and walked by packets or single rays
//!   (`accel::bvh`); no ray hierarchy. The default: the fastest exact engine for a Whitted
//!   frame on this project's measurements.
//! - `crsh`: the thesis's Coherent Ray-Space Hierarchy (Reis 2015, §3.2): rays hashed by
//!   type, compressed, radix-sorted, decompressed and bundled into a B × D sphere-cone
//!   hierarchy, traversed against the object tree (the dual traversal, §5.1's future work)
//!   or the per-mesh spheres (the thesis's own), exact final tests (`rsh`).
//! - `rah`: Roger et al. 2007's ray hierarchy: the same pyramid over rays in screen order.
//! - `grid`, `grid2l`: the irregular grid (Pérard-Gayot et al. 2017) and its two-level
//!   baseline (`accel::grid`).
//! - `brute`: every ray against every triangle, the oracle.
//! - the peers: obvhs's BVHs, Embree 3 (`accel::peers`).

pub mod config;

pub use config::{Backend, Config, EngineOptions};

use accel::grid::GridError;
use rsh::{Method, RshError};
use scene::Geometry;
use trace::{NameError, OptionError, Tracer};

/// Why an engine was not built, or its options not taken. Options are named by keyword
/// between backticks (`` `levels` ``), as every library message names them; the command
/// line spells them as its flags, the bindings as keywords.
#[derive(Debug, thiserror::Error)]
pub enum EngineError {
    /// An option's value out of its range, or one that does not parse.
    #[error(transparent)]
    Option(#[from] OptionError),
    /// No engine takes an option of this name.
    #[error("unknown engine option `{option}` (options: {})", known.join(", "))]
    Unknown {
        /// The name given.
        option: String,
        /// Every option's keyword.
        known: Vec<&'static str>,
    },
    /// The option is another engine's.
    #[error("`{option}` does not apply to `engine`={engine} (it is an option of {})", takers.join(", "))]
    NotFor {
        /// The option.
        option: &'static str,
        /// The engine asked for.
        engine: &'static str,
        /// The engines that take it.
        takers: Vec<&'static str>,
    },
    /// The option matters only with another option's value, which this configuration does
    /// not have.
    #[error("`{option}` applies with `{needs}`={value}, and `engine`={engine} runs with `{needs}`={has} here")]
    Requires {
        /// The option.
        option: &'static str,
        /// The option it depends on …
        needs: &'static str,
        /// … the value it needs …
        value: &'static str,
        /// … and the value it has.
        has: String,
        /// The engine.
        engine: &'static str,
    },
    /// The GPU backend takes one value of this option only.
    #[error(
        "`{option}`={value}: the GPU backend takes only {only} (the others run on the CPU backend)"
    )]
    GpuOnly {
        /// The option.
        option: &'static str,
        /// The value asked for.
        value: String,
        /// The one value the device takes.
        only: &'static str,
    },
    /// The engine has no GPU path.
    #[error("`engine`={engine} has no GPU path (the GPU runs {})", Engine::gpu_names().join(", "))]
    NoGpu {
        /// The engine.
        engine: &'static str,
    },
    /// The engine's build would need more memory than the limit leaves (checked before
    /// anything is allocated).
    #[error("`engine`={engine} over {triangles} triangles needs about {} for its build, more than the {} the memory limit (`max_memory`) leaves after the scene and the render; raise it, lower the size, or take a lighter engine (`engine`=bvh)", trace::memory::gib(*need), trace::memory::gib(*left))]
    Memory {
        /// The engine.
        engine: &'static str,
        /// Its triangles.
        triangles: u64,
        /// The bytes its model needs.
        need: u64,
        /// The bytes left for it.
        left: u64,
    },
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
    /// The object-tree walk refused its input.
    #[error(transparent)]
    Bvh(#[from] accel::BvhError),
    /// Embree refused the scene.
    #[cfg(feature = "embree")]
    #[error(transparent)]
    Embree(#[from] accel::peers::EmbreeError),
    /// An Embree engine asked of a build without the peer.
    #[error("`engine` {0}: this build has no Embree peer; install Embree 3 (Debian: libembree-dev) and build with `cargo build --release --features embree`")]
    NoEmbree(&'static str),
}

/// An engine, as the command line names it (`--engine`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Engine {
    /// Object tree (SAH BVH per frame) walked by packets or single rays; no ray hierarchy.
    Bvh,
    /// The thesis's ray-space hierarchy: hashed, sorted rays in sphere-cone nodes.
    Crsh,
    /// Roger et al.'s ray hierarchy: the same pyramid over screen-ordered rays.
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

/// The engine `render`, `view`, `trace`, `cargo run --release` and Python use when none is
/// named: `bvh`, the fastest exact engine for a Whitted frame in the README's table (Kitchen
/// 512², 3 bounces: packets and single rays through the SAH tree take about 0.6 of the ray
/// hierarchy's frame time and beat the irregular grid's build + trace).
pub const DEFAULT_ENGINE: Engine = Engine::Bvh;

impl Engine {
    /// Every engine by its name, in the order the command line lists them.
    pub const NAMES: [(&'static str, Engine); 10] = [
        ("bvh", Engine::Bvh),
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

    /// What the engine runs, in one line, with its paper and section.
    pub fn summary(self) -> &'static str {
        match self {
            Engine::Bvh => "SAH object tree built per frame, walked by packets of 16 rays or single rays (Wald et al. 2001, 2008); no ray hierarchy",
            Engine::Crsh => "the thesis's ray-space hierarchy: rays hashed, compressed, sorted, decompressed, bundled B x D into sphere-cone nodes, traversed against the object tree or mesh spheres (Reis 2015, §3.2)",
            Engine::Rah => "Roger et al.'s ray hierarchy: a pyramid of sphere-cone nodes over rays in screen order (Roger et al. 2007; thesis §2.4)",
            Engine::Brute => "every ray against every triangle: the oracle",
            Engine::Grid => "irregular grid: top grid + octrees, SAH cell merging, expansion, voxel-map traversal (Pérard-Gayot et al. 2017, §4)",
            Engine::Grid2l => "two-level grid: the irregular grid's initial cells (Kalojanov et al. 2011; Pérard-Gayot et al. 2017, §4.1)",
            Engine::ObvhsCwbvh => "peer: obvhs's compressed 8-wide BVH (Ylitie et al. 2017), our triangle test at the leaves",
            Engine::ObvhsBvh2 => "peer: obvhs's binary BVH, our triangle test at the leaves",
            Engine::Embree => "peer: Embree 3, one ray at a time (rtcIntersect1)",
            Engine::EmbreeStream => "peer: Embree 3's stream API (rtcIntersect1M)",
        }
    }

    /// Every engine worth comparing except brute force: ours, then the peers this build has
    /// (the viewer cycles through them, `bench scale` runs them).
    pub fn all_but_brute() -> Vec<Engine> {
        let mut v = vec![
            Engine::Bvh,
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

    /// Whether the engine runs on the GPU backend.
    pub fn has_gpu(self) -> bool {
        matches!(
            self,
            Engine::Bvh | Engine::Crsh | Engine::Rah | Engine::Grid | Engine::Grid2l
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

/// `--engine`'s values are the names, listed inline (`rayspace engines` says what each runs).
#[cfg(feature = "cli")]
impl clap::ValueEnum for Engine {
    fn value_variants<'a>() -> &'a [Self] {
        const ALL: [Engine; 10] = {
            let mut a = [Engine::Bvh; 10];
            let mut i = 0;
            while i < 10 {
                a[i] = Engine::NAMES[i].1;
                i += 1;
            }
            a
        };
        &ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.name()))
    }
}

/// A built engine, with its configuration and a one-line description of what was built
/// where the engine has one (the grids: cells, references, memory, build passes).
pub struct Built {
    /// The engine (`Send`, so that a binding may own it on any thread).
    pub tracer: Box<dyn Tracer + Send>,
    /// What was built, in one line.
    pub report: Option<String>,
}

/// Build `engine` over `geo` with `cfg` (its configuration on the CPU backend:
/// [`config::config`]).
pub fn build(engine: Engine, cfg: &Config, geo: &Geometry) -> Result<Built, EngineError> {
    let mut report = None;
    let tracer: Box<dyn Tracer + Send> = match (engine, cfg) {
        (Engine::Grid | Engine::Grid2l, Config::Grid(c)) => {
            let g = accel::GridEngine::new(geo, c).map_err(|e| EngineError::Grid {
                engine: engine.name(),
                error: e,
            })?;
            let (c, r, v) = g.grid.memory();
            let b = &g.grid.build;
            report = Some(format!(
                "{}: {} cells (initial {}), {} references, top grid {:?}, virtual grid {:?}; memory cells {} B, references {} B, voxel map {} B; build ms: references {:.1}, octrees {:.1}, voxel map {:.1}, merge {:.1} ({} rounds), expansion {:.1}",
                if engine == Engine::Grid2l { "two-level grid" } else { "irregular grid" },
                g.grid.cells(), b.initial_cells, g.grid.refs.len(), g.grid.top_dims, g.grid.dims, c, r, v,
                b.top_refs_seconds * 1e3, b.octree_seconds * 1e3, b.voxel_map_seconds * 1e3, b.merge_seconds * 1e3, b.merge_rounds, b.expand_seconds * 1e3
            ));
            Box::new(g)
        }
        (Engine::Bvh, Config::Bvh(c)) => Box::new(accel::BvhEngine::new(geo, c.clone())?),
        (Engine::Crsh | Engine::Rah, Config::Rsh(c)) => {
            Box::new(rsh::RshEngine::new(geo, c.clone())?)
        }
        (Engine::Brute, _) => Box::new(accel::BruteForce::new(geo)),
        (Engine::ObvhsCwbvh, _) => Box::new(accel::peers::ObvhsEngine::new(
            geo,
            accel::peers::BvhKind::CwBvh,
        )),
        (Engine::ObvhsBvh2, _) => Box::new(accel::peers::ObvhsEngine::new(
            geo,
            accel::peers::BvhKind::Bvh2,
        )),
        (Engine::Embree | Engine::EmbreeStream, _) => embree(engine, geo)?,
        (e, c) => panic!(
            "{} built with another engine's configuration {c:?}",
            e.name()
        ),
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

/// Every phase an engine of this build reports, in pipeline order: CRSH's and RAH's
/// (`rsh::stats::PHASES`, which holds the traversal every engine shares) and, with the GPU
/// backend, its transfers.
pub fn phases() -> Vec<trace::Phase> {
    let mut v = rsh::stats::PHASES.to_vec();
    #[cfg(feature = "gpu")]
    v.extend([gpu::stats::UPLOAD, gpu::stats::READ_BACK]);
    v.sort();
    v
}

/// Every counter an engine of this build reports besides the tests and hits, by name.
pub fn counters() -> Vec<trace::Counter> {
    let mut v = rsh::stats::COUNTERS.to_vec();
    v.extend([
        trace::RAY_BOX_TESTS,
        accel::bvh::RAY_BOX_PASSES,
        accel::bvh::PACKET_BATCHES,
        accel::bvh::SINGLE_RAY_BATCHES,
        accel::grid::TRAVERSAL_STEPS,
    ]);
    #[cfg(feature = "gpu")]
    v.extend([gpu::stats::KERNEL_LAUNCHES, gpu::stats::STACK_OVERFLOWS]);
    v.sort();
    v
}

/// The obvhs version this binary is built with (for benchmark provenance).
pub const OBVHS_VERSION: &str = "0.4";
