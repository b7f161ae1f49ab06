//! The leaf order on the GPU, the twin of `crates/rsh/src/order.rs`: CRSH's hash → trim →
//! compress → sort → decompress (thesis §3.2.3–3.2.6), or RAH's screen order, each step a
//! kernel or a primitive of [`crate::prims`] and one timed phase, as on the CPU.

use super::device_scene::DeviceScene;
use super::hash::hash_keys;
use crate::kernels::Exec;
use crate::rays::DeviceRays;
use ::rsh::Method;
use trace::Counter;
use trace::{Phase, TraceStats};

/// The sorted leaves (ray indices of the rays that can hit anything) and their count.
pub fn leaf_order(
    eng: &DeviceScene,
    ex: &mut Exec,
    rays: &DeviceRays,
    stats: &mut TraceStats,
) -> (wgpu::Buffer, u64) {
    let crsh = eng.cfg.method == Method::Crsh;
    ex.phase(if crsh {
        Phase::Hash
    } else {
        Phase::ScreenOrder
    });
    let (keys, valid) = hash_keys(eng, ex, rays, !crsh);
    ex.phase(Phase::Trim);
    let (tk, tv, m) = ex.compact(&valid, &keys, None, rays.len);
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
    (leaves, m)
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
    ex.sort_pairs(&runs.keys, &order, runs.len, 32);
    ex.phase(Phase::Decompress);
    ex.expand_runs(&runs, &order, rays, m)
}
