//! Object-space engines behind [`trace::Tracer`]: brute force, the irregular grid
//! ([`grid`]), the object-tree walk ([`bvh`]) and other people's structures ([`peers`]).
//!
//! [`BruteForce`] tests every ray against every triangle with the shared watertight kernel.
//! It is the oracle: every other engine must return the same closest hits (same triangle,
//! bit-identical t and barycentrics, because all use [`geom::intersect`]) and the same
//! any-hit booleans.

#![warn(missing_docs)]

pub mod brute;
pub mod bvh;
pub mod grid;
pub mod oracle;
pub mod peers;

pub use brute::BruteForce;
pub use bvh::{BvhConfig, BvhEngine, BvhError};
pub use grid::{GridConfig, GridEngine, GridError};
