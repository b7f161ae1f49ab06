//! rayspace as a library: the engine registry ([`engines`]: every engine, its options from
//! the engines' own declarations, one build function), one frame of a dynamic scene
//! ([`frames`]); with the `cli` feature also the engine and load options as the command
//! line spells them (`options`) and the papers' evaluations (`bench`, `report`). The `rayspace` command line and the Python bindings
//! (`python/`, built without `cli`) share it.

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
#[cfg(feature = "view")]
pub mod view;
