//! The GPU backend of rayspace, on wgpu (Vulkan, Metal, DX12; Mesa's lavapipe on machines
//! without a GPU).
//!
//! - [`device`]: adapter and device set-up, buffers, read-back.
//! - [`kernels`]: the WGSL kernels (`src/shaders/`) and the launch recorder with per-phase
//!   timestamp queries, plus the data-parallel primitives (reduce-then-scan, compaction,
//!   stable radix sort) built from them.
//! - [`engine`]: CRSH and RAH as a [`render::Tracer`], kernel for kernel the pipeline of
//!   the `rsh` crate, with the same counters.
//! - [`raster`]: primary visibility by real rasterization (render pipeline, depth test) into
//!   the G-buffer's render targets.
//! - [`stages`]: the Whitted loop's shadow-ray generation, reflection/refraction-ray
//!   generation and shading as kernels.

//!
//! Every kernel mirrors a CPU pass over flat structure-of-arrays buffers of the same layout;
//! the CPU engines are this backend's oracle (see `tests/`).

pub mod device;
pub mod engine;
pub mod kernels;
pub mod raster;
pub mod stages;

pub use device::{Gpu, GpuError};
pub use engine::GpuRsh;
pub use raster::GpuRaster;
pub use stages::GpuStages;
