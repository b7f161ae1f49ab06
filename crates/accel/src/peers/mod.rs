//! Peers: other people's acceleration structures behind the same [`trace::Tracer`] trait, so
//! that benchmarks trace exactly the same rays through ours and theirs in one process.
//!
//! - [`ObvhsEngine`]: the pure-Rust `obvhs` crate (a PLOC-built BVH2, optionally collapsed to
//!   an 8-wide compressed CWBVH). Its traversal calls back into our watertight triangle kernel,
//!   so its records are bit-identical to brute force's: it differs from our engines only in
//!   the index structure, which is what the irregular-grid paper compares.
//! - `EmbreeEngine` (cargo feature `embree`): Intel Embree 3 through the `embree` crate's raw
//!   bindings, with Embree's own kernel; its hits agree with ours within a tolerance (its
//!   triangle test is not the watertight one).

pub mod obvhs;
pub use obvhs::{BvhKind, ObvhsEngine};

#[cfg(feature = "embree")]
pub mod embree;
#[cfg(feature = "embree")]
pub use self::embree::{EmbreeEngine, EmbreeError, EmbreeMode};

/// The memory models of the peers' builds: resident bytes added per triangle at their peak,
/// above what was measured on hairball and city scenes (`bench/results/2026-12-07-2core/
/// memory.txt`: obvhs CWBVH 374–377, BVH2 262–264, Embree 151–152, each with its copy of
/// the triangles), checked against the memory limit before a peer is built.
pub const CWBVH_BUILD_BYTES_PER_TRIANGLE: u64 = 420;
/// obvhs's binary BVH.
pub const BVH2_BUILD_BYTES_PER_TRIANGLE: u64 = 300;
/// Embree 3 (either API).
pub const EMBREE_BUILD_BYTES_PER_TRIANGLE: u64 = 175;

/// Whether this build has the Embree peer (the cargo feature `embree`).
pub const HAS_EMBREE: bool = cfg!(feature = "embree");
