//! The leaf order on the GPU, the twin of `crates/rsh/src/order.rs`: CRSH's hash → trim →
//! compress → sort → decompress (thesis §3.2.3–3.2.6), or RAH's screen order, each step a
//! kernel or a primitive of [`crate::prims`] and one timed phase, as on the CPU.

use super::device_scene::DeviceScene;
use super::hash::hash_keys;
use crate::kernels::params::{
    CompactParams, RunsBelowParams, RunsParams, TrimKindsParams, TrimPadParams,
};
use crate::kernels::{launch, DevLen, DevSize, Exec, Threads};
use crate::prims::Runs;
use crate::rays::DeviceRays;
use ::rsh::Method;
use trace::TraceStats;

/// The sorted leaves (ray indices of the rays that can hit anything), their count and
/// their count per ray kind (the hierarchy's layout: [`super::build::build`]), the counts
/// in one read-back. `count`: of the first `count.n` rays only (a size on the device): the
/// trim's read-back is the first the host learns of it.
pub fn leaf_order(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    stats: &mut TraceStats,
    count: Option<&DevSize>,
) -> (wgpu::Buffer, u64, [u32; 4]) {
    let crsh = eng.cfg.method == Method::Crsh;
    // The trimmed rays per kind, read with their count.
    let (keys, valid, kinds) = hashed_kinds(eng, ex, rays, count);
    let (tk, tv, m, per_kind) =
        ex.compact_reading(&valid, &keys, None, rays.len, Some((&kinds, 4)));
    drop((keys, valid));
    let leaves = if crsh {
        chunked_order(eng, ex, &tk, &tv, m, stats)
    } else {
        ex.phase(::rsh::stats::SCREEN_ORDER);
        // Every digit sorted (an equal digit's pass is the identity): no read-back of which
        // digits vary.
        ex.sort_pairs_all(&tk, &tv, m, 32);
        tv
    };
    (
        leaves,
        m,
        [per_kind[0], per_kind[1], per_kind[2], per_kind[3]],
    )
}

/// [`leaf_order`] with nothing read back (`count`: of the first `count.n` rays only): the
/// trimmed rays compacted into buffers of the batch's `n` slots, the slots past their
/// count padded with the largest key (`kinds.wgsl`'s `trim_pad`); RAH sorts every slot,
/// stably, so the first `m` are [`leaf_order`]'s leaves; CRSH compresses every slot into
/// runs, pads the runs' slots past their count the same way, sorts and expands them: the
/// padding's own run (or the last real run, which it joins) sorts last, so again the first
/// `m` leaves are [`leaf_order`]'s. Returns the leaves and the trimmed rays' count per kind,
/// both on the device (their sum is `m`), and for CRSH a word there holding its chunks
/// (the runs before the padding: `::rsh::stats::CHUNKS`).
pub fn leaf_order_laid(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    count: Option<&DevSize>,
) -> (wgpu::Buffer, wgpu::Buffer, Option<wgpu::Buffer>) {
    let crsh = eng.cfg.method == Method::Crsh;
    let n = rays.len;
    let (keys, valid, kinds) = hashed_kinds(eng, ex, rays, count);
    let offs = eng.gpu.storage("compact offsets", (n + 1) * 4);
    ex.scan(&valid, &offs, n);
    let (tk, tv) = (
        eng.gpu.storage("trimmed keys", n * 4),
        eng.gpu.storage("trimmed rays", n * 4),
    );
    ex.run(
        launch::Compact {
            x_flag: &valid,
            x_off: &offs,
            x_a: &keys,
            x_b: &keys,
            y_a: &tk,
            y_b: &tv,
        },
        CompactParams {
            n: n as u32,
            index_as_b: 1,
        },
        n,
        256,
    );
    pad_past(ex, &offs, (&tk, &tv), n, u32::MAX);
    if !crsh {
        ex.phase(::rsh::stats::SCREEN_ORDER);
        ex.sort_pairs_all(&tk, &tv, n, 32);
        return (tv, kinds, None);
    }
    // Compress every slot (thesis §3.2.4): the runs' count stays on the device.
    ex.phase(::rsh::stats::COMPRESS);
    let g = &eng.gpu;
    let heads = g.storage("heads", n * 4);
    ex.run(
        launch::RunHeads {
            x_a: &tk,
            y_a: &heads,
        },
        RunsParams {
            n: n as u32,
            total: 0,
        },
        n,
        256,
    );
    let hoffs = g.storage("head offsets", (n + 1) * 4);
    ex.scan(&heads, &hoffs, n);
    // Sizes past the runs' count stay zero (a fresh buffer), so they expand to nothing.
    let runs = Runs {
        keys: g.storage("chunk keys", n * 4),
        bases: g.storage("chunk bases", n * 4),
        sizes: g.storage("chunk sizes", n * 4),
        len: n,
    };
    ex.run(
        launch::RunChunks {
            x_flag: &heads,
            x_off: &hoffs,
            x_a: &tk,
            y_a: &runs.keys,
            y_b: &runs.bases,
        },
        RunsParams {
            n: n as u32,
            total: 0,
        },
        n,
        256,
    );
    let nruns = DevLen {
        buf: hoffs.clone(),
        at: n,
        cap: n,
    };
    let size = ex.size(&nruns, 1, 256);
    ex.run_on(
        launch::RunSizes {
            x_b: &runs.bases,
            y_c: &runs.sizes,
        },
        RunsParams {
            n: 0,
            total: n as u32,
        },
        Threads::Patched {
            first: &size,
            threads: n,
        },
        256,
    );
    let spare = g.storage("padding", n * 4);
    pad_past(ex, &hoffs, (&runs.keys, &spare), n, u32::MAX);
    let chunks = g.storage("chunks", 4);
    ex.run(
        launch::RunsBelow {
            x_off: &hoffs,
            x_a: &offs,
            y_a: &chunks,
        },
        RunsBelowParams { n: n as u32 },
        1,
        1,
    );
    ex.phase(::rsh::stats::SORT);
    let order = ex.iota(n);
    ex.sort_pairs_all(&runs.keys, &order, n, 32);
    ex.phase(::rsh::stats::DECOMPRESS);
    (ex.expand_runs(&runs, &order, &tv, n), kinds, Some(chunks))
}

