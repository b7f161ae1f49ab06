//! Object-space engines behind [`trace::Tracer`]: brute force and the irregular grid.
//!
//! [`BruteForce`] tests every ray against every triangle with the shared watertight kernel.
//! It is the oracle: every other engine must return the same closest hits (same triangle,
//! bit-identical t and barycentrics, because all use [`geom::intersect`]) and the same
//! any-hit booleans.

#![warn(missing_docs)]

pub mod brute;
pub mod grid;
pub mod oracle;
pub mod peers;

pub use brute::BruteForce;
pub use grid::{GridConfig, GridEngine, GridError};
