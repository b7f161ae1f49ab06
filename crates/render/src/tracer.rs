//! The tracing trait every engine implements, so engines can be swapped and compared on
//! identical rays.

use crate::batch::{Hit, RayBatch};
use crate::stats::TraceStats;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceMode {
    /// Nearest hit in (t_min, t_max): reflection, refraction, primary rays.
    Closest,
    /// Any hit in (t_min, t_max): shadow rays (occlusion only).
    Any,
}

pub trait Tracer: Sync {
    /// Engine name as used on the command line.
    fn name(&self) -> &str;

    /// Trace every ray of `rays`, writing one record per ray into `hits`
    /// (`hits.len() == rays.len()`), and add this call's counters to `stats`.
    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats);
}
