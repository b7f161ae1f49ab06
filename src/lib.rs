//! rayspace as a library. Programs that bring their own geometry start at the front door
//! ([`api`], re-exported here: a scene from arrays, an engine by name, batches of rays, a
//! frame rendered; `examples/own_mesh.rs`). Underneath: the engine registry ([`engines`]: every engine, its options from
//! the engines' own declarations, one build function), one frame of a dynamic scene
//! ([`frames`]); with the `cli` feature also the engine and load options as the command
//! line spells them (`options`) and the papers' evaluations (`bench`, `report`). The `rayspace` command line and the Python bindings
//! (`python/`, built without `cli`) share it.

pub mod api;
#[cfg(feature = "cli")]
pub mod bench;
pub mod engines;
pub mod frames;
#[cfg(feature = "gpu")]
pub mod gpu_frame;
#[cfg(feature = "cli")]
pub mod options;
#[cfg(feature = "cli")]
pub mod report;
pub mod runner;
#[cfg(feature = "view")]
pub mod view;

pub use api::{SceneEngine, TraceError};
pub use engines::{Config, Engine, EngineError};
pub use geom::{Mat4, Ray, Vec3};
pub use render::whitted::{RenderOptions, Rendered};
pub use runner::{render, Frame, FrameError, Runner};
pub use scene::{ArrayError, Camera, Geometry, Light, Material, Scene, SceneBuilder, SceneError};
pub use trace::options::Value;
pub use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};
