//! A frame's record (`--frame-csv`: update, build and render times, the render's counts and
//! the engine's phases) and the buffers a sequence of frames keeps. Frames themselves are
//! made by the runner ([`crate::runner::Runner`]), the one place every front end makes them.

use crate::engines;
use render::whitted::Rendered;
use scene::Geometry;
use serde::Serialize;
use trace::Phase;

/// One frame's record for `--frame-csv`.
#[derive(Clone, Debug, Serialize)]
pub struct FrameRow {
    pub frame: u32,
    pub time: f32,
    pub triangles: usize,
    pub update_ms: f64,
    pub build_ms: f64,
    /// The whole render (the CSV's `render_ms`): rasterization, ray creation, the engine's
    /// trace calls and shading, the four phase columns below.
    pub render_ms: f64,
    pub rays: u64,
    pub total_tests: u64,
    /// Engine phases inside the render (ms): for CRSH/RAH the per-frame ray-hierarchy build
    /// (hash … hierarchy creation) and its traversal, in [`engine_phases`] order.
    pub phases_ms: Vec<(Phase, f64)>,
    /// The render's phases (ms): primary visibility into the G-buffer, ray creation, the
    /// engine's trace calls, shading (the CSV's last four columns).
    pub raster_ms: f64,
    pub ray_creation_ms: f64,
    pub trace_ms: f64,
    pub shading_ms: f64,
}

/// The engine phases `--frame-csv` reports (the CPU's: no transfers; absent phases are 0).
pub fn engine_phases() -> impl Iterator<Item = Phase> {
    engines::phases().into_iter().filter(|p| !p.is_transfer())
}

impl FrameRow {
    /// The CSV header line (without the line end).
    pub fn csv_header() -> String {
        let mut h =
            String::from("frame,time,triangles,update_ms,build_ms,render_ms,rays,total_tests");
        for p in engine_phases() {
            h += &format!(",{}_ms", p.as_str().replace(' ', "_"));
        }
        h + ",raster_ms,ray_creation_ms,trace_ms,shading_ms"
    }

    /// The record as a CSV line (without the line end).
    pub fn csv_line(&self) -> String {
        let mut l = format!(
            "{},{},{},{:.3},{:.3},{:.3},{},{}",
            self.frame,
            self.time,
            self.triangles,
            self.update_ms,
            self.build_ms,
            self.render_ms,
            self.rays,
            self.total_tests
        );
        for (_, p) in &self.phases_ms {
            l += &format!(",{p:.3}");
        }
        l + &format!(
            ",{:.3},{:.3},{:.3},{:.3}",
            self.raster_ms, self.ray_creation_ms, self.trace_ms, self.shading_ms
        )
    }
}

/// What a sequence of frames keeps from one frame to the next: the geometry's buffers
/// and the renderer's ([`render::cpu::FrameArena`]), refilled in place each frame.
#[derive(Default)]
pub struct FrameBuffers {
    pub(crate) geo: Geometry,
    pub(crate) arena: render::cpu::FrameArena,
}

impl FrameRow {
    /// The record of frame `index` at time `t`: seconds of update, build and render, and the
    /// render's counts and engine phases.
    pub(crate) fn of(
        index: u32,
        t: f32,
        geo: &Geometry,
        secs: [f64; 3],
        out: &Rendered,
    ) -> FrameRow {
        FrameRow {
            frame: index,
            time: t,
            triangles: geo.len(),
            update_ms: secs[0] * 1e3,
            build_ms: secs[1] * 1e3,
            render_ms: secs[2] * 1e3,
            rays: out.stats.rays_traced(),
            total_tests: out.stats.trace.total_tests(),
            phases_ms: engine_phases()
                .map(|p| (p, out.stats.trace.seconds(p) * 1e3))
                .collect(),
            raster_ms: out.stats.raster_ms,
            ray_creation_ms: out.stats.ray_creation_ms,
            trace_ms: out.stats.trace_ms,
            shading_ms: out.stats.shading_ms,
        }
    }
}