/// The hash (CRSH's key, or RAH's screen key) of rays `rays` (of the first `count.n` only,
/// where given), their trim flags, and the trimmed rays per kind counted on the device
/// (`kinds.wgsl`'s `trim_kinds`, 4 words).
fn hashed_kinds(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    count: Option<&DevSize>,
) -> (wgpu::Buffer, wgpu::Buffer, wgpu::Buffer) {
    let crsh = eng.cfg.method == Method::Crsh;
    ex.phase(if crsh {
        ::rsh::stats::HASH
    } else {
        ::rsh::stats::SCREEN_ORDER
    });
    let (keys, valid) = hash_keys(eng, ex, rays, !crsh, count);
    ex.phase(::rsh::stats::TRIM);
    let kinds = eng.gpu.upload("kind counts", &[0u32; 4]);
    ex.run(
        launch::TrimKinds {
            x_flag: &valid,
            x_a: &rays.kl,
            y_kinds: &kinds,
        },
        TrimKindsParams {
            rays: rays.len as u32,
        },
        rays.len,
        256,
    );
    (keys, valid, kinds)
}

/// Slots `i ≥ offs[n]` (a scan's total) of both buffers of `ab` set to `value`.
fn pad_past(
    ex: &mut Exec,
    offs: &wgpu::Buffer,
    ab: (&wgpu::Buffer, &wgpu::Buffer),
    n: u64,
    value: u32,
) {
    ex.run(
        launch::TrimPad {
            x_off: offs,
            y_a: ab.0,
            y_b: ab.1,
        },
        TrimPadParams { n: n as u32, value },
        n,
        256,
    );
}

/// Trim is done; compress → sort → decompress (thesis §3.2.4–3.2.6).
fn chunked_order(
    eng: &DeviceScene,
    ex: &mut Exec,
    keys: &wgpu::Buffer,
    rays: &wgpu::Buffer,
    m: u64,
    stats: &mut TraceStats,
) -> wgpu::Buffer {
    ex.phase(::rsh::stats::COMPRESS);
    if m == 0 {
        stats.count(::rsh::stats::CHUNKS, 0);
        return eng.gpu.storage("leaves", 4);
    }
    let runs = ex.compress_runs(keys, m);
    stats.count(::rsh::stats::CHUNKS, runs.len);
    ex.phase(::rsh::stats::SORT);
    let order = ex.iota(runs.len);
    // Every digit (no read-back of which vary; an equal digit's pass is the identity).
    ex.sort_pairs_all(&runs.keys, &order, runs.len, 32);
    ex.phase(::rsh::stats::DECOMPRESS);
    ex.expand_runs(&runs, &order, rays, m)
}
