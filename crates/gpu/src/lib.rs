//! The GPU backend of rayspace, on wgpu (Vulkan, Metal, DX12; Mesa's lavapipe on machines
//! without a GPU).
//!
//! - [`device`]: adapter and device set-up, buffers, read-back.
//! - [`kernels`]: the WGSL kernels, named by the typed key [`kernels::Kernel`], and the
//!   launch recorder with per-phase timestamp queries.
//! - [`prims`]: the GPU's `par` — reduce-then-scan, compaction, runs, stable radix sort
//!   (`src/prims/*.wgsl`).
//! - [`rsh`]: CRSH and RAH as a [`render::Tracer`], file for file the `rsh` crate's pipeline
//!   (`hash → order → build → traverse`, `src/rsh/*.rs` beside `src/rsh/*.wgsl`), with the
//!   same counters.
//! - [`raster`]: primary visibility by real rasterization (render pipeline, depth test) into
//!   the G-buffer's render targets.
//! - [`stages`]: the Whitted loop's shadow-ray generation, reflection/refraction-ray
//!   generation and shading as kernels.
//!
//! Every kernel mirrors a CPU pass over flat structure-of-arrays buffers of the same layout;
//! the CPU engines are this backend's oracle (see `tests/`).

#![warn(missing_docs)]

pub mod device;
pub mod kernels;
pub mod prims;
pub mod raster;
pub mod rsh;
pub mod stages;

pub use crate::rsh::GpuRsh;
pub use device::{Gpu, GpuError};
pub use raster::GpuRaster;
pub use stages::GpuStages;
