//! The leaf order on the GPU, the twin of `crates/rsh/src/order.rs`: CRSH's hash → trim →
//! compress → sort → decompress (thesis §3.2.3–3.2.6), or RAH's screen order, each step a
//! kernel or a primitive of [`crate::prims`] and one timed phase, as on the CPU.

use super::device_scene::DeviceScene;
use super::hash::hash_keys;
use crate::kernels::params::TrimKindsParams;
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
