//! The GPU backend of rayspace, on wgpu (Vulkan, Metal, DX12; Mesa's lavapipe on machines
//! without a GPU).
//!
//! - [`device`]: adapter and device set-up, buffers, read-back.
//! - [`kernels`]: the WGSL kernels, named by the typed key [`kernels::Kernel`], and the
//!   launch recorder with per-phase timestamp queries.
//! - [`prims`]: the GPU's `par` — reduce-then-scan, compaction, runs, stable radix sort
//!   (`src/prims/*.wgsl`).
//! - [`bvh`]: the object tree built on the device (LBVH) and the `bvh` engine's single-ray
//!   walk as a [`trace::Tracer`] (`src/bvh/*` beside `accel/src/bvh/*`).
//! - [`rsh`]: CRSH and RAH as a [`trace::Tracer`], file for file the `rsh` crate's pipeline
//!   (`hash → order → build → traverse`, `src/rsh/*.rs` beside `src/rsh/*.wgsl`), with the
//!   same counters; their dual traversal descends [`bvh`]'s tree.
//! - [`grid`]: the irregular grid's traversal as a [`trace::Tracer`] (`src/grid/*`
//!   beside `accel/src/grid/*`): every build pass and the traversal as kernels.
//! - [`raster`]: primary visibility by real rasterization (render pipeline, depth test) into
//!   the G-buffer's render targets.
//! - [`stages`]: the Whitted loop's shadow-ray generation, reflection/refraction-ray
//!   generation and shading as kernels.
//! - [`frame`]: the GPU backend of `render`'s one Whitted loop ([`frame::GpuBackend`]): a
//!   whole frame resident on the device (G-buffer, surfaces, rays, traces, shading and the
//!   image all stay there; the host reads back the sRGB image and a few totals), built from
//!   the kernels above.
//!
//! Every kernel mirrors a CPU pass over flat structure-of-arrays buffers of the same layout;
//! the CPU engines are this backend's oracle (see `tests/`).

#![warn(missing_docs)]

pub mod bvh;
pub mod device;
pub mod frame;
pub mod grid;
pub mod kernels;
pub mod prims;
pub mod raster;
pub mod rays;
pub mod rsh;
pub mod stages;
pub mod stats;

pub use crate::bvh::GpuBvh;
pub use crate::rsh::GpuRsh;
pub use device::{Gpu, GpuError};
pub use grid::GpuGrid;
pub use raster::GpuRaster;
/// The wgpu this backend is built with (the viewer's window shares it).
pub use wgpu;

/// A tracing engine on the GPU: a [`trace::Tracer`] whose device and compiled kernels the
/// Whitted stages share ([`GpuStages`]), and whose GPU time per phase can be drained.
pub trait GpuEngine: trace::Tracer {
    /// The device.
    fn gpu(&self) -> &Gpu;
    /// The compiled kernels.
    fn kernels(&self) -> &kernels::Kernels;
    /// GPU seconds per phase since the last call (empty without timestamp queries).
    fn take_times(&self) -> Vec<(trace::Phase, f64)>;
    /// Take a dynamic scene's next frame: rebuild over `geo` on the same device, with the
    /// same kernels and configuration (what the CPU engine rebuilds per frame).
    fn rebuild(&mut self, geo: &scene::Geometry) -> Result<(), GpuError>;
    /// Most rays one [`GpuEngine::trace_device_part`] takes (one binding's worth).
    fn max_rays(&self) -> usize;
    /// The scene's triangles on the device, 3 × vec4 (xyz, 0) per triangle (the rasterizer
    /// draws from them: [`GpuRaster::with_triangles`]).
    fn triangles(&self) -> &wgpu::Buffer;
    /// Trace rays already on the device (at most [`GpuEngine::max_rays`]) and leave their
    /// hit records there (triangle, t, u, v bits per ray; triangle `NO_HIT`: a miss), with
    /// the counters of [`trace::Tracer::trace`] in `stats` (less `stats.rays`, which
    /// [`frame::trace_device`] counts). Only totals are read back.
    fn trace_device_part(
        &self,
        rays: &rays::DeviceRays,
        mode: trace::TraceMode,
        stats: &mut trace::TraceStats,
    ) -> wgpu::Buffer;
    /// Whether [`GpuEngine::trace_device_counted`] traces batches whose size only the device
    /// knows (else the frame reads each batch's size back first).
    fn counts_on_device(&self) -> bool {
        false
    }
    /// [`GpuEngine::trace_device_part`] of the first `count.n` rays of `rays` (`rays.len`,
    /// at most [`GpuEngine::max_rays`], bounds it), a size on the device made ready for
    /// launches of 256 threads: the engine's launches read it there (indirect dispatches),
    /// so nothing is read back; records past it are left unwritten. `None` when the engine cannot ([`GpuEngine::counts_on_device`]).
    fn trace_device_counted(
        &self,
        _rays: &rays::DeviceRays,
        _count: &kernels::DevSize,
        _mode: trace::TraceMode,
        _stats: &mut trace::TraceStats,
    ) -> Option<wgpu::Buffer> {
        None
    }
    /// The counter blocks (buffer, words) that [`GpuEngine::trace_device_part`] left on the
    /// device instead of reading them back, drained: the frame reads them with its image, in
    /// one read-back, and hands their words to [`GpuEngine::settle`].
    fn take_pending(&self) -> Vec<(wgpu::Buffer, u64)> {
        Vec::new()
    }
    /// The words of [`GpuEngine::take_pending`]'s blocks (in its order, concatenated) into
    /// `stats`: the counts those traces did not report.
    fn settle(&self, _words: &[u32], _stats: &mut trace::TraceStats) {}
    /// Whether a trace whose counts [`GpuEngine::settle`] read since the last call did not
    /// finish on the device (a traversal the device paced alone ran out of rounds or of
    /// room): its records are not the CPU's, so the frame must be traced again with the
    /// host pacing ([`GpuEngine::pace`]; [`frame::render_frame`] does). Cleared.
    fn take_incomplete(&self) -> bool {
        false
    }
    /// With `on`, every trace is paced by the host (reading back the sizes its steps need)
    /// until called with `false`.
    fn pace(&self, _on: bool) {}
}

