//! The irregular grid's traversal on the GPU (paper §5; `traverse.wgsl`), the twin of
//! `accel/src/grid/traverse.rs`: one thread per ray runs the CPU's `trace_ray` step for step
//! (same slab entry, same voxel lookups, same watertight tests, same exits), so hits and
//! per-ray counts are the CPU's bit for bit. Per trace call: upload the rays, one launch,
//! read back the records and the per-ray counts (summed on the host in u64, so no count can
//! wrap).

use super::GpuGrid;
use crate::kernels::{Exec, Kernel, Params};
use crate::rsh::engine::{records_to_hits, sub_batch, upload_segments};
use render::stats::counter;
use render::{Hit, Phase, RayBatch, TraceMode, TraceStats};

/// Trace `rays` (in parts of at most as many rays as one binding holds) into `hits`,
/// counting into `stats` as `accel::GridEngine` does.
pub fn trace(
    grid: &GpuGrid,
    rays: &RayBatch,
    mode: TraceMode,
    hits: &mut [Hit],
    stats: &mut TraceStats,
) {
    assert_eq!(hits.len(), rays.len(), "one hit record per ray");
    stats.rays += rays.len() as u64;
    if rays.is_empty() {
        return;
    }
    if rays.len() <= grid.max_rays {
        trace_part(grid, rays, mode, hits, stats);
        return;
    }
    for (p, out) in hits.chunks_mut(grid.max_rays).enumerate() {
        let lo = p * grid.max_rays;
        let part = sub_batch(rays, lo..lo + out.len());
        trace_part(grid, &part, mode, out, stats);
    }
}

fn trace_part(
    grid: &GpuGrid,
    rays: &RayBatch,
    mode: TraceMode,
    hits: &mut [Hit],
    stats: &mut TraceStats,
) {
    let g = &grid.gpu;
    let n = rays.len();
    let mut ex = Exec::new(g, &grid.kernels);
    let (org, dir) = upload_segments(g, rays);
    let rec = g.storage("grid records", n as u64 * 16);
    let cnt = g.storage("grid counts", n as u64 * 8);
    ex.phase(Phase::Traversal);
    let mut p = Params::n(n as u32, (mode == TraceMode::Any) as u32, grid.shift, 0);
    p.u[1] = [grid.dims[0], grid.dims[1], grid.dims[2], 0];
    p.u[2] = [grid.top_dims[0], grid.top_dims[1], grid.top_dims[2], 0];
    ex.run(
        Kernel::GridTrace,
        p,
        &[
            (1, &grid.consts),
            (2, &grid.map),
            (3, &grid.cells),
            (4, &grid.refs),
            (5, &grid.tris),
            (6, &org),
            (7, &dir),
            (8, &rec),
            (9, &cnt),
        ],
        n as u64,
        256,
    );
    ex.phase(Phase::ReadBack);
    records_to_hits(&ex.read(&rec, n), hits);
    let counts: Vec<[u32; 2]> = ex.read(&cnt, n);
    ex.report(stats, &grid.times);
    let (steps, tests) = counts
        .iter()
        .fold((0u64, 0u64), |(s, t), c| (s + c[0] as u64, t + c[1] as u64));
    stats.ray_tri_tests += tests;
    stats.hits += hits.iter().filter(|h| h.is_hit()).count() as u64;
    stats.count(counter::TRAVERSAL_STEPS, steps);
}
