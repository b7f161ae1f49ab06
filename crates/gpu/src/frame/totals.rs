//! What a device-resident frame reads back of its traces, and tracing rays that are on the
//! device: per-chunk totals of hit records and per-ray counters ([`totals_on_device`],
//! summed on the host in u64 by [`sum_totals`]), the counter blocks engines leave on the device until one read-back
//! ([`settle`]), and [`trace_device`], a batch traced in the engine's parts. The twin of
//! the sums `trace::TraceStats` keeps on the CPU (`frame.wgsl`'s `fr_totals`).

use crate::kernels::params::TotalsParams;
use crate::kernels::{launch, DevSize, Exec, Threads};
use crate::rays::DeviceRays;
use crate::GpuEngine;
use trace::{TraceMode, TraceStats};

/// Rays per chunk of [`totals_on_device`] (`fr_totals` in `frame.wgsl`).
pub(crate) const TOTALS_CHUNK: u64 = 1024;

/// A trace's totals as [`sum_totals`] adds them up.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Totals {
    pub hits: u64,
    pub steps: u64,
    pub tests: u64,
}

/// Hits among the `n` records `rec`, and with per-ray (steps, tests) counters `cnt` their
/// sums, as per-chunk sums (64-bit, as two words) left on the device: (buffer, words), none
/// for no rays (read back with the frame's image and added by [`sum_totals`]);
/// `count`: of the first `count.n` of the `n` records only (a size on the device; the
/// chunks past it sum to zero).
pub(crate) fn totals_on_device(
    ex: &mut Exec,
    rec: &wgpu::Buffer,
    cnt: Option<&wgpu::Buffer>,
    n: u64,
    count: Option<&DevSize>,
) -> Option<(wgpu::Buffer, u64)> {
    if n == 0 {
        return None;
    }
    let chunks = n.div_ceil(TOTALS_CHUNK);
    let out = ex.g.storage("trace totals", chunks * 20);
    let dummy;
    let cb = match cnt {
        Some(c) => c,
        None => {
            dummy = ex.g.storage("no counters", 8);
            &dummy
        }
    };
    let l = launch::FrTotals {
        rec,
        out_u: &out,
        cnt: cb,
    };
    let p = TotalsParams {
        rays: n as u32,
        counters: cnt.is_some() as u32,
    };
    let threads = match count {
        Some(c) => {
            // A thread per chunk of the bound: the chunks past the count write nothing,
            // and stay zero.
            ex.clear(&out);
            Threads::Patched {
                first: c,
                threads: chunks,
            }
        }
        None => Threads::Host(chunks),
    };
    ex.run_on(l, p, threads, 256);
    Some((out, chunks * 5))
}

/// The sum of per-chunk totals (5 words each: hits, steps low/high, tests low/high), of one
/// trace or of several laid end to end.
pub(crate) fn sum_totals(words: &[u32]) -> Totals {
    let w = |lo: u32, hi: u32| lo as u64 | (hi as u64) << 32;
    words
        .chunks_exact(5)
        .fold(Totals::default(), |t, c| Totals {
            hits: t.hits + c[0] as u64,
            steps: t.steps + w(c[1], c[2]),
            tests: t.tests + w(c[3], c[4]),
        })
}

/// The counts `engine`'s traces on the device left there ([`GpuEngine::take_pending`]) read
/// back, in one read-back, into `stats`: for a caller of [`trace_device`] outside a frame
/// (a frame reads them with its image).
pub fn settle(engine: &dyn GpuEngine, stats: &mut TraceStats) {
    let pending = engine.take_pending();
    let words: u64 = pending.iter().map(|p| p.1).sum();
    if words == 0 {
        return;
    }
    let g = engine.gpu();
    let mut ex = Exec::new(g, engine.kernels());
    let all = g.storage("pending counters", words * 4);
    copy_pending(&mut ex, &pending, &all, 0);
    let raw: Vec<u32> = ex.read(&all, words as usize);
    engine.settle(&raw, stats);
}

/// The pending counter blocks laid end to end into `all` from byte `at`.
pub(crate) fn copy_pending(
    ex: &mut Exec,
    pending: &[(wgpu::Buffer, u64)],
    all: &wgpu::Buffer,
    at: u64,
) {
    let mut at = at;
    for (b, w) in pending {
        ex.copy_at(b, 0, all, at, w * 4);
        at += w * 4;
    }
}

/// Trace rays `rays` on the device with `engine`, in parts of at most its
/// [`GpuEngine::max_rays`] (each part's rays copied out on the device, its records copied
/// back), counting into `stats` as [`trace::Tracer::trace`] does, less the counts the engine
/// keeps on the device until [`settle`] (or the frame's image) reads them; the records
/// (triangle, t, u, v bits) stay on the device.
pub fn trace_device(
    engine: &dyn GpuEngine,
    rays: &DeviceRays,
    mode: TraceMode,
    stats: &mut TraceStats,
) -> wgpu::Buffer {
    let g = engine.gpu();
    let n = rays.len;
    stats.rays += n;
    let max = engine.max_rays().max(1) as u64;
    if n <= max {
        return engine.trace_device_part(rays, mode, stats);
    }
    let rec = g.storage("records", n * 16);
    let mut lo = 0;
    while lo < n {
        let m = max.min(n - lo);
        let part = {
            let mut ex = Exec::new(g, engine.kernels());
            let cut = |ex: &mut Exec, b: &wgpu::Buffer, size: u64, label| {
                let p = g.storage(label, m * size);
                ex.copy(b, lo * size, &p, m * size);
                p
            };
            let p = DeviceRays {
                org: cut(&mut ex, &rays.org, 16, "part org"),
                dir: cut(&mut ex, &rays.dir, 16, "part dir"),
                kl: cut(&mut ex, &rays.kl, 4, "part kind"),
                pix: cut(&mut ex, &rays.pix, 4, "part pixel"),
                pre: g.storage("part ray constants", m * 16),
                len: m,
                width: rays.width,
            };
            ex.finish();
            p
        };
        let r = engine.trace_device_part(&part, mode, stats);
        let mut ex = Exec::new(g, engine.kernels());
        ex.copy_at(&r, 0, &rec, lo * 16, m * 16);
        ex.finish();
        lo += m;
    }
    rec
}
