//! The irregular grid's traversal on the GPU (paper §5; `traverse.wgsl`), the twin of
//! `accel/src/grid/traverse.rs`: one thread per ray runs the CPU's `trace_ray` step for step
//! (same slab entry, same voxel lookups, same watertight tests, same exits), so hits and
//! per-ray counts are the CPU's bit for bit. Per trace call: upload the rays, one launch,
//! read back the records and the per-ray counts (summed on the host in u64, so no count can
//! wrap). The device-resident frame's calls (`trace_device_part`) keep rays and records on
//! the device and read back only the counts' sums per chunk of rays (low and high words).

use super::GpuGrid;
use crate::kernels::params::GridTraceParams;
use crate::kernels::{launch, DevSize, Exec, Threads};
use crate::rays::{records_to_hits, upload_segments, DeviceRays};
use trace::{Hit, RayBatch, TraceMode, TraceStats};

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
        let part = rays.slice(lo..lo + out.len());
        trace_part(grid, &part, mode, out, stats);
    }
}

/// The traversal of `n` rays (origin | t_min, direction | t_max) into hit records and
/// per-ray (steps, tests) counts, both left on the device; `count`: only the first
/// `count.n` of the `n` (a size on the device: an indirect launch).
fn records(
    grid: &GpuGrid,
    ex: &mut Exec,
    org: &wgpu::Buffer,
    dir: &wgpu::Buffer,
    n: u64,
    mode: TraceMode,
    count: Option<&DevSize>,
) -> (wgpu::Buffer, wgpu::Buffer) {
    let g = &grid.gpu;
    let rec = g.storage("grid records", n * 16);
    let cnt = g.storage("grid counts", n * 8);
    ex.phase(trace::TRAVERSAL);
    let p = GridTraceParams {
        rays: n as u32,
        any_hit: (mode == TraceMode::Any) as u32,
        shift: grid.shift,
        dims: grid.dims,
        top_dims: grid.top_dims,
    };
    let l = launch::GridTrace {
        gr_const: &grid.consts,
        gr_map: &grid.map,
        gr_cell: &grid.cells,
        gr_ref: &grid.refs,
        gr_tris: &grid.tris,
        gr_org: org,
        gr_dir: dir,
        gr_rec: &rec,
        gr_cnt: &cnt,
    };
    ex.run_on(l, p, Threads::of(count, n), 256);
    (rec, cnt)
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
    let (rec, cnt) = records(grid, &mut ex, &org, &dir, n as u64, mode, None);
    ex.phase(crate::stats::READ_BACK);
    records_to_hits(&ex.read(&rec, n), hits);
    let counts: Vec<[u32; 2]> = ex.read(&cnt, n);
    ex.report(stats, &grid.times);
    let (steps, tests) = counts
        .iter()
        .fold((0u64, 0u64), |(s, t), c| (s + c[0] as u64, t + c[1] as u64));
    stats.ray_tri_tests += tests;
    stats.hits += hits.iter().filter(|h| h.is_hit()).count() as u64;
    stats.count(accel::grid::TRAVERSAL_STEPS, steps);
}

/// [`crate::GpuEngine::trace_device`]: rays already on the device (at most `max_rays`);
/// the records stay there, and the hits, steps and tests come back as per-chunk sums.
pub(crate) fn trace_device_part(
    grid: &GpuGrid,
    dr: &DeviceRays,
    mode: TraceMode,
    stats: &mut TraceStats,
) -> wgpu::Buffer {
    trace_device_sized(grid, dr, None, mode, stats)
}

/// [`crate::GpuEngine::trace_device_counted`]: the first `count` rays of `dr` (a size on
/// the device), launched indirectly.
pub(crate) fn trace_device_counted(
    grid: &GpuGrid,
    dr: &DeviceRays,
    count: &DevSize,
    mode: TraceMode,
    stats: &mut TraceStats,
) -> wgpu::Buffer {
    trace_device_sized(grid, dr, Some(count), mode, stats)
}

fn trace_device_sized(
    grid: &GpuGrid,
    dr: &DeviceRays,
    count: Option<&DevSize>,
    mode: TraceMode,
    stats: &mut TraceStats,
) -> wgpu::Buffer {
    let mut ex = Exec::new(&grid.gpu, &grid.kernels);
    let (rec, cnt) = records(grid, &mut ex, &dr.org, &dr.dir, dr.len, mode, count);
    // The totals stay on the device until the frame's end (`GpuEngine::settle`).
    let sums = crate::frame::totals_on_device(&mut ex, &rec, Some(&cnt), dr.len, count);
    grid.pending.lock().unwrap().extend(sums);
    ex.report(stats, &grid.times);
    rec
}

/// [`crate::GpuEngine::settle`]: the pending totals' words into `stats`.
pub(crate) fn settle(words: &[u32], stats: &mut TraceStats) {
    let t = crate::frame::sum_totals(words);
    stats.ray_tri_tests += t.tests;
    stats.hits += t.hits;
    stats.count(accel::grid::TRAVERSAL_STEPS, t.steps);
}