impl GpuEngine for GpuRsh {
    fn gpu(&self) -> &Gpu {
        GpuRsh::gpu(self)
    }
    fn kernels(&self) -> &kernels::Kernels {
        GpuRsh::kernels(self)
    }
    fn take_times(&self) -> Vec<(trace::Phase, f64)> {
        GpuRsh::take_times(self)
    }
    fn rebuild(&mut self, geo: &scene::Geometry) -> Result<(), GpuError> {
        GpuRsh::rebuild(self, geo)
    }
    fn max_rays(&self) -> usize {
        GpuRsh::max_rays(self)
    }
    fn triangles(&self) -> &wgpu::Buffer {
        GpuRsh::triangles(self)
    }
    fn trace_device_part(
        &self,
        rays: &rays::DeviceRays,
        mode: trace::TraceMode,
        stats: &mut trace::TraceStats,
    ) -> wgpu::Buffer {
        // The bundles find the closest hit of every ray in either mode, as trace does.
        GpuRsh::trace_device_part(self, rays, mode, stats)
    }
    fn counts_on_device(&self) -> bool {
        // A batch whose size the device holds (the bundles' first read-back is then their
        // trim's count, or none where the device lays the hierarchy out).
        true
    }
    fn trace_device_counted(
        &self,
        rays: &rays::DeviceRays,
        count: &kernels::DevSize,
        mode: trace::TraceMode,
        stats: &mut trace::TraceStats,
    ) -> Option<wgpu::Buffer> {
        GpuRsh::trace_device_counted(self, rays, count, mode, stats)
    }
    fn take_pending(&self) -> Vec<(wgpu::Buffer, u64)> {
        GpuRsh::take_pending(self)
    }
    fn settle(&self, words: &[u32], stats: &mut trace::TraceStats) {
        GpuRsh::settle(self, words, stats)
    }
    fn take_incomplete(&self) -> bool {
        GpuRsh::take_incomplete(self)
    }
    fn pace(&self, on: bool) {
        GpuRsh::pace(self, on)
    }
}

impl GpuEngine for GpuGrid {
    fn gpu(&self) -> &Gpu {
        &self.gpu
    }
    fn kernels(&self) -> &kernels::Kernels {
        &self.kernels
    }
    fn take_times(&self) -> Vec<(trace::Phase, f64)> {
        std::mem::take(&mut *self.times.lock().unwrap())
    }
    fn rebuild(&mut self, geo: &scene::Geometry) -> Result<(), GpuError> {
        GpuGrid::rebuild(self, geo)
    }
    fn max_rays(&self) -> usize {
        self.max_rays
    }
    fn triangles(&self) -> &wgpu::Buffer {
        &self.tris
    }
    fn trace_device_part(
        &self,
        rays: &rays::DeviceRays,
        mode: trace::TraceMode,
        stats: &mut trace::TraceStats,
    ) -> wgpu::Buffer {
        grid::traverse::trace_device_part(self, rays, mode, stats)
    }
    fn counts_on_device(&self) -> bool {
        true
    }
    fn trace_device_counted(
        &self,
        rays: &rays::DeviceRays,
        count: &kernels::DevSize,
        mode: trace::TraceMode,
        stats: &mut trace::TraceStats,
    ) -> Option<wgpu::Buffer> {
        Some(grid::traverse::trace_device_counted(
            self, rays, count, mode, stats,
        ))
    }
    fn take_pending(&self) -> Vec<(wgpu::Buffer, u64)> {
        std::mem::take(&mut *self.pending.lock().unwrap())
    }
    fn settle(&self, words: &[u32], stats: &mut trace::TraceStats) {
        grid::traverse::settle(words, stats)
    }
}
pub use stages::GpuStages;
