//! Ray-space hierarchies: the thesis's Coherent Ray-Space Hierarchy (CRSH, Reis 2015, §3.2)
//! and Roger et al.'s RAH (2007), as engines of [`trace::Tracer`].
//!
//! Per trace call: order the rays ([`order`]: CRSH hashes, compresses, sorts and
//! decompresses; RAH uses screen order), build a sphere-cone hierarchy bottom-up
//! ([`build`]), push the scene's triangles top-down through it as (node, triangle) pairs
//! ([`traverse`]) and finish with exact ray–triangle tests. Every step is a flat,
//! data-parallel pass built on `par`.

#![warn(missing_docs)]

pub mod build;
pub mod dual;
pub mod engine;
pub mod hash;
pub mod node8;
pub mod options;
pub mod order;
pub mod stats;
pub mod traverse;

pub use accel::bvh::ObjectBuilder;
pub use build::Union;
pub use dual::{Descent, Schedule};
pub use engine::{RshEngine, RshError};
pub use hash::{HashBits, HashBitsError, HashKind};
pub use options::{Method, ObjectHierarchy, RshConfig};
pub use traverse::NodeTest;
