//! The leaf order on the GPU, the twin of `crates/rsh/src/order.rs`: CRSH's hash → trim →
//! compress → sort → decompress (thesis §3.2.3–3.2.6), or RAH's screen order, each step a
//! kernel or a primitive of [`crate::prims`] and one timed phase, as on the CPU.

use super::device_scene::DeviceScene;
use super::hash::hash_keys;
use crate::kernels::params::{CompactParams, TrimKindsParams, TrimPadParams};
use crate::kernels::{launch, DevSize, Exec};
use crate::rays::DeviceRays;
use ::rsh::Method;
use trace::Counter;
use trace::{Phase, TraceStats};

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
    ex.phase(if crsh {
        Phase::Hash
    } else {
        Phase::ScreenOrder
    });
    let (keys, valid) = hash_keys(eng, ex, rays, !crsh, count);
    ex.phase(Phase::Trim);
    // The trimmed rays per kind, read with their count.
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
    let (tk, tv, m, per_kind) =
        ex.compact_reading(&valid, &keys, None, rays.len, Some((&kinds, 4)));
    drop((keys, valid));
    let leaves = if crsh {
        chunked_order(eng, ex, &tk, &tv, m, stats)
    } else {
        ex.phase(Phase::ScreenOrder);
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

/// RAH's leaf order with nothing read back (`count`: of the first `count.n` rays only, as
/// in [`leaf_order`]): the trimmed rays compacted into buffers of the batch's `n` slots, the
/// slots past their count padded with the largest key (`kinds.wgsl`'s `trim_pad`), and every
/// slot sorted, stably, so the first `m` are [`leaf_order`]'s leaves. Returns the leaves and
/// the trimmed rays' count per kind, both on the device (their sum is `m`).
pub fn leaf_order_laid(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    count: Option<&DevSize>,
) -> (wgpu::Buffer, wgpu::Buffer) {
    assert_eq!(
        eng.cfg.method,
        Method::Rah,
        "CRSH's order reads its runs' count"
    );
    let n = rays.len;
    ex.phase(Phase::ScreenOrder);
    let (keys, valid) = hash_keys(eng, ex, rays, true, count);
    ex.phase(Phase::Trim);
    let kinds = eng.gpu.upload("kind counts", &[0u32; 4]);
    ex.run(
        launch::TrimKinds {
            x_flag: &valid,
            x_a: &rays.kl,
            y_kinds: &kinds,
        },
        TrimKindsParams { rays: n as u32 },
        n,
        256,
    );
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
    ex.run(
        launch::TrimPad {
            x_off: &offs,
            y_a: &tk,
            y_b: &tv,
        },
        TrimPadParams {
            n: n as u32,
            value: u32::MAX,
        },
        n,
        256,
    );
    ex.phase(Phase::ScreenOrder);
    ex.sort_pairs_all(&tk, &tv, n, 32);
    (tv, kinds)
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
    ex.phase(Phase::Compress);
    if m == 0 {
        stats.count(Counter::Chunks, 0);
        return eng.gpu.storage("leaves", 4);
    }
    let runs = ex.compress_runs(keys, m);
    stats.count(Counter::Chunks, runs.len);
    ex.phase(Phase::Sort);
    let order = ex.iota(runs.len);
    // Every digit (no read-back of which vary; an equal digit's pass is the identity).
    ex.sort_pairs_all(&runs.keys, &order, runs.len, 32);
    ex.phase(Phase::Decompress);
    ex.expand_runs(&runs, &order, rays, m)
}
