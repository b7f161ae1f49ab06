//! The trace contract every engine answers, below the renderer and the engines alike.
//!
//! A [`RayBatch`] of structure-of-arrays rays goes into [`Tracer::trace`] with a
//! [`TraceMode`] (closest hit for reflection, refraction and primary rays; any hit for the
//! shadow rays of the thesis's §3.1) and comes back as one [`Hit`] per ray, with the call's
//! counters in [`TraceStats`]. Every engine (CRSH and RAH, the irregular grids, brute force,
//! the peers, the GPU backend's) answers the same trait, so engines are swapped and compared
//! on identical rays; brute force's records are the oracle (same triangle, same t bits).
//! [`memory`] holds the limits that every structure's memory model is checked against
//! before it allocates; [`OptionError`] is how every configuration refuses a value.

#![warn(missing_docs)]

pub mod batch;
pub mod error;
pub mod fill;
pub mod memory;
pub mod options;
pub mod stats;
pub mod tracer;

pub use batch::{BatchError, Hit, RayBatch, RayKind};
pub use error::{by_name, NameError, OptionError};
pub use stats::{
    BuildPass, Counter, CounterKind, Counters, Device, LevelCounts, LevelRow, PassTime, Phase,
    PhaseKind, TraceStats, RAY_BOX_TESTS, TRAVERSAL,
};
pub use tracer::{trace_per_ray, TraceMode, Tracer};
