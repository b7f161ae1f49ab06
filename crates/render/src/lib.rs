//! The hybrid renderer of the CRSH thesis (chapter 3), engine-agnostic.
//!
//! Primary visibility is rasterized into a G-buffer ([`raster`], thesis §3.1); secondary rays
//! (shadow, reflection, refraction; eqs. 3.1–3.7) are generated as flat [`trace::RayBatch`]es
//! ([`secondary`]) and traced by any engine implementing [`trace::Tracer`]; hits are shaded
//! with Blinn-Phong and distance attenuation (eqs. 3.17–3.19, [`shade`]) in a batched
//! Whitted loop ([`whitted`]), written once over a backend ([`whitted::Backend`]: the CPU's
//! is [`cpu`], the GPU's `gpu::frame`), that records per-phase times and counters ([`stats`]).

#![warn(missing_docs)]

pub mod cpu;
pub mod output;
pub mod raster;
pub mod rayfile;
pub mod raygen;
pub mod secondary;
pub mod shade;
pub mod stats;
pub mod view;
pub mod whitted;

pub use stats::{FramePhase, RenderStats};
pub use view::View;
