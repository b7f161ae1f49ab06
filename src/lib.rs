//! rayspace as a library: the engine registry ([`engines`]), the engine and load options as
//! the command line spells them ([`options`]), one frame of a dynamic scene ([`frames`]) and
//! the papers' evaluations ([`bench`](mod@bench)), shared by the `rayspace` command line and
//! the Python bindings (`python/`).

pub mod bench;
pub mod engines;
pub mod frames;
#[cfg(feature = "gpu")]
pub mod gpu_frame;
pub mod options;
pub mod report;
#[cfg(feature = "view")]
pub mod view;
