//! What the GPU backend adds to its engines' reports: the transfers between host and device
//! as phases, its dispatches and second-pass walks as counters, and its own build passes.
//! (Every other phase and counter is the CPU twin's: the GPU engines report the same.)

use trace::{BuildPass, Counter, Phase, PhaseKind};

/// The rays uploaded before the first kernel.
pub const UPLOAD: Phase = Phase::new(0, "upload", PhaseKind::Transfer);
/// The hit records read back.
pub const READ_BACK: Phase = Phase::new(100, "read-back", PhaseKind::Transfer);

/// Compute dispatches.
pub const KERNEL_LAUNCHES: Counter = Counter::sum("gpu kernel launches");
/// Single rays through the object tree whose walk outgrew the private stack, walked again
/// by the second pass with its stack in storage memory.
pub const STACK_OVERFLOWS: Counter = Counter::sum("gpu stack overflows");

/// The engine's WGSL modules compiled.
pub const KERNEL_COMPILATION: BuildPass = BuildPass::new("kernel compilation");
/// A structure built on the host, uploaded.
pub const UPLOAD_PASS: BuildPass = BuildPass::new("upload");
